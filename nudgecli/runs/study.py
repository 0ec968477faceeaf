"""Running a study: where its participants run (serially, on local processes or on a dask
cluster) and the run folder's life while they do (lock, manifest, parts, resume). What runs in
the workers, and their lifecycle, is :mod:`nudgecli.runs.study_tasks`: they send back a
participant's columns, and the tables are made here, in the process that writes them.

The domain (the plan, one participant's study) is :mod:`nudgecli.sim.study`; a participant's
results are a pure function of (experiment, seed, participant index), so the tables are
identical whichever executor runs them, in any order.
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import json
import math
import os
import pickle
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nudgecli.config import ExperimentConfig
from nudgecli.config_files import problem_words, resolve_plan
from nudgecli.cores import pool_workers
from nudgecli.errors import ConfigError, NudgeError, PolicyError
from nudgecli.locks import run_lock
from nudgecli.model.mdp import SolvedLayout
from nudgecli.recording_digests import recordings
from nudgecli.rng import check_seed
from nudgecli.run_folder_calibration import write_calibration_logs
from nudgecli.run_folder_names import LAYOUTS, PARTICIPANTS
from nudgecli.run_folder_record import CONSTANT_METRICS_KEY, FILE_CHECKSUMS
from nudgecli.run_folder_state import DASK_EXECUTOR, refuse_linked_out
from nudgecli.runs.dask_cluster import checked_client, one_line, scheduler_label, submit_checked
from nudgecli.runs.size import check_study_size
from nudgecli.runs.solved_layouts import solve_layouts_cached
from nudgecli.runs.study_tasks import (
    _init_worker,
    _run_in_worker,
    drew_from_global_rng,
    global_rng_warning,
    pool_worker_started,
    process_context,
    simulate_on_worker,
    simulate_watched,
    stop_pool,
    tune_allocator,
)
from nudgecli.sim.counterbalance import design_record
from nudgecli.sim.people_file import MANIFEST_KEY as PEOPLE_KEY
from nudgecli.sim.people_file import People, check_same_people, keep_copy, people_of
from nudgecli.sim.policy_files import MANIFEST_KEY as POLICY_FILES_KEY
from nudgecli.sim.policy_files import (
    check_copies_placeable,
    check_resumed_policies,
    keep_policy_copies,
    loaded_policy_files,
    missing_copies,
    missing_copy_error,
    outside_policy_sources,
    record_policies,
)
from nudgecli.sim.policy_registry import checked_policy_specs, constant_metrics_of
from nudgecli.sim.study import (
    ParticipantColumns,
    ParticipantResult,
    StudyPlan,
    build_layouts,
    check_physiology_logs,
    left_out_notes,
)
from nudgecli.store import RunFolder, new_manifest, utc_now

if TYPE_CHECKING:  # pandas loads on first use, after the workers have started
    import pandas as pd

    from nudgecli.report.plans import AnalysisPlan


# --- the plan, its layouts solved in parallel ---------------------------------------------

def contiguous_chunks(n: int, parts: int) -> list[tuple[int, int]]:
    """``range(n)`` as at most ``parts`` contiguous ``(start, stop)`` chunks of near-equal size (a
    study's layouts over its layout tasks, a replication's metrics over its analysis tasks)."""
    parts = max(1, min(parts, n))
    edges = [round(k * n / parts) for k in range(parts + 1)]
    return [(a, b) for a, b in itertools.pairwise(edges) if b > a]


def solve_layout_chunk(config: ExperimentConfig, seed: int, start: int, stop: int) -> list[SolvedLayout]:
    """The study's layouts ``start:stop`` solved: one piece of a plan built in parallel."""
    tune_allocator()
    return solve_layouts_cached(config, build_layouts(config, seed)[start:stop])


def solve_layout_chunk_into(path: str, config: ExperimentConfig, seed: int, start: int, stop: int) -> str:
    """:func:`solve_layout_chunk`, its result pickled into the file ``path`` (on a worker that shares
    this machine's files, so that the solved layouts reach the other workers without passing
    through the batch's process); returns ``path``."""
    layouts = solve_layout_chunk(config, seed, start, stop)
    with open(path, "wb") as handle:
        pickle.dump(layouts, handle, protocol=pickle.HIGHEST_PROTOCOL)
    return path


def _solve_chunk(args: tuple[ExperimentConfig, int, int, int]) -> list[SolvedLayout]:
    return solve_layout_chunk(*args)


def build_plan_on(config: ExperimentConfig, seed: int, workers: int, client: Any = None) -> StudyPlan:
    """:meth:`StudyPlan.build`, with the grid world's layouts solved by ``workers`` short-lived processes,
    or, given a dask ``client``, by the cluster's workers: a study on many workers does not wait for
    one process to solve every layout first."""
    if client is not None:
        workers = max(1, len(client.scheduler_info().get("workers", {})))
    if workers <= 1 or config.world.kind == "ciaa":
        return StudyPlan.build(config, seed)
    chunks = contiguous_chunks(len(build_layouts(config, seed)), workers)
    if client is not None:
        futures = [submit_checked(client, solve_layout_chunk, config, seed, a, b) for a, b in chunks]
        return StudyPlan.assemble(config, seed, client.gather(futures))
    pool = ProcessPoolExecutor(max_workers=len(chunks), mp_context=process_context(),
                               initializer=pool_worker_started, initargs=(os.getpid(),))
    try:
        solved = list(pool.map(_solve_chunk, [(config, seed, a, b) for a, b in chunks]))
    except BaseException:
        stop_pool(pool)  # Ctrl-C: its workers ignore it, and the pool's exit would wait for them
        raise
    pool.shutdown(wait=True)
    return StudyPlan.assemble(config, seed, solved)



# --- executors --------------------------------------------------------------------------------

#: Seconds to wait for a dask scheduler to answer before ``--scheduler`` is refused: a scheduler
#: answers in milliseconds, and a refusal, the start of Python included, comes within 10 s.
SCHEDULER_TIMEOUT_S = 7.0


def _serial(plan: StudyPlan, todo: list[int]) -> Iterator[ParticipantColumns]:
    for index in todo:
        yield simulate_watched(plan, index)


#: Participants submitted to the local pool per worker at a time (the one it runs and the next).
PARTICIPANTS_AHEAD_PER_WORKER = 2


def _processes(plan: StudyPlan, todo: list[int], workers: int) -> Iterator[ParticipantColumns]:
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=process_context(), initializer=_init_worker,
                               initargs=(plan, os.getpid()))
    try:
        # a few participants ahead of the workers, not all of them: a result is held until this
        # process has written it, so a run of many participants whose writing here is slower
        # than its workers' simulating held every finished one (1 GB for 300 paper participants)
        queued = iter(todo)
        pending = {pool.submit(_run_in_worker, index)
                   for index in itertools.islice(queued, PARTICIPANTS_AHEAD_PER_WORKER * workers)}
        while pending:
            finished, pending = wait(pending, return_when=FIRST_COMPLETED)
            for future in finished:
                following = next(queued, None)
                if following is not None:
                    pending.add(pool.submit(_run_in_worker, following))
                yield future.result()
    except BaseException:
        stop_pool(pool)  # Ctrl-C or a failure: drop the queued participants, stop the running ones
        raise
    else:
        pool.shutdown(wait=True)


def connect_scheduler(address: str, log: Callable[[str], None] | None = None) -> Any:
    """A ``dask.distributed.Client`` of the scheduler at ``address``.

    The address is probed first (:func:`probe_scheduler`), so that a service that is not a
    dask scheduler is refused within :data:`SCHEDULER_TIMEOUT_S` seconds: the client alone
    waits for ever on a server that never answers, and takes a greeting from one that speaks
    first (SSH, SMTP) as the length of a message of exabytes. Then the cluster is checked once
    (:func:`~nudgecli.runs.dask_cluster.checked_client`): it has workers, and they run this nudgecli.

    Raises
    ------
    ConfigError
        dask.distributed is not installed, the address is malformed, no dask scheduler answers
        within :data:`SCHEDULER_TIMEOUT_S` seconds, it has no workers, or they cannot run nudge.
    """
    try:
        from dask.distributed import Client
    except ImportError as exc:  # pragma: no cover - depends on the optional extra
        raise ConfigError(f"{scheduler_label(address)} needs dask.distributed: "
                          "pip install 'nudgecli[cluster]'") from exc
    fix = "give the address of a running dask scheduler, e.g. tcp://host:8786"
    problem = probe_scheduler(address, SCHEDULER_TIMEOUT_S)
    if problem is not None:
        raise ConfigError(f"{scheduler_label(address)}: {problem}; {fix}")
    try:
        client = Client(address, timeout=f"{SCHEDULER_TIMEOUT_S}s")
    except (OSError, ValueError, TypeError) as exc:
        raise ConfigError(f"{scheduler_label(address)}: cannot connect ({one_line(exc)}); {fix}") from None
    return checked_client(client, address, log)  # before anything is written: no folder for a failing cluster


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
            return f"cannot connect ({one_line(exc)})"
        except Exception:
            # e.g. a MemoryError: a greeting's bytes read as the length of a message
            return "the service there is not a dask scheduler (its answer is not dask's protocol)"
        return None

    # in a thread of its own: the caller may itself be running an event loop (a notebook)
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="nudge-probe") as pool:
        return pool.submit(run).result()


def _dask(plan: StudyPlan, todo: list[int], client: Any) -> Iterator[ParticipantColumns]:
    from dask.distributed import as_completed as dask_completed

    from nudgecli.runs.dask_results import ClusterWatch, next_finished, watched_result

    with client:
        shared = client.scatter(plan, broadcast=True)
        futures = [submit_checked(client, simulate_on_worker, shared, index) for index in todo]
        participant = dict(zip((future.key for future in futures), todo, strict=True))
        completed = dask_completed(futures)
        futures.clear()  # a result is released once taken (the cluster held every one till the end)
        watch = ClusterWatch(client)  # no participant finishes once every worker is gone: never wait for ever
        while not completed.is_empty():
            future = next_finished(completed, watch)
            yield watched_result(future, f"participant {participant[future.key]}", watch)


@dataclass
class StudyRun:
    """What :func:`run_study` did."""

    path: Path
    config: ExperimentConfig  # as simulated: its seed and participant count the run's
    mode: str
    participants: int
    computed: list[int]
    trials: pd.DataFrame


def with_participants(config: ExperimentConfig, participants: int | None) -> ExperimentConfig:
    """``config`` with ``--participants`` as its study's participant count (``None``: as it is),
    within the bounds of ``study.participants``, the ones ``--set study.participants=N`` meets.

    Raises
    ------
    ConfigError
        A count below 1 or above the field's bound (10,000), naming both spellings.
    """
    if participants is None:
        return config
    if participants < 1:
        raise ConfigError(f"--participants must be at least 1, got {participants}")
    from pydantic import ValidationError

    try:  # the field's own bound, so --participants and --set study.participants are one rule
        type(config.study).model_validate({**config.study.model_dump(), "participants": participants})
    except ValidationError as exc:
        raise ConfigError(f"--participants {participants}: study.participants: "
                          f"{problem_words(exc.errors()[0])} (as with --set study.participants); give "
                          "fewer participants") from None
    return config.model_copy(update={"study": config.study.model_copy(update={"participants": participants})})


def checked_plan(plan: str | AnalysisPlan, configs: Sequence[ExperimentConfig]) -> AnalysisPlan:
    """The plan of a run or a batch, loaded, and refused where it cannot load or its ``conditions``
    misname the conditions its studies will hold (their experiments'):
    :func:`~nudgecli.report.plans.check_plan_conditions`, before any study is simulated."""
    from nudgecli.report.plans import check_plan_conditions, load_plan

    chosen = load_plan(plan)
    label = str(plan) if isinstance(plan, str) else chosen.label
    for config in configs:
        check_plan_conditions(chosen, label, config.study.conditions, f"experiment {config.experiment.name}")
    return chosen


def checked_default_plan(config: ExperimentConfig) -> AnalysisPlan:
    """The plan ``nudge run`` analyses with when no ``--plan`` is given (the one named like the
    experiment, else its world's, else ``paper``: :func:`~nudgecli.config_files.resolve_plan`),
    checked against the experiment's conditions (:func:`checked_plan`) before anything is simulated.

    Raises
    ------
    ConfigError
        The plan's refusal, with the fix: a plan of one's own for these conditions, given with
        ``--plan``.
    """
    name = resolve_plan(None, experiment=config.experiment.name, world=config.world.kind)
    try:
        return checked_plan(name, [config])
    except ConfigError as exc:
        why = ("it is the plan named like the experiment" if name == config.experiment.name else
               f"it is the plan of world.kind = {config.world.kind!r}" if name != "paper" else
               f"no analysis plan is named like experiment {config.experiment.name!r}, so it is the default")
        raise ConfigError(f"{exc} ({why}); nothing was simulated: "
                          f"{own_plan_advice(config.study.conditions)}") from None


def own_plan_advice(conditions: Sequence[str]) -> str:
    """The fix of a default plan that cannot analyse ``conditions`` (nudge run; analyze without --plan)."""
    return ("write a plan for these conditions (copy the custom-policy plan, analysis/custom-policy.toml, "
            f"with conditions = {json.dumps(list(map(str, conditions)))}) and pass it with --plan PLAN.toml")


def run_study(config: ExperimentConfig, out: Path, seed: int | None = None, participants: int | None = None,
              workers: int = 1, scheduler: str | None = None, resume: bool = False, force: bool = False,
              progress: Callable[[int, int], None] | None = None, plan: str | None = None,
              confirm: bool = False, people: People | str | Path | None = None,
              log: Callable[[str], None] | None = None) -> StudyRun:
    """Simulate a study into the run folder ``out``.

    Parameters
    ----------
    config
        The resolved experiment.
    out
        The run folder.
    seed, participants
        Overrides of the experiment's seed and participant count (both recorded in the run's
        config.toml and the manifest's experiment).
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
        Run a study above :data:`nudgecli.runs.size.MAX_TRIALS_WITHOUT_YES` trials (``--yes``).
    people
        Twins of real people (``--people``: a people file or its :class:`People`): participant ``i``
        has the habits of person ``i mod P``; recorded in the manifest (file name and SHA-256), its
        bytes copied into ``out/people/`` (what the resume command names), and ``resume`` refuses
        other people.
    log
        Called with a line for the user (a ``Note:`` of people or physiology logs no participant
        takes, :func:`~nudgecli.sim.study.left_out_notes`) once the folder is prepared.

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
    check_seed(seed)
    n = config.study.participants if participants is None else participants
    config = with_participants(config, participants)
    check_study_size(config, n, confirm)  # trials and steps, before the folder is touched
    # config.toml records the seed (its people: kept_run_people): simulating it gives the same tables
    config = config.model_copy(update={"experiment": config.experiment.model_copy(update={"seed": seed})})
    check_physiology_logs(config)
    people = people_of(people)  # a bad people file is refused before the folder is touched
    policy_files = _loaded_policy_files(config, out)  # the policy code the run keeps a copy of
    sources = outside_policy_sources(config)  # and the digests of what it imports from elsewhere
    checked_policy_specs(config)  # a value the policy refuses: refused before the folder is touched
    if plan is not None:  # refused before anything is simulated or written
        checked_plan(plan, [config])
        RunFolder(out).check_plan_not_its_copy(plan)  # the copy the run writes, --force removes first
    refuse_linked_out(Path(out))  # a linked --out: refused before anything (its lock) is written through it
    client = connect_scheduler(scheduler, log) if scheduler else None  # refused before the folder exists
    try:
        with run_lock(out, log=log):
            return _run_locked(RunFolder(out), config, seed, n, workers, scheduler, client, resume, force,
                               progress, plan, people, policy_files, log, sources)
    except BaseException:
        if client is not None:
            client.close()
        raise


def _run_locked(folder: RunFolder, config: ExperimentConfig, seed: int, n: int, workers: int,
                scheduler: str | None, client: Any, resume: bool, force: bool,
                progress: Callable[[int, int], None] | None, plan_name: str | None,
                people: People | None = None, policy_files: Mapping[str, bytes] | None = None,
                log: Callable[[str], None] | None = None,
                sources: Mapping[str, str] | None = None) -> StudyRun:
    """:func:`run_study` once the folder's lock is held (``client``: the connected dask client, or None)."""
    policy_files = _placeable_copies(folder, policy_files or {})  # before the folder is touched
    mode = folder.prepare(config, seed, n, resume=resume, force=force, log=log)
    _keep_inputs(folder, mode == "resume", config, people, policy_files, log, sources or {})
    done = set(folder.completed_participants()) & set(range(n)) if mode == "resume" else set()
    if mode == "resume":
        done -= _unvouched_participants(folder, done, log)
    plan = build_plan_on(config, seed, workers, client)
    plan = plan if people is None else dataclasses.replace(plan, people=people.twins)
    trials_per = plan.trials_per_participant()
    # a new run records its recordings' digests (a resume compares them: RunRecord.resume_differences)
    manifest = folder.read_manifest() if mode == "resume" else {**new_manifest(config, seed, n, trials_per),
                                                               **recordings(config)}
    if plan.paths is None:  # the CIAA world takes its subjects' block orders from the task file
        manifest["counterbalancing"] = design_record(list(config.study.conditions),
                                                     config.study.counterbalancing, n)
    manifest.update({"status": "running", "completed": sorted(done),
                     "executor": executor_name(workers, bool(scheduler)),
                     # what each policy makes constant: an analysis need not import a researcher's policy
                     CONSTANT_METRICS_KEY: {c: sorted(m) for c, m in constant_metrics_of(config).items()}})
    if people is not None:
        manifest[PEOPLE_KEY] = people.record()
    record_policies(manifest, policy_files, sources or {})
    if plan_name is not None or "plan" not in manifest:  # a plan file's copy: the run's, edited or moved
        folder.keep_plan(manifest, plan_name, config)
    manifest[FILE_CHECKSUMS] = {LAYOUTS: folder.write_layouts(plan.layouts_frame())}  # read back by plot
    todo = [i for i in range(n) if i not in done]
    started = time.perf_counter()
    # from the manifest's "running" on, any exit marks it: a signal can land before the first
    # participant as well (in the manifest's own write, the progress bar's start, the pool's)
    try:
        folder.write_manifest(manifest)
        if progress:
            progress(len(done) * trials_per, n * trials_per)
        if client is not None:
            results = _dask(plan, todo, client)
        elif (pool := pool_workers(workers, len(todo))) > 1:  # no more workers than participants left
            results = _processes(plan, todo, pool)
        else:
            results = _serial(plan, todo)
        warned = False
        for columns in results:
            if log is not None and not warned and drew_from_global_rng(columns):  # once; tables as simulated
                log(global_rng_warning(plan.config, folder.path))
                warned = True
            # the workers send columns; the tables are made here, in the process that writes them
            result = ParticipantResult.from_columns(columns)
            if result.calibration is not None:  # with their SHA-256: verified where read, as the parts are
                write_calibration_logs(folder.path, manifest, result.participant, result.calibration)
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
    manifest[FILE_CHECKSUMS][PARTICIPANTS] = folder.write_participants_table()
    manifest.update({"status": "complete", "finished": utc_now(),
                     "wall_s": round(time.perf_counter() - started, 3),
                     "peak_rss_mb": _finite_or_none(round(peak_memory_mb(), 1))})
    folder.write_manifest(manifest)
    return StudyRun(path=folder.path, config=config, mode=mode, participants=n,
                    computed=todo, trials=folder.read_trials())


def _unvouched_participants(folder: RunFolder, done: set[int], log: Callable[[str], None] | None) -> set[int]:
    """The finished participants of a resumed run whose parts the manifest does not vouch for (the
    SHA-256 recorded when this run wrote them): they are simulated again, a participant being a pure
    function of the seed. ``log`` (the command's stderr, an API caller's ``log=``) is told which."""
    unvouched = folder.unvouched_parts(folder.read_manifest(), sorted(done))
    if unvouched and log is not None:
        listed = ", ".join(part for parts in unvouched.values() for part in parts)
        log(f"Warning: {folder.path}: {listed}: not vouched for by the manifest (not as this run wrote "
            f"them); simulating participant(s) {', '.join(map(str, sorted(unvouched)))} again")
    return set(unvouched)


def _loaded_policy_files(config: ExperimentConfig, out: Path) -> dict[str, bytes]:
    """:func:`~nudgecli.sim.policy_files.loaded_policy_files`; a module that does not import because
    it is the run ``out``'s own copy, deleted (a resume from ``out/config.toml``), says so."""
    try:
        return loaded_policy_files(config)
    except PolicyError as exc:
        folder, missing = RunFolder(out), []
        if config.policy_search_path is None or not folder.is_run() or \
                Path(config.policy_search_path).resolve() != folder.path.resolve():
            raise
        with contextlib.suppress(NudgeError, OSError):
            missing = missing_copies(folder.read_manifest().get(POLICY_FILES_KEY), folder.path)
        if not missing:
            raise
        raise missing_copy_error(missing[0], folder.path) from exc


def _placeable_copies(folder: RunFolder, policy_files: Mapping[str, bytes]) -> Mapping[str, bytes]:
    """``policy_files``, once none of their copies would write over a file of the person's own in
    ``folder`` (:func:`~nudgecli.sim.policy_files.check_copies_placeable`; the copies a run there
    records are its own); checked before the folder is prepared."""
    if policy_files:
        held = folder.read_manifest() if folder.is_run() else None
        check_copies_placeable(policy_files, folder.path,
                               held.get(POLICY_FILES_KEY) if isinstance(held, dict) else None)
    return policy_files


def _keep_inputs(folder: RunFolder, resuming: bool, config: ExperimentConfig, people: People | None,
                 policy_files: Mapping[str, bytes], log: Callable[[str], None] | None = None,
                 sources: Mapping[str, str] | None = None) -> None:
    """Refuse a resume with other people or other policy code than the run was simulated with, then
    keep exact copies of both in the run folder: its resume command names the people file's copy,
    and its ``config.toml`` imports the policy modules' copies (``policy_files``:
    :func:`~nudgecli.sim.policy_files.loaded_policy_files`); then tell ``log`` the people (and
    physiology logs) no participant takes (the folder prepared: a refusal is its one error line).
    ``sources``: the digests of the policy modules imported from elsewhere
    (:func:`~nudgecli.sim.policy_files.outside_policy_sources`), compared, not copied."""
    notes: list[str] = []
    if resuming:
        recorded = folder.read_manifest()
        check_same_people(recorded.get(PEOPLE_KEY), people, folder.path)
        started = bool(recorded.get("completed")) or folder.has_completed_participant()
        notes = check_resumed_policies(recorded, policy_files, sources or {}, config.policy_search_path,
                                       folder.path, started)
    keep_copy(people, folder.path)
    keep_policy_copies(policy_files, folder.path)
    if log is not None:
        for note in [*notes, *left_out_notes(config, config.study.participants, people)]:
            log(f"Note: {note}")


def _finite_or_none(value: float) -> float | None:
    """JSON has no NaN: an unknown measurement is ``null``."""
    return value if math.isfinite(value) else None


def executor_name(workers: int, on_dask: bool) -> str:
    """What runs a study's or a batch's work, as its manifest records it: ``dask`` (a scheduler),
    ``serial`` (one worker: this process) or ``processes:W`` (``W`` local worker processes)."""
    if on_dask:
        return DASK_EXECUTOR
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


def success_by_condition(trials: pd.DataFrame, conditions: Sequence[str] = ()) -> pd.DataFrame:
    """Trials and success rate per condition (the summary ``nudge simulate`` prints), one row per
    condition in the toolkit's one order (:func:`~nudgecli.report.stats.order_conditions`, as
    ``nudge analyze`` orders them: the paper's first, then ``conditions``, the experiment's
    ``study.conditions``, then the rest by name), not the trials' order of first appearance."""
    import pandas as pd

    from nudgecli.report.stats import order_conditions

    grouped = trials.groupby("condition", sort=False)
    table = pd.DataFrame({
        "trials": grouped.size(),
        "success_rate": grouped["success"].mean(),
        "timed_out": grouped["timed_out"].sum(),
        "median_duration_s": grouped["duration_s"].median(),
    })
    return table.loc[order_conditions(table.index, conditions)]
