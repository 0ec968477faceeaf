"""The study: shared layouts, blocks and counterbalancing, and its execution.

One participant is the unit of work. A participant's results are a pure function of
(experiment, seed, participant index): their physiology, calibration, schedule and every
trial draw from their own branches of the seed tree, and the layouts (with their solved goal
MDPs) are made once per study from the study's branch. So the tables are identical whether
the participants run serially, on local processes or on a dask cluster, in any order.
"""

from __future__ import annotations

import contextlib
import itertools
import json
import math
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from multiprocessing import get_context
from multiprocessing.context import BaseContext
from pathlib import Path
from typing import Any

import pandas as pd

from nudgecli.config import ExperimentConfig, default_plan_name
from nudgecli.errors import ConfigError, NudgeError
from nudgecli.model.disambiguation import DisambiguationModel
from nudgecli.model.interface import default_distortion_table, default_mapping_table
from nudgecli.model.mdp import MDPRewards, SolvedLayout, solve_layout
from nudgecli.model.path_world import PathLayout, PathWorld, optimal_policy
from nudgecli.model.world import MODE_NAMES, Layout, sample_layout
from nudgecli.rng import generator, seed_key
from nudgecli.sim.calibration import FittedTables, fit_participant_tables
from nudgecli.sim.calibration_io import DistortionSession, MappingSession, write_sessions
from nudgecli.sim.ciaa import packaged_task, subject_schedule, task_layouts
from nudgecli.sim.counterbalance import design_record, participant_order
from nudgecli.sim.participants import Participant, draw_participant, participant_from_log
from nudgecli.sim.protocol import ProtocolSettings, TrialResult, TrialSpec, run_trial, run_world_trial
from nudgecli.sim.size import check_size, trials_per_participant
from nudgecli.steplog import STEP_COLUMNS
from nudgecli.store import RunFolder, library_versions, run_lock, utc_now

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
                         layouts: list[StudyLayout], first_condition: str | None = None) -> list[TrialSpec]:
    """The participant's trials in the order they do them.

    Each condition's trials are shuffled into ``blocks_per_condition`` blocks; the blocks of the
    conditions alternate in the participant's condition order, the row ``participant`` mod the
    number of orders of the ``[study] counterbalancing`` design (a Williams square by default,
    :mod:`nudgecli.sim.counterbalance`; with two conditions the start rotates with the index, as
    in the paper). Each trial's true goal is one
    of its layout's goals, uniformly, drawn from the trial's own seed branch
    (``participant/i/trial/t/true_goal``), so nothing can favour a goal by its index.
    ``first_condition`` (a live session's ``--condition-order``) takes the design's first order
    that starts with that condition; the blocks and true goals stay those of the participant's seed.
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
                                   first_condition)
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


def solve_layouts(config: ExperimentConfig, layouts: list[StudyLayout]) -> list[SolvedLayout]:
    """Value iteration once per layout (the agent's epsilon-greedy human model included)."""
    m = config.model
    rewards = MDPRewards(move=m.move_reward, mode_switch=m.mode_switch_reward, bump=m.bump_reward,
                         goal=m.goal_reward)
    return [solve_layout(item.layout.goal_cells, item.layout.goal_headings, rewards, m.gamma, m.epsilon)
            for item in layouts]


def layout_chunks(n_layouts: int, parts: int) -> list[tuple[int, int]]:
    """``range(n_layouts)`` as at most ``parts`` contiguous ``(start, stop)`` chunks of near-equal size."""
    parts = max(1, min(parts, n_layouts))
    edges = [round(k * n_layouts / parts) for k in range(parts + 1)]
    return [(a, b) for a, b in itertools.pairwise(edges) if b > a]


def solve_layout_chunk(config: ExperimentConfig, seed: int, start: int, stop: int) -> list[SolvedLayout]:
    """The study's layouts ``start:stop`` solved: one piece of a plan built in parallel."""
    tune_allocator()
    return solve_layouts(config, build_layouts(config, seed)[start:stop])


def _solve_chunk(args: tuple[ExperimentConfig, int, int, int]) -> list[SolvedLayout]:
    return solve_layout_chunk(*args)


def path_layouts_frame(paths: dict[int, PathLayout]) -> pd.DataFrame:
    """``layouts.parquet`` of the CIAA world: one row per task layout with its path."""
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

    In the grid world: the shared layouts and their solved goal MDPs. In the CIAA world: the
    task's path layouts (``paths``, by trial index) and their optimal command plans (``policies``).
    """

    config: ExperimentConfig
    seed: int
    layouts: list[StudyLayout]
    solved: list[SolvedLayout]
    paths: dict[int, PathLayout] | None = None
    policies: dict[int, Any] | None = None

    @classmethod
    def build(cls, config: ExperimentConfig, seed: int) -> StudyPlan:
        if config.world.kind == "ciaa":
            paths = task_layouts(packaged_task())
            return cls(config=config, seed=seed, layouts=[], solved=[], paths=paths,
                       policies={k: optimal_policy(lay) for k, lay in paths.items()})
        layouts = build_layouts(config, seed)
        return cls(config=config, seed=seed, layouts=layouts, solved=solve_layouts(config, layouts))

    @classmethod
    def assemble(cls, config: ExperimentConfig, seed: int, chunks: Sequence[list[SolvedLayout]]) -> StudyPlan:
        """The grid world's plan from :func:`solve_layout_chunk` results in chunk order (as :meth:`build`)."""
        return cls(config=config, seed=seed, layouts=build_layouts(config, seed),
                   solved=[solved for chunk in chunks for solved in chunk])

    @classmethod
    def build_on(cls, config: ExperimentConfig, seed: int, workers: int, client: Any = None) -> StudyPlan:
        """:meth:`build`, with the grid world's layouts solved by ``workers`` short-lived processes,
        or, given a dask ``client``, by the cluster's workers.

        So a study on many workers does not wait for one process to solve every layout first.
        """
        if client is not None:
            workers = max(1, len(client.scheduler_info().get("workers", {})))
        if workers <= 1 or config.world.kind == "ciaa":
            return cls.build(config, seed)
        chunks = layout_chunks(len(build_layouts(config, seed)), workers)
        if client is not None:
            futures = [client.submit(solve_layout_chunk, config, seed, a, b, pure=False) for a, b in chunks]
            return cls.assemble(config, seed, client.gather(futures))
        with ProcessPoolExecutor(max_workers=len(chunks), mp_context=process_context(),
                                 initializer=die_with_parent, initargs=(os.getpid(),)) as pool:
            solved = list(pool.map(_solve_chunk, [(config, seed, a, b) for a, b in chunks]))
        return cls.assemble(config, seed, solved)

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


@dataclass
class ParticipantResult:
    """One participant's tables (the unit of work's output)."""

    participant: int
    trials: pd.DataFrame
    steps: pd.DataFrame
    record: pd.DataFrame
    wall_s: float
    calibration: tuple[MappingSession, DistortionSession] | None = None


def agent_tables(config: ExperimentConfig, participant: Participant, seed: int) -> FittedTables:
    """The tables the agent uses for this participant: fitted from a simulated calibration (whose
    logs come along), or the defaults."""
    if config.model.tables == "default":
        noise = config.model.default_table_noise
        return FittedTables(default_mapping_table(noise), default_distortion_table(noise),
                            {"tables": "default"})
    rng = generator(seed, "participant", participant.index, "calibration")
    return fit_participant_tables(participant, config.calibration, config.interface, rng)


def study_participant(config: ExperimentConfig, seed: int, index: int) -> Participant:
    """Participant ``index``: drawn from the population, with the pressure physiology of
    ``population.physiology_logs[index]`` when the experiment names a real log for them."""
    drawn = draw_participant(config.population, index, generator(seed, "participant", index, "physiology"),
                             key=seed_key("participant", index))
    logs = config.population.physiology_logs
    if index < len(logs):
        return participant_from_log(logs[index], index=index, template=drawn, population=config.population)
    return drawn


def check_physiology_logs(config: ExperimentConfig) -> None:
    """Fail before a run starts if a ``population.physiology_logs`` folder cannot give a participant."""
    for position, folder in enumerate(config.population.physiology_logs):
        if not Path(folder).is_dir():
            raise ConfigError(f"population.physiology_logs[{position}] = {folder!r}: no such folder; give a "
                              "participant's calibration folder (with p_phm_given_phi/)")
        participant_from_log(folder, index=position, population=config.population)


def simulate_participant(plan: StudyPlan, participant_index: int) -> ParticipantResult:
    """Simulate every trial of one participant (a pure function of the plan and the index)."""
    start = time.perf_counter()
    config, seed = plan.config, plan.seed
    participant = study_participant(config, seed, participant_index)
    fitted = agent_tables(config, participant, seed)
    mapping, distortion = fitted.mapping, fitted.distortion
    settings = ProtocolSettings.from_config(config)
    summaries: list[dict[str, Any]] = []
    # one frame per participant, not per trial: building frames was a tenth of the run
    step_columns: dict[str, list[Any]] = {column: [] for column in STEP_COLUMNS}
    models: dict[int, DisambiguationModel] = {}
    for spec in plan.schedule(participant_index):
        rng = generator(seed, "participant", participant_index, "trial", spec.trial)
        if plan.paths is not None:
            result = _path_trial(plan, spec, settings, participant, rng)
        else:
            solved = plan.solved[spec.layout_index]
            model = models.get(spec.layout_index)
            if model is None:
                assert isinstance(spec.layout, Layout)
                model = models[spec.layout_index] = DisambiguationModel(
                    spec.layout.goal_cells, solved.p_a_given_sg, mapping, distortion)
            result = run_trial(spec, settings, solved, model, participant, rng)
        summaries.append(result.summary)
        for column, values in result.steps.items():
            step_columns[column].extend(values)
    record = participant.to_record()
    record.update({
        "agent_p_phi_given_a": _json(mapping.tolist()),
        "agent_p_phm_given_phi": _json(distortion.tolist()),
        "calibration": _json(fitted.provenance),
    })
    return ParticipantResult(
        participant=participant_index,
        trials=pd.DataFrame(summaries),
        steps=pd.DataFrame(step_columns),
        record=pd.DataFrame([record]),
        wall_s=time.perf_counter() - start,
        calibration=fitted.sessions,
    )


def _path_trial(plan: StudyPlan, spec: TrialSpec, settings: ProtocolSettings, participant: Participant,
                rng: Any) -> TrialResult:
    """One CIAA trial: a fresh path world, the layout's optimal command plan, no agent model."""
    assert plan.paths is not None and plan.policies is not None
    w = plan.config.world
    world = PathWorld(plan.paths[spec.layout_index], snap_tolerance=w.snap_tolerance,
                      heading_tolerance=w.heading_tolerance, success_distance=w.success_distance)
    policy = plan.policies[spec.layout_index]
    return run_world_trial(spec, settings, world, policy, -1, None, participant, rng)


def _json(value: Any) -> str:
    return json.dumps(value, default=lambda v: v.tolist() if hasattr(v, "tolist") else str(v))


# --- executors --------------------------------------------------------------------------------

#: Seconds a worker waits between two checks that its parent is alive (where prctl is missing).
PARENT_POLL_S = 0.5
#: Seconds to wait for a dask scheduler to answer before ``--scheduler`` is refused: a scheduler
#: answers in milliseconds, and a refusal, the start of Python included, comes within 10 s.
SCHEDULER_TIMEOUT_S = 7.0
_PR_SET_PDEATHSIG = 1

_WORKER_PLAN: StudyPlan | None = None


def die_with_parent(parent_pid: int) -> None:
    """Make this (worker) process exit when the process ``parent_pid`` dies.

    On Linux the kernel sends SIGKILL at the parent's death (``prctl(PR_SET_PDEATHSIG)``);
    everywhere, a daemon thread also checks ``os.getppid()`` every :data:`PARENT_POLL_S`
    seconds and exits the process once it differs from ``parent_pid`` (the orphan was
    re-parented). So a killed ``nudge`` never leaves workers behind holding its pipes.
    """
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        except (OSError, AttributeError):  # pragma: no cover - no prctl: the thread below covers it
            pass
    if os.getppid() != parent_pid:  # the parent died before prctl took effect
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(PARENT_POLL_S)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, name="nudge-parent-watch", daemon=True).start()


_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
_ALLOCATOR_TUNED = False


def tune_allocator() -> None:
    """Undo a tiny ``MALLOC_TRIM_THRESHOLD_`` in this process (once; glibc only).

    dask's nanny starts its workers with ``MALLOC_TRIM_THRESHOLD_=65536``, which also fixes glibc's
    mmap threshold at 128 KiB: every large numpy temporary is then mapped and unmapped anew, and
    the layout solving and trials run 2.5-3.5 times slower than in a plain process (measured on
    the paper preset's plan). Where that variable is set, this raises the mmap threshold to 32 MB
    and the trim threshold to 64 MB, so freed memory above 64 MB is still returned to the system.
    """
    global _ALLOCATOR_TUNED
    if _ALLOCATOR_TUNED or "MALLOC_TRIM_THRESHOLD_" not in os.environ or not sys.platform.startswith("linux"):
        return
    _ALLOCATOR_TUNED = True
    try:
        import ctypes

        libc = ctypes.CDLL(None)
        libc.mallopt(_M_MMAP_THRESHOLD, 32 * 1024 * 1024)
        libc.mallopt(_M_TRIM_THRESHOLD, 64 * 1024 * 1024)
    except (OSError, AttributeError):  # pragma: no cover - not glibc
        pass


def simulate_on_worker(plan: StudyPlan, participant_index: int) -> ParticipantResult:
    """:func:`simulate_participant` as a dask task (with :func:`tune_allocator` first)."""
    tune_allocator()
    return simulate_participant(plan, participant_index)


def _init_worker(plan: StudyPlan, parent_pid: int) -> None:
    global _WORKER_PLAN
    die_with_parent(parent_pid)
    _WORKER_PLAN = plan


def _run_in_worker(participant_index: int) -> ParticipantResult:
    assert _WORKER_PLAN is not None, "worker not initialised"
    return simulate_participant(_WORKER_PLAN, participant_index)


def _serial(plan: StudyPlan, todo: list[int]) -> Iterator[ParticipantResult]:
    for index in todo:
        yield simulate_participant(plan, index)


def process_context() -> BaseContext:
    """``fork`` where it exists (workers inherit the plan without pickling), else ``spawn``."""
    return get_context("fork") if os.name == "posix" else get_context("spawn")


def _processes(plan: StudyPlan, todo: list[int], workers: int) -> Iterator[ParticipantResult]:
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=process_context(), initializer=_init_worker,
                               initargs=(plan, os.getpid()))
    try:
        futures = [pool.submit(_run_in_worker, index) for index in todo]
        for future in as_completed(futures):
            yield future.result()
    except BaseException:
        # Ctrl-C or a failure: drop the queued participants and stop the running ones now (their
        # results would be thrown away); the pool's own exit waits for every queued task
        processes = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:
            with contextlib.suppress(OSError, ValueError, AttributeError):
                process.terminate()
        raise
    else:
        pool.shutdown(wait=True)


def connect_scheduler(address: str) -> Any:
    """A ``dask.distributed.Client`` of the scheduler at ``address``.

    The address is probed first (:func:`probe_scheduler`), so that a service that is not a
    dask scheduler is refused within :data:`SCHEDULER_TIMEOUT_S` seconds: the client alone
    waits for ever on a server that never answers, and takes a greeting from one that speaks
    first (SSH, SMTP) as the length of a message of exabytes.

    Raises
    ------
    ConfigError
        dask.distributed is not installed, the address is malformed, or no dask scheduler
        answers within :data:`SCHEDULER_TIMEOUT_S` seconds.
    """
    try:
        from dask.distributed import Client
    except ImportError as exc:  # pragma: no cover - depends on the optional extra
        raise ConfigError("--scheduler needs dask.distributed: pip install 'nudgecli[cluster]'") from exc
    fix = "give the address of a running dask scheduler, e.g. tcp://host:8786"
    problem = probe_scheduler(address, SCHEDULER_TIMEOUT_S)
    if problem is not None:
        raise ConfigError(f"--scheduler {address}: {problem}; {fix}")
    try:
        return Client(address, timeout=f"{SCHEDULER_TIMEOUT_S}s")
    except (OSError, ValueError, TypeError) as exc:
        raise ConfigError(f"--scheduler {address}: cannot connect ({_one_line(exc)}); {fix}") from None


def probe_scheduler(address: str, timeout_s: float) -> str | None:
    """Open and close one dask connection to ``address`` (its handshake included), within ``timeout_s``.

    Returns
    -------
    str or None
        None when a dask scheduler answered; else what went wrong, in a few words.
    """
    import asyncio
    from concurrent.futures import ThreadPoolExecutor

    from distributed.comm import connect

    async def handshake() -> None:
        comm = await connect(address, timeout=timeout_s)
        await comm.close()

    def run() -> str | None:
        try:
            asyncio.run(asyncio.wait_for(handshake(), timeout_s))
        except TimeoutError:
            return f"cannot connect (no dask scheduler answered within {timeout_s:g} s)"
        except (OSError, ValueError, TypeError) as exc:
            return f"cannot connect ({_one_line(exc)})"
        except Exception:
            # e.g. a MemoryError: a greeting's bytes read as the length of a message
            return "the service there is not a dask scheduler (its answer is not dask's protocol)"
        return None

    # in a thread of its own: the caller may itself be running an event loop (a notebook)
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="nudge-probe") as pool:
        return pool.submit(run).result()


def _one_line(exc: BaseException) -> str:
    """An exception's message on one line (or its type's name when it has none)."""
    text = " ".join(str(exc).split())
    return text or type(exc).__name__


def _dask(plan: StudyPlan, todo: list[int], client: Any) -> Iterator[ParticipantResult]:
    from dask.distributed import as_completed as dask_completed

    with client:
        shared = client.scatter(plan, broadcast=True)
        futures = [client.submit(simulate_on_worker, shared, index, pure=False) for index in todo]
        for future in dask_completed(futures):
            yield future.result()


@dataclass
class StudyRun:
    """What :func:`run_study` did."""

    path: Path
    experiment: str
    mode: str
    participants: int
    computed: list[int]
    trials: pd.DataFrame


def run_study(config: ExperimentConfig, out: Path, seed: int | None = None, participants: int | None = None,
              workers: int = 1, scheduler: str | None = None, resume: bool = False, force: bool = False,
              progress: Callable[[int, int], None] | None = None, plan: str | None = None,
              confirm: bool = False) -> StudyRun:
    """Simulate a study into the run folder ``out``.

    Parameters
    ----------
    config
        The resolved experiment.
    out
        The run folder.
    seed, participants
        Overrides of the experiment's seed and participant count.
    workers
        Local processes (1: in this process).
    scheduler
        Address of a dask.distributed scheduler; overrides ``workers``.
    resume, force
        See :meth:`RunFolder.prepare`.
    progress
        Called with (trials done, trials in all) as participants complete.
    plan
        The analysis plan recorded in the manifest for ``nudge analyze`` (default: the plan
        preset named like the experiment, else ``paper``).
    confirm
        Run a study above :data:`nudgecli.sim.size.MAX_TRIALS_WITHOUT_YES` trials (``--yes``).

    Returns
    -------
    StudyRun

    Raises
    ------
    ConfigError
        Bad workers, seed or participant count, a study too large without ``confirm``, or an
        unreachable scheduler.
    LockError
        Another command is writing ``out`` (the run folder is locked for the whole run).
    """
    if workers < 1:
        raise ConfigError(f"--workers must be at least 1, got {workers}")
    seed = config.experiment.seed if seed is None else seed
    if seed < 0:
        raise ConfigError(f"--seed must be a non-negative integer, got {seed}")
    n = config.study.participants if participants is None else participants
    if n < 1:
        raise ConfigError(f"--participants must be at least 1, got {n}")
    check_size(n * trials_per_participant(config), confirm, fix="fewer participants")
    if participants is not None:
        config = config.model_copy(update={"study": config.study.model_copy(update={"participants": n})})
    check_physiology_logs(config)
    if plan is not None:  # a plan that cannot load is refused before anything is simulated or written
        from nudgecli.report.plans import load_plan

        load_plan(plan)
    client = connect_scheduler(scheduler) if scheduler else None  # refused before the folder exists
    try:
        with run_lock(out):
            return _run_locked(RunFolder(out), config, seed, n, workers, scheduler, client, resume, force,
                               progress, plan)
    except BaseException:
        if client is not None:
            client.close()
        raise


def _run_locked(folder: RunFolder, config: ExperimentConfig, seed: int, n: int, workers: int,
                scheduler: str | None, client: Any, resume: bool, force: bool,
                progress: Callable[[int, int], None] | None, plan_name: str | None) -> StudyRun:
    """:func:`run_study` once the folder's lock is held (``client``: the connected dask client, or None)."""
    mode = folder.prepare(config, seed, n, resume=resume, force=force)
    done = set(folder.completed_participants()) & set(range(n)) if mode == "resume" else set()
    if mode == "resume":
        changed = folder.changed_parts(folder.read_manifest())
        if changed:  # not what was written: recompute them (a participant is a pure function of the seed)
            listed = ", ".join(part for parts in changed.values() for part in parts)
            print(f"Warning: {folder.path}: {listed} changed since written (SHA-256 differs from the "
                  "manifest's); simulating again", file=sys.stderr)
            done -= set(changed)
    plan = StudyPlan.build_on(config, seed, workers, client)
    trials_per = plan.trials_per_participant()
    manifest: dict[str, Any] = folder.read_manifest() if mode == "resume" else {
        "experiment": config.experiment.name,
        "config": config.model_dump(mode="json"),
        "seed": seed,
        "participants": n,
        "trials_per_participant": trials_per,
        "versions": library_versions(),
        "created": utc_now(),
        "timings_s": {},
    }
    if plan.paths is None:  # the CIAA world takes its subjects' block orders from the task file
        manifest["counterbalancing"] = design_record(list(config.study.conditions),
                                                     config.study.counterbalancing, n)
    manifest.update({"status": "running", "completed": sorted(done),
                     "executor": _executor_name(workers, scheduler)})
    if plan_name is not None or "plan" not in manifest:
        manifest["plan"] = plan_name or default_plan_name(config.experiment.name)
    folder.write_layouts(plan.layouts_frame())
    folder.write_manifest(manifest)
    todo = [i for i in range(n) if i not in done]
    started = time.perf_counter()
    if progress:
        progress(len(done) * trials_per, n * trials_per)
    if client is not None:
        results = _dask(plan, todo, client)
    elif workers > 1 and len(todo) > 1:
        results = _processes(plan, todo, min(workers, len(todo)))
    else:
        results = _serial(plan, todo)
    try:
        for result in results:
            if result.calibration is not None:
                write_sessions(folder.calibration_dir(result.participant), *result.calibration)
            sums = folder.write_participant_parts(result.participant, result.trials, result.steps,
                                                  result.record)
            manifest.setdefault("checksums", {})[str(result.participant)] = sums
            done.add(result.participant)
            manifest["completed"] = sorted(done)
            manifest["timings_s"][str(result.participant)] = round(result.wall_s, 3)
            folder.write_manifest(manifest)
            if progress:
                progress(len(done) * trials_per, n * trials_per)
    except BaseException:
        # Ctrl-C, a failed participant, a write error: the run must not read as still running
        manifest["status"] = "interrupted"
        with contextlib.suppress(NudgeError, OSError):
            folder.write_manifest(manifest)
        raise
    folder.write_participants_table()
    manifest.update({"status": "complete", "finished": utc_now(),
                     "wall_s": round(time.perf_counter() - started, 3),
                     "peak_rss_mb": _finite_or_none(round(peak_memory_mb(), 1))})
    folder.write_manifest(manifest)
    return StudyRun(path=folder.path, experiment=config.experiment.name, mode=mode, participants=n,
                    computed=todo, trials=folder.read_trials())


def _finite_or_none(value: float) -> float | None:
    """JSON has no NaN: an unknown measurement is ``null``."""
    return value if math.isfinite(value) else None


def _executor_name(workers: int, scheduler: str | None) -> str:
    if scheduler:
        return "dask"
    return "serial" if workers == 1 else f"processes:{workers}"


def peak_memory_mb() -> float:
    """Peak resident memory of this process and its finished children, in MB (Linux ru_maxrss is KiB)."""
    try:
        import resource  # Unix only
    except ImportError:  # pragma: no cover - Windows has no getrusage
        return float("nan")
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return max(own, children) / 1024.0


def success_by_condition(trials: pd.DataFrame) -> pd.DataFrame:
    """Trials and success rate per condition (the summary ``nudge simulate`` prints)."""
    grouped = trials.groupby("condition", sort=False)
    return pd.DataFrame({
        "trials": grouped.size(),
        "success_rate": grouped["success"].mean(),
        "timed_out": grouped["timed_out"].sum(),
        "median_duration_s": grouped["duration_s"].median(),
    })
