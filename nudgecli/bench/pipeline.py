"""The pipeline figures of ``nudge bench`` (``--only pipeline``, not part of ``all``): how much of a
batch's wall time its workers spend in the trial loop.

A batch's *pipeline efficiency* is the time its trials would take at the trial loop's own speed,
spread over its workers, against its wall time:

    efficiency = trials x loop seconds per trial / (workers x wall seconds)

It is 100 % when nothing but trials runs on the batch's critical path (no imports before the
workers start, no analysis, figure or table after the last trial, no idle worker), and it is what
issue 39 asks of ``nudge replicate paper -R 4 --workers 2`` (>= 80 %) and ``-R 20`` (>= 90 %).
Everything is measured side by side in one run: the loop (every participant of the experiment's
study in this process as a participant task simulates it, the plan built beforehand, the best CPU
time of ``study_repeats`` runs of each: :func:`loop_seconds_per_trial`),
then both batches end to end as a user runs them (``python -m nudgecli.cli replicate ...`` in a
child, interpreter start-up included), then issue 39's power analysis (``nudge power EXPERIMENT
--participants 6,9,12,18,24 -R 50``, about a minute and a quarter on 2 cores: under two minutes is
its target), then the loop again, whose better time per participant
counts (on a machine shared with other work, other processes only ever add time). The CPU seconds
of each batch (the command and its reaped workers) check the size estimate's cost model
(:func:`nudgecli.runs.size.size_estimate`, whose constants say how they were measured) and give the
*CPU share* of the loop,
``trials x loop seconds per trial / the batch's CPU seconds``: what the batch computes besides
trials, which a machine shared with other work does not distort as it does the wall time.
"""

from __future__ import annotations

import json
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nudgecli.bench.common import BENCH_SEED, BenchOptions, Figure, available_cores, row, run_child
from nudgecli.bench.targets import (
    PIPELINE_EFFICIENCY_TARGET,
    PIPELINE_THROUGHPUT_TARGET_PER_HOUR,
    POWER_PARTICIPANTS,
    POWER_REPLICATIONS,
    POWER_WALL_TARGET_S,
)
from nudgecli.config import load_experiment

#: The replications of the two batches, each with its efficiency target.
PIPELINE_REPLICATIONS = tuple(PIPELINE_EFFICIENCY_TARGET)


@dataclass(frozen=True)
class BatchTiming:
    """One batch run end to end.

    Attributes
    ----------
    replications
        ``-R``.
    trials
        Trials of every study of the batch.
    wall_s
        Wall seconds of the whole command.
    cpu_s
        CPU seconds of the command and of its workers together.
    worker_peak_mb
        The largest worker's peak resident memory (``batch.json``), None where unknown.
    """

    replications: int
    trials: int
    wall_s: float
    cpu_s: float
    worker_peak_mb: float | None


@dataclass(frozen=True)
class PipelineMeasurement:
    """What the pipeline figures report: the loop's seconds per trial, each replicate batch's timing
    (by ``-R``) and the power analysis's."""

    experiment: str
    workers: int
    loop_s_per_trial: float
    batches: dict[int, BatchTiming]
    power: BatchTiming


def pipeline_efficiency(trials: int, loop_s_per_trial: float, workers: int, wall_s: float) -> float:
    """``trials x loop_s_per_trial / (workers x wall_s)``: the share of the workers' wall time the
    trials would take at the loop's speed."""
    return trials * loop_s_per_trial / (workers * wall_s)


def cpu_share(trials: int, loop_s_per_trial: float, cpu_s: float) -> float:
    """``trials x loop_s_per_trial / cpu_s``: the share of a batch's CPU seconds its trials would
    take at the loop's speed."""
    return trials * loop_s_per_trial / cpu_s


def trials_per_hour(trials: int, wall_s: float) -> float:
    return trials / wall_s * 3600.0


def loop_seconds_per_trial(experiment: str, repeats: int) -> list[tuple[float, int]]:
    """Every participant of the experiment's study simulated in this process as a batch's
    participant task simulates it (its plan built first): per participant, the best CPU seconds of
    ``repeats`` runs and the participant's trials.

    The task's own loop (:func:`~nudgecli.runs.batch_tasks.simulate_task_participant`: the columns
    its metrics read, no frames), not ``nudge simulate``'s (which also builds the step log's frames,
    about a sixth of a paper trial, that no batch worker makes). CPU seconds, not wall: the loop is
    single-threaded and CPU-bound, so unloaded they are its wall time, and on a machine shared with
    other work they still are its own cost (its wall time there is doubled by a second busy process
    per core, which would flatter every efficiency)."""
    from nudgecli.runs import batch_tasks
    from nudgecli.sim.study import StudyPlan

    config = load_experiment(experiment)
    plan = StudyPlan.build(config, config.experiment.seed)
    measured = []
    for index in range(config.study.participants):
        best, trials = float("inf"), 0
        for _ in range(max(1, repeats)):
            start = time.process_time()
            result = batch_tasks.simulate_task_participant(plan, index)
            best = min(best, time.process_time() - start)
            trials = len(result.trials)
        measured.append((best, trials))
    return measured


def time_replicate(experiment: str, replications: int, workers: int) -> BatchTiming:
    """``nudge replicate EXPERIMENT -R replications --workers workers`` in a child Python, timed end
    to end, with its CPU seconds (the child and its reaped workers) and its largest worker's peak."""
    config = load_experiment(experiment)
    trials = replications * config.study.participants * len(config.study.conditions) \
        * config.study.trials_per_condition
    return _time_batch(["replicate", experiment, "-R", str(replications)], replications, trials, workers)


def time_power(experiment: str, participants: tuple[int, ...], replications: int,
               workers: int) -> BatchTiming:
    """``nudge power EXPERIMENT --participants N,N,... -R replications --workers workers`` in a child
    Python, timed as :func:`time_replicate` times a batch. Its trials are those it simulates: each
    replication's largest study, once (a smaller count analyses that study's first participants)."""
    config = load_experiment(experiment)
    study = config.study
    trials = replications * max(participants) * len(study.conditions) * study.trials_per_condition
    counts = ",".join(map(str, participants))
    arguments = ["power", experiment, "--participants", counts, "-R", str(replications)]
    return _time_batch(arguments, replications, trials, workers)


def _time_batch(arguments: list[str], replications: int, trials: int, workers: int) -> BatchTiming:
    """The batch command ``nudge ARGUMENTS`` (its seed, workers and a temporary folder added) run in
    a child Python and timed; the folder is removed after."""
    from nudgecli.runs.batch_folder import BATCH_MANIFEST

    folder = Path(tempfile.mkdtemp(prefix="nudge-bench-pipeline-"))
    try:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        command = [sys.executable, "-m", "nudgecli.cli", *arguments, "--workers", str(workers),
                   "--seed", str(BENCH_SEED), "--out", str(folder / "batch"), "--yes"]
        run_child(command, f"pipeline (nudge {' '.join(arguments)})", stdout=subprocess.DEVNULL,
                  stderr=subprocess.DEVNULL)
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        manifest = json.loads((folder / "batch" / BATCH_MANIFEST).read_text(encoding="utf-8"))
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    peak = manifest.get("worker_peak_rss_mb")
    return BatchTiming(replications, trials, wall, cpu, None if peak is None else float(peak))


def measure_pipeline(options: BenchOptions) -> PipelineMeasurement:
    """The loop, both batches, the power analysis, the loop again (see the module's note)."""
    experiment, workers = options.throughput_experiment, options.study_workers
    first = loop_seconds_per_trial(experiment, options.study_repeats)
    batches = {r: time_replicate(experiment, r, workers) for r in PIPELINE_REPLICATIONS}
    power = time_power(experiment, POWER_PARTICIPANTS, POWER_REPLICATIONS, workers)
    second = loop_seconds_per_trial(experiment, options.study_repeats)
    seconds = sum(min(a[0], b[0]) for a, b in zip(first, second, strict=True))
    trials = sum(t for _, t in first)
    return PipelineMeasurement(experiment, workers, seconds / trials, batches, power)


def pipeline_row(measured: PipelineMeasurement, replications: int) -> dict[str, Any]:
    """The row of one batch: ``time_s`` its wall time, ``baseline_s`` the wall time at the loop's
    speed on its workers, so ``ratio`` is the pipeline efficiency."""
    timing = measured.batches[replications]
    ideal = timing.trials * measured.loop_s_per_trial / measured.workers
    efficiency = pipeline_efficiency(timing.trials, measured.loop_s_per_trial, measured.workers,
                                     timing.wall_s)
    target = PIPELINE_EFFICIENCY_TARGET[replications]
    return row(f"pipeline: replicate {measured.experiment} -R {replications}, {measured.workers} workers",
               timing.wall_s, ideal, f"efficiency >= {target:.0%}", efficiency >= target,
               f"pipeline efficiency {efficiency:.0%} ({timing.trials:,} trials x "
               f"{measured.loop_s_per_trial * 1e3:.2f} ms, the loop's time per trial, over "
               f"{measured.workers} workers x {timing.wall_s:.2f} s); "
               f"{trials_per_hour(timing.trials, timing.wall_s):,.0f} trials per hour; CPU "
               f"{timing.cpu_s:.1f} s, {timing.cpu_s / timing.trials * 1e3:.2f} ms a trial end to end, "
               f"{cpu_share(timing.trials, measured.loop_s_per_trial, timing.cpu_s):.0%} of it the loop; "
               f"{available_cores()} cores; memory: the largest worker's peak RSS; baseline = the wall "
               "time at the loop's speed", peak_mb=timing.worker_peak_mb)


def throughput_row(measured: PipelineMeasurement) -> dict[str, Any]:
    """Trials an hour of the largest batch, against the issue's target (``baseline_s``: its wall
    time at the target rate, so ``ratio`` >= 1 meets it)."""
    timing = measured.batches[max(measured.batches)]
    per_hour = trials_per_hour(timing.trials, timing.wall_s)
    at_loop = 3600.0 * measured.workers / measured.loop_s_per_trial
    return row(f"pipeline: trials an hour, replicate {measured.experiment} -R {timing.replications}, "
               f"{measured.workers} workers", timing.wall_s,
               timing.trials / PIPELINE_THROUGHPUT_TARGET_PER_HOUR * 3600.0,
               f">= {PIPELINE_THROUGHPUT_TARGET_PER_HOUR:,.0f} trials/h (issue 39)",
               per_hour >= PIPELINE_THROUGHPUT_TARGET_PER_HOUR,
               f"{per_hour:,.0f} trials per hour end to end; the loop alone on {measured.workers} workers: "
               f"{at_loop:,.0f}; baseline = the wall time at the target rate")


def power_row(measured: PipelineMeasurement) -> dict[str, Any]:
    """The power analysis's row: ``time_s`` its wall time, ``baseline_s`` the target's, so ``ratio``
    >= 1 meets it."""
    timing = measured.power
    counts = ",".join(map(str, POWER_PARTICIPANTS))
    efficiency = pipeline_efficiency(timing.trials, measured.loop_s_per_trial, measured.workers,
                                     timing.wall_s)
    return row(f"pipeline: power {measured.experiment} --participants {counts} -R {timing.replications}, "
               f"{measured.workers} workers", timing.wall_s, POWER_WALL_TARGET_S,
               f"<= {POWER_WALL_TARGET_S:.0f} s", timing.wall_s <= POWER_WALL_TARGET_S,
               f"{timing.trials:,} trials simulated (each replication's largest study, once), "
               f"{trials_per_hour(timing.trials, timing.wall_s):,.0f} trials per hour; "
               f"pipeline efficiency {efficiency:.0%}; CPU {timing.cpu_s:.1f} s; baseline = the target",
               peak_mb=timing.worker_peak_mb)


def figure_pipeline_power(options: BenchOptions) -> dict[str, Any]:
    return power_row(_measured(options))


_MEASURED: dict[str, PipelineMeasurement] = {}


def _measured(options: BenchOptions) -> PipelineMeasurement:
    """One measurement per options for all the pipeline figures of a run (side by side)."""
    key = repr(options)
    if key not in _MEASURED:
        _MEASURED[key] = measure_pipeline(options)
    return _MEASURED[key]


def _efficiency_figure(replications: int) -> Figure:
    def figure(options: BenchOptions) -> dict[str, Any]:
        return pipeline_row(_measured(options), replications)

    figure.__name__ = f"figure_pipeline_{replications}"
    return figure


def figure_pipeline_throughput(options: BenchOptions) -> dict[str, Any]:
    return throughput_row(_measured(options))


def pipeline_figures() -> list[Figure]:
    """The efficiency of each batch, the trials an hour, then the power analysis."""
    return [*(_efficiency_figure(r) for r in PIPELINE_REPLICATIONS), figure_pipeline_throughput,
            figure_pipeline_power]
