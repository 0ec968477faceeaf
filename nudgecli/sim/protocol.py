"""One trial of Algorithm 1 at the interface's 10 Hz rate: step records and a trial summary.

A trial alternates the human's turn and the autonomy's turn, starting and ending in the
human's. Every 10 Hz step of the human's turn:

1. the simulated participant decides what they are doing (resting, holding an intended
   label, pausing between actions, or idling to hand over) from their own epsilon-greedy
   policy for the true goal at the current discrete state;
2. their true physiology turns the intended label into a pressure, the driver's bands into a
   measured label ``phi_m`` (soft labels move, hard labels switch mode once per blow, deadbands
   and no-input samples do nothing);
3. each measured label updates the agent's belief with the agent's fitted tables (Eq. 7);
4. the command is blended with the autonomy's ``u_a`` towards ``g' = argmax b`` while the
   human's command is non-zero (Algorithm 1, line 8), and the robot moves for one step;
5. the trial ends if the robot is within the success tolerance of any goal pose (once the
   human has given an input in this turn).

The human hands over after idling for ``handover_idle_s``. In the autonomy's turn the
belief is frozen; the Disambiguation condition nudges to s* when the normalised entropy
exceeds kappa and otherwise steps towards g'; the Control condition steps towards the mean of
the goals tied for the highest belief. The autonomy drives at its own speeds until it is within
``arrival_tolerance`` of its target position, then hands back.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from nudgecli.config import ExperimentConfig
from nudgecli.model import assistance, interface
from nudgecli.model.disambiguation import (
    DisambiguationModel,
    DisambiguationSettings,
    maximally_disambiguating_state,
)
from nudgecli.model.inference import (
    DecayCounters,
    DecaySettings,
    bayes_update,
    decay_on_empty_sample,
    normalised_entropy,
)
from nudgecli.model.interface import HARD_PUFF, HARD_SIP, LABELS, NO_INPUT, SOFT_PUFF, SOFT_SIP
from nudgecli.model.mdp import SolvedLayout
from nudgecli.model.world import (
    MODE_NAMES,
    N_CELLS_Y,
    N_HEADINGS,
    N_MODES,
    Layout,
    angle_difference,
    clamp_position,
    discretise,
    state_index,
)
from nudgecli.sim.participants import Participant
from nudgecli.steplog import (
    AUTONOMY_TURN as AUTONOMY,
)
from nudgecli.steplog import (
    HANDOVER_TO_AUTONOMY,
    HANDOVER_TO_HUMAN,
    MODE_SWITCH_AUTONOMY,
    MODE_SWITCH_HUMAN,
    NUDGE,
    STEP,
    STEP_COLUMNS,
    TRIAL_START,
    join_events,
)
from nudgecli.steplog import (
    HUMAN_TURN as HUMAN,
)

_ZERO3 = np.zeros(3)
#: Longest a participant holds one move before re-planning (e.g. pushing against a wall).
MAX_HOLD_S = 3.0
#: Per-axis position error (units) and heading error (rad) a participant accepts when fine
#: positioning inside the goal's cell; both lie inside the success tolerance (1.0 unit, 0.2 rad).
FINE_POSITION_TOLERANCE = 0.5
FINE_HEADING_TOLERANCE = 0.15



@dataclass(frozen=True)
class ProtocolSettings:
    """The experiment's knobs as plain numbers, read once per run (the step loop is hot)."""

    dt: float
    time_limit_steps: int
    handover_idle_steps: int
    success_distance: float
    success_angle: float
    soft_threshold: float
    hard_threshold: float
    zero_threshold: float
    human_speed: float
    human_turn_rate: float
    kappa: float
    decay: DecaySettings | None
    goal_stay: float
    rho1_factor: float
    rho2_factor: float
    rho3: float
    entropy_gate: bool
    startup_delay_steps: int
    distance_weighting: bool
    autonomy_speed: float
    autonomy_turn_rate: float
    arrival_tolerance: float
    disambiguation: DisambiguationSettings
    step_sizes: tuple[float, ...]

    @classmethod
    def from_config(cls, config: ExperimentConfig) -> ProtocolSettings:
        study, itf, inf, dis, ass = (config.study, config.interface, config.inference,
                                     config.disambiguation, config.assistance)
        dt = 1.0 / study.rate_hz
        return cls(
            dt=dt,
            time_limit_steps=round(study.time_limit_s / dt),
            handover_idle_steps=round(study.handover_idle_s / dt),
            success_distance=study.success_distance,
            success_angle=study.success_angle,
            soft_threshold=itf.soft_threshold,
            hard_threshold=itf.hard_threshold,
            zero_threshold=itf.zero_threshold,
            human_speed=itf.human_speed,
            human_turn_rate=itf.human_turn_rate,
            kappa=inf.kappa,
            decay=DecaySettings(inf.decay_delay, inf.decay_rate, inf.decay_cap) if inf.decay else None,
            goal_stay=inf.goal_stay,
            rho1_factor=ass.rho1_factor,
            rho2_factor=ass.rho2_factor,
            rho3=ass.rho3,
            entropy_gate=ass.entropy_gate,
            startup_delay_steps=round(ass.startup_delay_s / dt),
            distance_weighting=ass.distance_weighting,
            autonomy_speed=ass.autonomy_speed,
            autonomy_turn_rate=ass.autonomy_turn_rate,
            arrival_tolerance=ass.arrival_tolerance,
            disambiguation=DisambiguationSettings(
                estimator=dis.estimator, samples=dis.samples, weighting=dis.weighting,
                mi_weight=dis.mi_weight, distance_weight=dis.distance_weight, distance=dis.distance,
                distance_unit=dis.distance_unit, window=dis.window, domain=dis.domain,
                rotation_gate=dis.rotation_gate),
            step_sizes=assistance.step_sizes(dis.window),
        )


@dataclass(frozen=True)
class TrialSpec:
    """Which trial this is and in which world."""

    participant: int
    condition: str
    block: int
    trial: int
    layout_index: int
    layout: Layout


@dataclass
class TrialResult:
    """The summary row and the step columns of one trial."""

    summary: dict[str, Any]
    steps: dict[str, list[Any]]


@dataclass
class _Trial:
    """Mutable state of one running trial (private to :func:`run_trial`)."""

    spec: TrialSpec
    settings: ProtocolSettings
    solved: SolvedLayout
    model: DisambiguationModel
    participant: Participant
    rng: np.random.Generator
    goal_poses: np.ndarray
    goal_transition: np.ndarray | None
    goal_state: int = 0
    x: float = 0.0
    y: float = 0.0
    theta: float = 0.0
    mode: int = 0
    belief: np.ndarray = field(default_factory=lambda: np.zeros(0))
    # what depends on the belief only, recomputed when it changes (most steps leave it alone)
    entropy: float = 1.0
    leader: int = 0  # argmax of the belief, first on ties
    ramp_alpha: float = 0.0  # alpha of the paper's piecewise-linear rule for p(leader)
    step: int = 0
    goal_list: list[tuple[float, float, float]] = field(default_factory=list)
    columns: dict[str, list[Any]] = field(default_factory=lambda: {c: [] for c in STEP_COLUMNS})

    def set_belief(self, belief: np.ndarray) -> None:
        """Replace the belief and refresh what is derived from it."""
        self.belief = belief
        self.entropy = float(normalised_entropy(belief))
        self.leader = int(np.argmax(belief))
        s = self.settings
        self.ramp_alpha = float(assistance.blending_factor(float(belief[self.leader]), belief.shape[0],
                                                           s.rho1_factor, s.rho2_factor, s.rho3))

    @property
    def state(self) -> int:
        i, j, h = discretise(self.x, self.y, self.theta)
        return int(state_index(i, j, h, self.mode))


def _goal_transition(n_goals: int, stay: float) -> np.ndarray | None:
    if stay >= 1.0:
        return None
    off = (1.0 - stay) / (n_goals - 1)
    return np.full((n_goals, n_goals), off) + np.eye(n_goals) * (stay - off)


def run_trial(spec: TrialSpec, settings: ProtocolSettings, solved: SolvedLayout, model: DisambiguationModel,
              participant: Participant, rng: np.random.Generator) -> TrialResult:
    """Simulate one trial.

    Parameters
    ----------
    spec
        The trial and its layout (goal 0 is the true goal).
    settings
        The protocol's knobs (from the experiment).
    solved
        The layout's solved goal MDPs (``policy (G, S)`` drives the participant).
    model
        The agent's model of this participant in this layout (fitted tables, ``p(phi_m | g, s)``).
    participant
        The simulated person (true physiology and habits).
    rng
        This trial's random stream.

    Returns
    -------
    TrialResult
    """
    layout = spec.layout
    n_goals = layout.n_goals
    start = layout.start_pose
    tr = _Trial(spec=spec, settings=settings, solved=solved, model=model, participant=participant, rng=rng,
                goal_poses=layout.goal_poses, goal_transition=_goal_transition(n_goals, settings.goal_stay),
                x=float(start[0]), y=float(start[1]), theta=float(start[2]), mode=layout.start_mode,
                belief=np.full(n_goals, 1.0 / n_goals),
                goal_state=int(state_index(int(layout.goal_cells[0, 0]), int(layout.goal_cells[0, 1]),
                                           int(layout.goal_headings[0]), 0)),
                goal_list=[(float(x), float(y), float(t)) for x, y, t in layout.goal_poses])
    tr.set_belief(tr.belief)
    human_turns = autonomy_turns = nudges = human_switches = 0
    reached = -1
    while tr.step < settings.time_limit_steps:
        human_turns += 1
        outcome, switches = _human_turn(tr)
        human_switches += switches
        if outcome >= 0:
            reached = outcome
            break
        if tr.step >= settings.time_limit_steps:
            break
        autonomy_turns += 1
        nudges += _autonomy_turn(tr)
    timed_out = reached < 0
    summary = {
        "participant": spec.participant,
        "condition": spec.condition,
        "block": spec.block,
        "trial": spec.trial,
        "layout": spec.layout_index,
        "n_goals": n_goals,
        "true_goal": 0,
        "reached_goal": reached,
        "success": reached == 0,
        "timed_out": timed_out,
        "duration_s": round(tr.step * settings.dt, 10),
        "steps": tr.step,
        "human_turns": human_turns,
        "autonomy_turns": autonomy_turns,
        "nudges": nudges,
        "human_mode_switches": human_switches,
        "final_x": tr.x,
        "final_y": tr.y,
        "final_theta": tr.theta,
        "final_belief_true_goal": float(tr.belief[0]),
        "final_entropy": float(normalised_entropy(tr.belief)),
    }
    return TrialResult(summary=summary, steps=tr.columns)


# --- the human's turn -----------------------------------------------------------------------

def _human_turn(tr: _Trial) -> tuple[int, int]:
    """Run one human turn; return (index of the goal reached or -1, human mode switches)."""
    s, p, rng = tr.settings, tr.participant, tr.rng
    rest_steps = round(p.rest_s * rng.uniform(0.5, 1.5) / s.dt)
    operate_steps = max(1, round(p.operate_s * rng.uniform(0.7, 1.3) / s.dt))
    initiated_at = -1  # step of the first input of this turn
    idle = 0  # consecutive steps without a command after the first input
    switches = 0
    held_label = NO_INPUT  # the intended label being held
    held_action = -1  # the task action it was chosen for
    hold_left = 0  # steps left in the current hold
    hold_state = -1  # discrete state when a move started (hold until it changes)
    hold_fine = False
    locked = False  # a hard sample switched the mode: no command until the blow ends
    pause_left = 0
    blow = np.zeros(0)  # the pressures of the current blow, drawn when it starts
    blow_pos = 0
    blow_held = 0  # samples of the current blow so far (a continued soft blow keeps its level)
    decay_counters = DecayCounters()
    event = HANDOVER_TO_HUMAN if tr.step > 0 else TRIAL_START
    first = True
    while tr.step < s.time_limit_steps:
        events = [event] if first and event else []
        first = False
        state = tr.state
        mode_before = tr.mode
        operating = initiated_at < 0 or (tr.step - initiated_at) < operate_steps
        intended = NO_INPUT
        if rest_steps > 0:
            rest_steps -= 1
        elif pause_left > 0:
            pause_left -= 1
        elif held_label != NO_INPUT and hold_left > 0 and not _hold_done(
                tr, state, held_label, held_action, hold_state, hold_fine):
            intended = held_label
            hold_left -= 1
        elif operating:
            # end of the previous action: pick the next one
            action, fine = _next_action(tr, state)
            label = p.intended_label(action, tr.mode, rng)
            was_holding_same = held_label == label and label in (SOFT_PUFF, SOFT_SIP) and not locked
            if held_label != NO_INPUT and not was_holding_same and initiated_at >= 0:
                pause_left = round(p.action_pause_s * rng.uniform(0.5, 1.5) / s.dt)
            locked = locked if was_holding_same else False
            held_label = label
            held_action = action
            hold_state = state
            hold_fine = fine
            if label in (HARD_PUFF, HARD_SIP):
                hold_left = max(1, round(p.hard_blow_s * rng.uniform(0.8, 1.2) / s.dt))
            else:
                hold_left = round(MAX_HOLD_S / s.dt)
            # a continued soft blow is already at its level; a new one starts with the onset ramp
            blow = p.pressures(label, hold_left, rng, start=blow_held if was_holding_same else 0)
            blow_held = blow_held if was_holding_same else 0
            blow_pos = 0
            if pause_left > 0:
                pause_left -= 1
            else:
                intended = held_label
                hold_left -= 1
        else:
            held_label = NO_INPUT
        if intended == NO_INPUT:
            locked = False  # released: the driver's "input stopped" unlocks switching
        pressure = 0.0
        if intended != NO_INPUT:
            pressure = float(blow[blow_pos])
            blow_pos += 1
            blow_held += 1
        measured = interface.label_of_pressure(pressure, s.soft_threshold, s.hard_threshold, s.zero_threshold)
        if measured != NO_INPUT and initiated_at < 0:
            initiated_at = tr.step
        # Bayesian update with the state the label was produced in (Eq. 7)
        if 0 <= measured < 4:
            likelihood = tr.model.likelihood[:, state, measured]
            tr.set_belief(bayes_update(tr.belief, likelihood, tr.goal_transition))
            decay_counters = DecayCounters()
        elif s.decay is not None and initiated_at >= 0:
            decayed, decay_counters = decay_on_empty_sample(tr.belief, decay_counters, s.decay)
            if decayed is not tr.belief:
                tr.set_belief(decayed)
        # the command of the measured label
        u_h = np.zeros(3)
        commanded = False
        if measured in (SOFT_PUFF, SOFT_SIP) and not locked:
            u_h = interface.human_velocity(measured, tr.mode, s.human_speed, s.human_turn_rate)
            commanded = True
        elif measured in (HARD_PUFF, HARD_SIP) and not locked:
            tr.mode = interface.switch_mode(tr.mode, measured)
            locked = True
            switches += 1
            commanded = True
            events.append(MODE_SWITCH_HUMAN)
        idle = 0 if commanded or initiated_at < 0 else idle + 1
        # blending (Algorithm 1, lines 7-8)
        entropy = tr.entropy
        inferred, alpha = _inferred_goal_and_alpha(tr, initiated_at)
        u_a = np.zeros(3)
        if inferred >= 0:
            u_a = assistance.autonomy_velocity(np.array([tr.x, tr.y, tr.theta]), tr.goal_poses[inferred],
                                               s.autonomy_speed, s.autonomy_turn_rate, s.dt)
        u_f = assistance.blend(u_a, u_h, alpha) if u_h.any() else u_h
        _record(tr, HUMAN, state, mode_before, intended, pressure, measured, u_h, u_a, alpha, inferred,
                entropy, events)
        _move(tr, u_f)
        tr.step += 1
        if initiated_at >= 0:
            reached = _goal_reached(tr)
            if reached >= 0:
                return reached, switches
        if initiated_at >= 0 and idle > s.handover_idle_steps:
            return -1, switches
    return -1, switches


def _hold_done(tr: _Trial, state: int, label: int, action: int, hold_state: int, fine: bool) -> bool:
    """Whether the participant releases the current blow.

    A hard blow is held for its planned duration; a move until the discrete state changes, or,
    when fine positioning inside the goal's cell, until that correction is no longer needed.
    """
    if label in (HARD_PUFF, HARD_SIP):
        return False
    if fine:
        return not _in_goal_state(tr, state) or _fine_action(tr) != action
    return state != hold_state


def _in_goal_state(tr: _Trial, state: int) -> bool:
    return state // N_MODES == tr.goal_state // N_MODES


def _next_action(tr: _Trial, state: int) -> tuple[int, bool]:
    """The participant's next task action: epsilon-greedy on the true goal's policy, or fine
    positioning once inside the true goal's discrete state (the MDP cannot see inside a cell)."""
    p, rng = tr.participant, tr.rng
    if rng.random() < p.epsilon:
        return int(rng.integers(4)), False
    if _in_goal_state(tr, state):
        fine = _fine_action(tr)
        return (fine if fine is not None else _nudge_towards_goal(tr)), True
    return int(tr.solved.policy[0, state]), False


def _fine_action(tr: _Trial) -> int | None:
    """Inside the goal cell: the action that reduces a remaining error, or ``None`` if none is left."""
    errors = _true_goal_errors(tr)
    needs = (abs(errors[0]) > FINE_POSITION_TOLERANCE, abs(errors[1]) > FINE_POSITION_TOLERANCE,
             abs(errors[2]) > FINE_HEADING_TOLERANCE)
    if not any(needs):
        return None
    if needs[tr.mode]:
        return _move_action(tr.mode, errors[tr.mode])
    target = next(d for d in range(3) if needs[d])
    return interface.TO_MODE_R if (target - tr.mode) % 3 == 1 else interface.TO_MODE_L


def _true_goal_errors(tr: _Trial) -> tuple[float, float, float]:
    """What is left to the true goal's pose along x, y and the heading (signed, shortest turn)."""
    gx, gy, gth = tr.goal_poses[0]
    return gx - tr.x, gy - tr.y, float(angle_difference(gth, tr.theta))


def _move_action(mode: int, error: float) -> int:
    # move_p is +x / +y, and clockwise (negative angle) in the theta mode
    if mode == 2:
        return interface.MOVE_N if error > 0 else interface.MOVE_P
    return interface.MOVE_P if error > 0 else interface.MOVE_N


def _nudge_towards_goal(tr: _Trial) -> int:
    """Already within tolerance: a short input towards the goal along the active axis."""
    return _move_action(tr.mode, _true_goal_errors(tr)[tr.mode])


def _inferred_goal_and_alpha(tr: _Trial, initiated_at: int) -> tuple[int, float]:
    s = tr.settings
    if s.entropy_gate and tr.entropy > s.kappa:
        return -1, 0.0
    inferred, alpha = tr.leader, tr.ramp_alpha
    if s.startup_delay_steps and (initiated_at < 0 or tr.step - initiated_at < s.startup_delay_steps):
        alpha = 0.0
    if s.distance_weighting and alpha > 0.0:
        gx, gy = tr.goal_poses[inferred, :2]
        alpha *= float(assistance.distance_weight(math.hypot(gx - tr.x, gy - tr.y)))
    return inferred, alpha


def _goal_reached(tr: _Trial) -> int:
    """The first goal whose pose is within the success tolerance, or -1 (scalar math: every step)."""
    s = tr.settings
    for index, (gx, gy, gth) in enumerate(tr.goal_list):
        if math.hypot(gx - tr.x, gy - tr.y) <= s.success_distance:
            turn = (gth - tr.theta + math.pi) % (2.0 * math.pi) - math.pi
            if abs(turn) <= s.success_angle:
                return index
    return -1


# --- the autonomy's turn --------------------------------------------------------------------

def _autonomy_turn(tr: _Trial) -> int:
    """Run one autonomy turn; return 1 if it was a nudge to s*, else 0."""
    s, rng = tr.settings, tr.rng
    state = tr.state
    entropy = tr.entropy
    position = np.array([tr.x, tr.y])
    nudged = 0
    if tr.spec.condition == "disambiguation" and entropy > s.kappa:
        choice = maximally_disambiguating_state(tr.belief, tr.model, state, s.disambiguation,
                                                robot_position=position, rng=rng,
                                                goal_transition=tr.goal_transition)
        target, m = assistance.nudge_target(choice.state)
        events = [NUDGE]
        if m != tr.mode:
            tr.mode = m
            events.append(MODE_SWITCH_AUTONOMY)
        nudged = 1
        inferred = -1
    else:
        radius = float(s.step_sizes[int(rng.integers(len(s.step_sizes)))])
        if tr.spec.condition == "disambiguation":
            inferred = int(np.argmax(tr.belief))
            goal_xy = tr.goal_poses[inferred, :2]
            heading = float(tr.goal_poses[inferred, 2])
        else:
            inferred = -1
            goal_xy = assistance.control_target(tr.belief, tr.goal_poses[:, :2])
            heading = tr.theta
        step_xy = assistance.step_target(position, goal_xy, radius)
        target = np.array([step_xy[0], step_xy[1], heading])
        events = [STEP]
    step_events = [HANDOVER_TO_AUTONOMY, *events]
    # the turn lasts at least one step and ends within arrival_tolerance of the target position
    while tr.step < s.time_limit_steps:
        if not step_events and math.hypot(target[0] - tr.x, target[1] - tr.y) <= s.arrival_tolerance:
            break
        pose = np.array([tr.x, tr.y, tr.theta])
        u_a = assistance.autonomy_velocity(pose, target, s.autonomy_speed, s.autonomy_turn_rate, s.dt)
        _record(tr, AUTONOMY, tr.state, tr.mode, NO_INPUT, 0.0, NO_INPUT, _ZERO3, u_a, 0.0, inferred,
                entropy, step_events)
        step_events = []
        _move(tr, u_a)
        tr.step += 1
    return nudged


# --- shared helpers -------------------------------------------------------------------------

def _move(tr: _Trial, velocity: np.ndarray) -> None:
    dt = tr.settings.dt
    tr.x, tr.y = clamp_position(tr.x + float(velocity[0]) * dt, tr.y + float(velocity[1]) * dt)
    tr.theta = (tr.theta + float(velocity[2]) * dt) % (2.0 * math.pi)


def _record(tr: _Trial, turn: str, state: int, mode: int, intended: int, pressure: float, measured: int,
            u_h: np.ndarray, u_a: np.ndarray, alpha: float, inferred: int, entropy: float,
            events: list[str]) -> None:
    """Append one step: the pose, cell and mode at the start of the step, what happened in it."""
    c = tr.columns
    cell, h = divmod(state // N_MODES, N_HEADINGS)
    i, j = divmod(cell, N_CELLS_Y)
    c["participant"].append(tr.spec.participant)
    c["trial"].append(tr.spec.trial)
    c["step"].append(tr.step)
    c["t"].append(round(tr.step * tr.settings.dt, 10))
    c["turn"].append(turn)
    c["x"].append(tr.x)
    c["y"].append(tr.y)
    c["theta"].append(tr.theta)
    c["mode"].append(MODE_NAMES[mode])
    c["cell_x"].append(int(i))
    c["cell_y"].append(int(j))
    c["heading"].append(int(h))
    c["phi_i"].append(LABELS[intended] if intended >= 0 else "")
    c["pressure"].append(pressure)
    c["phi_m"].append(_stream_label(measured))
    c["u_h_x"].append(float(u_h[0]))
    c["u_h_y"].append(float(u_h[1]))
    c["u_h_theta"].append(float(u_h[2]))
    c["u_a_x"].append(float(u_a[0]))
    c["u_a_y"].append(float(u_a[1]))
    c["u_a_theta"].append(float(u_a[2]))
    c["alpha"].append(alpha)
    c["inferred_goal"].append(inferred)
    c["belief"].append(tr.belief.tolist())
    c["entropy"].append(entropy)
    c["event"].append(join_events(events))


def _stream_label(code: int) -> str:
    if 0 <= code < 4:
        return LABELS[code]
    if code == interface.PUFF_DEADBAND:
        return interface.PUFF_DEADBAND_LABEL
    if code == interface.SIP_DEADBAND:
        return interface.SIP_DEADBAND_LABEL
    return ""


