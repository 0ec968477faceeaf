"""Many studies as one task graph: replications, power and sweeps, on processes or dask.

A batch is a list of design points (one for ``replicate`` and ``power``, many for ``sweep``),
each run ``R`` times. Replication ``r`` of every point uses the same seed (common random numbers,
:func:`replication_seed`), so differences between points are not seed noise. Two kinds of task
make up the graph, all submitted to one executor:

- a *participant task* ``(study, participant)``: simulate one participant of one study
  (:func:`nudgecli.sim.study.simulate_participant`) and reduce their trials to the plan's
  per-trial metrics (one row per trial). A study is ``(experiment, seed)``; tasks of points
  whose experiments are equal are one task. A study with ``n`` participants holds the studies
  with fewer: participant ``i``'s results do not depend on how many others there are, so a
  power curve simulates each replication's largest study once and analyses its first ``n``;
- an *analysis task* ``(study, n)``: the plan's statistics (:mod:`nudgecli.report.stats`, as
  ``nudge analyze``) of the first ``n`` participants, submitted as soon as they are done.

Layouts and their solved goal MDPs (the :class:`~nudgecli.sim.study.StudyPlan`) are kept in a
small cache in each worker, keyed by what they depend on (:func:`layout_key`), never built once
per task: the process pool sends each worker the tasks of the studies it already holds, and on
dask the tasks of a study are hinted to one worker (work stealing may still move them). In a
batch of fewer studies than workers, a study with at least as many unfinished participants as
there are workers would have every worker solve all its layouts at the start; its layouts are
solved once instead, in chunks spread over
the workers (*layout tasks*, :func:`nudgecli.sim.study.solve_layout_chunk`), and the assembled
plan is sent to every worker (:func:`install_plan`) before its participant tasks.
Every result is written by this process as an atomic part file (``tasks/``, ``analyses/``), so
``--resume`` finishes an interrupted batch without recomputing a finished task, and the tables
assembled from the parts are the same for any executor and number of workers. The executors
themselves are in :mod:`nudgecli.runs.executors`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import shutil
import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import pandas as pd
import pyarrow.parquet as pq

from nudgecli.config import ExperimentConfig
from nudgecli.config_files import resolve_plan
from nudgecli.errors import ConfigError, NudgeError, RunFolderError
from nudgecli.locks import run_lock
from nudgecli.model.mdp import SolvedLayout
from nudgecli.report.metrics import trial_metrics
from nudgecli.rng import seed_sequence
from nudgecli.run_folder_names import FIGURES_DIR
from nudgecli.runs.executors import HELD_AFFINITIES, Executor, Job, format_duration, make_executor
from nudgecli.runs.size import check_size, trials_per_participant
from nudgecli.runs.study import connect_scheduler, layout_chunks, solve_layout_chunk, tune_allocator
from nudgecli.sim.study import StudyPlan, build_layouts, check_physiology_logs, simulate_participant
from nudgecli.store import prepare_mode, provenance, utc_now, write_json_atomic, write_parquet_atomic

if TYPE_CHECKING:  # the statistics (scipy.stats, scikit-posthocs) load in analysis tasks only
    from nudgecli.report.plans import AnalysisPlan

BATCH_MANIFEST = "batch.json"
#: Wall seconds per simulated trial on one core (``nudge bench``: one participant of ``paper``,
#: 48 trials in about 0.4-0.7 s on the 2-core development machine) -- for the size estimate only.
SECONDS_PER_TRIAL = 0.012
#: Wall seconds of one analysis (7 metrics, 2000 bootstrap resamples, a paper-scale study: 0.4 s).
SECONDS_PER_ANALYSIS = 0.4
#: Bytes on disk: a participant task's part file (about 7 KB of Parquet overhead and 60 bytes per
#: trial, measured on ``smoke``) and an analysis (its JSON document, about 14 KB).
BYTES_PER_TASK = 7_000
BYTES_PER_TRIAL = 60
BYTES_PER_ANALYSIS = 14_000
#: Study plans (layouts + solved MDPs, about 20 MB at the paper's 48 layouts) a worker keeps; the
#: process pool's dispatch mirrors this cache.
PLAN_CACHE_SIZE = HELD_AFFINITIES


# --- the batch ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class Point:
    """One design point: the swept values, its experiment and the participant counts analysed."""

    index: int
    parameters: dict[str, Any]
    config: ExperimentConfig
    participants: tuple[int, ...]


@dataclass(frozen=True)
class Batch:
    """A batch: points x replications, analysed with one plan.

    Attributes
    ----------
    kind
        ``replicate``, ``power`` or ``sweep`` (recorded in the manifest).
    points
        The design points.
    replications
        ``R``: studies per point.
    seed
        The master seed; replication ``r`` uses :func:`replication_seed` ``(seed, r)`` at every point.
    plan
        The analysis plan of every replication.
    extra
        JSON-ready facts recorded in the manifest and compared on ``--resume`` (e.g. the design).
    """

    kind: Literal["replicate", "power", "sweep"]
    points: tuple[Point, ...]
    replications: int
    seed: int
    plan: AnalysisPlan
    extra: dict[str, Any] = field(default_factory=dict)

    def describe(self) -> dict[str, Any]:
        """What identifies the batch (a resumed batch must describe itself identically)."""
        return {
            "kind": self.kind,
            "replications": self.replications,
            "seed": self.seed,
            "plan": self.plan.model_dump(mode="json"),
            "points": [{"index": p.index, "parameters": p.parameters, "participants": list(p.participants),
                        "study": study_key(p.config, 0)} for p in self.points],
            **self.extra,
        }


def replication_seed(master_seed: int, replication: int) -> int:
    """The seed of replication ``r``: its own branch of the master seed (63 bits)."""
    state = seed_sequence(master_seed, "replication", replication).generate_state(1, dtype=np.uint64)
    return int(state[0] >> np.uint64(1))


def _normalised_toml(config: ExperimentConfig) -> str:
    """The experiment without its participant count (participant ``i`` does not depend on it)."""
    study = config.study.model_copy(update={"participants": 1})
    return config.model_copy(update={"study": study}).to_toml()


def study_key(config: ExperimentConfig, seed: int) -> str:
    """A stable name of the study ``(experiment, seed)``, whatever its participant count."""
    text = f"{_normalised_toml(config)}\nseed = {seed}\n"
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


#: Sections that neither draw nor solve layouts (the study's layouts depend on ``[study]`` and
#: the seed, their MDPs on ``[model]``); every other section, present or future, is in the key.
_NOT_LAYOUT_SECTIONS = ("experiment", "interface", "inference", "disambiguation", "assistance", "population",
                        "calibration")


def layout_key(config: ExperimentConfig, seed: int) -> str:
    """What a study's layouts and their solved MDPs depend on, as a short hash."""
    data = config.model_dump(mode="json", exclude=set(_NOT_LAYOUT_SECTIONS))
    data["study"].pop("participants", None)
    text = f"{sorted(data.items())!r}\nseed = {seed}"
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


@dataclass(frozen=True)
class Study:
    """One study of the batch."""

    key: str
    config: ExperimentConfig
    seed: int
    participants: int
    layouts: str


@dataclass(frozen=True)
class Analysis:
    """One analysis: the first ``participants`` of a study, for (point, replication)."""

    key: str
    study: str
    participants: int


@dataclass
class Graph:
    """The batch's tasks.

    Attributes
    ----------
    studies
        Study key -> study (each with the most participants any point needs of it).
    analyses
        Analysis key -> analysis.
    entries
        One row per (point, replication, participant count): ``point, replication, seed,
        participants, study, analysis``.
    """

    studies: dict[str, Study]
    analyses: dict[str, Analysis]
    entries: pd.DataFrame

    @property
    def participant_tasks(self) -> int:
        return sum(s.participants for s in self.studies.values())

    @property
    def trials(self) -> int:
        return sum(s.participants * trials_per_participant(s.config) for s in self.studies.values())


def build_graph(batch: Batch) -> Graph:
    """Every study and analysis of the batch, deduplicated (equal experiments share tasks)."""
    studies: dict[str, Study] = {}
    analyses: dict[str, Analysis] = {}
    rows = []
    for r in range(batch.replications):
        seed = replication_seed(batch.seed, r)
        for point in batch.points:
            key = study_key(point.config, seed)
            need = max(point.participants)
            known = studies.get(key)
            if known is None or known.participants < need:
                config = point.config.model_copy(update={
                    "study": point.config.study.model_copy(update={"participants": need})})
                studies[key] = Study(key, config, seed, need, layout_key(point.config, seed))
            for n in point.participants:
                analysis = f"{key}-n{n:04d}"
                analyses[analysis] = Analysis(analysis, key, n)
                rows.append({"point": point.index, "replication": r, "seed": seed, "participants": n,
                             "study": key, "analysis": analysis})
    return Graph(studies, analyses, pd.DataFrame(rows))


@dataclass(frozen=True)
class SizeEstimate:
    """How big a batch is, from the figures ``nudge bench`` measures (see the constants above)."""

    studies: int
    participant_tasks: int
    analyses: int
    trials: int
    seconds: float
    bytes: int
    workers: int

    def describe(self) -> str:
        return (f"{self.studies:,} studies, {self.participant_tasks:,} participant tasks + {self.analyses:,} "
                f"analyses, {self.trials:,} trials; about {format_duration(self.seconds)} on {self.workers} "
                f"worker(s) and {self.bytes / 1e6:.1f} MB on disk")


def estimate(graph: Graph, workers: int) -> SizeEstimate:
    """The size of the batch and its estimated wall time on ``workers`` and disk use."""
    return _size(len(graph.studies), graph.participant_tasks, len(graph.analyses), graph.trials, workers)


def estimate_batch(batch: Batch, workers: int) -> SizeEstimate:
    """:func:`estimate` of the batch's graph without building it: constant memory in the replications.

    Every replication has the same studies up to their seeds (points with equal experiments
    share a study whatever the seed), so one replication's counts times ``R`` are the graph's.
    This is what the size guard checks before anything is built.
    """
    participants: dict[str, int] = {}  # one replication's studies: normalised experiment -> participants
    per_trial: dict[str, int] = {}
    analysed: set[tuple[str, int]] = set()
    for point in batch.points:
        key = _normalised_toml(point.config)
        participants[key] = max(participants.get(key, 0), max(point.participants))
        per_trial[key] = trials_per_participant(point.config)
        analysed.update((key, n) for n in point.participants)
    r = batch.replications
    tasks = sum(participants.values())
    trials = sum(n * per_trial[key] for key, n in participants.items())
    return _size(r * len(participants), r * tasks, r * len(analysed), r * trials, workers)


def _size(studies: int, participant_tasks: int, analyses: int, trials: int, workers: int) -> SizeEstimate:
    seconds = (trials * SECONDS_PER_TRIAL + analyses * SECONDS_PER_ANALYSIS) / max(1, workers)
    size = participant_tasks * BYTES_PER_TASK + trials * BYTES_PER_TRIAL + analyses * BYTES_PER_ANALYSIS
    return SizeEstimate(studies, participant_tasks, analyses, trials, seconds, size, workers)


# --- tasks (run in a worker) -------------------------------------------------------------------

_PLANS: OrderedDict[str, StudyPlan] = OrderedDict()
_PLANS_LOCK = threading.Lock()


def cached_plan(config: ExperimentConfig, seed: int) -> StudyPlan:
    """The study plan of ``(config, seed)`` from this process's cache, built on a miss.

    Keyed by :func:`layout_key`: studies that differ only in settings that do not touch the
    layouts (e.g. ``inference.kappa`` in a sweep) share one plan. Holds :data:`PLAN_CACHE_SIZE`
    plans at most (least recently used dropped), so a worker's memory does not grow with the batch.
    """
    key = layout_key(config, seed)
    with _PLANS_LOCK:  # a dask worker may run tasks in several threads
        plan = _PLANS.get(key)
        if plan is None:
            plan = StudyPlan.build(config, seed)
        _remember_plan(key, plan)
    return dataclasses.replace(plan, config=config)


def _remember_plan(key: str, plan: StudyPlan) -> None:
    """Make ``plan`` the cache's most recent (dropping the oldest beyond ``PLAN_CACHE_SIZE``); the
    caller holds ``_PLANS_LOCK``."""
    _PLANS[key] = plan
    _PLANS.move_to_end(key)
    while len(_PLANS) > PLAN_CACHE_SIZE:
        _PLANS.popitem(last=False)


def install_plan(plan: StudyPlan) -> None:
    """Put a study's plan, built elsewhere, into this process's cache (:func:`cached_plan` finds it)."""
    with _PLANS_LOCK:
        _remember_plan(layout_key(plan.config, plan.seed), plan)


def participant_metrics(plan: StudyPlan, index: int, analysis: AnalysisPlan) -> pd.DataFrame:
    """One participant's per-trial metrics under the analysis plan's definitions.

    Returns
    -------
    pd.DataFrame
        One row per trial: ``participant, condition, block, trial`` and the metrics of
        :func:`nudgecli.report.metrics.trial_metrics`.
    """
    result = simulate_participant(plan, index)
    definitions = analysis.metrics.model_dump(exclude={"include"})
    return trial_metrics(result.trials, result.steps, **definitions)


def run_participant_task(config: ExperimentConfig, seed: int, index: int,
                         analysis: AnalysisPlan) -> pd.DataFrame:
    """A participant task, with this worker's cached plan of the study."""
    tune_allocator()
    return participant_metrics(cached_plan(config, seed), index, analysis)


def run_analysis_task(metrics: pd.DataFrame, analysis: AnalysisPlan, names: Sequence[str],
                      study_conditions: Sequence[str] = ()) -> dict[str, Any]:
    """An analysis task: the replication's statistics (:func:`analyse_replication`; the study's
    conditions give their order after the plan's)."""
    tune_allocator()
    from nudgecli.report.replication import analyse_replication

    return analyse_replication(metrics, analysis, names, study_conditions)


# --- the run -----------------------------------------------------------------------------------

def task_part(folder: Path, study: str, participant: int) -> Path:
    """The part file of a participant task."""
    return folder / "tasks" / study / f"part-{participant:04d}.parquet"


def analysis_part(folder: Path, analysis: str) -> Path:
    """The part file of an analysis."""
    return folder / "analyses" / f"{analysis}.json"


def _readable_parquet(path: Path) -> bool:
    if not path.is_file():
        return False
    try:
        pq.ParquetFile(path)
    except Exception:  # pyarrow raises several types for broken files
        return False
    return True


def _readable_json(path: Path) -> bool:
    """Whether ``path`` holds an analysis's stats document: a JSON object with a list of
    ``conditions`` and of ``metrics`` (anything else, e.g. a damaged or edited file, is
    recomputed by ``--resume``)."""
    if not path.is_file():
        return False
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(document, dict) and isinstance(document.get("conditions"), list) and \
        isinstance(document.get("metrics"), list) and all(isinstance(m, dict) for m in document["metrics"])


def read_study_metrics(folder: Path, study: str, participants: int) -> pd.DataFrame:
    """The per-trial metrics of a study's first ``participants``, in participant order."""
    frames = [pd.read_parquet(task_part(folder, study, i)) for i in range(participants)]
    return pd.concat(frames, ignore_index=True)


def prepare_folder(folder: Path, description: dict[str, Any], resume: bool, force: bool) -> str:
    """Make ``folder`` ready for the batch; ``"new"`` or ``"resume"`` (same description required).

    The rule is the run folder's (:func:`nudgecli.store.prepare_mode`); a folder that is not empty
    but holds no batch is written into with ``force``, not cleared."""
    manifest, old = folder / BATCH_MANIFEST, None
    if manifest.is_file():
        try:
            old = json.loads(manifest.read_text(encoding="utf-8"))
        except ValueError as exc:
            raise RunFolderError(f"{manifest}: unreadable ({exc}); use --force to start again") from None
    held = None if old is None else f"{old.get('batch', {}).get('kind')}, {old.get('status')}"
    mode = prepare_mode(folder, held, resume, force, kind="batch")
    if old is not None and mode == "resume":
        if old.get("batch") != json.loads(json.dumps(description)):
            raise RunFolderError(f"{folder}: holds a different batch (experiment, design, seed, "
                                 "replications or plan); resume it with the same settings, or use --force")
        return "resume"
    if mode == "replace":
        for name in ("tasks", "analyses", FIGURES_DIR):
            shutil.rmtree(folder / name, ignore_errors=True)
        manifest.unlink()
    folder.mkdir(parents=True, exist_ok=True)
    return "new"


@dataclass
class BatchRun:
    """What :func:`run_batch` did: the folder, the graph, the analyses' stats documents."""

    path: Path
    mode: str
    graph: Graph
    estimate: SizeEstimate
    stats: dict[str, dict[str, Any]]
    computed: int
    worker_peak_mb: float | None = None


def run_batch(batch: Batch, out: str | Path, workers: int = 1, scheduler: str | None = None,
              resume: bool = False, force: bool = False, confirm: bool = False,
              progress: Callable[[int, int], None] | None = None,
              log: Callable[[str], None] | None = None) -> BatchRun:
    """Run every task of the batch into the folder ``out``.

    Parameters
    ----------
    batch
        Points, replications, seed and plan.
    out
        The batch folder (``batch.json``, ``tasks/``, ``analyses/``).
    workers
        Local worker processes (1: in this process).
    scheduler
        A dask.distributed scheduler address; overrides ``workers``. Checked before the folder
        is created.
    resume, force
        Finish the batch already in ``out`` / replace it.
    confirm
        Run a batch above :data:`nudgecli.runs.size.MAX_TRIALS_WITHOUT_YES` trials (``--yes``).
    progress
        Called with (tasks done, tasks in all) after every task.
    log
        Called with lines for the user (the size estimate).

    Returns
    -------
    BatchRun

    Raises
    ------
    ConfigError
        Bad workers, an unreachable scheduler, or a batch too large without ``confirm``.
    RunFolderError
        ``out`` holds something else (see :func:`prepare_folder`).
    LockError
        Another command is writing ``out`` (the batch folder is locked for the whole batch, as a
        run folder is).
    """
    if workers < 1:
        raise ConfigError(f"--workers must be at least 1, got {workers}")
    size = estimate_batch(batch, workers)  # before anything is built: constant memory
    check_size(size.trials, confirm, details=size.describe(),
               fix="fewer replications, participants or design points")
    for point in batch.points:
        check_physiology_logs(point.config)
    client = connect_scheduler(scheduler) if scheduler else None  # refused before the folder exists
    folder = Path(out)
    made = not folder.exists()
    try:
        with run_lock(folder):
            return _run_batch_locked(batch, folder, size, workers, client, resume, force, progress, log)
    except BaseException:
        if made and folder.is_dir() and not any(folder.iterdir()):
            folder.rmdir()  # made only for this batch, which was refused: leave nothing behind
        raise
    finally:
        if client is not None:
            client.close()


def _run_batch_locked(batch: Batch, folder: Path, size: SizeEstimate, workers: int, client: Any, resume: bool,
                      force: bool, progress: Callable[[int, int], None] | None,
                      log: Callable[[str], None] | None) -> BatchRun:
    """:func:`run_batch` once the batch folder's lock is held."""
    mode = prepare_folder(folder, batch.describe(), resume=resume, force=force)
    if log is not None:  # only now: a refusal is its one error line
        log(f"batch: {size.describe()}")
    graph = build_graph(batch)
    manifest: dict[str, Any] = {
        "batch": batch.describe(),
        "status": "running",
        "executor": "dask" if client is not None else ("serial" if workers == 1 else f"processes:{workers}"),
        **provenance(),
        "studies": len(graph.studies),
        "participant_tasks": graph.participant_tasks,
        "analyses": len(graph.analyses),
        "trials": graph.trials,
    }
    write_json_atomic(folder / BATCH_MANIFEST, manifest)
    started = time.perf_counter()
    try:
        executor = make_executor(workers, client)
        computed = _run_graph(batch, graph, folder, executor, progress)
    except BaseException:
        # an interrupted batch (Ctrl-C, a failed task, a write error) must not read as running
        manifest.update({"status": "interrupted", "interrupted": utc_now()})
        with contextlib.suppress(NudgeError, OSError):
            write_json_atomic(folder / BATCH_MANIFEST, manifest)
        raise
    stats = {key: _read_json(analysis_part(folder, key)) for key in sorted(graph.analyses)}
    peak = getattr(executor, "peak_rss_mb", None)
    manifest.update({"status": "complete", "finished": utc_now(),
                     "wall_s": round(time.perf_counter() - started, 3),
                     "worker_peak_rss_mb": None if peak is None else round(peak, 1)})
    write_json_atomic(folder / BATCH_MANIFEST, manifest)
    return BatchRun(folder, mode, graph, size, stats, computed, peak)


def _read_json(path: Path) -> dict[str, Any]:
    return json.loads(path.read_text(encoding="utf-8"))


def _run_graph(batch: Batch, graph: Graph, folder: Path, executor: Executor,
               progress: Callable[[int, int], None] | None) -> int:
    """Submit every unfinished task, write each result as it comes; returns the tasks computed."""
    remaining: dict[str, set[int]] = {}
    for study in graph.studies.values():
        remaining[study.key] = {i for i in range(study.participants)
                                if not _readable_parquet(task_part(folder, study.key, i))}
    waiting = [a for a in graph.analyses.values() if not _readable_json(analysis_part(folder, a.key))]
    total = graph.participant_tasks + len(graph.analyses)
    done = total - sum(len(v) for v in remaining.values()) - len(waiting)
    metrics = list(batch.plan.metrics.include)
    in_flight = 0

    def ready(analysis: Analysis) -> bool:
        return not any(i < analysis.participants for i in remaining[analysis.study])

    def submit_ready() -> int:
        nonlocal waiting
        submitted = [a for a in waiting if ready(a)]
        waiting = [a for a in waiting if not ready(a)]
        for analysis in submitted:
            data = read_study_metrics(folder, analysis.study, analysis.participants)
            conditions = tuple(graph.studies[analysis.study].config.study.conditions)
            executor.submit(Job(analysis.key, run_analysis_task, (data, batch.plan, metrics, conditions)))
        return len(submitted)

    def submit_participants(study: Study) -> int:
        for i in sorted(remaining[study.key]):
            executor.submit(Job(f"{study.key}-p{i:04d}", run_participant_task,
                                (study.config, study.seed, i, batch.plan), affinity=study.layouts))
        return len(remaining[study.key])

    # layout tasks: job key -> (study, chunk); a study's finished chunks by index
    layout_jobs: dict[str, tuple[str, int]] = {}
    solved: dict[str, dict[int, list[SolvedLayout]]] = {}
    busy = sum(1 for study in graph.studies.values() if remaining[study.key])
    try:
        for study in graph.studies.values():
            if not shares_plan(study, len(remaining[study.key]), busy, executor.workers):
                in_flight += submit_participants(study)
                continue
            solved[study.key] = {}
            chunks = layout_chunks(len(build_layouts(study.config, study.seed)), executor.workers)
            for c, (start, stop) in enumerate(chunks):
                key = f"{study.key}-layouts{c:03d}"
                layout_jobs[key] = (study.key, c)
                executor.submit(Job(key, solve_layout_chunk, (study.config, study.seed, start, stop)))
                in_flight += 1
        in_flight += submit_ready()
        if progress:
            progress(done, total)
        computed = 0
        while in_flight:
            job, result = executor.next_result()
            in_flight -= 1
            if job.key in layout_jobs:  # a layout task: not a part of the batch's tables
                study_key, chunk = layout_jobs.pop(job.key)
                solved[study_key][chunk] = result
                if not any(owner == study_key for owner, _ in layout_jobs.values()):
                    study = graph.studies[study_key]
                    parts = solved.pop(study_key)
                    plan = StudyPlan.assemble(study.config, study.seed, [parts[c] for c in sorted(parts)])
                    executor.broadcast(Job(f"{study_key}-plan", install_plan, (plan,),
                                           affinity=study.layouts))
                    in_flight += submit_participants(study)
                continue
            if job.affinity is not None:  # a participant task
                study_name, index = job.key.rsplit("-p", 1)
                write_parquet_atomic(task_part(folder, study_name, int(index)), result)
                remaining[study_name].discard(int(index))
                in_flight += submit_ready()
            else:
                write_json_atomic(analysis_part(folder, job.key), result)
            done += 1
            computed += 1
            if progress:
                progress(done, total)
    except BaseException:
        executor.abort()  # Ctrl-C or a failure: do not wait for the running tasks
        raise
    executor.close()
    return computed


def shares_plan(study: Study, unfinished: int, studies: int, workers: int) -> bool:
    """Whether the study's layouts are solved in layout tasks and its plan sent to every worker.

    Only where several workers would otherwise each solve all of them: a grid-world study (the
    CIAA world has no MDPs to solve) with at least as many unfinished participant tasks as there
    are workers, in a batch of fewer ``studies`` (with work left) than workers, so that the
    study's tasks spread over most of them. With as many studies as workers, each study stays
    on one or two workers (the pool sends a study's tasks to the workers that hold its plan),
    and sending every plan to every worker would cost more than it saves.
    """
    return workers > 1 and unfinished >= workers and studies < workers and study.config.world.kind != "ciaa"


def point_table(batch: Batch) -> pd.DataFrame:
    """One row per point: ``point`` and its swept parameters (values as they were given)."""
    return pd.DataFrame([{"point": p.index, **p.parameters} for p in batch.points])


def parameter_names(batch: Batch) -> list[str]:
    """The swept parameters, in the design's order."""
    names: list[str] = []
    for point in batch.points:
        names += [n for n in point.parameters if n not in names]
    return names


def single_point(config: ExperimentConfig, participants: Sequence[int]) -> tuple[Point, ...]:
    """The one design point of ``replicate`` and ``power``."""
    return (Point(index=0, parameters={}, config=config, participants=tuple(participants)),)



# --- the commands: replicate, power, sweep ----------------------------------------------------

@dataclass
class BatchResult:
    """What a command computed and wrote.

    Attributes
    ----------
    run
        The batch run.
    rows
        One row per replication, metric and pair of conditions (``replications.csv``).
    summary
        The command's main table (printed by the CLI).
    tables
        Every table written, by file stem.
    files
        Every file written.
    """

    run: BatchRun
    rows: pd.DataFrame
    summary: pd.DataFrame
    tables: dict[str, pd.DataFrame]
    files: list[Path]


def _write_tables(folder: Path, tables: dict[str, pd.DataFrame]) -> list[Path]:
    from nudgecli.store import write_text_atomic

    written = []
    for stem, table in tables.items():
        path = folder / f"{stem}.csv"
        write_text_atomic(path, table.to_csv(index=False))
        written.append(path)
    return written


def _figures(folder: Path, figures: dict[str, Any]) -> list[Path]:
    from nudgecli.report.figures.output import save_figure

    written: list[Path] = []
    for stem, fig in figures.items():
        written += save_figure(fig, folder / FIGURES_DIR, stem, ("png",))
    return written


def _load(experiment: str, overrides: Sequence[str], participants: int | None) -> ExperimentConfig:
    from nudgecli.config import load_experiment

    config = load_experiment(experiment, tuple(overrides))
    if participants is not None:
        if participants < 1:
            raise ConfigError(f"--participants must be at least 1, got {participants}")
        study = config.study.model_copy(update={"participants": participants})
        config = config.model_copy(update={"study": study})
    return config


def _check(replications: int, seed: int | None) -> None:
    if replications < 1:
        raise ConfigError(f"--replications must be at least 1, got {replications}")
    if seed is not None and seed < 0:
        raise ConfigError(f"--seed must be a non-negative integer, got {seed}")


def replicate(experiment: str, replications: int, out: str | Path, *, seed: int | None = None,
              plan: str | AnalysisPlan | None = None, participants: int | None = None,
              overrides: Sequence[str] = (), **options: Any) -> BatchResult:
    """``nudge replicate``: R independent studies of one experiment, each analysed with the plan.

    Writes ``replications.csv`` (per replication), ``conditions.csv`` (tidy medians per
    condition), ``summary.csv`` (per metric: significance rates, median p, pooled effects) and
    ``figures/forest.png``. ``options`` go to :func:`run_batch`.
    """
    from nudgecli.report.figures.replication import forest_figure
    from nudgecli.report.plans import load_plan
    from nudgecli.report.replication import condition_values, replication_rows, summarise

    _check(replications, seed)
    config = _load(experiment, overrides, participants)
    chosen = load_plan(resolve_plan(plan, experiment=config.experiment.name))
    batch = Batch("replicate", single_point(config, (config.study.participants,)), replications,
                  config.experiment.seed if seed is None else seed, chosen,
                  {"experiment": config.experiment.name})
    run = run_batch(batch, out, **options)
    rows = replication_rows(run.graph.entries, run.stats, chosen)
    summary = summarise(rows).drop(columns=["point"])
    tables = {"replications": rows.drop(columns=["point"]),
              "conditions": condition_values(run.graph.entries, run.stats).drop(columns=["point"]),
              "summary": summary}
    figures = {"forest": forest_figure(rows, summarise(rows))}
    files = _write_tables(run.path, tables) + _figures(run.path, figures)
    return BatchResult(run, rows, summary, tables, files)


def power(experiment: str, participant_counts: Sequence[int], replications: int, out: str | Path, *,
          seed: int | None = None, plan: str | AnalysisPlan | None = None, overrides: Sequence[str] = (),
          target: float = 0.8, **options: Any) -> BatchResult:
    """``nudge power``: the power curve of every metric over participant counts.

    Replication ``r`` simulates its largest study once; each count ``n`` analyses its first
    ``n`` participants. Writes ``power.csv`` (per count, metric and level of test, with the
    Clopper-Pearson interval), ``smallest_n.csv``, ``replications.csv`` and ``figures/power.png``.
    """
    from nudgecli.report.figures.replication import power_figure
    from nudgecli.report.plans import load_plan
    from nudgecli.report.replication import power_table, replication_rows, smallest_n

    _check(replications, seed)
    counts = sorted(set(int(n) for n in participant_counts))
    if not counts or counts[0] < 2:
        raise ConfigError("--participants: give counts of at least 2, e.g. --participants 6,9,12,18,24")
    if not 0 < target < 1:
        raise ConfigError(f"--target must be between 0 and 1, got {target}")
    config = _load(experiment, overrides, None)
    chosen = load_plan(resolve_plan(plan, experiment=config.experiment.name))
    batch = Batch("power", single_point(config, counts), replications,
                  config.experiment.seed if seed is None else seed, chosen,
                  {"experiment": config.experiment.name})
    run = run_batch(batch, out, **options)
    rows = replication_rows(run.graph.entries, run.stats, chosen)
    curves = power_table(rows)
    smallest = smallest_n(curves, target)
    tables = {"power": curves, "smallest_n": smallest, "replications": rows.drop(columns=["point"])}
    files = _write_tables(run.path, tables) + _figures(run.path, {"power": power_figure(curves, target)})
    return BatchResult(run, rows, curves, tables, files)


def sweep(sweep_file: str, out: str | Path, *, replications: int | None = None, seed: int | None = None,
          **options: Any) -> BatchResult:
    """``nudge sweep``: every design point of a sweep file, R replications each with common seeds.

    Writes ``sweep.csv`` (tidy: ``point, replication, seed, <parameters...>, condition, metric,
    value``), ``replications.csv``, ``points.csv`` (per point and metric: the summary of
    :func:`nudgecli.report.replication.summarise` with the parameters), for Sobol and Morris
    designs ``sensitivity.csv``, and the figures ``figures/sweep.png`` (and ``sensitivity.png``).
    """
    from nudgecli.report.figures.replication import sensitivity_figure, sweep_figure
    from nudgecli.report.plans import load_plan
    from nudgecli.report.replication import (
        condition_values,
        point_outputs,
        replication_rows,
        sensitivity,
        summarise,
    )
    from nudgecli.runs.sweep import load_sweep

    loaded = load_sweep(sweep_file)
    spec = loaded.spec
    count = spec.replications if replications is None else replications
    _check(count, seed)
    chosen = load_plan(spec.plan)
    points = tuple(Point(p.index, p.parameters, p.config, (p.config.study.participants,))
                   for p in loaded.points)
    batch = Batch("sweep", points, count, spec.seed if seed is None else seed, chosen,
                  {"design": spec.design.model_dump(mode="json"), "experiment": spec.experiment})
    run = run_batch(batch, out, **options)
    names = parameter_names(batch)
    table = point_table(batch).astype(object)
    for name in names:
        table[name] = table[name].map(lambda v: v if isinstance(v, int | float | str | bool) else str(v))
    rows = replication_rows(run.graph.entries, run.stats, chosen, table)
    summary = summarise(rows).merge(table, on="point", how="left")
    tidy = condition_values(run.graph.entries, run.stats, table)
    tables = {"sweep": tidy, "replications": rows, "points": summary}
    figures: dict[str, Any] = {"sweep": sweep_figure(rows, names)}
    if loaded.problem is not None and loaded.samples is not None:
        indices = sensitivity(spec.design.method, loaded.problem, loaded.samples, point_outputs(rows),
                              levels=spec.design.levels, seed=batch.seed)
        tables["sensitivity"] = indices
        if not indices.empty:
            figures["sensitivity"] = sensitivity_figure(indices)
    files = _write_tables(run.path, tables) + _figures(run.path, figures)
    return BatchResult(run, rows, tables.get("sensitivity", summary), tables, files)
