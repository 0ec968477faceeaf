"""The person's side of Algorithm 1 (lines 2-4) as a named state machine.

A human turn is, for the person, three phases:

- ``RESTING``: before the first command of the turn ("they may wait any amount of time before
  issuing a first command", paper Section 5.1). The rest is drawn per turn around the
  participant's habit.
- ``OPERATING``: issuing commands. The person picks a task action ``a`` (epsilon-greedy on
  their own goal's optimal policy), chooses ``phi_i ~ p(phi_i | a)`` once for it from their own
  internal mapping, and holds it: a hard blow for their blow duration, a soft blow until the
  next decision. Between two different blows they release for a short pause.
- ``IDLE``: done with this turn (after operating for about their operating time): no input,
  so the protocol hands the turn over once their handover idle time has passed.

When a person decides is the behaviour setting ``decisions``:

- ``events``: at what a person can see: the robot reached the next cell centre (or the next
  multiple of 45 degrees) along the commanded axis, it moved the other way than the person
  meant, the mode changed, a hard blow ended, a correction inside the goal's cell is done, or
  the command has been held ``max_hold_s``;
- ``grid``: whenever the robot enters another discrete state (the model's hidden grid).

Two habits of people working with blending (paper Sections 6 and 7):

- ``lean_on_blending``: when the policy says "switch mode" while the person holds a soft
  command and the last step (moved by blending, i.e. also along an axis they do not command)
  reduced the remaining error to their goal, they keep their command instead;
- ``release_when_dragged``: when the last step, moved by blending, took the robot away from their
  goal, they let go (the robot stops: blending only acts on a non-zero command) and decide
  again with a new blow, whose first sample is new evidence for the agent;
- ``after_autonomy``: ``replan`` acts from the state and mode the autonomy left; ``resume``
  first repeats the task action they were doing before the autonomy's turn.

:class:`SimulatedPerson` is one source of the protocol's input stream (intended label and
pressure per 10 Hz step); a live person at a keyboard is another. Both feed the same protocol.
"""

from __future__ import annotations

import math
from enum import Enum
from typing import Protocol

import numpy as np

from nudgecli.model import interface
from nudgecli.model.interface import HARD_PUFF, HARD_SIP, NO_INPUT, SOFT_PUFF, SOFT_SIP
from nudgecli.model.world import (
    N_MODES,
    World,
    grid_next_mark,
    turn_between,
)
from nudgecli.sim.behaviour_settings import BehaviourSettings
from nudgecli.sim.behaviour_strays import controlled_pressure, stray_hazard, stray_schedule
from nudgecli.sim.participants import Participant
from nudgecli.sim.pressure_model import LABEL_SIGN

#: Below this a change of position or angle is rounding, not motion.
_MOTION_EPS = 1e-9


#: :meth:`SimulatedPerson.quiet_steps` while idle: until the turn or the trial ends.
_FOREVER = 1 << 62
#: Each label's pressure sign as plain floats (read per sample of a soft hold).
_SIGNS = tuple(LABEL_SIGN.tolist())


class Phase(Enum):
    """Where the person is in their turn."""

    RESTING = "resting"
    OPERATING = "operating"
    IDLE = "idle"


# the phases as module names: a member read through the class costs more than the test, every step
_RESTING, _OPERATING, _IDLE = Phase.RESTING, Phase.OPERATING, Phase.IDLE


class RobotView(Protocol):
    """What the person sees at the start of a step (the protocol's trial session provides it)."""

    @property
    def x(self) -> float: ...
    @property
    def y(self) -> float: ...
    @property
    def theta(self) -> float: ...
    @property
    def mode(self) -> int: ...
    @property
    def state(self) -> int: ...


class InputSource(Protocol):
    """A source of the human's input stream: a simulated person, or a live one."""

    def start_turn(self, after_autonomy: bool) -> None:
        """A human turn begins (``after_autonomy``: it follows an autonomy turn)."""

    def next_input(self, view: RobotView) -> tuple[int, float]:
        """``(intended label or NO_INPUT, signed pressure)`` for this 10 Hz step."""


def move_action(mode: int, error: float) -> int:
    """The move that reduces a signed error along the active axis.

    ``move_p`` is +x / +y, and clockwise (a negative angle) in the theta mode.
    """
    if mode == 2:
        return interface.MOVE_N if error > 0 else interface.MOVE_P
    return interface.MOVE_P if error > 0 else interface.MOVE_N


def next_centre(coordinate: float, direction: float, axis: int) -> float:
    """The next visible mark along ``axis`` strictly beyond ``coordinate`` in ``direction``.

    Marks are the cell centres along x (``X_MIN + w (k + 1/2)``) and y, and the multiples of
    45 degrees for the heading (where goal headings lie). ``direction`` is the sign of the motion.
    The grid world's marks (:func:`nudgecli.model.world.grid_next_mark`).
    """
    return grid_next_mark(coordinate, direction, axis)


def mark_reached(coordinate: float, target: float, direction: float, axis: int) -> bool:
    """Whether ``coordinate`` has reached ``target`` moving in ``direction`` (angles unwrapped locally).
    ``SimulatedPerson._decision_due`` has it written out: keep the two in step."""
    if axis == 2:
        ahead = turn_between(target, coordinate)
        return ahead * direction <= 1e-9
    return (target - coordinate) * direction <= 1e-9


class SimulatedPerson:
    """A simulated participant producing the input stream of their human turns.

    Parameters
    ----------
    participant
        Their physiology (pressures, internal mapping) and habits.
    settings
        How they decide (:class:`BehaviourSettings`).
    policy
        ``(S,)`` optimal task action per discrete state for *their* goal.
    goal_pose
        ``(3,)`` their goal's pose (they know it).
    goal_cell
        Flat index of their goal's discrete cell and heading (``state // N_MODES``).
    rng
        Their random stream.
    world
        The trial's world, whose visible marks (:meth:`~nudgecli.model.world.World.next_mark`) end
        a held move; ``None``: the grid's cell centres (:func:`next_centre`).
    hands_over
        Whether they end their turn by going idle after their operating time (``False`` where there
        is no autonomy to hand over to: they operate until the trial ends).
    """

    def __init__(self, participant: Participant, settings: BehaviourSettings, policy: np.ndarray,
                 goal_pose: np.ndarray, goal_cell: int, rng: np.random.Generator, *,
                 world: World | None = None, hands_over: bool = True) -> None:
        # the person's per-sample traits (ramps, drift) at this rate: the same person at any rate
        self.participant = participant.at_sample_period(settings.dt)
        self.world = world
        self.next_mark = world.next_mark if world is not None else next_centre
        self.hands_over = hands_over
        self.settings = settings
        self.policy = policy
        self.goal = (float(goal_pose[0]), float(goal_pose[1]), float(goal_pose[2]))
        self.goal_cell = int(goal_cell)
        self.rng = rng
        self.phase = Phase.RESTING
        self.rest_left = 0
        self.operate_left = 0
        self.pause_left = 0
        self.held_label = NO_INPUT
        self.held_action = -1
        self.hold_left = 0
        self.hold_fine = False
        self.hold_mode = -1
        self.hold_state = -1
        self.hold_axis = -1
        self.hold_target = 0.0
        self.hold_direction = 0.0
        # the current blow's pressures and deviations, as lists: read one sample per step
        self.blow: list[float] = []
        self.blow_normals: list[float] = []
        self.blow_pos = 0
        self.blow_innovations: list[float] = []  # the current soft hold's draws, one per sample
        self.blow_label = NO_INPUT  # the label of the current soft hold
        self.blow_start = 0  # the position of the hold's first sample within its blow
        self.blow_held = 0
        self.last_normal = 0.0  # the deviation of the blow's last sample, where a held blow drifts on from
        self.still_steps = 0  # steps the robot has stood still under the current soft hold
        self.last_action = -1
        self.resume_action = -1
        self.previous_pose: tuple[float, float, float] | None = None
        self.release = False  # the next action starts a new blow, whatever it is
        # the operating habits (BehaviourSettings.event_reactions ... notice_mode_errors)
        self.clock = 0  # steps of input given in this trial (the person's own sense of time)
        self.react_at = -1  # step at which they act on the last visible event (-1: none pending)
        self.notice_at = -1  # step at which they notice a surprise under their soft blow (-1: none)
        self.hold_on_left = -1  # steps they blow on after the robot stopped at a mark (-1: not now)
        self.seen_mode = -1  # the mode they last saw
        self.switched = False  # the mode changed during the current hard blow
        self.planned = False  # the trial's first turn has begun
        # pressure control within a soft blow (BehaviourSettings.deadband_strays, sim/behaviour_strays.py)
        self.stray_median = participant.deadband_stray_s / settings.dt  # their median stray, samples
        self.stray_hazard = (stray_hazard(participant.deadband_share, self.stray_median)
                             if settings.deadband_strays else 0.0)
        self.strays: list[bool] | None = None  # the current soft hold's straying samples (None: no control)
        self.stray_release_at = -1  # the sample of the hold before which they let go after a stray
        self.thresholds = (settings.zero_threshold, settings.soft_threshold, settings.hard_threshold)

    # --- the turn ---------------------------------------------------------------------------

    def start_turn(self, after_autonomy: bool) -> None:
        """Rest first (drawn for this turn), then operate; resume the previous action if so inclined."""
        s, p = self.settings, self.participant
        self.phase = Phase.RESTING
        if not self.planned and s.planning:
            # the trial's start: they look at the layout and the mode before the first command
            self.rest_left = round(p.planning_s * self._jitter(s.planning_jitter) / s.dt)
        elif self.planned and after_autonomy and s.event_reactions:
            self.rest_left = round(self._reaction() / s.dt)  # the turn came back: a visible event
        else:
            self.rest_left = round(p.rest_s * self._jitter(s.rest_jitter) / s.dt)
        self.planned = True
        self.react_at = self.notice_at = self.hold_on_left = -1
        self.seen_mode = -1
        self.operate_left = max(1, round(p.operate_s * self._jitter(s.operate_jitter) / s.dt))
        self.pause_left = 0
        self._release()
        self.resume_action = self.last_action if after_autonomy and s.after_autonomy == "resume" else -1
        self.previous_pose = None

    def quiet_steps(self, view: RobotView) -> int:
        """How many steps from this one on certainly give no input, whatever the robot does: the
        rest before operating, a release pause between blows (once the mode on display has been
        seen), or the idling after their operating time. 0 where this step has to be decided, and
        always 0 at the step after one of the same turn that gave input (they are operating and
        no pause has begun: a pause begins at a step without input), so the trial loop does not
        ask then."""
        phase = self.phase
        if phase is _OPERATING:
            # a mode that changed since the last step is an event for _see_mode: that step in full
            return self.pause_left if view.mode == self.seen_mode else 0
        return self.rest_left if phase is _RESTING else _FOREVER

    def skip_quiet(self, steps: int, pose: tuple[float, float, float], mode: int) -> None:
        """What :meth:`next_input` does in ``steps >= 1`` of the :meth:`quiet_steps` (each gives
        ``NO_INPUT, 0.0``), the robot at ``pose`` in ``mode`` at the start of the last of them."""
        if self.phase is _RESTING:
            self.rest_left -= steps
        elif self.phase is _OPERATING:
            self.operate_left -= steps
            self.pause_left -= steps
        self.previous_pose = pose
        self.seen_mode = mode
        self.clock += steps
        self.blow_held = 0

    def next_input(self, view: RobotView) -> tuple[int, float]:
        """The intended label and the pressure of this step (``NO_INPUT, 0.0`` for none)."""
        pose = (view.x, view.y, view.theta)
        intended = self._intend(view)
        self.previous_pose = pose
        self.seen_mode = view.mode
        self.clock += 1
        if intended == NO_INPUT:
            self.blow_held = 0
            return NO_INPUT, 0.0
        position = self.blow_pos
        if position == len(self.blow):
            self._next_soft_sample()
        # the blow's lists hold floats already (tolist(), or the samples computed as given)
        pressure = self.blow[position]
        self.last_normal = self.blow_normals[position]
        self.blow_pos = position + 1
        self.blow_held += 1
        return intended, pressure

    def _intend(self, view: RobotView) -> int:
        phase = self.phase
        if phase is not _OPERATING:
            if phase is _IDLE:
                return NO_INPUT
            if self.rest_left > 0:  # resting
                self.rest_left -= 1
                return NO_INPUT
            self.phase = _OPERATING
        # OPERATING: the operating time counts from the first step of operating
        self.operate_left -= 1
        if view.mode != self.seen_mode:  # _see_mode's own first test, here: most steps see no change
            self._see_mode(view)
        if self.pause_left > 0:  # releasing between two blows
            self.pause_left -= 1
            return NO_INPUT
        if self.hold_on_left > 0:  # the robot stopped at a mark: blowing on a little
            self.hold_on_left -= 1
            if self.hold_on_left > 0 and self.hold_left > 0:
                self.hold_left -= 1  # _continue, written out (as below)
                return self.held_label
            self.hold_on_left = -1
            self.release = True  # then they let go and act on what they saw
        elif self.held_label != NO_INPUT and self.hold_left > 0 and not self._decision_due(view):
            self.hold_left -= 1
            return self.held_label
        if self.held_label in (HARD_PUFF, HARD_SIP) and not self.switched and self.settings.event_reactions:
            self._saw_event()  # a mode-switch blow ended and the mode did not change: a visible event
        if self.operate_left < 0 and self.hands_over:
            self.phase = Phase.IDLE
            self._release()
            return NO_INPUT
        return self._decide(view)

    def _continue(self) -> int:
        self.hold_left -= 1
        return self.held_label

    # --- what they see and when they act on it ----------------------------------------------

    def _reaction(self) -> float:
        """One reaction delay, s: drawn from their log-normal, or their median without the tail."""
        p = self.participant
        return p.event_reaction(self.rng) if self.settings.pause_tail else p.event_reaction_s

    def _saw_event(self) -> None:
        """A visible event now: they act on it after a reaction delay (the next blow starts then)."""
        self.react_at = self.clock + round(self._reaction() / self.settings.dt)

    def _see_mode(self, view: RobotView) -> None:
        """The mode display changed since the last step: an event (their own switch, or a surprise)."""
        if self.seen_mode < 0 or view.mode == self.seen_mode or not self.settings.event_reactions:
            return
        if self.held_label in (HARD_PUFF, HARD_SIP):
            self.switched = True
        self._saw_event()

    def _surprise_noticed(self) -> bool:
        """Something went wrong under their soft blow: noticed now, or after their reaction delay."""
        if not self.settings.notice_mode_errors:
            return True
        if self.notice_at < 0:  # seen now (or when the mode display changed): they act after reacting
            self.notice_at = (self.react_at if self.react_at >= 0
                              else self.clock + round(self._reaction() / self.settings.dt))
        if self.clock < self.notice_at:
            return False
        self.release = True  # they let go and correct it by their own plan
        self.react_at = -1  # the reaction is spent: the correction follows their release pause
        return True

    def _robot_stops(self, view: RobotView) -> bool:
        """Whether their held soft command leaves the robot standing where it is now (a waypoint
        where the path turns, a wall): the world's own rule, as the person sees it next step."""
        if self.world is None:
            return False
        # unit speeds: only the command's direction decides whether the robot stands still
        velocity = interface.human_command(self.held_label, view.mode, 1.0, 1.0)
        x, y, theta = view.x, view.y, view.theta
        return self.world.holds_still(x, y, theta, velocity)

    # --- decisions --------------------------------------------------------------------------

    def _decision_due(self, view: RobotView) -> bool:
        """Whether the current hold ends at this step (the person decides again)."""
        label = self.held_label
        if label in (HARD_PUFF, HARD_SIP):
            return False  # a mode-switch blow lasts its planned duration
        if view.mode != self.hold_mode:
            return self._surprise_noticed()  # the mode changed under their blow (an unintended switch)
        if self.notice_at >= 0:
            return self._surprise_noticed()  # a surprise seen earlier, not yet acted on
        if self.stray_release_at == len(self.blow):  # a stray they end by letting go: the robot stood still
            self.release = True
            if self.settings.event_reactions:
                self._saw_event()
            return True
        if self._stalled(view):
            self.release = True  # the robot stands still under their command: let go, try again
            if self.settings.event_reactions:
                self._saw_event()
            return True
        if self.hold_fine:
            return not self._in_goal_cell(view) or self._fine_action(view) != self.held_action
        if self.settings.decisions == "grid":
            return view.state != self.hold_state
        if self._moving_against_intent(view):
            return self._surprise_noticed()  # the robot goes the other way than they meant
        if self.settings.release_when_dragged and self._blending_effect(view) < 0:
            self.release = True  # blending drags the robot away from their goal: let go
            return True
        # mark_reached, written out (every step of a soft hold asks)
        axis = self.hold_axis
        coordinate = (view.x, view.y, view.theta)[axis]
        ahead = turn_between(self.hold_target, coordinate) if axis == 2 else self.hold_target - coordinate
        if not ahead * self.hold_direction <= 1e-9:
            return False
        if self.settings.hold_on and self._robot_stops(view):
            # the robot stops here under their blow: they see it stop and blow on a little first
            s = self.settings
            hold_on_s = self.participant.hold_on_s * self._jitter(s.hold_on_jitter)
            self.hold_on_left = max(1, round(hold_on_s / s.dt))
            if s.event_reactions:
                self._saw_event()
            return False
        return True

    def _stalled(self, view: RobotView) -> bool:
        """Whether the robot has now stood still for ``stall_steps`` steps of this soft hold."""
        if self.settings.stall_steps <= 0 or self.previous_pose is None:
            return False
        px, py, ptheta = self.previous_pose
        # the three comparisons written out (a generator over the axes was a twentieth of the loop)
        still = (abs(view.x - px) <= _MOTION_EPS and abs(view.y - py) <= _MOTION_EPS
                 and abs(view.theta - ptheta) <= _MOTION_EPS)
        if still and self.strays is not None and self.blow and self.strays[len(self.blow) - 1]:
            return False  # a stray stopped it: they know why and answer with its end, not a stall
        self.still_steps = self.still_steps + 1 if still else 0
        return self.still_steps >= self.settings.stall_steps

    def _moving_against_intent(self, view: RobotView) -> bool:
        """The last step moved the robot along the commanded axis opposite to the direction of
        the move they meant (e.g. a Soft Puff produced for ``move_n`` by their internal mapping)."""
        if self.previous_pose is None or self.held_action not in (interface.MOVE_P, interface.MOVE_N):
            return False
        axis = self.hold_axis
        before, now = self.previous_pose[axis], (view.x, view.y, view.theta)[axis]
        moved = turn_between(now, before) if axis == 2 else now - before
        meant = 1.0 if self.held_action == interface.MOVE_P else -1.0
        if axis == 2:
            meant = -meant  # move_p turns clockwise
        return moved * meant < -_MOTION_EPS

    def _decide(self, view: RobotView) -> int:
        """Pick the next action and its label, and start holding it."""
        s, p, rng = self.settings, self.participant, self.rng
        keep = False
        if self.resume_action >= 0:
            action, fine = self.resume_action, False
            self.resume_action = -1
        else:
            action, fine = self._policy_action(view)
            keep = (s.lean_on_blending and action in (interface.TO_MODE_R, interface.TO_MODE_L)
                    and self.held_label in (SOFT_PUFF, SOFT_SIP) and view.mode == self.hold_mode
                    and self._blending_effect(view) > 0)
        if keep:
            label, action, fine = self.held_label, self.held_action, self.hold_fine
        else:
            label = p.intended_label(action, view.mode, rng)
        continuing = (label == self.held_label and label in (SOFT_PUFF, SOFT_SIP)
                      and view.mode == self.hold_mode and not self.release)
        self.release = False
        previous = self.held_label
        if (s.event_reactions and not continuing and previous in (SOFT_PUFF, SOFT_SIP) and self.react_at < 0
                and not self.hold_fine):
            self._saw_event()  # the robot reached the mark where their plan changes: they let go here
        self._start_hold(view, label, action, fine, continuing)
        if not continuing and previous != NO_INPUT:
            # a new blow after another one: release first, for at least this one sample (so the
            # driver sees the end of a hard blow and accepts the next switch), and, where they saw
            # something happen, until they have reacted to it
            pause = max(1, round(p.action_pause_s * self._jitter(s.pause_jitter) / s.dt))
            if self.react_at >= 0:
                pause = max(pause, self.react_at - self.clock)
            self.react_at = -1
            self.pause_left = pause - 1
            return NO_INPUT
        self.react_at = -1
        return self._continue()

    def _start_hold(self, view: RobotView, label: int, action: int, fine: bool, continuing: bool) -> None:
        s, p = self.settings, self.participant
        self.held_label, self.held_action, self.hold_fine = label, action, fine
        self.hold_mode, self.hold_state = view.mode, view.state
        self.last_action = action
        self.still_steps = 0
        self.notice_at = self.hold_on_left = self.stray_release_at = -1
        self.strays = None
        self.switched = False
        if label in (HARD_PUFF, HARD_SIP) and s.hard_pulses:
            # a short pulse: onset ramp, peak, offset ramp, then a full release
            peak = max(1, round(p.hard_peak_s * self._jitter(s.hard_blow_jitter) / s.dt))
            self.hold_left = p.onset_ramp_samples + peak + p.offset_ramp_samples
            self.blow_held = 0
            normals = p.drift_normals(self.hold_left, self.rng)
            self.blow = p.pulse_pressures(label, normals, peak).tolist()
            self.blow_normals = normals.tolist()
            self.blow_pos = 0
            return
        if label in (HARD_PUFF, HARD_SIP):
            self.hold_left = max(1, round(p.hard_blow_s * self._jitter(s.hard_blow_jitter) / s.dt))
        else:
            self.hold_left = s.max_hold_steps
            along = interface.human_command(label, view.mode, 1.0, 1.0)[view.mode]  # its sign is what counts
            self.hold_axis = int(view.mode)
            self.hold_direction = 1.0 if along > 0.0 else -1.0 if along < 0.0 else 0.0  # np.sign
            coordinate = (view.x, view.y, view.theta)[self.hold_axis]
            self.hold_target = self.next_mark(coordinate, self.hold_direction, self.hold_axis)
        start = self.blow_held if continuing else 0
        self.blow_held = start
        # the hold's deviations are drawn now (the same draw as Participant.drift_normals), its
        # samples computed as they are given (_next_soft_sample)
        self.blow_innovations = self.rng.standard_normal(self.hold_left).tolist()
        if s.deadband_strays and label in (SOFT_PUFF, SOFT_SIP):
            self.strays, self.stray_release_at = stray_schedule(self.stray_hazard, self.stray_median,
                                                                self.hold_left, self.rng)
        self.blow_label, self.blow_start = label, start
        self.blow, self.blow_normals = [], []
        self.blow_pos = 0

    def _next_soft_sample(self) -> None:
        """Append the current soft hold's next sample to ``blow`` and ``blow_normals``: the values
        :meth:`Participant.pressures_from_normals` of :meth:`Participant.drift_normals` would give."""
        p, k = self.participant, len(self.blow)
        innovation = self.blow_innovations[k]
        # the deviation of the sample given last (next_input keeps it), unless a new blow starts here
        new_blow = k == 0 and self.blow_start == 0
        normal = innovation if new_blow else p.drift_step(self.last_normal, innovation)
        self.blow_normals.append(normal)
        pressure = p.sample_pressure(self.blow_label, self.blow_start + k, normal)
        if self.strays is not None:  # their control keeps the blow soft but for its strays
            returning = k > 0 and self.strays[k - 1] and not self.strays[k]
            pressure = controlled_pressure(pressure, _SIGNS[self.blow_label], self.strays[k], returning,
                                           self.thresholds)
        self.blow.append(pressure)

    def _release(self) -> None:
        self.held_label = NO_INPUT
        self.held_action = -1
        self.hold_left = 0
        self.hold_fine = False
        self.hold_mode = -1

    def _policy_action(self, view: RobotView) -> tuple[int, bool]:
        """Epsilon-greedy on their goal's policy, or fine positioning inside the goal's cell
        (the MDP cannot see inside a cell)."""
        if self.rng.random() < self.participant.epsilon:
            return int(self.rng.integers(4)), False
        if self._in_goal_cell(view):
            fine = self._fine_action(view)
            if fine is None:  # within tolerance: a short input towards the goal on the active axis
                fine = move_action(view.mode, self._errors(view)[view.mode])
            return fine, True
        return int(self.policy[view.state]), False

    def _in_goal_cell(self, view: RobotView) -> bool:
        return view.state // N_MODES == self.goal_cell

    def _errors(self, view: RobotView) -> tuple[float, float, float]:
        """What is left to the goal along x, y and the heading (signed, shortest turn)."""
        gx, gy, gth = self.goal
        return gx - view.x, gy - view.y, turn_between(gth, view.theta)

    def _fine_action(self, view: RobotView) -> int | None:
        """Inside the goal cell: the action that reduces a remaining error, or ``None`` if none is left."""
        s = self.settings
        errors = self._errors(view)
        needs = (abs(errors[0]) > s.fine_position_tolerance, abs(errors[1]) > s.fine_position_tolerance,
                 abs(errors[2]) > s.fine_heading_tolerance)
        if not any(needs):
            return None
        if needs[view.mode]:
            return move_action(view.mode, errors[view.mode])
        target = next(d for d in range(3) if needs[d])
        return interface.TO_MODE_R if (target - view.mode) % 3 == 1 else interface.TO_MODE_L

    def _blending_effect(self, view: RobotView) -> int:
        """What blending did in the last step, as the person sees it: ``+1`` it moved the robot
        towards their goal, ``-1`` away from it, ``0`` no blending seen.

        Blending is seen when the robot moved along an axis the person does not command; towards
        or away is judged on the remaining position error, then (when that did not change) on
        the heading error.
        """
        if self.previous_pose is None or self.hold_mode < 0:
            return 0
        before, now = self.previous_pose, (view.x, view.y, view.theta)
        held = self.hold_mode
        # moved along an axis they do not command (written out: this runs every step of a hold)
        if not ((held != 0 and abs(now[0] - before[0]) > _MOTION_EPS)
                or (held != 1 and abs(now[1] - before[1]) > _MOTION_EPS)
                or (held != 2 and abs(turn_between(now[2], before[2])) > _MOTION_EPS)):
            return 0
        gx, gy, gth = self.goal
        change = math.hypot(gx - now[0], gy - now[1]) - math.hypot(gx - before[0], gy - before[1])
        if abs(change) <= _MOTION_EPS:
            change = abs(turn_between(gth, now[2])) - abs(turn_between(gth, before[2]))
        if abs(change) <= _MOTION_EPS:
            return 0
        return 1 if change < 0 else -1

    def _jitter(self, jitter: float) -> float:
        return float(self.rng.uniform(1.0 - jitter, 1.0 + jitter))
