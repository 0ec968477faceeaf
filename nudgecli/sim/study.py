"""The study: shared layouts, blocks and counterbalancing, and its execution.

One participant is the unit of work. A participant's results are a pure function of
(experiment, seed, participant index): their physiology, calibration, schedule and every
trial draw from their own branches of the seed tree, and the layouts (with their solved goal
MDPs) are made once per study from the study's branch. So the tables are identical whether
the participants run serially, on local processes or on a dask cluster, in any order.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import pandas as pd

from nudgecli.config import ExperimentConfig
from nudgecli.errors import ConfigError
from nudgecli.model.disambiguation import DisambiguationModel
from nudgecli.model.interface import default_distortion_table, default_mapping_table
from nudgecli.model.mdp import MDPRewards, SolvedLayout, solve_layout
from nudgecli.model.world import MODE_NAMES, Layout, sample_layout
from nudgecli.rng import generator, seed_key
from nudgecli.sim.calibration import FittedTables, fit_participant_tables
from nudgecli.sim.calibration_io import DistortionSession, MappingSession, write_sessions
from nudgecli.sim.participants import Participant, draw_participant, participant_from_log
from nudgecli.sim.protocol import ProtocolSettings, TrialSpec, run_trial
from nudgecli.store import RunFolder, library_versions, utc_now


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
    Disambiguation and 24-47 Control).
    """
    study = config.study
    layouts: list[StudyLayout] = []
    for condition in study.conditions:
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
    conditions alternate, and the condition that starts rotates with the participant's index so
    that the starting condition is balanced across participants. Each trial's true goal is one
    of its layout's goals, uniformly, drawn from the trial's own seed branch
    (``participant/i/trial/t/true_goal``), so nothing can favour a goal by its index.
    ``first_condition`` (a live session's ``--condition-order``) starts with that condition
    instead of the rotation; the blocks and true goals stay those of the participant's seed.
    """
    study = config.study
    rng = generator(seed, "participant", participant, "schedule")
    n_blocks = study.blocks_per_condition
    blocks_by_condition: dict[str, list[list[StudyLayout]]] = {}
    for condition in study.conditions:
        mine = [lay for lay in layouts if lay.condition == condition]
        order = rng.permutation(len(mine))
        size = len(mine) // n_blocks
        blocks_by_condition[condition] = [[mine[k] for k in order[b * size:(b + 1) * size]]
                                          for b in range(n_blocks)]
    conditions = list(study.conditions)
    shift = participant % len(conditions) if first_condition is None else \
        [str(c) for c in conditions].index(first_condition)
    conditions = conditions[shift:] + conditions[:shift]
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


@dataclass(frozen=True)
class StudyPlan:
    """Everything a worker needs, computed once per study."""

    config: ExperimentConfig
    seed: int
    layouts: list[StudyLayout]
    solved: list[SolvedLayout]

    @classmethod
    def build(cls, config: ExperimentConfig, seed: int) -> StudyPlan:
        layouts = build_layouts(config, seed)
        return cls(config=config, seed=seed, layouts=layouts, solved=solve_layouts(config, layouts))


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
    step_parts: list[pd.DataFrame] = []
    models: dict[int, DisambiguationModel] = {}
    for spec in participant_schedule(config, seed, participant_index, plan.layouts):
        solved = plan.solved[spec.layout_index]
        model = models.get(spec.layout_index)
        if model is None:
            model = models[spec.layout_index] = DisambiguationModel(
                spec.layout.goal_cells, solved.p_a_given_sg, mapping, distortion)
        rng = generator(seed, "participant", participant_index, "trial", spec.trial)
        result = run_trial(spec, settings, solved, model, participant, rng)
        summaries.append(result.summary)
        step_parts.append(pd.DataFrame(result.steps))
    record = participant.to_record()
    record.update({
        "agent_p_phi_given_a": _json(mapping.tolist()),
        "agent_p_phm_given_phi": _json(distortion.tolist()),
        "calibration": _json(fitted.provenance),
    })
    return ParticipantResult(
        participant=participant_index,
        trials=pd.DataFrame(summaries),
        steps=pd.concat(step_parts, ignore_index=True),
        record=pd.DataFrame([record]),
        wall_s=time.perf_counter() - start,
        calibration=fitted.sessions,
    )


def _json(value: Any) -> str:
    return json.dumps(value, default=lambda v: v.tolist() if hasattr(v, "tolist") else str(v))


# --- executors --------------------------------------------------------------------------------

_WORKER_PLAN: StudyPlan | None = None


def _init_worker(plan: StudyPlan) -> None:
    global _WORKER_PLAN
    _WORKER_PLAN = plan


def _run_in_worker(participant_index: int) -> ParticipantResult:
    assert _WORKER_PLAN is not None, "worker not initialised"
    return simulate_participant(_WORKER_PLAN, participant_index)


def _serial(plan: StudyPlan, todo: list[int]) -> Iterator[ParticipantResult]:
    for index in todo:
        yield simulate_participant(plan, index)


def _processes(plan: StudyPlan, todo: list[int], workers: int) -> Iterator[ParticipantResult]:
    context = get_context("fork") if os.name == "posix" else get_context("spawn")
    with ProcessPoolExecutor(max_workers=workers, mp_context=context, initializer=_init_worker,
                             initargs=(plan,)) as pool:
        futures = [pool.submit(_run_in_worker, index) for index in todo]
        for future in as_completed(futures):
            yield future.result()


def _dask(plan: StudyPlan, todo: list[int], address: str) -> Iterator[ParticipantResult]:
    try:
        from dask.distributed import Client
        from dask.distributed import as_completed as dask_completed
    except ImportError as exc:  # pragma: no cover - depends on the optional extra
        raise ConfigError("--scheduler needs dask.distributed: pip install 'nudgecli[cluster]'") from exc
    try:
        client = Client(address, timeout="20s")
    except OSError as exc:
        raise ConfigError(f"--scheduler {address}: cannot connect ({exc}); check the address") from exc
    with client:
        shared = client.scatter(plan, broadcast=True)
        futures = [client.submit(simulate_participant, shared, index, pure=False) for index in todo]
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
              progress: Callable[[int, int], None] | None = None) -> StudyRun:
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

    Returns
    -------
    StudyRun
    """
    if workers < 1:
        raise ConfigError(f"--workers must be at least 1, got {workers}")
    seed = config.experiment.seed if seed is None else seed
    if seed < 0:
        raise ConfigError(f"--seed must be a non-negative integer, got {seed}")
    n = config.study.participants if participants is None else participants
    if n < 1:
        raise ConfigError(f"--participants must be at least 1, got {n}")
    if participants is not None:
        config = config.model_copy(update={"study": config.study.model_copy(update={"participants": n})})
    check_physiology_logs(config)
    folder = RunFolder(out)
    mode = folder.prepare(config, seed, n, resume=resume, force=force)
    done = set(folder.completed_participants()) if mode == "resume" else set()
    plan = StudyPlan.build(config, seed)
    trials_per = len(plan.layouts)
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
    manifest.update({"status": "running", "completed": sorted(done),
                     "executor": _executor_name(workers, scheduler)})
    folder.write_layouts(layouts_frame(plan.layouts))
    folder.write_manifest(manifest)
    todo = [i for i in range(n) if i not in done]
    started = time.perf_counter()
    if progress:
        progress(len(done) * trials_per, n * trials_per)
    if scheduler:
        results = _dask(plan, todo, scheduler)
    elif workers > 1 and len(todo) > 1:
        results = _processes(plan, todo, min(workers, len(todo)))
    else:
        results = _serial(plan, todo)
    for result in results:
        if result.calibration is not None:
            write_sessions(folder.calibration_dir(result.participant), *result.calibration)
        folder.write_participant_parts(result.participant, result.trials, result.steps, result.record)
        done.add(result.participant)
        manifest["completed"] = sorted(done)
        manifest["timings_s"][str(result.participant)] = round(result.wall_s, 3)
        folder.write_manifest(manifest)
        if progress:
            progress(len(done) * trials_per, n * trials_per)
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
