"""The built-in assistance policies, each an implementation of :class:`~nudgecli.sim.policy_interface.Policy`.

============== ============ =========== ===================================================
policy         inference    turn-taking what the assistance does
============== ============ =========== ===================================================
disambiguation Eq. 7        yes         blends in the human's turn; nudges to s* (Eq. 16)
control        Eq. 7        yes         blends; steps towards the mean of the tied leaders
turn-taking    Eq. 7        yes         blends; its turn does nothing (the control that
                                        isolates what an autonomy turn adds)
teleoperation  none         no          nothing (the person's turn is the whole trial)
blending       Eq. 7        no          blends towards g' (Dragan & Srinivasa, 2013), convex
                                        or additive (ADA's blend)
mode-switch    Eq. 7        yes         blends; in its turn changes the mode only, by a
                                        named criterion (:func:`select_mode`)
hindsight      Eq. 7        no          adds sum_g b_g u_a^g (Javdani et al. 2015/2018 as
                                        ADA's code computes it)
============== ============ =========== ===================================================

The CIAA study's ``no_assistance`` condition is the teleoperation policy under the study's name.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from nudgecli.model import assistance, hindsight, mode_criteria, policies
from nudgecli.model.disambiguation import disambiguation_scores, maximally_disambiguating_state
from nudgecli.model.interface import NO_COMMAND
from nudgecli.sim.policy_interface import Assistance, AtStep, AutonomyTurn, QuietRun, StepView
from nudgecli.steplog import MODE_SELECT, NO_GOAL, NUDGE, STEP

if TYPE_CHECKING:
    from nudgecli.sim.protocol import ProtocolSettings

_NO_POSE = (math.nan,) * 4


class FloatGoals:
    """The trial's goal poses as plain floats, made at a policy's first step (numpy scalars cost
    more than the arithmetic they feed, every step; a policy lives for one trial)."""

    _goals: list[tuple[float, float, float]] | None = None

    def goals(self, view: StepView) -> list[tuple[float, float, float]]:
        """``(G,)`` goal poses as ``(x, y, theta)`` float triples."""
        goals = self._goals
        if goals is None:
            goals = self._goals = [(float(x), float(y), float(t)) for x, y, t in view.goal_poses]
        return goals


class PaperBlending(FloatGoals):
    """The paper's blending in the human's turn (Algorithm 1, line 8): ``u_f = alpha u_a + (1 -
    alpha) u_h`` towards ``g' = argmax b`` while the person's command is non-zero, alpha by the one
    alpha rule (:func:`nudgecli.model.assistance.assistance_alpha`); no ``g'`` (alpha 0) when two or
    more goals tie for the highest belief. Its autonomy turn is the subclasses'."""

    infers = True
    takes_turns = True

    def __init__(self, settings: ProtocolSettings) -> None:
        self.settings = settings
        # the command of the last step and what it was computed for: the robot often stands
        self._last: tuple[tuple[float, ...], tuple[float, float, float]] = (_NO_POSE, NO_COMMAND)

    def goal_and_alpha(self, view: StepView) -> tuple[int, float]:
        """``(g', alpha)`` of this step (``-1, 0`` without a unique, ungated leader)."""
        s = self.settings.blending
        leader = view.leader
        if leader == NO_GOAL or assistance.entropy_gated(view.entropy, s.entropy_gate):
            return NO_GOAL, 0.0
        goals = self.goals(view)
        gx, gy, _ = goals[leader]
        since_first = ((view.step - view.initiated_at) * self.settings.dt if view.initiated_at >= 0
                       else -math.inf)
        alpha = assistance.assistance_alpha(view.leader_probability, len(goals), view.entropy,
                                            since_first, math.hypot(gx - view.x, gy - view.y), s)
        return leader, alpha

    def goal_command(self, view: StepView, goal: int) -> tuple[float, float, float]:
        """``u_a``: the autonomy's command towards ``goal``'s pose (remembered while the robot stands)."""
        towards = (view.x, view.y, view.theta, goal)
        if towards == self._last[0]:
            return self._last[1]
        s = self.settings
        u_a = assistance.autonomy_command(view.x, view.y, view.theta, *self.goals(view)[goal],
                                          s.autonomy_speed, s.autonomy_turn_rate, s.dt)
        self._last = (towards, u_a)
        return u_a

    def assist(self, view: StepView) -> Assistance:
        # goal_and_alpha and goal_command written out: every step of a person's turn runs this,
        # and the calls cost more than the rule (assist_quiet relies on it reading the step only
        # through alpha's start-up gate: keep it so, here and in Blending.assist)
        settings = self.settings
        s = settings.blending
        leader = view.leader
        u_h = view.u_h
        gate = s.entropy_gate  # assistance.entropy_gated, written out
        if leader == NO_GOAL or (gate is not None and view.entropy > gate):
            inferred, alpha, u_a = NO_GOAL, 0.0, NO_COMMAND
        else:
            inferred = leader
            x, y, theta = view.x, view.y, view.theta
            goals = self._goals
            if goals is None:
                goals = self.goals(view)
            gx, gy, gtheta = goals[leader]
            initiated_at = view.initiated_at
            since_first = (view.step - initiated_at) * settings.dt if initiated_at >= 0 else -math.inf
            alpha = assistance.assistance_alpha(view.leader_probability, len(goals), view.entropy,
                                                since_first, math.hypot(gx - x, gy - y), s)
            towards = (x, y, theta, leader)
            last_towards, u_a = self._last
            if towards != last_towards:
                u_a = assistance.autonomy_command(x, y, theta, gx, gy, gtheta, settings.autonomy_speed,
                                                  settings.autonomy_turn_rate, settings.dt)
                self._last = (towards, u_a)
        # blending acts only on a motion command (a mode switch or no input leaves the robot still)
        # (u_h is the tuple of a soft label's command or NO_COMMAND itself)
        u_f = assistance.blend_command(u_a, u_h, alpha) if u_h is not NO_COMMAND else u_h  # type: ignore[arg-type]
        # Assistance(...) without its constructor's keyword handling (every step makes one)
        return tuple.__new__(Assistance, (u_f, u_a, alpha, inferred))

    def assist_quiet(self, view: StepView, steps: int) -> tuple[QuietRun, ...]:
        """:meth:`assist` at each of ``steps`` steps from ``view.step`` on where only the step
        moves. Of the view, :meth:`assist` reads the step only through the start-up gate of alpha
        (:func:`nudgecli.model.assistance.assistance_alpha`): the run is one assistance, or two
        where the gate opens inside it (the second :meth:`assist` at the step it opens)."""
        first = self.assist(view)
        s, initiated_at = self.settings, view.initiated_at
        if initiated_at < 0 or not s.blending.startup_delay > 0.0:  # no gate, or closed throughout
            return ((steps, first),)
        opens = assistance.startup_delay_end(initiated_at, s.dt, s.blending.startup_delay)
        if not view.step < opens < view.step + steps:
            return ((steps, first),)
        return ((opens - view.step, first), (view.step + steps - opens, self.assist(AtStep(view, opens))))

    def start_turn(self, view: StepView) -> AutonomyTurn:
        return AutonomyTurn.stay()


def bounded_step(view: StepView, goal: int) -> AutonomyTurn:
    """A step of a random size ``R' = min(R, D / 2)`` towards ``goal``'s pose, or, with ``goal`` -1,
    towards the mean position of the goals tied for the highest belief, heading kept (Algorithm 1,
    lines 13-15; the paper's Control)."""
    radius = assistance.draw_step_size(view.rng, view.settings.window)
    if goal != NO_GOAL:
        goal_xy = view.goal_poses[goal, :2]
        heading = float(view.goal_poses[goal, 2])
    else:
        goal_xy = assistance.control_target(view.belief, view.goal_poses[:, :2])
        heading = view.theta
    step_xy = assistance.step_target(np.array([view.x, view.y]), goal_xy, radius)
    return AutonomyTurn(np.array([step_xy[0], step_xy[1], heading]), None, (STEP,), goal)


class Disambiguation(PaperBlending):
    """The paper's Disambiguation condition: in its turn, a nudge to s* (Eq. 16) while the
    normalised entropy exceeds kappa, else a bounded step towards ``g'`` (the tied goals' mean
    when the leaders tie)."""

    def start_turn(self, view: StepView) -> AutonomyTurn:
        s = self.settings
        assert view.model is not None
        if view.entropy > s.kappa:
            choice = maximally_disambiguating_state(view.belief, view.model, view.state, s.disambiguation,
                                                    robot_position=np.array([view.x, view.y]), rng=view.rng,
                                                    goal_transition=view.goal_transition)
            target, mode = assistance.nudge_target(choice.state)
            return AutonomyTurn(target, mode, (NUDGE,), NO_GOAL, nudge=True)
        return bounded_step(view, view.leader)


class Control(PaperBlending):
    """The paper's Control condition: in its turn, a bounded step towards the mean of the goals
    tied for the highest belief."""

    def start_turn(self, view: StepView) -> AutonomyTurn:
        return bounded_step(view, NO_GOAL)


class TurnTaking(PaperBlending):
    """The paper's protocol (blending, the person's idle handover) whose autonomy turn does
    nothing: one step without motion, then the person's turn again. Against it, a condition's
    difference is what its autonomy turn adds."""


class Blending(PaperBlending):
    """Policy blending without turn-taking (Dragan & Srinivasa 2013): the person's turn is the
    whole trial.

    ``[blending] kind``: ``convex`` blends with the paper's alpha (``u_f = alpha u_a + (1 - alpha)
    u_h``, ``u_a`` at the autonomy's speed) on steps with a motion command, zeroed unless the
    confidence gap ``p1 - p2`` exceeds ``gap`` when ``gate = "gap"``: a hybrid of the paper's ramp
    and ADA's gate, this toolkit's choice. ``additive`` is ADA's own blend
    (``AdaAssistancePolicy.get_blend_action``): every step while the gate passes (one goal always
    passes), the most likely goal's whole Huber-cost assistance
    (:func:`nudgecli.model.hindsight.goal_command`, with ``[hindsight]``'s ``strength`` and ``zone``
    as in ADA, whose blend and hindsight share it) is added to the person's command (alpha 1).
    """

    takes_turns = False

    def __init__(self, settings: ProtocolSettings) -> None:
        super().__init__(settings)
        self.additive = settings.blending_kind == "additive"

    def assist(self, view: StepView) -> Assistance:
        gap = self.settings.blending_gap
        if self.additive:  # AdaAssistancePolicy.get_blend_action: every step, input or not
            u_h = view.u_h
            goal = hindsight.ada_blend_goal(view.belief, gap)
            if goal == NO_GOAL:
                return Assistance(u_h, NO_COMMAND, 0.0, view.leader)
            # that goal's whole Huber-cost assistance, evaluated after the person's command
            s = self.settings
            u_a = hindsight.goal_command(view.x, view.y, view.theta, self.goals(view)[goal], s.hindsight,
                                         s.dt, tuple(u_h))  # type: ignore[arg-type]
            return Assistance.additive(u_h, u_a, goal)
        inferred, alpha = self.goal_and_alpha(view)
        if gap is not None:
            alpha = policies.gap_gated_alpha(alpha, view.belief, gap)
        u_a = self.goal_command(view, inferred) if inferred != NO_GOAL else NO_COMMAND
        u_h = view.u_h
        u_f = assistance.blend_command(u_a, u_h, alpha) if u_h is not NO_COMMAND else u_h  # type: ignore[arg-type]
        return Assistance(u_f, u_a, alpha, inferred)


class Teleoperation:
    """No assistance: no inference, no blending, no autonomy (the CIAA study's ``no_assistance``)."""

    infers = False
    takes_turns = False

    def __init__(self, settings: ProtocolSettings) -> None:
        self.settings = settings

    def assist(self, view: StepView) -> Assistance:
        return Assistance(view.u_h)

    def assist_quiet(self, view: StepView, steps: int) -> tuple[QuietRun, ...]:
        """:meth:`assist` of a quiet run: the person's command (none) throughout."""
        return ((steps, self.assist(view)),)

    def start_turn(self, view: StepView) -> AutonomyTurn:
        return AutonomyTurn.stay()


class ModeSwitch(PaperBlending):
    """Mode-switch assistance (after Gopinath & Argall 2017): blends in the person's turn and
    selects modes by ``[mode-switch] criterion``, never moving the robot itself.

    ``[mode-switch] trigger``: ``handover`` (the paper's turn-taking): the autonomy's turn is one
    step that switches to the mode ranked best (event ``mode_select``, with
    ``mode_switch_autonomy`` when the mode changes). ``request`` (Gopinath & Argall's button, here
    the person's own mode-switch blow): no turns; each mode switch the person makes goes to the
    mode ranked best among the other two (:meth:`choose_mode`).
    """

    def __init__(self, settings: ProtocolSettings) -> None:
        super().__init__(settings)
        self.takes_turns = settings.mode_trigger == "handover"

    def start_turn(self, view: StepView) -> AutonomyTurn:
        return AutonomyTurn(None, select_mode(view, self.settings.mode_criterion), (MODE_SELECT,))

    def choose_mode(self, view: StepView, requested: int) -> int | None:
        """The mode a person's switch (to ``requested``) goes to: with ``trigger = "request"`` the
        criterion's best mode other than the current one, else ``None`` (the person's own)."""
        if self.takes_turns:
            return None
        return select_mode(view, self.settings.mode_criterion, requested)


#: What a mode switch costs Herlant et al.'s time-optimal plan: a hard blow and the reaction
#: before it, about 1 s for real sip-and-puff users (data/ciaa-task/HABITS.md, "a stop to the next
#: switch"). In this world each mode moves one axis, so it orders nothing but the choice to switch.
HERLANT_SWITCH_TIME_S = 1.0


def select_mode(view: StepView, criterion: str, requested: int | None = None) -> int:
    """The mode ``criterion`` chooses over the states that differ from the current one in mode
    alone (the current mode wins ties, then the first in mode order x, y, theta); on a person's
    request to switch (``requested``: the mode their blow asked for) the current mode is not a
    choice.

    - ``paper-mi``: the seed paper's D(s) (Eq. 15) over those states; its distance term is the
      same for each, so this is Eq. 13's mutual information.
    - ``gopinath2017``: Gopinath & Argall's disambiguation metric of beliefs projected 1 s and 2 s
      along each mode's motion (:func:`nudgecli.model.mode_criteria.gopinath_disambiguation`), one
      update per 0.1 s (the MATLAB's), not per step of the study.
    - ``gopinath2017-kl``: its KL variant, KL(belief projected 1 s || current belief).
    - ``herlant2016``: the mode the time-optimal plan to ``g'`` uses next (Herlant et al. 2016);
      without a unique ``g'`` the mode is kept. On a request: the plan's first dimension other
      than the current mode's, or the requested mode when the plan needs no other.
    """
    s = view.settings
    assert view.model is not None
    keep = view.mode if requested is None else requested  # what no better choice leaves
    if criterion == "herlant2016":
        if view.leader == NO_GOAL:
            return keep
        speeds = np.array([s.human_speed, s.human_speed, s.human_turn_rate])
        tolerance = np.array([s.success_distance, s.success_distance, s.success_angle])
        _, order = mode_criteria.herlant_time_optimal_plan(np.array([view.x, view.y, view.theta]),
                                                           view.goal_poses[view.leader], view.mode, speeds,
                                                           HERLANT_SWITCH_TIME_S, tolerance)
        if requested is not None:
            order = tuple(mode for mode in order if mode != view.mode)
        return order[0] if order else keep
    mode_only = replace(s.disambiguation, scope="mode-only")
    candidates = view.model.candidates(view.state, mode_only, np.array([view.x, view.y]))
    if criterion == "paper-mi":  # D(s), Eq. 15, over the mode-only states (in mode order)
        score = disambiguation_scores(view.belief, view.model, candidates, mode_only, view.rng,
                                      view.goal_transition).score
        return _best_mode(score, view.mode, requested)
    likelihood = view.model.likelihood[:, candidates.states, :].transpose(1, 0, 2)  # (M, G, F)

    def projected(horizon_s: float) -> np.ndarray:
        # the MATLAB's loop: one update per 0.1 s of the horizon whatever the study's step rate
        steps = mode_criteria.horizon_steps(horizon_s, mode_criteria.GOPINATH_PROJECTION_DT_S)
        return mode_criteria.project_beliefs(view.belief, likelihood, steps=steps,
                                             goal_transition=view.goal_transition)

    if criterion == "gopinath2017":
        score = mode_criteria.gopinath_disambiguation(projected(mode_criteria.GOPINATH_SHORT_HORIZON_S),
                                                      projected(mode_criteria.GOPINATH_LONG_HORIZON_S))
    else:  # gopinath2017-kl
        score = mode_criteria.projected_kl(projected(mode_criteria.GOPINATH_KL_HORIZON_S), view.belief)
    return _best_mode(score, view.mode, requested)


def _best_mode(scores: np.ndarray, mode: int, requested: int | None) -> int:
    """:func:`~nudgecli.model.mode_criteria.choose_mode` of ``(M,)`` scores in mode order; on a
    request the current mode is out of the choice."""
    if requested is None:
        return mode_criteria.choose_mode(scores, mode)
    others = np.array(scores, dtype=float)
    others[mode] = -np.inf
    return mode_criteria.choose_mode(others, requested)


class Hindsight(FloatGoals):
    """First-order hindsight optimisation (Javdani et al. 2015/2018) as the authors' open code
    computes it (``AssistancePolicy.get_assisted_action``): the belief-weighted sum of each goal's
    Huber-cost assistance (:func:`nudgecli.model.hindsight.hindsight_command`, evaluated after the
    person's command for the source's 0.1 s) added to the person's command; no turn-taking.
    ``[hindsight] assist = "always"`` (the source) adds it every step, ``"on-command"`` only on
    steps with a motion command. alpha is 1 on the steps it acts (additive: the whole sum is added)."""

    infers = True
    takes_turns = False

    def __init__(self, settings: ProtocolSettings) -> None:
        self.settings = settings
        self.on_command = settings.hindsight_assist == "on-command"

    def assist(self, view: StepView) -> Assistance:
        u_h = view.u_h
        if self.on_command and u_h is NO_COMMAND:
            return Assistance(u_h, NO_COMMAND, 0.0, view.leader)
        s = self.settings
        u_a = hindsight.hindsight_command(view.x, view.y, view.theta, self.goals(view), view.belief,
                                          s.hindsight, s.dt, tuple(u_h))  # type: ignore[arg-type]
        return Assistance.additive(u_h, u_a, view.leader)

    def assist_quiet(self, view: StepView, steps: int) -> tuple[QuietRun, ...]:
        """:meth:`assist` of a quiet run, one assistance throughout: it reads the pose, the belief
        and the person's command, never the step."""
        return ((steps, self.assist(view)),)

    def start_turn(self, view: StepView) -> AutonomyTurn:
        return AutonomyTurn.stay()


#: The built-in policies by name (a condition names one, or its alias; ``nudgecli.model.conditions``).
BUILTIN_POLICIES: dict[str, type] = {
    "disambiguation": Disambiguation,
    "control": Control,
    "turn-taking": TurnTaking,
    "teleoperation": Teleoperation,
    "blending": Blending,
    "mode-switch": ModeSwitch,
    "hindsight": Hindsight,
}
