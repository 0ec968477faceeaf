"""The study figures of ``nudge bench`` (``--only study``): the study plan's value iteration, one
participant's trials in this process, the whole study with worker processes in a child Python
(so that its peak memory is measured apart from this one's), the command's start-up and a fresh
worker's."""

from __future__ import annotations

import functools
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

from nudgecli.bench.common import (
    BenchOptions,
    available_cores,
    best_child_time,
    format_seconds,
    row,
    run_child_script,
)
from nudgecli.bench.targets import (
    CLI_STARTUP_TARGET_S,
    STUDY_MEMORY_TARGET_MB,
    STUDY_WALL_TARGET_S,
    TRIAL_SPEEDUP_TARGET,
    TRIAL_TARGET_S,
    VI_TARGET_PER_LAYOUT_S,
    WORKER_READY_TARGET_S,
)
from nudgecli.config import load_experiment
from nudgecli.sim.study import StudyPlan, simulate_participant

# Run inside the child Python of ``figure_study``: the study through ``run_study`` (as
# ``nudge simulate EXPERIMENT --workers W --out OUT`` does, its exit included), progress on
# stderr, then one JSON line with the wall time of run_study and ru_maxrss (KiB on Linux) of the
# child itself and of its largest finished (reaped) child, i.e. the largest worker process.
_STUDY_SCRIPT = """
import json, resource, sys, time
from pathlib import Path
from nudgecli.cli import freeze_collector_at_exit
freeze_collector_at_exit()  # as the program does
from nudgecli.config import load_experiment
from nudgecli.runs.study import run_study

experiment, out, workers, participants = sys.argv[1], Path(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
config = load_experiment(experiment)
last = [-1]

def progress(done, total):
    if done != last[0]:
        last[0] = done
        print(f"bench:   study {done}/{total} trials", file=sys.stderr, flush=True)

start = time.perf_counter()
run = run_study(config, out, participants=int(participants) if participants else None, workers=workers,
                progress=progress)
wall = time.perf_counter() - start
print(json.dumps({"wall_s": wall, "trials": len(run.trials), "participants": run.participants,
                  "seed": config.experiment.seed,
                  "self_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
                  "children_kib": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss}))
"""


@functools.lru_cache(maxsize=1)
def _study_plan(experiment: str, repeats: int) -> tuple[StudyPlan, float]:
    """The experiment's study plan (at its own seed) and the best of ``repeats`` build times.

    Cached so that the setup and the trial figures of one ``nudge bench`` build the plan once.
    """
    config = load_experiment(experiment)
    best = float("inf")
    plan: StudyPlan | None = None
    for _ in range(max(1, repeats)):
        start = time.perf_counter()
        plan = StudyPlan.build(config, config.experiment.seed)
        best = min(best, time.perf_counter() - start)
    assert plan is not None
    return plan, best


def figure_study_setup(options: BenchOptions) -> dict[str, Any]:
    """The study plan: every layout drawn and its goal MDPs solved (value iteration included).

    The target is derived from DESIGN section 8: 50 ms per layout (its value-iteration target for
    the 4 goals of one layout) times the study's layouts.
    """
    plan, elapsed = _study_plan(options.study_experiment, options.study_repeats)
    n_layouts = len(plan.layouts)
    target = VI_TARGET_PER_LAYOUT_S * n_layouts
    return row(f"study setup: {n_layouts} layouts' value iteration", elapsed, None,
               f"<= {format_seconds(target)} ({n_layouts} x 50 ms)", elapsed <= target,
               f"StudyPlan.build of {options.study_experiment!r} (seed {plan.seed}): layouts drawn, "
               f"solve_layout each (transitions, value iteration, policy, p(a|s,g)); "
               f"{format_seconds(elapsed / n_layouts)} per layout; "
               f"best of {max(1, options.study_repeats)}; excluded from the trial figure")


def figure_trials(options: BenchOptions) -> dict[str, Any]:
    """One participant's trials in this process: simulated seconds per wall second.

    ``baseline_s`` is the simulated time of the trials (what they take in real time, with a
    person), ``time_s`` the wall time of ``simulate_participant`` (participant draw, calibration
    fit and every trial; the plan is built beforehand), so ``ratio`` is the speed-up over real time.
    """
    plan, _ = _study_plan(options.study_experiment, options.study_repeats)
    best = float("inf")
    simulated = 0.0
    n_trials = 0
    for _ in range(max(1, options.study_repeats)):
        start = time.perf_counter()
        result = simulate_participant(plan, 0)
        best = min(best, time.perf_counter() - start)
        simulated = float(result.trials["duration_s"].sum())
        n_trials = len(result.trials)
    ratio = simulated / best
    per_trial = best / max(n_trials, 1)
    return row("trials, simulated s per wall s", best, simulated,
               f">= {TRIAL_SPEEDUP_TARGET:,.0f}x; <= {format_seconds(TRIAL_TARGET_S)} per trial",
               ratio >= TRIAL_SPEEDUP_TARGET and per_trial <= TRIAL_TARGET_S,
               f"participant 0 of {options.study_experiment!r} (seed {plan.seed}), {n_trials} trials, "
               f"{simulated:,.1f} s simulated; {format_seconds(best / max(n_trials, 1))} per trial; "
               f"baseline = simulated s (real time); best of {max(1, options.study_repeats)}")


def figure_study(options: BenchOptions) -> dict[str, Any]:
    """The whole study with worker processes, run in a child Python: wall time and peak memory.

    The child runs ``run_study`` (what ``nudge simulate EXPERIMENT --workers W --out TMP`` runs)
    into a temporary folder that is removed afterwards. ``time_s`` is the child's whole wall time
    (interpreter start-up and imports included, as a user of ``nudge simulate`` waits), the note
    gives ``run_study``'s own. The child reports ``ru_maxrss`` of itself (the
    parent of the study: plan, result tables, Parquet writing) and of its largest worker.
    ``peak_mb`` is the larger of the two, the peak of any single process. With forked workers the
    processes' peaks need not coincide and their shared copy-on-write pages count in each, so the
    memory in use at once lies between ``peak_mb`` and the upper bound ``self + workers x largest
    worker`` given in the note; the row is ok only when that upper bound meets the target.
    """
    config = load_experiment(options.study_experiment)
    n = config.study.participants if options.study_participants is None else options.study_participants
    n_trials = n * len(config.study.conditions) * config.study.trials_per_condition
    workers = max(1, options.study_workers)
    folder = Path(tempfile.mkdtemp(prefix="nudge-bench-"))
    try:
        participants = "" if options.study_participants is None else str(options.study_participants)
        arguments = [options.study_experiment, str(folder / "run"), str(workers), participants]
        process_s, report = run_child_script(_STUDY_SCRIPT, arguments, "study")
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    wall = float(report["wall_s"])
    self_mb = report["self_kib"] / 1024.0
    worker_mb = report["children_kib"] / 1024.0
    used_workers = workers if n > 1 else 1
    peak = max(self_mb, worker_mb)
    upper = self_mb + (used_workers * worker_mb if used_workers > 1 else 0.0)
    ok = process_s <= STUDY_WALL_TARGET_S and upper <= STUDY_MEMORY_TARGET_MB
    return row(f"{options.study_experiment}-scale study ({report['trials']} trials), {workers} workers",
               process_s, None,
               f"<= {STUDY_WALL_TARGET_S:.0f} s on 2 cores, <= {STUDY_MEMORY_TARGET_MB:.0f} MB", ok,
               f"time: the child Python end to end (start-up, imports, run_study {wall:.2f} s) on "
               f"{available_cores()} cores; seed {report['seed']}, {report['participants']} participants, "
               f"{n_trials} trials planned; peak_mb = max(study process {self_mb:.0f} MB, largest "
               f"worker {worker_mb:.0f} MB); upper bound on memory at once (process + {used_workers} x "
               f"worker, shared pages counted twice) {upper:.0f} MB", peak_mb=peak)


def figure_cli_startup(options: BenchOptions) -> dict[str, Any]:
    """``nudge --help`` in a fresh Python: what every command pays before it starts its work."""
    elapsed = best_child_time(["-m", "nudgecli.cli", "--help"], options.repeats, "nudge --help start-up")
    return row("nudge --help (start-up)", elapsed, None, f"<= {format_seconds(CLI_STARTUP_TARGET_S)}",
               elapsed <= CLI_STARTUP_TARGET_S,
               f"python -m nudgecli.cli --help in a child process, interpreter start-up included; "
               f"best of {max(1, options.repeats)}")


#: The modules a worker of each executor imports before its first task (process-pool workers are
#: forked and inherit them; dask and spawned workers import them).
WORKER_MODULES = {"study": "nudgecli.runs.study_tasks", "batch": "nudgecli.runs.batch_tasks"}

# Run inside the child Python of ``figure_pool_ready``: the task modules loaded (as a command has them
# when it starts its pool), then the time from starting W pool workers until each has answered a
# first task, as one JSON line.
_POOL_READY_SCRIPT = """
import json, os, sys, time
from nudgecli.runs.executors import Job, ProcessExecutor
from nudgecli.runs.study_tasks import process_context
import nudgecli.runs.batch_tasks

workers = int(sys.argv[1])
start = time.perf_counter()
pool = ProcessExecutor(workers)
for k in range(workers):
    pool.submit(Job(f"ready-{k}", os.getpid, ()))
pids = {pool.next_result()[1] for _ in range(workers)}
ready = time.perf_counter() - start
pool.close()
print(json.dumps({"ready_s": ready, "workers": len(pids), "start": process_context().get_start_method()}))
"""


def figure_worker_ready(options: BenchOptions) -> dict[str, Any]:
    """A fresh Python importing what a study's and a batch's tasks need: a spawned worker's start-up."""
    # a start-up like `nudge --help`'s, so measured as often (a best of 3 caught load too often)
    times = {kind: best_child_time(["-c", f"import {module}"], options.repeats, "worker ready")
             for kind, module in WORKER_MODULES.items()}
    worst = max(times.values())
    return row("worker ready (fresh process: dask, spawn)", worst, None,
               f"<= {format_seconds(WORKER_READY_TARGET_S)}", worst <= WORKER_READY_TARGET_S,
               "; ".join(f"{kind} tasks ({WORKER_MODULES[kind]}) {format_seconds(t)}"
                          for kind, t in times.items())
               + f"; interpreter start-up included; best of {max(1, options.repeats)}")


def figure_pool_ready(options: BenchOptions) -> dict[str, Any]:
    """The local worker pool of a command: from starting its workers until every one has answered
    a first task (forked from the command where the platform forks, so they start with its imports)."""
    workers = max(2, available_cores())
    best: float = float("inf")
    report: dict[str, Any] = {}
    for _ in range(max(1, options.study_repeats)):
        _, report = run_child_script(_POOL_READY_SCRIPT, [str(workers)], "pool start-up")
        best = min(best, float(report["ready_s"]))
    return row(f"worker ready (local pool, {report['start']})", best, None,
               f"<= {format_seconds(WORKER_READY_TARGET_S)}", best <= WORKER_READY_TARGET_S,
               f"{report['workers']} pool workers started by a process that has loaded the task modules "
               f"(as nudge simulate, run, replicate, power and sweep have), until each answered a first "
               f"task; best of {max(1, options.study_repeats)}")
