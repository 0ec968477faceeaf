"""The study: shared layouts, blocks and counterbalancing, and one participant's study.

Where and in what order participants run is :mod:`nudgecli.runs.study`.

One participant is the unit of work. A participant's results are a pure function of
(experiment, seed, participant index): their physiology, calibration, schedule and every
trial draw from their own branches of the seed tree, and the layouts (with their solved goal
MDPs) are made once per study from the study's branch. So the tables are identical whether
the participants run serially, on local processes or on a dask cluster, in any order.
"""

from __future__ import annotations

import contextlib
import gc
import json
import time
from collections.abc import Callable, Collection, Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from nudgecli.config import ExperimentConfig
from nudgecli.errors import ConfigError, DataError
from nudgecli.model.disambiguation import DisambiguationModel
from nudgecli.model.interface import default_distortion_table, default_mapping_table
from nudgecli.model.mdp import MDPRewards, SolvedLayout, solve_layout
from nudgecli.model.path_world import PathLayout, PathWorld, optimal_policy
from nudgecli.model.world import MODE_NAMES, Layout, sample_layout
from nudgecli.rng import generator, seed_key
from nudgecli.sim.calibration_io import DistortionSession, MappingSession
from nudgecli.sim.calibration_sessions import FittedTables, fit_participant_tables
from nudgecli.sim.ciaa import packaged_task, subject_schedule, task_layouts
from nudgecli.sim.counterbalance import participant_order
from nudgecli.sim.participant_fitting import participant_from_log
from nudgecli.sim.participants import Participant, draw_participant
from nudgecli.sim.people_file import People
from nudgecli.sim.policy_registry import unused_policy_notes
from nudgecli.sim.protocol import ProtocolSettings, TrialSpec
from nudgecli.sim.step_record import StepRecording, step_columns
from nudgecli.sim.trials import TrialResult, run_trial, run_world_trial
from nudgecli.sim.twins import Twin, apply_twin, twin_at
from nudgecli.steplog import STEP_COLUMNS, steps_frame

if TYPE_CHECKING:  # pandas loads where frames are built (the parent of a study), never in its workers
    import pandas as pd

#: The ``condition`` of a layout every condition runs (``[study] shared_layouts``).
SHARED = "shared"


@dataclass(frozen=True)
class StudyLayout:
    """One of the study's layouts and the cell of the design it belongs to."""

    index: int
    condition: str
    n_goals: int
    corner: str
    start_mode: int
    layout: Layout


def build_layouts(config: ExperimentConfig, seed: int) -> list[StudyLayout]:
    """The study's layouts: conditions x goal counts x corners x start modes, each drawn once.

    Layout ``k`` is drawn from ``generator(seed, "layout", k)``; all participants share them.
    The conditions get independently drawn layouts, as in the study (its trials 0-23 were
    Disambiguation and 24-47 Control). With ``[study] shared_layouts = n`` the first ``n`` sets
    are drawn the same way and every condition runs all of them (their ``condition`` is
    :data:`SHARED`); ``n = 2`` with the paper's seed and design gives the paper's 48 layouts.
    """
    study = config.study
    layouts: list[StudyLayout] = []
    # shared layouts: the draws of a study of `shared_layouts` conditions, run by every condition
    owners = [SHARED] * study.shared_layouts if study.shared_layouts else list(study.conditions)
    for condition in owners:
        for n_goals in study.goal_counts:
            for corner in study.corners:
                for mode_name in study.start_modes:
                    k = len(layouts)
                    mode = MODE_NAMES.index(mode_name)
                    layout = sample_layout(generator(seed, "layout", k), corner, n_goals, mode)
                    layouts.append(StudyLayout(k, condition, n_goals, corner, mode, layout))
    return layouts


def layouts_frame(layouts: Iterable[StudyLayout]) -> pd.DataFrame:
    """``layouts.parquet``: one row per layout with goal and start poses as lists."""
    import pandas as pd

    rows = []
    for item in layouts:
        lay = item.layout
        rows.append({
            "layout": item.index,
            "condition": item.condition,
            "n_goals": item.n_goals,
            "corner": item.corner,
            "start_mode": MODE_NAMES[item.start_mode],
            "start_cell_x": lay.start_cell[0],
            "start_cell_y": lay.start_cell[1],
            "start_heading": lay.start_heading,
            "start_pose": lay.start_pose.tolist(),
            "goal_cells": lay.goal_cells.ravel().tolist(),
            "goal_headings": lay.goal_headings.tolist(),
            "goal_poses": lay.goal_poses.ravel().tolist(),
        })
    return pd.DataFrame(rows)


def participant_schedule(config: ExperimentConfig, seed: int, participant: int,
                         layouts: list[StudyLayout],
                         condition_order: Sequence[str] | None = None) -> list[TrialSpec]:
    """The participant's trials in the order they do them.

    Each condition's trials are shuffled into ``blocks_per_condition`` blocks; the blocks of the
    conditions alternate in the participant's condition order, the row ``participant`` mod the
    number of orders of the ``[study] counterbalancing`` design (a Williams square by default,
    :mod:`nudgecli.sim.counterbalance`; with two conditions the start rotates with the index, as
    in the paper). Each trial's true goal is one
    of its layout's goals, uniformly, drawn from the trial's own seed branch
    (``participant/i/trial/t/true_goal``), so nothing can favour a goal by its index.
    ``condition_order`` (a live session's ``--condition-order``, one of the design's orders) replaces
    the participant's order; the blocks and true goals stay those of the participant's seed.
    """
    study = config.study
    rng = generator(seed, "participant", participant, "schedule")
    n_blocks = study.blocks_per_condition
    blocks_by_condition: dict[str, list[list[StudyLayout]]] = {}
    for condition in study.conditions:
        mine = [lay for lay in layouts if lay.condition in (condition, SHARED)]
        order = rng.permutation(len(mine))
        size = len(mine) // n_blocks
        blocks_by_condition[condition] = [[mine[k] for k in order[b * size:(b + 1) * size]]
                                          for b in range(n_blocks)]
    conditions = participant_order([str(c) for c in study.conditions], study.counterbalancing, participant,
                                   condition_order)
    specs: list[TrialSpec] = []
    block_number = 0
    for b in range(n_blocks):
        for condition in conditions:
            for item in blocks_by_condition[condition][b]:
                trial = len(specs)
                true_goal = int(generator(seed, "participant", participant, "trial", trial, "true_goal")
                                .integers(item.n_goals))
                specs.append(TrialSpec(participant=participant, condition=condition, block=block_number,
                                       trial=trial, layout_index=item.index, layout=item.layout,
                                       true_goal=true_goal))
            block_number += 1
    return specs


@dataclass(frozen=True)
class TaskCosts:
    """What a layout's goal MDPs are solved with besides its goals: the rewards, the discount and
    the epsilon of the epsilon-greedy ``p(a | s, g)`` built on the policy (all :func:`solve_layout`
    reads).

    Two sets of them: the agent's assumption of the person (``[model]``, :func:`agent_costs`) and
    the simulated person's own plan (``[behaviour]`` ``plan_*``, :func:`person_costs`).
    """

    rewards: MDPRewards
    gamma: float
    epsilon: float


def agent_costs(config: ExperimentConfig) -> TaskCosts:
    """The task costs the agent assumes the person plans with: ``[model]``'s."""
    m = config.model
    return TaskCosts(MDPRewards(move=m.move_reward, mode_switch=m.mode_switch_reward, bump=m.bump_reward,
                                goal=m.goal_reward), m.gamma, m.epsilon)


def person_costs(config: ExperimentConfig) -> TaskCosts:
    """The simulated person's own task costs (``[behaviour]`` ``plan_*``), which their plan (their
    goal's greedy policy) is solved with.

    The epsilon is ``[model]``'s: the person acts on the policy alone (their own slips are their
    ``[population]`` epsilon), so it changes nothing of theirs, and with it costs equal to the
    agent's are the agent's, solved once (:func:`person_policies`, the solve cache's key).
    """
    b = config.behaviour
    return TaskCosts(MDPRewards(move=b.plan_move_reward, mode_switch=b.plan_mode_switch_reward,
                                bump=b.plan_bump_reward, goal=b.plan_goal_reward), b.plan_gamma,
                     config.model.epsilon)


def solve_layouts(config: ExperimentConfig, layouts: Sequence[StudyLayout],
                  costs: TaskCosts | None = None) -> list[SolvedLayout]:
    """Value iteration once per layout with ``costs`` (the agent's, ``[model]``, when ``None``: its
    epsilon-greedy human model included)."""
    c = agent_costs(config) if costs is None else costs
    return [solve_layout(item.layout.goal_cells, item.layout.goal_headings, c.rewards, c.gamma, c.epsilon)
            for item in layouts]


def person_policies(config: ExperimentConfig, layouts: Sequence[StudyLayout],
                    solve: Callable[[ExperimentConfig, Sequence[StudyLayout], TaskCosts], list[SolvedLayout]]
                    = solve_layouts) -> list[np.ndarray] | None:
    """Each layout's ``(G, S)`` policy of the simulated person's own plan, solved with ``solve``
    where their task costs (:func:`person_costs`) differ from the agent's; ``None`` where they are
    the same (the agent's solutions are theirs too, and nothing more is solved)."""
    costs = person_costs(config)
    if costs == agent_costs(config):
        return None
    return [solved.policy for solved in solve(config, layouts, costs)]


def path_layouts_frame(paths: dict[int, PathLayout]) -> pd.DataFrame:
    """``layouts.parquet`` of the CIAA world: one row per task layout with its path."""
    import pandas as pd

    rows = []
    for index, lay in sorted(paths.items()):
        rows.append({
            "layout": index,
            "condition": lay.condition,
            "n_goals": 1,
            "start_mode": MODE_NAMES[lay.start_mode],
            "start_pose": lay.start_pose.tolist(),
            "goal_poses": lay.goal_poses.ravel().tolist(),
            "waypoints": lay.waypoints.ravel().tolist(),
            "leg_modes": [MODE_NAMES[m] for m in lay.leg_modes],
            "leg_directions": list(lay.leg_directions),
            "turn_waypoint": lay.turn_waypoint,
        })
    return pd.DataFrame(rows)


def path_schedule(config: ExperimentConfig, participant: int,
                  paths: dict[int, PathLayout]) -> list[TrialSpec]:
    """The participant's CIAA trials in their subject's order (:func:`nudgecli.sim.ciaa.subject_schedule`)."""
    return [TrialSpec(participant=participant, condition=item.condition, block=item.block, trial=trial,
                      layout_index=item.layout_index, layout=paths[item.layout_index], true_goal=0)
            for trial, item in enumerate(subject_schedule(packaged_task(), participant,
                                                          config.world.ciaa_conditions))]


@dataclass(frozen=True)
class StudyPlan:
    """Everything a worker needs, computed once per study.

    In the grid world: the shared layouts and their solved goal MDPs, the agent's (``solved``,
    ``[model]``) and, where the simulated person's own task costs differ from them, the person's
    plans (``person_policies``). In the CIAA world: the task's path layouts (``paths``, by trial
    index) and their optimal command plans (``policies``).
    """

    config: ExperimentConfig
    seed: int
    layouts: list[StudyLayout]
    solved: list[SolvedLayout]
    paths: dict[int, PathLayout] | None = None
    policies: dict[int, Any] | None = None
    people: tuple[Twin, ...] = ()  # twins of real people (--people): participant i is people[i mod P]
    #: Each layout's ``(G, S)`` policy the simulated person follows, solved with their own task
    #: costs (:func:`person_policies`); ``None``: their costs are the agent's, ``solved``'s policies.
    person_policies: list[np.ndarray] | None = None

    @classmethod
    def build(cls, config: ExperimentConfig, seed: int) -> StudyPlan:
        if config.world.kind == "ciaa":
            paths = task_layouts(packaged_task())
            return cls(config=config, seed=seed, layouts=[], solved=[], paths=paths,
                       policies={k: optimal_policy(lay) for k, lay in paths.items()})
        layouts = build_layouts(config, seed)
        return cls(config=config, seed=seed, layouts=layouts, solved=solve_layouts(config, layouts),
                   person_policies=person_policies(config, layouts))

    @classmethod
    def assemble(cls, config: ExperimentConfig, seed: int, chunks: Sequence[list[SolvedLayout]]) -> StudyPlan:
        """The grid world's plan from :func:`solve_layout_chunk` results in chunk order (as :meth:`build`).

        The chunks hold the agent's solutions; the person's own plans, where their costs differ
        (:func:`person_policies`), are solved here (about 0.16 s for the paper's 48 layouts).
        """
        layouts = build_layouts(config, seed)
        return cls(config=config, seed=seed, layouts=layouts,
                   solved=[solved for chunk in chunks for solved in chunk],
                   person_policies=person_policies(config, layouts))

    def person_policy(self, layout_index: int) -> np.ndarray:
        """The ``(G, S)`` policy the simulated person follows in grid layout ``layout_index``."""
        if self.person_policies is not None:
            return self.person_policies[layout_index]
        return self.solved[layout_index].policy

    def schedule(self, participant: int) -> list[TrialSpec]:
        """Participant ``participant``'s trials in order."""
        if self.paths is not None:
            return path_schedule(self.config, participant, self.paths)
        return participant_schedule(self.config, self.seed, participant, self.layouts)

    def trials_per_participant(self) -> int:
        """Trials of one participant (of participant 0 in the CIAA world, where all run 12 per condition)."""
        return len(self.schedule(0)) if self.paths is not None else len(self.layouts)

    def layouts_frame(self) -> pd.DataFrame:
        """The run folder's ``layouts.parquet``."""
        return path_layouts_frame(self.paths) if self.paths is not None else layouts_frame(self.layouts)


def trials_frame(summaries: Sequence[dict[str, Any]]) -> pd.DataFrame:
    """The trial table of trial summaries (one dict per trial, :meth:`TrialSession.summary`)."""
    import pandas as pd

    return pd.DataFrame(list(summaries))


@dataclass
class ParticipantColumns:
    """One participant's results as plain columns: what a worker computes and sends back.

    Numpy and Python values only, so a worker needs no pandas (:class:`ParticipantResult` makes the
    tables of them, in the process that writes them).
    """

    participant: int
    #: The trial summaries, one dict per trial in the participant's order.
    trials: list[dict[str, Any]]
    #: The step log's wanted columns (:func:`nudgecli.sim.step_record.step_columns`): numeric
    #: columns as typed arrays, text and ``belief`` columns as lists.
    steps: dict[str, np.ndarray | list[Any]]
    #: The participant's row of ``participants.parquet``.
    record: dict[str, Any]
    wall_s: float
    calibration: tuple[MappingSession, DistortionSession] | None = None


@dataclass
class ParticipantResult:
    """One participant's tables (the unit of work's output)."""

    participant: int
    trials: pd.DataFrame
    steps: pd.DataFrame
    record: pd.DataFrame
    wall_s: float
    calibration: tuple[MappingSession, DistortionSession] | None = None

    @classmethod
    def from_columns(cls, columns: ParticipantColumns) -> ParticipantResult:
        """The tables of a participant's columns (``wall_s``: the simulation's, as measured in the worker)."""
        import pandas as pd

        return cls(participant=columns.participant, trials=trials_frame(columns.trials),
                   steps=steps_frame(columns.steps), record=pd.DataFrame([columns.record]),
                   wall_s=columns.wall_s, calibration=columns.calibration)


def agent_tables(config: ExperimentConfig, participant: Participant, seed: int) -> FittedTables:
    """The tables the agent uses for this participant: fitted from a simulated calibration (whose
    logs come along), or the defaults."""
    if config.model.tables == "default":
        noise = config.model.default_table_noise
        return FittedTables(default_mapping_table(noise), default_distortion_table(noise),
                            {"tables": "default"})
    rng = generator(seed, "participant", participant.index, "calibration")
    return fit_participant_tables(participant, config.calibration, config.interface, rng)


def study_participant(config: ExperimentConfig, seed: int, index: int,
                      people: Sequence[Twin] = ()) -> Participant:
    """Participant ``index``: drawn from the population, with the pressure physiology of
    ``population.physiology_logs[index]`` when the experiment names a real log for them, and the
    habits of twin ``index mod P`` of ``people`` when given (:func:`~nudgecli.sim.twins.apply_twin`)."""
    drawn = draw_participant(config.population, index, generator(seed, "participant", index, "physiology"),
                             key=seed_key("participant", index))
    logs = config.population.physiology_logs
    if index < len(logs):
        drawn = participant_from_log(logs[index], index=index, template=drawn, population=config.population)
    return apply_twin(drawn, twin_at(people, index)) if people else drawn


def check_physiology_logs(config: ExperimentConfig) -> None:
    """Fail before a run starts if a ``population.physiology_logs`` folder cannot give a participant."""
    for position, folder in enumerate(config.population.physiology_logs):
        where = config.population.logs_source()  # the experiment file or the --set that named it
        key = f"{where + ': ' if where else ''}population.physiology_logs[{position}]"
        if not Path(folder).is_dir():
            from nudgecli.sim.calibration_readers import DISTORTION_LAYOUTS  # pandas: with a recording only

            what = f"{folder!r}, a file, not a folder" if Path(folder).exists() else \
                f"folder {folder!r}, which does not exist"
            raise ConfigError(f"{key} names {what} (a relative path is read from the working directory); the "
                              "list takes folders of calibration logs, each a participant's, with "
                              f"{DISTORTION_LAYOUTS}")
        try:
            participant_from_log(folder, index=position, population=config.population)
        except DataError as exc:  # a folder without a usable recording: named by the key, as one not there
            raise DataError(f"{key}: {exc}") from None


def left_out_notes(config: ExperimentConfig, participants: int, people: People | None = None, *,
                   study: str = "the study", fix: str = "--participants {}") -> tuple[str, ...]:
    """What a study of ``participants`` leaves out of its inputs, a note each: the people of a people
    file past the first ``participants`` (participant ``i`` is person ``i mod P``), the
    ``population.physiology_logs`` folders past them (participant ``k`` takes the ``k``-th) and the
    ``[policies.NAME]`` sections no condition runs
    (:func:`~nudgecli.sim.policy_registry.unused_policy_notes`).

    A note, not an error: a power curve's smaller studies rightly take the first ones. ``study``
    names the study of ``participants`` (``"the largest study"``); ``fix`` is the option that
    simulates all, ``{}`` the count it needs.
    """
    sources = [] if people is None else [(f"{people.name} has {len(people.twins)} people", [
        f"person {i} ({twin.participant})" for i, twin in enumerate(people.twins)])]
    logs = config.population.physiology_logs
    sources.append((f"population.physiology_logs lists {len(logs)} folders",
                    [f"physiology_logs[{k}] ({folder})" for k, folder in enumerate(logs)]))
    notes = []
    for has, named in sources:
        left = named[participants:]
        if left:
            shown = ", ".join(left[:5]) + (f" and {len(left) - 5} more" if len(left) > 5 else "")
            verb = "is" if len(left) == 1 else "are"
            notes.append(f"{has}; {study} simulates {participants}, so {shown} {verb} left out; "
                         f"{fix.format(len(named))} simulates all")
    return (*notes, *unused_policy_notes(config))


#: The cyclic garbage collector's first threshold during a participant's trials (Python's is 700).
TRIAL_LOOP_GC_THRESHOLD = 10_000


@contextlib.contextmanager
def fewer_collections(threshold: int = TRIAL_LOOP_GC_THRESHOLD) -> Iterator[None]:
    """Run the block with the garbage collector's first generation collected less often.

    A trial allocates a tuple or two per step and builds no reference cycles, so at Python's
    default the collector ran about 25 times per participant for nothing (4 % of the loop). Values
    are unaffected; the thresholds are restored after the block.
    """
    before = gc.get_threshold()
    gc.set_threshold(max(threshold, before[0]), *before[1:])
    try:
        yield
    finally:
        gc.set_threshold(*before)


def simulate_participant(plan: StudyPlan, participant_index: int,
                         step_log_columns: Collection[str] = STEP_COLUMNS) -> ParticipantResult:
    """Simulate every trial of one participant (a pure function of the plan and the index), as tables.

    :func:`simulate_participant_columns` made into frames (:meth:`ParticipantResult.from_columns`).
    """
    columns = simulate_participant_columns(plan, participant_index, step_log_columns)
    return ParticipantResult.from_columns(columns)


def simulate_participant_columns(plan: StudyPlan, participant_index: int,
                                 step_log_columns: Collection[str] = STEP_COLUMNS) -> ParticipantColumns:
    """Simulate every trial of one participant (a pure function of the plan and the index), as columns.

    What a worker runs: numpy and Python values only, no pandas.
    ``step_log_columns``: the step log's columns the result keeps (all by default: the run
    folder's step log; a batch computing metrics only keeps theirs).
    """
    start = time.perf_counter()
    config, seed = plan.config, plan.seed
    participant = study_participant(config, seed, participant_index, plan.people)
    fitted = agent_tables(config, participant, seed)
    mapping, distortion = fitted.mapping, fitted.distortion
    # the run checked its policies at its start: importing them again here would take an edited file
    settings = ProtocolSettings.from_config(config, check_policies=False)
    summaries: list[dict[str, Any]] = []
    # the step log's columns are made once per participant, of all the trials' raw steps
    recordings: list[StepRecording] = []
    schedule = plan.schedule(participant_index)
    models = _agent_models(plan, schedule, mapping, distortion)
    with fewer_collections():  # the loop allocates many short-lived tuples and no cycles
        for spec in schedule:
            rng = generator(seed, "participant", participant_index, "trial", spec.trial)
            if plan.paths is not None:
                result = _path_trial(plan, spec, settings, participant, rng, step_log_columns)
            else:
                result = run_trial(spec, settings, plan.solved[spec.layout_index], models[spec.layout_index],
                                   participant, rng, step_log_columns,
                                   person_policy=plan.person_policy(spec.layout_index))
            summaries.append(result.summary)
            recordings.append(result.recording)
    record = participant.to_record()
    record.update({
        "agent_p_phi_given_a": _json(mapping.tolist()),
        "agent_p_phm_given_phi": _json(distortion.tolist()),
        "calibration": _json(fitted.provenance),
    })
    return ParticipantColumns(
        participant=participant_index,
        trials=summaries,
        steps=step_columns(recordings, step_log_columns),
        record=record,
        wall_s=time.perf_counter() - start,
        calibration=fitted.sessions,
    )


def _agent_models(plan: StudyPlan, schedule: Sequence[TrialSpec], mapping: np.ndarray,
                  distortion: np.ndarray) -> dict[int, DisambiguationModel]:
    """The agent's model of the participant (their fitted tables) in each grid layout of their
    schedule, by layout index, made together (:meth:`DisambiguationModel.of_layouts`); none in the
    CIAA world."""
    if plan.paths is not None:
        return {}
    layouts: dict[int, Layout] = {}
    for spec in schedule:
        assert isinstance(spec.layout, Layout)
        layouts.setdefault(spec.layout_index, spec.layout)
    goal_cells = [layout.goal_cells for layout in layouts.values()]
    actions = [plan.solved[index].actions for index in layouts]
    models = DisambiguationModel.of_layouts(goal_cells, actions, mapping, distortion)
    return dict(zip(layouts, models, strict=True))


def _path_trial(plan: StudyPlan, spec: TrialSpec, settings: ProtocolSettings, participant: Participant,
                rng: Any, step_log_columns: Collection[str]) -> TrialResult:
    """One CIAA trial: a fresh path world, the layout's optimal command plan, no agent model."""
    assert plan.paths is not None and plan.policies is not None
    w = plan.config.world
    world = PathWorld(plan.paths[spec.layout_index], snap_tolerance=w.snap_tolerance,
                      heading_tolerance=w.heading_tolerance)
    policy = plan.policies[spec.layout_index]
    return run_world_trial(spec, settings, world, policy, -1, None, participant, rng, step_log_columns)


def _json(value: Any) -> str:
    return json.dumps(value, default=lambda v: v.tolist() if hasattr(v, "tolist") else str(v))
