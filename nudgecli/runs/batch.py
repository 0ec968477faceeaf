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
  ``nudge analyze``) of the first ``n`` participants, submitted as soon as they are done. On the
  process pool it runs in this process, in a thread beside the workers (a job marked ``here``,
  :mod:`nudgecli.runs.executors`), which otherwise only waits for them: the statistics' modules
  are imported there after the first part, while the trials run, and no analysis waits for a worker;
  only where the thread falls behind (many workers) does an idle worker take one (``overflow``).
  On dask its metrics are split into as many chunks as there are workers (each metric's
  statistics are its own), one task each, the chunks' documents merged in order
  (:func:`~nudgecli.runs.batch_tasks.merge_analysis_chunks`), so a batch's last analysis
  does not run on one worker while the others wait. Its input is the parts written in this run
  (kept while an analysis of the study waits) or, after ``--resume``, read from their files.
  What the command needs after the batch (its figures' modules) is imported there too (``prepare``).

Layouts and their solved goal MDPs (the :class:`~nudgecli.sim.study.StudyPlan`) are kept in a
small cache in each worker (:mod:`nudgecli.runs.batch_tasks`: the tasks and the cache, keyed by
what the plans depend on), never built once per task: the process pool sends each worker the
tasks of the studies it already holds, and on dask the tasks of a study are hinted to one worker
(work stealing may still move them). In a batch of fewer studies than workers, a study with at
least as many unfinished participants as there are workers would have every worker solve all its
layouts at the start. On the process pool its layouts are solved once instead, in chunks spread
over the workers (*layout tasks*, :func:`nudgecli.runs.study.solve_layout_chunk_into`, each
chunk pickled into a file), and every worker assembles the plan from those files
(:func:`~nudgecli.runs.batch_tasks.install_plan_of_files`) before the study's participant tasks.
On dask, whose workers need not share this machine's files, every worker builds the plan itself
(faster than sending it to many workers) and the study's tasks are hinted to none.
Every result is written by this process as an atomic part file (``tasks/``, ``analyses/``; a
part's bytes built in its worker on many, :data:`~nudgecli.runs.batch_tasks.PART_BUILDING_WORKERS`),
so ``--resume`` finishes an interrupted batch without recomputing a finished task, and the tables
from the parts are the same for any executor and number of workers. Executors: :mod:`.executors`;
the folder's parts: :mod:`.batch_folder`; the three kinds of batch: :mod:`.batch_kinds`.
"""

from __future__ import annotations

import contextlib
import hashlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from nudgecli.config import ExperimentConfig
from nudgecli.errors import ConfigError, NudgeError
from nudgecli.locks import run_lock
from nudgecli.recording_digests import recordings
from nudgecli.rng import seed_sequence
from nudgecli.run_folder_state import refuse_linked_out
from nudgecli.runs.batch_folder import (
    Log,
    PolicyCopies,
    analysis_part,
    policy_copies,
    prepare_folder,
    read_study_metrics,
    task_part,
)
from nudgecli.runs.batch_inputs import copies_record
from nudgecli.runs.batch_record import BatchRecord
from nudgecli.runs.batch_tasks import (
    PART_BUILDING_WORKERS,
    TasksLeft,
    analysis_design,
    import_analysis_modules,
    install_plan_of_files,
    layout_key,
    merge_analysis_chunks,
    metric_definitions,
    read_analyses,
    run_analysis_task,
    run_participant_task,
    run_quietly,
    shares_plan,
    tasks_left,
    warn_global_rng,
)
from nudgecli.runs.executors import Executor, Job, ProcessExecutor, make_executor
from nudgecli.runs.progress import Progress
from nudgecli.runs.size import SizeEstimate, check_batch_size, size_estimate, trials_per_participant
from nudgecli.runs.study import connect_scheduler, contiguous_chunks, executor_name, solve_layout_chunk_into
from nudgecli.sim.people_file import People
from nudgecli.sim.study import build_layouts, check_physiology_logs

if TYPE_CHECKING:  # scipy.stats, scikit-posthocs load in analysis tasks; pandas once workers start
    import pandas as pd

    from nudgecli.report.plans import AnalysisPlan


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
        JSON-ready facts recorded in the manifest and compared on ``--resume`` (e.g. the design, the
        people file's record).
    people
        Twins of real people (``--people``): participant ``i`` of every study has the habits of
        person ``i mod P`` (:func:`nudgecli.sim.study.study_participant`); the batch folder keeps
        the file's bytes (``people/<its name>``).
    notes
        Told once the folder is prepared (people no study takes, :func:`nudgecli.sim.study.left_out_notes`).
    inputs
        A sweep's inputs its folder keeps beside its plan, by file name (its sweep file and the
        experiment file it names: :func:`~nudgecli.runs.batch_folder.sweep_inputs`).
    """

    kind: Literal["replicate", "power", "sweep"]
    points: tuple[Point, ...]
    replications: int
    seed: int
    plan: AnalysisPlan
    extra: dict[str, Any] = field(default_factory=dict)
    people: People | None = None
    notes: tuple[str, ...] = ()
    inputs: Mapping[str, bytes] = field(default_factory=dict, repr=False)

    def describe(self) -> dict[str, Any]:
        """What identifies the batch (a resumed batch must describe itself identically)."""
        return {"kind": self.kind, "replications": self.replications, "seed": self.seed,
                "plan": self.plan.model_dump(mode="json"), "points": [
                    {"index": p.index, "parameters": p.parameters, "participants": list(p.participants),
                     "study": study_key(p.config, 0), **recordings(p.config)} for p in self.points],
                **self.extra}


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


@dataclass(frozen=True)
class Study:  # one study of the batch

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
    entry_rows
        One row per (point, replication, participant count): ``point, replication, seed, participants,
        study, analysis`` (:attr:`entries` as a table)."""

    studies: dict[str, Study]
    analyses: dict[str, Analysis]
    entry_rows: list[dict[str, Any]]

    @property
    def entries(self) -> pd.DataFrame:
        """:attr:`entry_rows` as a table (made when the batch's tables are, not before its workers start)."""
        import pandas as pd

        return pd.DataFrame(self.entry_rows)

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
    rows: list[dict[str, Any]] = []
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
    return Graph(studies, analyses, rows)


def estimate(graph: Graph, workers: int, power: bool = False) -> SizeEstimate:
    """The size of the batch and its estimated wall time on ``workers`` and disk use (``power``: a
    power batch, whose tail draws a line per participant count analysed)."""
    levels = len({analysis.participants for analysis in graph.analyses.values()}) if power else 0
    return size_estimate(len(graph.studies), graph.participant_tasks, len(graph.analyses), graph.trials,
                         workers, power_levels=levels)


def estimate_batch(batch: Batch, workers: int, tasks_left: int | None = None) -> SizeEstimate:
    """:func:`estimate` of the batch's graph without building it (what the size guard checks first):
    every replication has the same studies up to their seeds (points with equal experiments share a
    study whatever the seed): one replication's counts times ``R``; its pool for ``tasks_left``."""
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
    levels = len({n for _, n in analysed}) if batch.kind == "power" else 0  # its figure's lines
    return size_estimate(r * len(participants), r * tasks, r * len(analysed), r * trials, workers, tasks_left,
                         power_levels=levels)


# --- the run -----------------------------------------------------------------------------------

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
    outputs: Any = None  # what run_batch's finish returned (the command's tables and figures)


#: What a command writes from its batch (:func:`run_batch`'s ``finish``).
Finish = Callable[[BatchRun], object] | None


def run_batch(batch: Batch, out: str | Path, workers: int = 1, scheduler: str | None = None,
              resume: bool = False, force: bool = False, confirm: bool = False,
              progress: Callable[[int, int], None] | None = None,
              log: Callable[[str], None] | None = None,
              prepare: Callable[[], object] | None = None, finish: Finish = None) -> BatchRun:
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
    prepare
        What the command does after the batch and may do before (e.g. import its figures' modules):
        on the process pool it runs in this process beside the workers, before the first analysis,
        off the batch's critical path; elsewhere it is not called.
    finish
        What the command writes from the batch (its tables and figures), its result kept as
        :attr:`BatchRun.outputs`: ``batch.json`` says ``complete`` only once it has returned, and
        ``interrupted`` if it fails or is interrupted (a resume writes them again).

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
    size = estimate_batch(batch, workers).on(scheduler)  # its pool; from counts alone
    check_batch_size(batch, size, confirm)  # trials, then steps: before anything is built
    for point in batch.points:
        check_physiology_logs(point.config)
    copies = policy_copies(batch)  # the policy code (and inputs) kept in the folder, as a run's
    refuse_linked_out(Path(out))  # a linked --out: refused before anything (its lock) is written through it
    client = connect_scheduler(scheduler, log) if scheduler else None  # refused before the folder exists
    folder = Path(out)
    made = not folder.exists()
    try:
        with run_lock(folder, log=log):
            return _run_batch_locked(batch, folder, size, workers, client, resume, force, copies, progress,
                                     log, prepare, finish)
    except BaseException:
        if made and folder.is_dir() and not any(folder.iterdir()):
            folder.rmdir()  # made only for this batch, which was refused: leave nothing behind
        raise
    finally:
        if client is not None:
            client.close()


def _run_batch_locked(batch: Batch, folder: Path, size: SizeEstimate, workers: int, client: Any, resume: bool,
                      force: bool, copies: PolicyCopies, progress: Callable[[int, int], None] | None,
                      log: Log, prepare: Callable[[], object] | None, finish: Finish) -> BatchRun:
    """:func:`run_batch` once the batch folder's lock is held (``copies``: the policy code it keeps)."""
    mode = prepare_folder(folder, batch.describe(), resume, force, batch.people, copies)
    graph = build_graph(batch)
    left = tasks_left(folder, graph)
    runnable = left.at_once() if mode == "resume" else 0  # the tasks left that can run at once
    if mode == "resume" and client is None and workers > 1:  # its pool: the tasks left, not all of them
        size = estimate_batch(batch, workers, runnable)
    if isinstance(progress, Progress):  # its ETA counts the tables and figures after the last task too
        progress.tail_s = size.tail_seconds
    if log is not None:  # only now: a refusal is its one error line
        for line in (f"batch: {size.describe()}", *(f"Note: {note}" for note in batch.notes)):
            log(line)
    described = {"batch": batch.describe(), "studies": len(graph.studies),
                 "participant_tasks": graph.participant_tasks, "analyses": len(graph.analyses),
                 "trials": graph.trials, **copies_record(folder, copies, mode == "resume")}
    executor_named = executor_name(size.workers, client is not None)
    # a resume with nothing left keeps the record of the run that computed the tasks
    record = BatchRecord.resumed(folder, described, executor_named, bool(runnable)) \
        if mode == "resume" else BatchRecord(folder, described, executor_named)
    record.begin()
    try:
        executor = make_executor(size.workers, client)
        computed = _run_graph(batch, graph, left, folder, executor, progress, prepare, log, record)
        record.ran(getattr(executor, "peak_rss_mb", None))  # on record before the tables: a kill may follow
        stats = read_analyses(folder, sorted(graph.analyses), batch.plan.label, log)  # its filters said
        run = BatchRun(folder, mode, graph, size, stats, computed, record.peak_mb)
        run.outputs = None if finish is None else finish(run)  # its tables and figures, before "complete"
    except BaseException:
        # interrupted (Ctrl-C, a failed task or write, its outputs not all written): not running, nor complete
        with contextlib.suppress(NudgeError, OSError):
            record.interrupted()
        raise
    record.complete()
    return run


def _run_graph(batch: Batch, graph: Graph, left: TasksLeft, folder: Path, executor: Executor,
               progress: Callable[[int, int], None] | None, prepare: Callable[[], object] | None,
               log: Log, batch_record: BatchRecord) -> int:
    """Submit every unfinished task, write each result as it comes, each counted in ``batch_record``
    (which keeps the count so far in ``batch.json``); returns the tasks this run computed."""
    run = _GraphRun(batch, graph, left, folder, executor, log)
    try:
        if prepare is not None and isinstance(executor, ProcessExecutor):  # then the command's own
            executor.submit(Job(_PREPARE, run_quietly, (prepare,), here=True))
            run.in_flight += 1
        run.submit_first()
        if progress:
            progress(run.done, run.total)
        while run.in_flight:
            job, result = executor.next_result()
            run.in_flight -= 1
            if run.take(job, result):
                run.done += 1
                batch_record.task_computed()
                if progress:
                    progress(run.done, run.total)
        run.record.write_in_order()  # its lines came in the order the tasks finished
    except BaseException:
        executor.abort()  # Ctrl-C or a failure: do not wait for the running tasks
        raise
    executor.close()
    return batch_record.computed


class _GraphRun:
    """One run of the batch's graph: what is left, what is in flight, the layout tasks' results."""

    def __init__(self, batch: Batch, graph: Graph, left: TasksLeft, folder: Path, executor: Executor,
                 log: Log = None) -> None:
        self.batch, self.graph, self.folder, self.executor = batch, graph, folder, executor
        #: study key -> its participants without a part the record vouches for; the analyses without one
        self.record, self.remaining, self.waiting = left.record, left.remaining, left.waiting
        self.record.warn_refused(log)  # the command's stderr, an API caller's log=
        self.log, self.rng_warned = log, False  # a policy's draws from a global generator: told once
        self.total = graph.participant_tasks + len(graph.analyses)
        self.done = self.total - sum(len(v) for v in self.remaining.values()) - len(self.waiting)
        self.metrics, self.definitions = list(batch.plan.metrics.include), metric_definitions(batch.plan)
        #: the analyses' imports go beside the trials once this process has written a first part (and
        #: so imported pandas and pyarrow: begun beside those imports, a Ctrl-C was lost in 1 run of 20)
        self.in_flight, self.warm = 0, bool(self.waiting)
        #: layout tasks: job key -> (study, chunk); the files of a study's finished chunks by index
        self.layout_jobs: dict[str, tuple[str, int]] = {}
        self.solved: dict[str, dict[int, str]] = {}
        #: analysis tasks: job key -> (analysis, chunk of its metrics, its chunks); its finished chunks
        self.analysis_jobs: dict[str, tuple[str, int, int]] = {}
        self.analysed: dict[str, dict[int, dict[str, Any]]] = {}
        #: study key -> its metrics parts written in this run by participant, read by its waiting analyses
        self.written: dict[str, dict[int, pd.DataFrame]] = {}

    def submit_first(self) -> None:
        """Each study's participant tasks, or its layout tasks where its plan is shared
        (:func:`~nudgecli.runs.batch_tasks.shares_plan`); then the analyses whose participants are all done.
        A plan is shared only on the process pool, whose workers share this machine's files (on dask,
        sending the 22 MB plan to every worker took 0.22 s to 2, 2.1 s to 16; one builds it in 0.18 s)."""
        busy = sum(1 for study in self.graph.studies.values() if self.remaining[study.key])
        for study in self.graph.studies.values():
            if not shares_plan(study, len(self.remaining[study.key]), busy, self.executor.workers):
                self.submit_participants(study)
            elif isinstance(self.executor, ProcessExecutor):
                self.submit_layouts(study)
            else:
                self.executor.spread(study.layouts)
                self.submit_participants(study)
        self.submit_ready()

    def submit_layouts(self, study: Study) -> None:
        """The study's layout tasks (on the process pool: :meth:`submit_first`)."""
        assert isinstance(self.executor, ProcessExecutor)
        self.solved[study.key] = {}
        chunks = contiguous_chunks(len(build_layouts(study.config, study.seed)), self.executor.workers)
        for c, (start, stop) in enumerate(chunks):
            key = f"{study.key}-layouts{c:03d}"
            self.layout_jobs[key] = (study.key, c)
            path = self.executor.scratch_path(f"{key}.pickle")  # the chunk stays in a file the workers read
            self.executor.submit(Job(key, solve_layout_chunk_into,
                                     (path, study.config, study.seed, start, stop)))
            self.in_flight += 1

    def submit_participants(self, study: Study) -> None:
        twins = () if self.batch.people is None else self.batch.people.twins  # (not the file's bytes)
        built = isinstance(self.executor, ProcessExecutor) and self.executor.workers >= PART_BUILDING_WORKERS
        for i in sorted(self.remaining[study.key]):
            self.executor.submit(Job(f"{study.key}-p{i:04d}", run_participant_task,
                                     (study.config, study.seed, i, self.definitions, twins, built),
                                     affinity=study.layouts))
        self.in_flight += len(self.remaining[study.key])

    def ready(self, analysis: Analysis) -> bool:
        return not any(i < analysis.participants for i in self.remaining[analysis.study])

    def submit_ready(self) -> None:
        """The waiting analyses whose participants are all done, each as one task per chunk of its
        metrics: on the process pool one (it runs in this process's thread beside the workers),
        elsewhere as many chunks as workers at most (a batch's last analyses then finish in
        parallel, not on one worker while the others wait)."""
        submitted = [a for a in self.waiting if self.ready(a)]
        self.waiting = [a for a in self.waiting if not self.ready(a)]
        # the process pool runs them in this process, one at a time: chunks would only add merges
        parts = 1 if isinstance(self.executor, ProcessExecutor) else self.executor.workers
        chunks = [self.metrics[a:b] for a, b in contiguous_chunks(len(self.metrics), parts)]
        for analysis in submitted:
            data = read_study_metrics(self.folder, analysis.study, analysis.participants,
                                      self.written.get(analysis.study))
            self.warm_up()  # (a resumed batch may have only analyses left)
            design = analysis_design(self.graph.studies[analysis.study].config, self.batch.plan)
            self.analysed[analysis.key] = {}
            for c, names in enumerate(chunks):
                key = f"{analysis.key}-m{c:02d}"
                self.analysis_jobs[key] = (analysis.key, c, len(chunks))
                self.executor.submit(Job(key, run_analysis_task, (data, self.batch.plan, names, *design),
                                         here=True, overflow=True))
                self.in_flight += 1
        waiting = {a.study for a in self.waiting}
        for study in [s for s in self.written if s not in waiting]:
            del self.written[study]

    def take(self, job: Job, result: Any) -> bool:
        """Write a finished task's part (submitting what it unblocks); whether it was a task of
        the batch's tables (a layout task and the command's preparation are not)."""
        if job.key in (_PREPARE, _WARM):
            return False
        if job.key in self.layout_jobs:
            self.take_layouts(job.key, result)
            return False
        if job.key in self.analysis_jobs:
            key, chunk, chunks = self.analysis_jobs.pop(job.key)
            self.analysed[key][chunk] = result
            if len(self.analysed[key]) < chunks:
                return False
            parts = self.analysed.pop(key)
            document = merge_analysis_chunks([parts[c] for c in range(chunks)])
            self.record.write_json(analysis_part(self.folder, key), document)
            return True
        study_name, index = job.key.rsplit("-p", 1)  # a participant task
        frame, data = result.part()
        self.rng_warned = warn_global_rng(self.rng_warned, result, self.graph.studies[study_name].config,
                                          self.folder, self.log)
        self.record.write(task_part(self.folder, study_name, int(index)), data)
        self.written.setdefault(study_name, {})[int(index)] = frame
        self.remaining[study_name].discard(int(index))
        self.warm_up()
        self.submit_ready()
        return True

    def warm_up(self) -> None:
        """Once: the analyses' imports in the pool's thread (after a part is written or read here)."""
        if self.warm and isinstance(self.executor, ProcessExecutor):
            self.warm, self.in_flight = False, self.in_flight + 1
            self.executor.warm(Job(_WARM, import_analysis_modules, (), here=True))

    def take_layouts(self, key: str, path: str) -> None:
        """Keep the file of a chunk of solved layouts; once a study has all of them, send its plan to every
        worker (which assembles it from the chunks' files: its 20 MB are neither received nor pickled
        again here while the workers wait) and submit its participant tasks."""
        study_key, chunk = self.layout_jobs.pop(key)
        self.solved[study_key][chunk] = path
        if any(owner == study_key for owner, _ in self.layout_jobs.values()):
            return
        study = self.graph.studies[study_key]
        parts = self.solved.pop(study_key)
        files = [parts[c] for c in sorted(parts)]
        assert isinstance(self.executor, ProcessExecutor)
        self.executor.broadcast(Job(f"{study_key}-plan", install_plan_of_files,
                                    (study.config, study.seed, files), affinity=study.layouts), files=files)
        self.submit_participants(study)


#: The keys of the jobs that run ``run_batch``'s ``prepare`` and import the analyses' modules.
_PREPARE, _WARM = "prepare", "import-analysis-modules"


def single_point(config: ExperimentConfig, participants: Sequence[int]) -> tuple[Point, ...]:
    """The one design point of ``replicate`` and ``power``."""
    return (Point(index=0, parameters={}, config=config, participants=tuple(participants)),)
