"""A live person's sip-and-puff input: keys held down and a gamepad axis, sampled at the protocol rate.

This is the live twin of :class:`nudgecli.sim.behaviour.SimulatedPerson`: another
:class:`~nudgecli.sim.behaviour.InputSource` of the same stream (intended label, signed pressure)
that :class:`~nudgecli.sim.protocol.TrialSession` consumes, one sample per 10 Hz step.

Two devices, one stream:

- **keys** ``1`` Hard Puff, ``2`` Hard Sip, ``3`` Soft Puff, ``4`` Soft Sip (the study's answer
  keys). A key held down is a blow held: every sample while it is down carries the key's pressure
  (the middle of its band of the driver, puff negative, sip positive), so holding ``3`` keeps
  moving; releasing it ends the blow. A key pressed and released between two samples still gives
  one sample (a short hard blow switches the mode once). While several keys are down, the last
  one pressed counts. The intended label of a key sample is the key's label.
- **a gamepad axis** (the browser's Gamepad API), read as the raw pressure in ``[-1, 1]`` and
  labelled by the driver's bands like a real device's signal, so a sip-and-puff device that
  presents itself as a joystick works directly. Its samples have no intended label (a device
  does not say what the person meant); keys take precedence while one is down.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from nudgecli.config import InterfaceSection
from nudgecli.model.interface import LABELS, N_LABELS, NO_INPUT, human_command, switch_mode
from nudgecli.model.world import MODE_NAMES, N_MODES
from nudgecli.sim.behaviour import RobotView
from nudgecli.sim.pressure_model import LABEL_SIGN

#: Key -> interface label (the study's answer keys: 1 Hard Puff, 2 Hard Sip, 3 Soft Puff, 4 Soft Sip).
KEY_LABELS = {str(k + 1): k for k in range(N_LABELS)}


#: How the page writes each mode (the robot's heading mode as the Greek letter the paper uses).
MODE_SHOWN = {"x": "x", "y": "y", "theta": "\u03b8"}


def _motion_words(vx: float, vy: float, omega: float) -> str:
    """A command ``(vx, vy, omega)`` of one axis in words (omega anticlockwise, as in the world)."""
    if vx:
        return "move right" if vx > 0 else "move left"
    if vy:
        return "move up" if vy > 0 else "move down"
    if omega:
        return "turn counterclockwise" if omega > 0 else "turn clockwise"
    return "nothing"


def label_meaning(label: int) -> str:
    """What a label does in the task, in words read off the interface's own rules.

    A label that switches the mode (:func:`~nudgecli.model.interface.switch_mode`) is named by
    the cycle it walks from the x mode (``switch the mode forward (x -> y -> theta)``); a label that
    moves the robot (:func:`~nudgecli.model.interface.human_command`) by its motion in each mode.
    The page shows these words, so they cannot drift from what the protocol does with a key.
    """
    cycle = [0]
    while len(cycle) < N_MODES and switch_mode(cycle[-1], label) != cycle[-1]:
        cycle.append(switch_mode(cycle[-1], label))
    if len(cycle) > 1:
        direction = "forward" if cycle[1] == 1 else "backward"
        walk = " \u2192 ".join(MODE_SHOWN[MODE_NAMES[m]] for m in (*cycle, 0))
        return f"switch the mode {direction} ({walk})"
    motions = [
        (_motion_words(*human_command(label, mode, 1.0, 1.0)), MODE_SHOWN[MODE_NAMES[mode]])
        for mode in range(N_MODES)
    ]
    if all(words == "nothing" for words, _ in motions):
        return "nothing"
    return ", ".join(f"{words} in the {shown} mode" for words, shown in motions)


def key_meanings() -> dict[str, dict[str, str]]:
    """Each key's label and what it does in the task: ``{"1": {"label": "Hard Puff", "does":
    "switch the mode forward (x -> y -> theta -> x)"}, ...}`` (:func:`label_meaning`)."""
    return {key: {"label": LABELS[label], "does": label_meaning(label)} for key, label in KEY_LABELS.items()}


def key_pressures(interface: InterfaceSection) -> np.ndarray:
    """``(F,)`` the signed pressure a held key produces: the middle of its label's band.

    Soft labels sit halfway between the no-input threshold and the soft threshold, hard labels
    halfway between the hard threshold and full scale (1); puffs are negative, sips positive.
    """
    soft = (interface.zero_threshold + interface.soft_threshold) / 2.0
    hard = (interface.hard_threshold + 1.0) / 2.0
    magnitude = np.array([hard, hard, soft, soft])
    return magnitude * LABEL_SIGN


@dataclass
class LiveInput:
    """The live person's input source: key and axis events in, one sample per protocol step out.

    Parameters
    ----------
    pressures
        ``(F,)`` signed pressure of each key's label (:func:`key_pressures`).
    zero_threshold
        Axis values below this magnitude are no input.
    """

    pressures: np.ndarray
    zero_threshold: float
    held: list[int] = field(default_factory=list)
    pressed: list[int] = field(default_factory=list)
    axis_value: float | None = None

    @classmethod
    def from_interface(cls, interface: InterfaceSection) -> LiveInput:
        return cls(key_pressures(interface), interface.zero_threshold)

    def key(self, label: int, down: bool) -> None:
        """A key went down or up (``label`` 0-3)."""
        if not 0 <= label < N_LABELS:
            raise ValueError(f"label {label} is not one of {', '.join(LABELS)}")
        if label in self.held:
            self.held.remove(label)
        if down:
            self.held.append(label)
            self.pressed.append(label)

    def axis(self, value: float | None) -> None:
        """The gamepad axis moved (``None``: no gamepad)."""
        self.axis_value = None if value is None else float(min(max(value, -1.0), 1.0))

    def release_all(self) -> None:
        """Forget held keys and the axis (the page lost focus, the connection closed, a trial
        starts): a page that no longer sends cannot say its blow ended, so none is kept; a page
        that controls again sends its axis anew."""
        self.held.clear()
        self.pressed.clear()
        self.axis_value = None

    def sample(self) -> tuple[int, float]:
        """This step's ``(intended label or NO_INPUT, signed pressure)``; consumes the presses
        since the last sample."""
        active = self.held[-1] if self.held else (self.pressed[-1] if self.pressed else NO_INPUT)
        self.pressed.clear()
        if active != NO_INPUT:
            return active, float(self.pressures[active])
        if self.axis_value is not None and abs(self.axis_value) >= self.zero_threshold:
            return NO_INPUT, self.axis_value
        return NO_INPUT, 0.0

    # --- InputSource --------------------------------------------------------------------------

    def start_turn(self, after_autonomy: bool) -> None:
        """A human turn begins: a person needs no preparation."""

    def next_input(self, view: RobotView) -> tuple[int, float]:
        return self.sample()
