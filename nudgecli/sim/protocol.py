"""One trial of Algorithm 1 at the interface's 10 Hz rate: step records and a trial summary.

A trial alternates the human's turn and the autonomy's turn, starting and ending in the
human's. :class:`TrialSession` is the system side, advanced one 10 Hz step at a time; the
human's input comes from an input source (:mod:`nudgecli.sim.behaviour`: a simulated person,
or a live one), one intended label and pressure per step. Every step of the human's turn:

1. the driver's bands turn the pressure into a measured label ``phi_m`` (soft labels move,
   a hard label switches the mode once per blow, deadbands and no-input samples do nothing);
2. measured labels update the agent's belief with the agent's fitted tables (Eq. 7), once per
   task-level input event (``inference.update = "action"``: a new blow, or a change of measured
   label within a blow) or once per sample (``"sample"``, the study software), always with the
   state the label was produced in;
3. the command is blended with the autonomy's ``u_a`` towards ``g' = argmax b`` while the
   human's command is non-zero (Algorithm 1, line 8), and the robot moves for one step. When
   two or more goals are tied for the highest belief there is no ``g'`` (alpha is 0): a rule
   blind to which goal is true;
4. the trial ends if the robot is within the success tolerance of any goal pose (once the
   human has given an input in this turn).

The robot's kinematics, constraints, discrete states and success rule are the trial's world's
(:class:`nudgecli.model.world.World`): the paper's grid world by default, or the CIAA path world.

The trial's condition names its policy (:mod:`nudgecli.sim.policy_interface`: a built-in one of
:mod:`nudgecli.sim.builtin_policies`, or the experiment's own), one object per trial. Step 3's
command is the policy's (:meth:`~nudgecli.sim.policy_interface.Policy.assist`: the paper's
blending for the paper's conditions); a policy that does not infer leaves the belief uniform, and
one that takes no turns makes the human's turn the whole trial.

The turn passes to the autonomy after the participant's handover idle time without a command
(for a policy that takes turns). In the autonomy's turn the belief is frozen; the policy chooses,
once, what the turn does (:meth:`~nudgecli.sim.policy_interface.Policy.start_turn`: the
Disambiguation condition's nudge to s* or bounded step, the Control condition's step towards the
tied leaders' mean, a mode switch, or nothing), and the autonomy drives at its own speeds until it
is within ``arrival_tolerance`` of the turn's target position, then hands back (a turn without a
target is one step that does not move).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from nudgecli.config import (
    BlendingPolicySection,
    ExperimentConfig,
    HindsightSection,
    ModeSwitchSection,
    section_defaults,
)
from nudgecli.model import assistance, interface
from nudgecli.model.assistance import BlendingSettings
from nudgecli.model.disambiguation import DisambiguationModel, DisambiguationSettings
from nudgecli.model.hindsight import HindsightSettings
from nudgecli.model.inference import (
    DecayCounters,
    DecaySettings,
    bayes_update,
    decay_on_empty_sample,
    normalised_entropy,
)
from nudgecli.model.interface import HARD_PUFF, HARD_SIP, NO_INPUT, SOFT_PUFF, SOFT_SIP
from nudgecli.model.path_world import PathLayout
from nudgecli.model.ties import unique_argmax
from nudgecli.model.world import (
    Command,
    GridWorld,
    Layout,
    World,
)
from nudgecli.sim.behaviour_settings import BehaviourSettings
from nudgecli.sim.policy_interface import QuietRun, read_only_array, read_only_view
from nudgecli.sim.policy_registry import PolicySpec, checked_policy_specs, make_policy, policy_specs
from nudgecli.sim.step_record import StepRecording, step_columns
from nudgecli.steplog import (
    AUTONOMY_TURN,
    HANDOVER_TO_AUTONOMY,
    HANDOVER_TO_HUMAN,
    HUMAN_TURN,
    MODE_SELECT,
    MODE_SWITCH_AUTONOMY,
    MODE_SWITCH_HUMAN,
    STEP_COLUMNS,
    TRIAL_START,
)

_ZERO3 = interface.NO_COMMAND  # u_h of a step without a motion command, u_a without assistance
_NO_DECAY = DecayCounters()
#: A step's events where none are pending (shared: a step that adds one makes a new list).
_NO_EVENTS: tuple[str, ...] = ()


@dataclass(frozen=True)
class ProtocolSettings:
    """The experiment's knobs as plain numbers, read once per run (the step loop is hot)."""

    dt: float
    time_limit_steps: int
    success_distance: float
    success_angle: float
    soft_threshold: float
    hard_threshold: float
    zero_threshold: float
    human_speed: float
    human_turn_rate: float
    kappa: float
    update: str
    decay: DecaySettings | None
    goal_stay: float
    blending: BlendingSettings
    autonomy_speed: float
    autonomy_turn_rate: float
    arrival_tolerance: float
    disambiguation: DisambiguationSettings
    window: int
    behaviour: BehaviourSettings
    blending_gap: float | None
    blending_kind: str
    mode_criterion: str
    mode_trigger: str
    hindsight: HindsightSettings
    hindsight_assist: str
    custom_policies: tuple[PolicySpec, ...] = ()

    @classmethod
    def from_config(cls, config: ExperimentConfig, *, check_policies: bool = True) -> ProtocolSettings:
        """The protocol's settings of ``config``; its own policies imported and checked
        (:func:`~nudgecli.sim.policy_registry.checked_policy_specs`) when ``check_policies``. A run's
        participant tasks pass ``False``: the run checked them once at its start, and a check per
        participant would import an edited policy file afresh, mixing two policies in one run."""
        study, itf, inf, dis, ass = (config.study, config.interface, config.inference,
                                     config.disambiguation, config.assistance)
        dt = study.dt
        path = config.world.kind == "ciaa"
        return cls(
            dt=dt,
            time_limit_steps=study.time_limit_steps,
            success_distance=study.success_distance,
            success_angle=study.success_angle,
            soft_threshold=itf.soft_threshold,
            hard_threshold=itf.hard_threshold,
            zero_threshold=itf.zero_threshold,
            # the CIAA path world's own (wall-clock) speeds replace the interface's
            human_speed=config.world.linear_speed if path else itf.human_speed,
            human_turn_rate=config.world.angular_speed if path else itf.human_turn_rate,
            kappa=inf.kappa,
            update=inf.update,
            decay=DecaySettings(inf.decay_delay, inf.decay_rate, inf.decay_cap) if inf.decay else None,
            goal_stay=inf.goal_stay,
            blending=BlendingSettings(
                rho1_factor=ass.rho1_factor, rho2_factor=ass.rho2_factor, rho3=ass.rho3,
                entropy_gate=inf.kappa if ass.entropy_gate else None, startup_delay=ass.startup_delay_s,
                distance_weighting=ass.distance_weighting, distance_knee=ass.distance_knee,
                distance_drop=ass.distance_drop),
            autonomy_speed=ass.autonomy_speed,
            autonomy_turn_rate=ass.autonomy_turn_rate,
            arrival_tolerance=ass.arrival_tolerance,
            disambiguation=DisambiguationSettings(
                estimator=dis.estimator, samples=dis.samples, weighting=dis.weighting,
                mi_weight=dis.mi_weight, distance_weight=dis.distance_weight, distance=dis.distance,
                distance_unit=dis.distance_unit, window=dis.window, domain=dis.domain,
                rotation_gate=dis.rotation_gate, scope=dis.scope),
            window=dis.window,
            behaviour=BehaviourSettings.from_config(config),
            blending_gap=(config.blending.gap if config.blending is not None and config.blending.gate == "gap"
                          else None),
            blending_kind=(config.blending or section_defaults(BlendingPolicySection)).kind,
            # the sections of conditions the study does not run may be absent: their defaults then
            mode_criterion=(config.mode_switch or section_defaults(ModeSwitchSection)).criterion,
            mode_trigger=(config.mode_switch or section_defaults(ModeSwitchSection)).trigger,
            hindsight=hindsight_settings(config),
            hindsight_assist=(config.hindsight or section_defaults(HindsightSection)).assist,
            custom_policies=checked_policy_specs(config) if check_policies else policy_specs(config),
        )


def hindsight_settings(config: ExperimentConfig) -> HindsightSettings:
    """The hindsight policy's assistance in this world: the source's, scaled to the person's
    speeds (:meth:`HindsightSettings.from_source`), with ``[hindsight] strength`` / ``zone`` where set."""
    section = config.hindsight or section_defaults(HindsightSection)
    itf = config.interface
    derived = HindsightSettings.from_source(itf.human_speed, itf.human_turn_rate)
    changes = {key: value for key, value in (("strength", section.strength), ("zone", section.zone))
               if value is not None}
    return replace(derived, **changes) if changes else derived


@dataclass(frozen=True)
class TrialSpec:
    """Which trial this is, in which world, and which of the layout's goals is the true one."""

    participant: int
    condition: str
    block: int
    trial: int
    layout_index: int
    layout: Layout | PathLayout
    true_goal: int = 0


def goal_transition_matrix(n_goals: int, stay: float) -> np.ndarray | None:
    """``(G, G)`` p(g_t | g_{t-1}) with ``stay`` on the diagonal, or ``None`` for the identity (Eq. 7)."""
    if stay >= 1.0:
        return None
    off = (1.0 - stay) / (n_goals - 1)
    return np.full((n_goals, n_goals), off) + np.eye(n_goals) * (stay - off)


@dataclass
class TrialSession:
    """The system side of one trial: robot, driver, belief, blending and the autonomy's turn.

    Advance it with :meth:`human_step` (one 10 Hz sample of the human's input) while
    ``turn == "human"`` and :meth:`autonomy_step` while ``turn == "autonomy"``, until
    ``finished``. Every step appends one raw row to ``rows``; :attr:`columns` gives them in the
    :mod:`nudgecli.steplog` schema.

    Parameters
    ----------
    spec
        The trial, its layout and its true goal.
    settings
        The protocol's knobs.
    model
        The agent's model of this participant in this layout (fitted tables, ``p(phi_m | g, s)``);
        ``None`` in an unassisted condition (no inference).
    handover_idle_steps
        Steps without a command (after the turn's first input) that hand the turn over.
    rng
        The agent's random stream (step sizes, Monte-Carlo D(s)).
    world
        The trial's world; ``None`` is the paper's grid world of ``spec.layout``.
    """

    spec: TrialSpec
    settings: ProtocolSettings
    model: DisambiguationModel | None
    handover_idle_steps: int
    rng: np.random.Generator
    x: float = 0.0
    y: float = 0.0
    theta: float = 0.0
    mode: int = 0
    step: int = 0
    turn: str = HUMAN_TURN
    reached: int = -1
    human_turns: int = 0
    autonomy_turns: int = 0
    nudges: int = 0
    human_switches: int = 0
    rows: list[tuple[Any, ...]] = field(default_factory=list)
    world: World | None = None
    # _policy_view, what its policy is handed (this session, live, read-only): a slot, since the view
    # shares __dict__ and would be a reference cycle there
    __slots__ = ("__dict__", "_policy_view")

    def __post_init__(self) -> None:
        if self.world is None:
            layout = self.spec.layout
            if not isinstance(layout, Layout):
                raise TypeError("a trial on a path layout needs its world (world=PathWorld(...))")
            self.world = GridWorld(layout, self.settings.success_distance, self.settings.success_angle)
        world = self.world
        self.policy = make_policy(self.spec.condition, self.settings)
        self._policy_view = read_only_view(self)
        self.assisted = bool(self.policy.infers)
        self.turn_taking = bool(self.policy.takes_turns)
        # the optional hook through which a policy answers a person's mode switch
        self.choose_mode = getattr(self.policy, "choose_mode", None)
        # and the optional one that answers a quiet run at once (without it: assist at each step)
        self.assist_quiet = getattr(self.policy, "assist_quiet", None)
        if self.assisted and self.model is None:
            raise ValueError(f"condition {self.spec.condition!r} needs the agent's model")
        n_goals = world.n_goals
        if not 0 <= self.spec.true_goal < n_goals:
            raise ValueError(f"true_goal {self.spec.true_goal} is not one of the layout's {n_goals} goals")
        self.x, self.y, self.theta = (float(v) for v in world.start_pose)
        self.measured = NO_INPUT  # this step's measured label and command (what a policy sees)
        self.u_h: Command = _ZERO3
        self.mode = int(world.start_mode)
        self.goal_poses = read_only_array(world.goal_poses)
        transition = goal_transition_matrix(n_goals, self.settings.goal_stay)
        self.goal_transition = None if transition is None else read_only_array(transition)
        self._set_belief(np.full(n_goals, 1.0 / n_goals))
        self._start_human_turn()

    # --- state --------------------------------------------------------------------------------

    @property
    def state(self) -> int:
        """The current discrete state (the world's: cell, heading and mode in the grid world)."""
        assert self.world is not None
        return self.world.state(self.x, self.y, self.theta, self.mode)

    @property
    def finished(self) -> bool:
        return self.reached >= 0 or self.step >= self.settings.time_limit_steps

    def _set_belief(self, belief: np.ndarray) -> None:
        """Replace the belief and refresh what depends on it only (most steps leave it alone)."""
        # read-only: a policy's view reads this session, and a write into view.belief would corrupt the
        # inference; one flag per update (every update makes a new array), not a copy per step
        belief.setflags(write=False)
        self.belief = belief
        self.entropy = float(normalised_entropy(belief))
        self.leader = unique_argmax(belief)
        # belief.max() of the values as floats (numpy's method wrapper cost more than the rule): a
        # positive largest is the same float; NaN and zeros (whose sign numpy picks) are numpy's own
        values = belief.tolist()
        top = max(values)
        if not top > 0.0 or any(value != value for value in values):
            top = float(belief.max())
        self.leader_probability = top

    # --- the human's turn ---------------------------------------------------------------------

    def _start_human_turn(self) -> None:
        self.turn = HUMAN_TURN
        self.human_turns += 1
        self.pending_events: Sequence[str] = [HANDOVER_TO_HUMAN if self.step > 0 else TRIAL_START]
        self.initiated_at = -1  # step of the turn's first measured input
        self.idle = 0  # steps without a command since then
        self.locked = False  # a hard label switched the mode: no command until the blow ends
        self.blow_label = NO_INPUT  # the last measured label of the current blow
        self.decay_counters = DecayCounters()

    def human_step(self, intended: int, pressure: float) -> None:
        """One 10 Hz step of the human's turn with this input sample.

        Parameters
        ----------
        intended
            The intended label (0-3) or ``NO_INPUT`` (recorded only: the agent never sees it).
        pressure
            The signed pressure of the sample, in ``[-1, 1]``.
        """
        # locals instead of attribute reads, the row appended inline: this runs every step
        s, world, step = self.settings, self.world, self.step
        assert world is not None
        if self.turn != HUMAN_TURN or self.reached >= 0 or step >= s.time_limit_steps:  # finished
            raise RuntimeError("human_step outside a running human turn")
        events = self.pending_events
        if events:
            self.pending_events = _NO_EVENTS
        x, y, theta, mode_before = self.x, self.y, self.theta, self.mode
        state = world.state(x, y, theta, mode_before)
        measured = interface.label_of_pressure(pressure, s.soft_threshold, s.hard_threshold, s.zero_threshold)
        if measured != NO_INPUT and self.initiated_at < 0:
            self.initiated_at = step
        if self.assisted:
            # _observe's two commonest steps written out: a held blow's label again (no new event)
            # and no input without forgetting
            if measured == self.blow_label and 0 <= measured < 4 and s.update != "sample":
                self.decay_counters = _NO_DECAY
            elif measured == NO_INPUT and s.decay is None:
                self.blow_label = NO_INPUT
            else:
                self._observe(measured, state)
        u_h = _ZERO3
        commanded = False
        if measured == NO_INPUT:
            self.locked = False  # the driver's "input stopped" unlocks switching
        elif measured in (SOFT_PUFF, SOFT_SIP) and not self.locked:
            u_h = interface.human_command(measured, mode_before, s.human_speed, s.human_turn_rate)
            commanded = True
        elif measured in (HARD_PUFF, HARD_SIP) and not self.locked:
            requested = interface.switch_mode(mode_before, measured)
            # a policy that answers mode switches (a request for its choice) may send it elsewhere
            chosen = self.choose_mode(self._policy_view, requested) if self.choose_mode is not None else None
            self.mode = requested if chosen is None else chosen
            self.locked = True
            self.human_switches += 1
            commanded = True
            events = [*events, MODE_SWITCH_HUMAN]
            if chosen is not None:
                events.append(MODE_SELECT)
        initiated_at = self.initiated_at
        self.idle = 0 if commanded or initiated_at < 0 else self.idle + 1
        self.measured, self.u_h = measured, u_h
        u_f, u_a, alpha, inferred = self.policy.assist(self._policy_view)
        # _record's row, written out
        self.rows.append((step, HUMAN_TURN, x, y, theta, mode_before, state, intended, pressure, measured,
                          u_h, u_a, alpha, inferred, self.belief, self.entropy, events))
        self.x, self.y, self.theta = world.move(x, y, theta, u_f, s.dt)
        self.step = step = step + 1
        if initiated_at >= 0:
            self.reached = world.goal_reached(self.x, self.y, self.theta)
            if self.reached >= 0:
                return
            # _hand_over_when_idle, written out (not reached: finished only at the time limit)
            if self.turn_taking and self.idle >= self.handover_idle_steps and step < s.time_limit_steps:
                self._start_autonomy_turn()

    def _hand_over_when_idle(self) -> None:
        """The turn passes to the autonomy once the person has been idle for long enough."""
        if (self.turn_taking and self.initiated_at >= 0 and self.idle >= self.handover_idle_steps
                and not self.finished):
            self._start_autonomy_turn()

    def quiet_human_steps(self, limit: int) -> int:
        """Up to ``limit`` steps of the human's turn without input (each what ``human_step(NO_INPUT,
        0.0)`` does) while the robot stands; how many ran: at least one, fewer where the turn ends."""
        s, world = self.settings, self.world
        assert world is not None
        pose = (self.x, self.y, self.theta)
        self.human_step(NO_INPUT, 0.0)
        # the rest at once only where just the step, the idle count and alpha change: no input is
        # measured, no decay, the robot stands (the grid world's move is pure, so it may be asked)
        measured = interface.label_of_pressure(0.0, s.soft_threshold, s.hard_threshold, s.zero_threshold)
        if (limit <= 1 or self.turn != HUMAN_TURN or self.finished or measured != NO_INPUT
                or (s.decay is not None and self.initiated_at >= 0)
                or (self.x, self.y, self.theta) != pose or not isinstance(world, GridWorld)
                or world.move(*pose, _ZERO3, s.dt) != pose):
            return 1
        state, counting = world.state(*pose, self.mode), self.initiated_at >= 0
        steps = min(limit - 1, s.time_limit_steps - self.step)
        if self.turn_taking and counting:  # it passes at the step whose idle count reaches the threshold
            steps = min(steps, self.handover_idle_steps - self.idle)
        self.measured, self.u_h = NO_INPUT, _ZERO3
        if steps <= 0:
            ran = 0
        elif self.assist_quiet is None:
            ran = self._quiet_steps_one_by_one(steps, state, counting)
        else:
            ran = self._quiet_runs(self.assist_quiet(self._policy_view, steps), steps, state, counting)
        self._hand_over_when_idle()
        return 1 + ran

    def _quiet_steps_one_by_one(self, steps: int, state: int, counting: bool) -> int:
        """Up to ``steps`` quiet steps (see :meth:`quiet_human_steps`), the policy's ``assist`` asked
        at each; how many ran (it stops before a step whose command moves the robot)."""
        # what no step of the run changes, read once (the pose, mode and belief stand; the policy
        # sees the step and the idle count move)
        assist, append, view = self.policy.assist, self.rows.append, self._policy_view
        x, y, theta, mode, belief, entropy = self.x, self.y, self.theta, self.mode, self.belief, self.entropy
        step = self.step
        ran = 0
        while ran < steps:
            u_f, u_a, alpha, inferred = assist(view)
            if u_f is not _ZERO3 and any(u_f):  # the policy moves the robot: the steps run one by one
                break
            # _record's row, written out
            append((step, HUMAN_TURN, x, y, theta, mode, state, NO_INPUT, 0.0, NO_INPUT, _ZERO3, u_a, alpha,
                    inferred, belief, entropy, _NO_EVENTS))
            self.step = step = step + 1
            self.idle += counting
            ran += 1
        return ran

    def _quiet_runs(self, runs: Iterable[QuietRun], steps: int, state: int, counting: bool) -> int:
        """Up to ``steps`` quiet steps (see :meth:`quiet_human_steps`) as the policy's
        ``assist_quiet`` answered them (``(count, assistance)`` in step order); how many ran (it
        stops before a stretch whose command moves the robot)."""
        x, y, theta, mode, belief, entropy = self.x, self.y, self.theta, self.mode, self.belief, self.entropy
        first = step = self.step
        end = first + steps
        for count, (u_f, u_a, alpha, inferred) in runs:
            if count < 1:
                raise ValueError(f"assist_quiet of {self.spec.condition!r} gave a stretch of {count} steps")
            if u_f is not _ZERO3 and any(u_f):  # the policy moves the robot: the steps run one by one
                break
            stop = min(step + count, end)
            # _record's rows, written out: a stretch's rows differ in the step only
            self.rows.extend([(k, HUMAN_TURN, x, y, theta, mode, state, NO_INPUT, 0.0, NO_INPUT, _ZERO3, u_a,
                               alpha, inferred, belief, entropy, _NO_EVENTS) for k in range(step, stop)])
            step = stop
            if step == end:
                break
        self.step = step
        if counting:
            self.idle += step - first
        return step - first

    def _observe(self, measured: int, state: int) -> None:
        """The Bayesian update (Eq. 7) with the state the label was produced in, or forgetting."""
        s = self.settings
        assert self.model is not None
        if 0 <= measured < 4:
            new_event = s.update == "sample" or measured != self.blow_label
            self.blow_label = measured
            self.decay_counters = _NO_DECAY  # counters restart (frozen: one instance serves every step)
            if new_event:
                likelihood = self.model.label_likelihood(state, measured)
                self._set_belief(bayes_update(self.belief, likelihood, self.goal_transition))
            return
        if measured == NO_INPUT:
            self.blow_label = NO_INPUT  # the blow ended
        if s.decay is not None and self.initiated_at >= 0:
            decayed, self.decay_counters = decay_on_empty_sample(self.belief, self.decay_counters, s.decay)
            if decayed is not self.belief:
                self._set_belief(decayed)

    # --- the autonomy's turn ------------------------------------------------------------------

    def _start_autonomy_turn(self) -> None:
        """The policy chooses what its turn does (Algorithm 1, lines 10-15, for the paper's two)."""
        plan = self.policy.start_turn(self._policy_view)
        self.turn = AUTONOMY_TURN
        self.autonomy_turns += 1
        events = [HANDOVER_TO_AUTONOMY, *plan.events]
        if plan.mode is not None and plan.mode != self.mode:
            self.mode = plan.mode
            events.append(MODE_SWITCH_AUTONOMY)
        self.nudges += plan.nudge
        self.autonomy_target = plan.target
        # the target as plain floats, once per turn (each of its steps reads it)
        self._target_pose = (None if plan.target is None else
                             (float(plan.target[0]), float(plan.target[1]), float(plan.target[2])))
        self.autonomy_inferred = plan.goal
        self.pending_events = events

    def autonomy_step(self) -> None:
        """One 10 Hz step of the autonomy's turn (at least one step; it ends at the target)."""
        if self.turn != AUTONOMY_TURN or self.finished:
            raise RuntimeError("autonomy_step outside a running autonomy turn")
        s, world = self.settings, self.world
        assert world is not None
        target = self._target_pose
        events, self.pending_events = self.pending_events, _NO_EVENTS
        x, y, theta, mode = self.x, self.y, self.theta, self.mode
        if target is None:  # a turn that does not move: one step
            u_a = _ZERO3
        else:
            u_a = assistance.autonomy_command(x, y, theta, target[0], target[1], target[2], s.autonomy_speed,
                                              s.autonomy_turn_rate, s.dt)
        # _record's row and _move, written out (every step of the autonomy's turn)
        state = world.state(x, y, theta, mode)
        self.rows.append((self.step, AUTONOMY_TURN, x, y, theta, mode, state, NO_INPUT, 0.0, NO_INPUT, _ZERO3,
                          u_a, 0.0, self.autonomy_inferred, self.belief, self.entropy, events))
        x, y, theta = world.move(x, y, theta, u_a, s.dt)
        self.x, self.y, self.theta = x, y, theta
        self.step += 1
        arrived = target is None or math.hypot(target[0] - x, target[1] - y) <= s.arrival_tolerance
        if arrived and not self.finished:
            self._start_human_turn()

    # --- shared helpers -----------------------------------------------------------------------

    def _move(self, velocity: Command) -> None:
        assert self.world is not None
        self.x, self.y, self.theta = self.world.move(self.x, self.y, self.theta, velocity, self.settings.dt)

    def _record(self, turn: str, state: int, mode: int, intended: int, pressure: float, measured: int,
                u_h: Command, u_a: Command, alpha: float, inferred: int, events: Sequence[str]) -> None:
        """Append one step: the pose, cell and mode at the start of the step, what happened in it.

        The row is kept raw (a tuple; the belief array is never changed in place, only replaced)
        (:data:`~nudgecli.sim.step_record.ROW_FIELDS`) and put into the schema's columns once, by
        :attr:`columns`.
        """
        self.rows.append((self.step, turn, self.x, self.y, self.theta, mode, state, intended, pressure,
                          measured, u_h, u_a, alpha, inferred, self.belief, self.entropy, events))

    def recording(self, names: Collection[str] = STEP_COLUMNS) -> StepRecording:
        """The steps so far, raw, as the step log's columns ``names`` need them
        (:func:`~nudgecli.sim.step_record.step_columns` makes the log of them)."""
        spec, world = self.spec, self.world
        assert world is not None
        return StepRecording.of_rows(self.rows, spec.participant, spec.trial, self.settings.dt, world.cells,
                                     names)

    @property
    def columns(self) -> dict[str, np.ndarray | list[Any]]:
        """The steps so far as the step log's columns (:data:`~nudgecli.steplog.STEP_COLUMNS`)."""
        return step_columns([self.recording()])

    # --- the trial's end ----------------------------------------------------------------------

    def summary(self) -> dict[str, Any]:
        """The trial table's row."""
        spec, true_goal = self.spec, self.spec.true_goal
        return {
            "participant": spec.participant,
            "condition": spec.condition,
            "block": spec.block,
            "trial": spec.trial,
            "layout": spec.layout_index,
            "n_goals": spec.layout.n_goals,
            "true_goal": true_goal,
            "reached_goal": self.reached,
            "success": self.reached == true_goal,
            "timed_out": self.reached < 0,
            "duration_s": round(self.step * self.settings.dt, 10),
            "steps": self.step,
            "human_turns": self.human_turns,
            "autonomy_turns": self.autonomy_turns,
            "nudges": self.nudges,
            "human_mode_switches": self.human_switches,
            "final_x": self.x,
            "final_y": self.y,
            "final_theta": self.theta,
            "final_belief_true_goal": float(self.belief[true_goal]),
            "final_entropy": self.entropy,
        }
