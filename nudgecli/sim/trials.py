"""Running one trial: a :class:`~nudgecli.sim.protocol.TrialSession` driven to its end by an
input source (a simulated person in the grid world or another world, or a live one)."""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from nudgecli.model.disambiguation import DisambiguationModel
from nudgecli.model.interface import NO_INPUT
from nudgecli.model.mdp import SolvedLayout
from nudgecli.model.world import N_MODES, GridWorld, Layout, World, state_index
from nudgecli.sim.behaviour import InputSource, SimulatedPerson
from nudgecli.sim.participants import Participant
from nudgecli.sim.protocol import ProtocolSettings, TrialSession, TrialSpec
from nudgecli.sim.step_record import StepRecording, step_columns
from nudgecli.steplog import HUMAN_TURN, STEP_COLUMNS


@dataclass
class TrialResult:
    """One trial's summary row and its steps, raw (:attr:`steps`: the step log's columns of them)."""

    summary: dict[str, Any]
    recording: StepRecording
    #: The step log's columns :attr:`steps` keeps.
    step_log_columns: Collection[str] = field(default=STEP_COLUMNS)

    @cached_property
    def steps(self) -> dict[str, np.ndarray | list[Any]]:
        """The trial's step log columns (a participant's are made at once, of all their recordings)."""
        return step_columns([self.recording], self.step_log_columns)


def run_session(session: TrialSession, source: InputSource,
                step_log_columns: Collection[str] = STEP_COLUMNS, quiet_runs: bool = True) -> TrialResult:
    """Run a trial to its end with ``source`` giving the human's input; the result keeps the step
    log's columns ``step_log_columns``. ``quiet_runs=False`` asks a simulated person for every
    step (the same steps, slower: for the test that holds the quiet runs to it)."""
    new_turn = True
    after_autonomy = False
    # a simulated person says when they will give no input for a while: those steps run at once
    person = source if quiet_runs and isinstance(source, SimulatedPerson) else None
    # the bound methods and the end rule (TrialSession.finished) read once: the loop runs every step
    next_input, human_step, autonomy_step = source.next_input, session.human_step, session.autonomy_step
    time_limit = session.settings.time_limit_steps
    gave_input = False  # right after a step with input no quiet run starts (SimulatedPerson.quiet_steps)
    while session.reached < 0 and session.step < time_limit:
        if session.turn == HUMAN_TURN:
            if new_turn:
                source.start_turn(after_autonomy)
                new_turn = gave_input = False
            if person is not None and not gave_input and (quiet := person.quiet_steps(session)) > 1:
                pose, mode = (session.x, session.y, session.theta), session.mode
                person.skip_quiet(session.quiet_human_steps(quiet), pose, mode)
                continue
            intended, pressure = next_input(session)
            gave_input = intended != NO_INPUT
            human_step(intended, pressure)
        else:
            autonomy_step()
            new_turn = after_autonomy = True
    return TrialResult(session.summary(), session.recording(step_log_columns), step_log_columns)


def run_trial(spec: TrialSpec, settings: ProtocolSettings, solved: SolvedLayout, model: DisambiguationModel,
              participant: Participant, rng: np.random.Generator,
              step_log_columns: Collection[str] = STEP_COLUMNS, *,
              person_policy: np.ndarray | None = None) -> TrialResult:
    """Simulate one trial with a simulated participant.

    Parameters
    ----------
    spec
        The trial, its layout and its true goal.
    settings
        The protocol's knobs (from the experiment).
    solved
        The layout's goal MDPs as the agent's model solves them (``[model]``).
    model
        The agent's model of this participant in this layout (fitted tables, ``p(phi_m | g, s)``).
    participant
        The simulated person (true physiology and habits).
    rng
        This trial's random stream; the person and the agent each get a child stream of it.
    step_log_columns
        The step log's columns the result keeps (all by default).
    person_policy
        ``(G, S)`` the policy of the participant's own plan (their task costs, ``[behaviour]``
        ``plan_*``), of which they act on their goal's row; ``None``: ``solved.policy`` (their costs
        are the agent's).

    Returns
    -------
    TrialResult
    """
    layout, goal = spec.layout, spec.true_goal
    if not isinstance(layout, Layout):
        raise TypeError("run_trial simulates the grid world; use run_world_trial for another world")
    goal_cell = int(state_index(int(layout.goal_cells[goal, 0]), int(layout.goal_cells[goal, 1]),
                                int(layout.goal_headings[goal]), 0)) // N_MODES
    world = GridWorld(layout, settings.success_distance, settings.success_angle)
    policy = solved.policy if person_policy is None else person_policy
    return run_world_trial(spec, settings, world, policy[goal], goal_cell, model, participant, rng,
                           step_log_columns)


def run_world_trial(spec: TrialSpec, settings: ProtocolSettings, world: World, policy: np.ndarray,
                    goal_cell: int, model: DisambiguationModel | None, participant: Participant,
                    rng: np.random.Generator,
                    step_log_columns: Collection[str] = STEP_COLUMNS) -> TrialResult:
    """Simulate one trial in ``world`` with a simulated participant.

    Parameters
    ----------
    spec, settings, model, participant, rng, step_log_columns
        As for :func:`run_trial` (``model`` is ``None`` in an unassisted condition).
    world
        The trial's world (made for this trial: it may keep per-trial state).
    policy
        ``(S,)`` the optimal task action per discrete state of ``world`` for the true goal.
    goal_cell
        The goal's discrete cell (``state // N_MODES``) for fine positioning, or -1 for none.

    Returns
    -------
    TrialResult
    """
    person_rng, agent_rng = rng.spawn(2)
    goal = spec.true_goal
    session = TrialSession(spec, settings, model, handover_steps(participant.handover_idle_s, settings.dt),
                           agent_rng, world=world)
    # the person hands the turn over only where there is an autonomy's turn to hand it to
    person = SimulatedPerson(participant, settings.behaviour, policy, world.goal_poses[goal], goal_cell,
                             person_rng, world=world, hands_over=session.turn_taking)
    return run_session(session, person, step_log_columns)


def handover_steps(handover_idle_s: float, dt: float) -> int:
    """Idle steps that hand the turn over: the turn passes once the idle count reaches this, after
    ``handover_idle_s`` without a command (to the nearest step)."""
    return max(1, round(handover_idle_s / dt))
