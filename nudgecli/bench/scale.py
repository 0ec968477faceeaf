"""The scale figures of ``nudge bench`` (``--only scale``, not part of ``all``): batches of studies
on 1..cores local workers and on a local dask cluster (parallel efficiency, serial fraction, the
workers' memory), and ``nudge replicate`` end to end (trials per hour)."""

from __future__ import annotations

import math
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from nudgecli.bench.common import (
    BENCH_SEED,
    BenchOptions,
    Figure,
    available_cores,
    row,
    run_child,
    run_child_script,
)
from nudgecli.bench.targets import (
    DASK_RATIO_TARGET,
    SCALE_EFFICIENCY_TARGET,
    THROUGHPUT_TARGET_PER_HOUR,
    WORKER_MEMORY_TARGET_MB,
)
from nudgecli.config import load_experiment
from nudgecli.errors import NudgeError

_SCALE_TIMES: dict[tuple[str, str], float] = {}


def scale_batch(workload: str, options: BenchOptions) -> Any:
    """The batch of a scale workload: one ``paper`` study of ``scale_participants`` participants
    (``study``), or ``scale_studies`` replications of ``smoke`` (``sweep``: many small studies)."""
    from nudgecli.report.plans import load_plan
    from nudgecli.runs.batch import Batch, single_point

    if workload == "study":
        config = load_experiment(options.study_experiment)
        n = options.scale_participants
        config = config.model_copy(update={"study": config.study.model_copy(update={"participants": n})})
        return Batch("replicate", single_point(config, (n,)), 1, BENCH_SEED, load_plan("paper"))
    config = load_experiment("smoke")
    return Batch("replicate", single_point(config, (config.study.participants,)), options.scale_studies,
                 BENCH_SEED, load_plan("paper"))


_SCALE_PEAKS: dict[tuple[str, int], float | None] = {}
#: (CPU seconds of the batch's own process, CPU seconds of its finished workers) of each timed run.
_SCALE_CPU: dict[tuple[str, int], tuple[float, float]] = {}

# Run inside the child Python of ``_time_batch``: one workload through ``run_batch`` as a command
# runs it, then one JSON line with its wall time (imports excluded), the largest worker's peak
# memory and the CPU seconds of the process and of its reaped workers (on dask: a local cluster
# started before the clock starts). A child of its own, so that
# what this process loaded for earlier figures (dask, earlier batches) is neither in the forked
# workers' memory nor in the timing.
_BATCH_SCRIPT = """
import contextlib, json, resource, sys, time
from pathlib import Path
from nudgecli.bench.common import BenchOptions
from nudgecli.bench.scale import import_batch, scale_batch
from nudgecli.runs.batch import run_batch

workload, folder, workers, on_dask, experiment, participants, studies = sys.argv[1:8]
options = BenchOptions(study_experiment=experiment, scale_participants=int(participants),
                       scale_studies=int(studies))
batch = scale_batch(workload, options)
scheduler, stack = None, contextlib.ExitStack()
if on_dask == "dask":
    # a local cluster of single-thread worker processes, started and warmed before the clock starts
    from dask.distributed import Client, LocalCluster
    cluster = stack.enter_context(LocalCluster(n_workers=int(workers), threads_per_worker=1, processes=True,
                                               dashboard_address=":0", silence_logs=40))
    stack.enter_context(Client(cluster)).run(import_batch)
    scheduler = cluster.scheduler_address
usage = resource.getrusage(resource.RUSAGE_CHILDREN)
children = usage.ru_utime + usage.ru_stime
start, own = time.perf_counter(), time.process_time()
with stack:
    run = run_batch(batch, Path(folder), workers=int(workers), scheduler=scheduler, confirm=True)
    wall = time.perf_counter() - start
usage = resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({"wall_s": wall, "worker_peak_mb": run.worker_peak_mb,
                  "cpu_s": time.process_time() - own,
                  "workers_cpu_s": usage.ru_utime + usage.ru_stime - children}))
"""


def _time_batch(workload: str, options: BenchOptions, workers: int = 1, dask: bool = False) -> float:
    """Wall seconds of the workload in a child Python, on ``workers`` local processes or on a local
    dask cluster of as many (the largest worker's peak memory goes to ``_SCALE_PEAKS``, the CPU
    split to ``_SCALE_CPU``)."""
    folder = Path(tempfile.mkdtemp(prefix="nudge-bench-scale-"))
    try:
        _, report = run_child_script(_BATCH_SCRIPT, [
            workload, str(folder / "batch"), str(workers), "dask" if dask else "pool",
            options.study_experiment, str(options.scale_participants), str(options.scale_studies)],
            f"{workload} batch")
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    if not dask:  # a dask run's workers are not this child's: neither their peak nor their CPU is known here
        _SCALE_PEAKS[(workload, workers)] = report["worker_peak_mb"]
        _SCALE_CPU[(workload, workers)] = (float(report["cpu_s"]), float(report["workers_cpu_s"]))
    return float(report["wall_s"])


def _serial_time(workload: str, options: BenchOptions) -> float:
    key = (workload, repr(options))
    if key not in _SCALE_TIMES:
        _SCALE_TIMES[key] = _time_batch(workload, options, workers=1)
    return _SCALE_TIMES[key]


def _workload_text(workload: str, options: BenchOptions) -> str:
    if workload == "study":
        return f"one {options.study_experiment} study of {options.scale_participants} participants"
    return f"{options.scale_studies} smoke studies"


def scale_figure(workload: str, workers: int) -> Figure:
    """A figure: the workload on ``workers`` local processes, its parallel efficiency and serial fraction."""

    def figure(options: BenchOptions) -> dict[str, Any]:
        serial = _serial_time(workload, options)
        elapsed = serial if workers == 1 else _time_batch(workload, options, workers=workers)
        if workers > 1:
            _SCALE_TIMES[(workload + f":{workers}", repr(options))] = elapsed
        efficiency = serial / (workers * elapsed)
        karp_flatt = (1 / (serial / elapsed) - 1 / workers) / (1 - 1 / workers) if workers > 1 else 0.0
        target = SCALE_EFFICIENCY_TARGET[workload]
        parent_cpu, worker_cpu = _SCALE_CPU.get((workload, workers), (math.nan, math.nan))
        # the batch's process runs the analyses beside the workers (its share is not all serial)
        share = parent_cpu / (parent_cpu + worker_cpu)
        cpu = (f"; CPU: the batch's process {parent_cpu:.2f} s, its analyses included, workers "
               f"{worker_cpu:.2f} s (its share {share:.1%})" if workers > 1 else "")
        peak = _SCALE_PEAKS.get((workload, workers)) if workers > 1 else None
        ok = efficiency >= target and (peak is None or peak <= WORKER_MEMORY_TARGET_MB)
        return row(f"scale: {_workload_text(workload, options)}, {workers} worker(s)", elapsed, serial,
                   f"efficiency >= {target:.0%} (16-core target); worker <= "
                   f"{WORKER_MEMORY_TARGET_MB:.0f} MB", ok,
                   f"parallel efficiency {efficiency:.0%}; serial fraction (Karp-Flatt) {karp_flatt:.1%}; "
                   f"ratio = speed-up over 1 worker; {available_cores()} cores; memory: the largest "
                   f"worker's peak RSS{cpu}", peak_mb=peak)

    figure.__name__ = f"figure_scale_{workload}_{workers}"
    return figure


def scale_dask_figure(workload: str) -> Figure:
    """A figure: the workload on a local dask cluster of single-thread worker processes, one per core,
    against the process pool on the same cores."""

    def figure(options: BenchOptions) -> dict[str, Any]:
        try:
            import dask.distributed  # noqa: F401
        except ImportError:  # pragma: no cover - the optional extra
            return row(f"scale: {_workload_text(workload, options)}, dask", float("nan"), None,
                       f"<= {DASK_RATIO_TARGET}x the process pool", False,
                       "dask.distributed is not installed (pip install 'nudgecli[cluster]')")
        cores = available_cores()
        elapsed = _time_batch(workload, options, workers=cores, dask=True)
        pool = _SCALE_TIMES.get((workload + f":{cores}", repr(options)))
        if pool is None:
            pool = (_time_batch(workload, options, workers=cores) if cores > 1
                    else _serial_time(workload, options))
        ratio = elapsed / pool
        serial = _serial_time(workload, options)
        return row(f"scale: {_workload_text(workload, options)}, dask ({cores} workers)", elapsed, pool,
                   f"<= {DASK_RATIO_TARGET}x the process pool", ratio <= DASK_RATIO_TARGET,
                   f"dask / process pool on {cores} cores = {ratio:.2f}x (ratio column: pool / dask); "
                   f"parallel efficiency {serial / (cores * elapsed):.0%}; cluster start-up and the "
                   "workers' imports excluded")

    figure.__name__ = f"figure_scale_{workload}_dask"
    return figure


def import_batch() -> None:
    """What a dask worker imports for a batch's tasks, run on every worker before the clock starts
    (the figure excludes the workers' imports): the participant tasks' modules and the analysis
    tasks' (pandas and the statistics, about 1 s, which a fresh worker otherwise pays on its first
    analysis chunk, as the process pool's workers, forked from a process that has them, do not)."""
    import nudgecli.runs.batch  # noqa: F401
    from nudgecli.runs.batch_tasks import import_analysis_modules

    import_analysis_modules()


def figure_replicate_throughput(options: BenchOptions) -> dict[str, Any]:
    """``nudge replicate EXPERIMENT -R N --workers W`` end to end in a child: trials per hour.

    Everything a user waits for counts: start-up, every study simulated with its parts written,
    every study analysed, the batch's tables. ``baseline_s`` is the wall time at the target rate,
    so ``ratio`` >= 1 meets it.
    """
    config = load_experiment(options.throughput_experiment)
    per_study = config.study.participants * len(config.study.conditions) * config.study.trials_per_condition
    trials = per_study * options.throughput_replications
    folder = Path(tempfile.mkdtemp(prefix="nudge-bench-replicate-"))
    try:
        start = time.perf_counter()
        run_child([sys.executable, "-m", "nudgecli.cli", "replicate", options.throughput_experiment,
                   "-R", str(options.throughput_replications), "--workers", str(options.study_workers),
                   "--seed", str(BENCH_SEED), "--out", str(folder / "batch"), "--yes"],
                  "replicate throughput", stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        elapsed = time.perf_counter() - start
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    per_hour = trials / elapsed * 3600.0
    at_target = trials / THROUGHPUT_TARGET_PER_HOUR * 3600.0
    return row(f"replicate {options.throughput_experiment} -R {options.throughput_replications}, "
               f"{options.study_workers} workers, end to end", elapsed, at_target,
               f">= {THROUGHPUT_TARGET_PER_HOUR:,.0f} trials/h (issue 23)",
               per_hour >= THROUGHPUT_TARGET_PER_HOUR,
               f"{per_hour:,.0f} trials per hour ({trials:,} trials, every study analysed); "
               f"{available_cores()} cores; baseline = the wall time at the target rate")


def scale_worker_counts(counts: Sequence[int] | None = None) -> list[int]:
    """The worker counts the scale figures time: ``counts`` in increasing order without repeats,
    always with 1 (every efficiency is against the 1-worker run); ``None``: 1 to the cores.

    Raises
    ------
    NudgeError
        When no count is given, or one is below 1 or above the cores this process may use (its
        efficiency would measure the machine's oversubscription, not the batch).
    """
    cores = available_cores()
    if counts is None:
        return list(range(1, cores + 1))
    if not counts:
        raise NudgeError(f"--scale-workers: no worker count given; e.g. --scale-workers 1,2 on {cores} cores")
    wrong = [n for n in counts if not 1 <= n <= cores]
    if wrong:
        raise NudgeError(f"--scale-workers {','.join(map(str, counts))}: every count must be from 1 to "
                         f"the {cores} cores this process may use (not {', '.join(map(str, wrong))}); "
                         "e.g. --scale-workers 1,2,4,8,16 on 16 cores")
    return sorted({1, *counts})


def scale_figures(worker_counts: Sequence[int] | None = None) -> list[Figure]:
    """Both workloads on ``scale_worker_counts(worker_counts)`` local workers (default 1..cores),
    then on a local dask cluster of one worker per core; then the end-to-end replication
    throughput."""
    counts = scale_worker_counts(worker_counts)
    figures: list[Figure] = []
    for workload in ("study", "sweep"):
        figures += [scale_figure(workload, w) for w in counts]
        figures.append(scale_dask_figure(workload))
    figures.append(figure_replicate_throughput)
    return figures
