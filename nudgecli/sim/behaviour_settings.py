"""How a simulated person decides, in steps and plain numbers: the ``[behaviour]`` section as
:class:`~nudgecli.sim.behaviour.SimulatedPerson` reads it (once per run; the step loop is hot)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from nudgecli.config import BehaviourSection, ExperimentConfig, section_defaults
from nudgecli.model.interface import HARD_THRESHOLD_EARLY, SOFT_THRESHOLD_EARLY, ZERO_THRESHOLD

#: The ``[behaviour]`` defaults, which :class:`BehaviourSettings` takes.
_BEHAVIOUR = section_defaults(BehaviourSection)


@dataclass(frozen=True)
class BehaviourSettings:
    """The ``[behaviour]`` keys in steps and plain numbers (read once per run). The defaults are
    ``[behaviour]``'s, but for the operating habits (``event_reactions`` ...), which are off: the
    earlier person, whom the tests of one habit start from."""

    dt: float
    decisions: Literal["events", "grid"] = _BEHAVIOUR.decisions
    lean_on_blending: bool = _BEHAVIOUR.lean_on_blending
    release_when_dragged: bool = _BEHAVIOUR.release_when_dragged
    after_autonomy: Literal["replan", "resume"] = _BEHAVIOUR.after_autonomy
    stall_steps: int = 0
    #: ``[behaviour] max_hold_s`` in steps (derived from its default and ``dt`` when not given).
    max_hold_steps: int = -1
    fine_position_tolerance: float = _BEHAVIOUR.fine_position_tolerance
    fine_heading_tolerance: float = _BEHAVIOUR.fine_heading_tolerance
    rest_jitter: float = _BEHAVIOUR.rest_jitter
    operate_jitter: float = _BEHAVIOUR.operate_jitter
    pause_jitter: float = _BEHAVIOUR.pause_jitter
    hard_blow_jitter: float = _BEHAVIOUR.hard_blow_jitter
    event_reactions: bool = False
    planning: bool = False
    hard_pulses: bool = False
    hold_on: bool = False
    pause_tail: bool = False
    notice_mode_errors: bool = False
    planning_jitter: float = _BEHAVIOUR.planning_jitter
    hold_on_jitter: float = _BEHAVIOUR.hold_on_jitter
    deadband_strays: bool = False
    #: the driver's label bands, which the person's pressure control keeps a soft blow within
    zero_threshold: float = ZERO_THRESHOLD
    soft_threshold: float = SOFT_THRESHOLD_EARLY
    hard_threshold: float = HARD_THRESHOLD_EARLY

    def __post_init__(self) -> None:
        if self.max_hold_steps < 0:  # frozen: the derived default is set once, here
            object.__setattr__(self, "max_hold_steps", hold_steps(_BEHAVIOUR.max_hold_s, self.dt))

    @classmethod
    def from_config(cls, config: ExperimentConfig) -> BehaviourSettings:
        b = config.behaviour
        dt = config.study.dt
        return cls(dt=dt, decisions=b.decisions, lean_on_blending=b.lean_on_blending,
                   release_when_dragged=b.release_when_dragged,
                   after_autonomy=b.after_autonomy, stall_steps=round(b.stall_s / dt),
                   max_hold_steps=hold_steps(b.max_hold_s, dt),
                   fine_position_tolerance=b.fine_position_tolerance,
                   fine_heading_tolerance=b.fine_heading_tolerance, rest_jitter=b.rest_jitter,
                   operate_jitter=b.operate_jitter, pause_jitter=b.pause_jitter,
                   hard_blow_jitter=b.hard_blow_jitter, event_reactions=b.event_reactions,
                   planning=b.planning, hard_pulses=b.hard_pulses, hold_on=b.hold_on,
                   pause_tail=b.pause_tail, notice_mode_errors=b.notice_mode_errors,
                   planning_jitter=b.planning_jitter, hold_on_jitter=b.hold_on_jitter,
                   deadband_strays=b.deadband_strays, zero_threshold=config.interface.zero_threshold,
                   soft_threshold=config.interface.soft_threshold,
                   hard_threshold=config.interface.hard_threshold)


def hold_steps(max_hold_s: float, dt: float) -> int:
    """The steps of the longest hold of one command (at least one)."""
    return max(1, round(max_hold_s / dt))
