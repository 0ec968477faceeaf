"""``nudge bench``: the performance figures of DESIGN section 8, measured in one run.

Each figure is a function returning one row (a dict with the keys of ``COLUMNS``); ``FIGURES``
lists them in report order, so adding a figure is adding a function to that list. Times are in
seconds; ratios are ``baseline / time`` (how many times faster than the baseline measured in the
same run). Timings use ``time.perf_counter``: fast calls are looped in batches and the best
(minimum) per-call time over several batches is reported, the slow baselines are timed whole and
the best of a few runs is reported. The minimum is the usual estimate of a computation's own cost
on a machine shared with other work (other processes only ever add time); both sides of a ratio
use it, so the ratio is not flattered by load on one side.

The figures come in groups (``nudge bench --only model|study|scale``): the model figures (a few
seconds), the scale figures (batches of studies on 1..cores workers and on a local dask cluster:
parallel efficiency and serial fraction; not part of ``all``) and the study figures
(``STUDY_FIGURES``, about 10-15 s at the paper scale), which
simulate the study itself: the plan's value iteration, one participant's trials in this process,
and the whole study with worker processes in a child Python process so that its peak memory is
measured apart from this one's. A third group runs only when asked (``--only analyze``,
``ANALYZE_FIGURES``, a minute or so): ``nudge analyze`` of a large synthetic metrics table.
"""

from __future__ import annotations

import functools
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from nudgecli.config import load_experiment
from nudgecli.model import interface, world
from nudgecli.model.candidates import Candidates
from nudgecli.model.disambiguation import (
    DisambiguationModel,
    DisambiguationSettings,
    disambiguation_scores,
    maximally_disambiguating_state,
)
from nudgecli.model.information import monte_carlo_mutual_information_per_sample
from nudgecli.model.mdp import build_transitions, solve_layout, value_iteration
from nudgecli.rng import generator
from nudgecli.sim.study import StudyPlan, simulate_participant

COLUMNS = ("what", "time_s", "baseline_s", "ratio", "peak_mb", "target", "ok", "note")
BENCH_SEED = 20220214
MC_SAMPLES = 250


@dataclass(frozen=True)
class BenchOptions:
    """How hard ``nudge bench`` measures.

    Attributes
    ----------
    repeats
        Batches of each fast measurement (the best is reported).
    baseline_repeats
        Runs of each slow per-sample Monte-Carlo baseline (the best is reported).
    mc_states
        States the full-grid Monte-Carlo baseline is timed on (then scaled to 2400).
    study_experiment
        Experiment preset or file the study figures simulate (``paper`` for DESIGN section 8).
    study_participants
        Participants of the whole-study figure (``None``: the experiment's own count).
    study_workers
        Worker processes of the whole-study figure.
    study_repeats
        Runs of the plan build and of the one-participant simulation (the best is reported).
    scale_participants, scale_studies
        The scale figures' workloads: one study of this many participants, and this many
        ``smoke`` studies (``nudge bench --only scale``).
    analyze_rows, analyze_participants
        Size of the synthetic metrics table of the analyze figure (DESIGN section 8: 3.5 M rows).
    throughput_experiment, throughput_replications
        The end-to-end batch of the throughput figure: ``nudge replicate EXPERIMENT -R N
        --workers study_workers`` (``nudge bench --only scale``).
    """

    repeats: int = 7
    baseline_repeats: int = 3
    mc_states: int = 75
    study_experiment: str = "paper"
    study_participants: int | None = None
    study_workers: int = 2
    study_repeats: int = 3
    scale_participants: int = 16
    scale_studies: int = 24
    analyze_rows: int = 3_500_000
    analyze_participants: int = 1000
    throughput_experiment: str = "paper"
    throughput_replications: int = 20


Figure = Callable[[BenchOptions], dict[str, Any]]
"""A figure: measures one thing and returns its row (the keys of ``COLUMNS``)."""


def best_call_time(func: Callable[[], object], repeats: int = 7, min_duration: float = 0.05) -> float:
    """Minimum over ``repeats`` batches of the seconds per call of ``func``, each batch long enough
    to last about ``min_duration`` (after one warm-up call)."""
    func()
    start = time.perf_counter()
    func()
    single = max(time.perf_counter() - start, 1e-7)
    number = max(1, int(min_duration / single))
    per_call = []
    for _ in range(max(1, repeats)):
        start = time.perf_counter()
        for _ in range(number):
            func()
        per_call.append((time.perf_counter() - start) / number)
    return min(per_call)


def _bench_layout() -> world.Layout:
    """A fixed 4-goal layout (goals in the bottom-left region, y <= 3) whose 5 x 5 window
    around cell (6, 6) holds no goal, so the window has all 75 candidates."""
    return world.sample_layout(generator(BENCH_SEED, "bench", "layout"), "tr", 4, 0)


def _bench_model(layout: world.Layout) -> DisambiguationModel:
    solved = solve_layout(layout.goal_cells, layout.goal_headings)
    return DisambiguationModel(layout.goal_cells, solved.p_a_given_sg, interface.default_mapping_table(),
                               interface.default_distortion_table())


_BELIEF = np.array([0.4, 0.3, 0.2, 0.1])
_WINDOW_STATE = int(world.state_index(6, 6, 3, 1))


def _row(what: str, time_s: float, baseline_s: float | None, target: str, ok: bool,
         note: str, peak_mb: float | None = None) -> dict[str, Any]:
    ratio = None if baseline_s is None else baseline_s / time_s
    return {"what": what, "time_s": time_s, "baseline_s": baseline_s, "ratio": ratio, "peak_mb": peak_mb,
            "target": target, "ok": bool(ok), "note": note}


def figure_window(options: BenchOptions) -> dict[str, Any]:
    """Exact MI + D(s) + s* over one 5 x 5 window (75 states) vs per-sample MC at 250 samples."""
    layout = _bench_layout()
    model = _bench_model(layout)
    settings = DisambiguationSettings(window=5)
    candidates = model.candidates(_WINDOW_STATE, settings)
    if candidates.states.size != 75:
        raise RuntimeError(f"bench window has {candidates.states.size} candidates, expected 75")
    exact = best_call_time(lambda: maximally_disambiguating_state(_BELIEF, model, _WINDOW_STATE, settings),
                             options.repeats)
    rng, table = generator(BENCH_SEED, "bench", "window-mc"), np.asarray(model.p_a_given_sg)
    baseline = min(
        _time_once(lambda: monte_carlo_mutual_information_per_sample(
            _BELIEF, candidates.states, table, model.mapping, model.distortion, rng, MC_SAMPLES))
        for _ in range(max(1, options.baseline_repeats)))
    ratio = baseline / exact
    return _row("D(s), one 5x5 window (75 states), exact vs per-sample MC 250", exact, baseline,
                ">= 5000x (and <= 0.1 ms)", ratio >= 5000.0,
                "exact: candidates + Eq. 13 + R(s) + D(s) + argmax; baseline: MC MI only")


def figure_grid(options: BenchOptions) -> dict[str, Any]:
    """Exact MI + D(s) over all 2400 states x 4 goals vs per-sample MC (timed on a subset, scaled)."""
    layout = _bench_layout()
    model = _bench_model(layout)
    coords = world.all_state_coordinates()
    every_state = Candidates(states=np.arange(world.N_STATES), cells=coords[:, :2],
                             positions=world.cell_centre(coords[:, 0], coords[:, 1]))
    settings = DisambiguationSettings()
    exact = best_call_time(lambda: disambiguation_scores(_BELIEF, model, every_state, settings),
                             options.repeats)
    n_subset = max(1, min(options.mc_states, world.N_STATES))
    subset = np.linspace(0, world.N_STATES - 1, n_subset).round().astype(int)
    rng, table = generator(BENCH_SEED, "bench", "grid-mc"), np.asarray(model.p_a_given_sg)
    subset_time = min(
        _time_once(lambda: monte_carlo_mutual_information_per_sample(
            _BELIEF, subset, table, model.mapping, model.distortion, rng, MC_SAMPLES))
        for _ in range(max(1, options.baseline_repeats)))
    baseline = subset_time * world.N_STATES / n_subset
    ratio = baseline / exact
    return _row("D(s), full grid (2400 states x 4 goals), exact vs per-sample MC 250", exact, baseline,
                ">= 500x (and <= 2 ms)", ratio >= 500.0,
                f"MC timed on {n_subset} evenly spaced states, scaled linearly to {world.N_STATES}")


def figure_value_iteration(options: BenchOptions) -> dict[str, Any]:
    """Batched value iteration of the 4 goal MDPs of one layout (transitions built once)."""
    layout = _bench_layout()
    transitions = build_transitions(layout.goal_cells, layout.goal_headings)
    rewards = transitions.rewards()
    iterations = value_iteration(transitions.next_state, rewards)[2]
    elapsed = best_call_time(lambda: value_iteration(transitions.next_state, rewards), options.repeats,
                               min_duration=0.2)
    solve = best_call_time(lambda: solve_layout(layout.goal_cells, layout.goal_headings), options.repeats,
                             min_duration=0.2)
    return _row("value iteration, 4 goals x 2400 states", elapsed, None, "<= 50 ms", elapsed <= 0.050,
                f"{iterations} sweeps; solve_layout incl. transitions, policy, p(a|s,g): "
                f"{solve * 1e3:.1f} ms; study: about 2 s per goal (not measured here)")


# --- study figures ----------------------------------------------------------------------------

TRIAL_SPEEDUP_TARGET = 1000.0
#: The trial loop per paper trial (participant draw and calibration fit included), s.
TRIAL_TARGET_S = 0.0035
#: ``nudge simulate paper --workers 2``, the whole command on 2 cores, s (DESIGN said 20 s).
STUDY_WALL_TARGET_S = 3.0
STUDY_MEMORY_TARGET_MB = 1024.0
VI_TARGET_PER_LAYOUT_S = 0.050

# Run inside the child Python of ``figure_study``: the study through ``run_study`` (as
# ``nudge simulate EXPERIMENT --workers W --out OUT`` does), progress on stderr, then one JSON line
# with the wall time of run_study and ru_maxrss (KiB on Linux) of the child itself and of its
# largest finished (reaped) child, i.e. the largest worker process.
_STUDY_SCRIPT = """
import json, resource, sys, time
from pathlib import Path
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
    return _row(f"study setup: {n_layouts} layouts' value iteration", elapsed, None,
                f"<= {_format_seconds(target)} ({n_layouts} x 50 ms)", elapsed <= target,
                f"StudyPlan.build of {options.study_experiment!r} (seed {plan.seed}): layouts drawn, "
                f"solve_layout each (transitions, value iteration, policy, p(a|s,g)); "
                f"{_format_seconds(elapsed / n_layouts)} per layout; "
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
    return _row("trials, simulated s per wall s", best, simulated,
                f">= {TRIAL_SPEEDUP_TARGET:,.0f}x; <= {_format_seconds(TRIAL_TARGET_S)} per trial",
                ratio >= TRIAL_SPEEDUP_TARGET and per_trial <= TRIAL_TARGET_S,
                f"participant 0 of {options.study_experiment!r} (seed {plan.seed}), {n_trials} trials, "
                f"{simulated:,.1f} s simulated; {_format_seconds(best / max(n_trials, 1))} per trial; "
                f"baseline = simulated s (real time); best of {max(1, options.study_repeats)}")


def _child_environment() -> dict[str, str]:
    """This environment with the folder holding ``nudgecli`` first on ``PYTHONPATH``."""
    env = dict(os.environ)
    package_parent = str(Path(__file__).resolve().parent.parent)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (package_parent, env.get("PYTHONPATH")) if p)
    return env


def _available_cores() -> int:
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


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
        start = time.perf_counter()
        completed = subprocess.run(
            [sys.executable, "-c", _STUDY_SCRIPT, options.study_experiment, str(folder / "run"), str(workers),
             "" if options.study_participants is None else str(options.study_participants)],
            stdout=subprocess.PIPE, stderr=None, text=True, env=_child_environment(), check=False)
        process_s = time.perf_counter() - start
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    if completed.returncode != 0:
        raise RuntimeError(f"bench: the study subprocess failed with exit status {completed.returncode}")
    report = json.loads(completed.stdout.strip().splitlines()[-1])
    wall = float(report["wall_s"])
    self_mb = report["self_kib"] / 1024.0
    worker_mb = report["children_kib"] / 1024.0
    used_workers = workers if n > 1 else 1
    peak = max(self_mb, worker_mb)
    upper = self_mb + (used_workers * worker_mb if used_workers > 1 else 0.0)
    ok = process_s <= STUDY_WALL_TARGET_S and upper <= STUDY_MEMORY_TARGET_MB
    return _row(f"{options.study_experiment}-scale study ({report['trials']} trials), {workers} workers",
                process_s, None,
                f"<= {STUDY_WALL_TARGET_S:.0f} s on 2 cores, <= {STUDY_MEMORY_TARGET_MB:.0f} MB", ok,
                f"time: the child Python end to end (start-up, imports, run_study {wall:.2f} s) on "
                f"{_available_cores()} cores; seed {report['seed']}, {report['participants']} participants, "
                f"{n_trials} trials planned; peak_mb = max(study process {self_mb:.0f} MB, largest "
                f"worker {worker_mb:.0f} MB); upper bound on memory at once (process + {used_workers} x "
                f"worker, shared pages counted twice) {upper:.0f} MB", peak_mb=peak)


ANALYZE_WALL_TARGET_S = 60.0
ANALYZE_MEMORY_TARGET_MB = 1024.0

_ANALYZE_SCRIPT = """
import json, resource, sys, time
from nudgecli.cli import main

start = time.perf_counter()
main(["analyze", sys.argv[1], "--out", sys.argv[2], "--format", "json"], standalone_mode=False)
wall = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
try:  # Linux: this program's own high-water mark; ru_maxrss also counts the parent's pages at fork
    with open("/proc/self/status") as status:
        peak = next(int(line.split()[1]) for line in status if line.startswith("VmHWM:"))
except (OSError, StopIteration):
    pass
print()
print(json.dumps({"wall_s": wall, "self_kib": peak}))
"""


def synthetic_metrics_table(rows: int, participants: int, seed: int = BENCH_SEED) -> Any:
    """A metrics table like a large real study's: the paper's seven metrics, two conditions.

    Participant ``p`` has ``rows / participants`` trials (half per condition, the remainder
    spread over the first participants), a participant level and a condition effect; the
    metrics have the types and ranges of real ones (fractions, counts, seconds, booleans).

    Returns
    -------
    pd.DataFrame
        ``rows`` rows: ``participant, condition, block, trial`` and the seven metrics.
    """
    import pandas as pd

    rng = np.random.default_rng(seed)
    participant = np.sort(np.arange(rows) % participants)
    trial = np.arange(rows) - np.searchsorted(participant, participant)
    control = (trial % 2).astype(bool)
    level = rng.normal(0.0, 1.0, participants)[participant]
    effect = np.where(control, 0.3, 0.0)
    completion = np.exp(3.0 + 0.2 * level + effect + rng.normal(0.0, 0.4, rows)).round(1)
    return pd.DataFrame({
        "participant": participant,
        "condition": np.where(control, "control", "disambiguation"),
        "block": trial // 8,
        "trial": trial,
        "assistance_engagement": np.clip(0.4 - 0.1 * effect + rng.normal(0.0, 0.15, rows), 0, 1).round(4),
        "assistance_strength": np.clip(0.6 + rng.normal(0.0, 0.1, rows), 0, 1).round(4),
        "mode_switches": rng.poisson(np.exp(1.0 + 0.2 * level + effect)),
        "human_effort": np.clip(0.5 + 0.1 * effect + rng.normal(0.0, 0.1, rows), 0, 1).round(4),
        "completion_time": completion,
        "human_turns": 1 + rng.poisson(2.0 + effect),
        "success": rng.random(rows) < 0.9 - 0.1 * effect,
    })


def figure_analyze(options: BenchOptions) -> dict[str, Any]:
    """``nudge analyze`` of a large synthetic metrics table (CSV), in a child Python.

    The table (:func:`synthetic_metrics_table`) is written to a temporary folder, which is
    removed afterwards; the child runs the command as a user would (reading the CSV, checking
    it, every paper metric's statistics with the default 2000 bootstrap resamples, writing the
    results) and reports its own peak resident memory. ``time_s`` is the child's whole wall time
    (start-up included).
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv

    table = synthetic_metrics_table(options.analyze_rows, options.analyze_participants)
    folder = Path(tempfile.mkdtemp(prefix="nudge-bench-"))
    try:
        source = folder / "study.csv"
        pacsv.write_csv(pa.Table.from_pandas(table, preserve_index=False), source)
        size_mb = source.stat().st_size / 1e6
        del table
        start = time.perf_counter()
        completed = subprocess.run([sys.executable, "-c", _ANALYZE_SCRIPT, str(source), str(folder / "out")],
                                   stdout=subprocess.PIPE, stderr=None, text=True, env=_child_environment(),
                                   check=False)
        process_s = time.perf_counter() - start
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    if completed.returncode != 0:
        raise RuntimeError(f"bench: the analyze subprocess failed with exit status {completed.returncode}")
    report = json.loads(completed.stdout.strip().splitlines()[-1])
    peak = report["self_kib"] / 1024.0
    ok = process_s <= ANALYZE_WALL_TARGET_S and peak <= ANALYZE_MEMORY_TARGET_MB
    return _row(f"analyze, {options.analyze_rows:,}-row metrics table", process_s, None,
                f"<= {ANALYZE_WALL_TARGET_S:.0f} s on 2 cores, <= {ANALYZE_MEMORY_TARGET_MB:.0f} MB", ok,
                f"time: the child Python end to end (start-up, imports, analyze {report['wall_s']:.2f} s) on "
                f"{_available_cores()} cores; {options.analyze_participants} participants, 2 conditions, "
                f"7 metrics, CSV of {size_mb:,.0f} MB, 2000 bootstrap resamples (paper plan); "
                "peak_mb = the analyze process's peak resident memory (VmHWM)", peak_mb=peak)


#: ``nudge --help``, interpreter start-up included, s.
CLI_STARTUP_TARGET_S = 0.3
#: A fresh worker process ready: interpreter start-up and the imports of its tasks, s.
WORKER_READY_TARGET_S = 0.5
#: Trials per hour of ``nudge replicate paper -R 20 --workers 2`` end to end on 2 cores.
THROUGHPUT_TARGET_PER_HOUR = 1_000_000.0


def _best_child_time(arguments: list[str], repeats: int) -> float:
    """The best wall time of ``repeats`` runs of a child Python with ``arguments`` (the checkout first
    on its path); the child must succeed."""
    best = float("inf")
    for _ in range(max(1, repeats)):
        start = time.perf_counter()
        subprocess.run([sys.executable, *arguments], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                       env=_child_environment(), check=True)
        best = min(best, time.perf_counter() - start)
    return best


def figure_cli_startup(options: BenchOptions) -> dict[str, Any]:
    """``nudge --help`` in a fresh Python: what every command pays before it starts its work."""
    elapsed = _best_child_time(["-m", "nudgecli.cli", "--help"], options.repeats)
    return _row("nudge --help (start-up)", elapsed, None, f"<= {_format_seconds(CLI_STARTUP_TARGET_S)}",
                elapsed <= CLI_STARTUP_TARGET_S,
                f"python -m nudgecli.cli --help in a child process, interpreter start-up included; "
                f"best of {max(1, options.repeats)}")


#: The modules a worker of each executor imports before its first task (process-pool workers are
#: forked and inherit them; dask and spawned workers import them).
WORKER_MODULES = {"study": "nudgecli.runs.study", "batch": "nudgecli.runs.batch"}


def figure_worker_ready(options: BenchOptions) -> dict[str, Any]:
    """A fresh Python importing what a study's and a batch's tasks need: a spawned worker's start-up."""
    times = {kind: _best_child_time(["-c", f"import {module}"], options.study_repeats)
             for kind, module in WORKER_MODULES.items()}
    worst = max(times.values())
    return _row("worker ready (fresh process, task imports)", worst, None,
                f"<= {_format_seconds(WORKER_READY_TARGET_S)}", worst <= WORKER_READY_TARGET_S,
                "; ".join(f"{kind} tasks ({WORKER_MODULES[kind]}) {_format_seconds(t)}"
                          for kind, t in times.items())
                + f"; interpreter start-up included; best of {max(1, options.study_repeats)}")


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
        subprocess.run([sys.executable, "-m", "nudgecli.cli", "replicate", options.throughput_experiment,
                        "-R", str(options.throughput_replications), "--workers", str(options.study_workers),
                        "--seed", str(BENCH_SEED), "--out", str(folder / "batch"), "--yes"],
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=_child_environment(),
                       check=True)
        elapsed = time.perf_counter() - start
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    per_hour = trials / elapsed * 3600.0
    at_target = trials / THROUGHPUT_TARGET_PER_HOUR * 3600.0
    return _row(f"replicate {options.throughput_experiment} -R {options.throughput_replications}, "
                f"{options.study_workers} workers, end to end", elapsed, at_target,
                f">= {THROUGHPUT_TARGET_PER_HOUR:,.0f} trials per hour",
                per_hour >= THROUGHPUT_TARGET_PER_HOUR,
                f"{per_hour:,.0f} trials per hour ({trials:,} trials, every study analysed); "
                f"{_available_cores()} cores; baseline = the wall time at the target rate")


ANALYZE_FIGURES: list[Figure] = [
    figure_analyze,
]

STUDY_FIGURES: list[Figure] = [
    figure_study_setup,
    figure_trials,
    figure_study,
    figure_cli_startup,
    figure_worker_ready,
]

FIGURES: list[Figure] = [
    figure_window,
    figure_grid,
    figure_value_iteration,
    *STUDY_FIGURES,
]


# --- scale figures (``nudge bench --only scale``) ----------------------------------------------

SCALE_EFFICIENCY_TARGET = {"study": 0.80, "sweep": 0.90}
DASK_RATIO_TARGET = 1.25
WORKER_MEMORY_TARGET_MB = 300.0
_SCALE_TIMES: dict[tuple[str, str], float] = {}


def _scale_batch(workload: str, options: BenchOptions) -> Any:
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
#: (CPU seconds of this process, CPU seconds of the finished workers) of each timed run.
_SCALE_CPU: dict[tuple[str, int], tuple[float, float]] = {}


def _children_cpu_s() -> float:
    """CPU seconds of this process's reaped children (0 where unknown)."""
    try:
        import resource
    except ImportError:  # pragma: no cover - Windows
        return 0.0
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _time_batch(workload: str, options: BenchOptions, workers: int = 1,
                scheduler: str | None = None) -> float:
    """Wall seconds of the workload (the largest worker's peak memory goes to ``_SCALE_PEAKS``)."""
    from nudgecli.runs.batch import run_batch

    batch = _scale_batch(workload, options)
    folder = Path(tempfile.mkdtemp(prefix="nudge-bench-scale-"))
    try:
        children = _children_cpu_s()
        start, own = time.perf_counter(), time.process_time()
        run = run_batch(batch, folder / "batch", workers=workers, scheduler=scheduler, confirm=True)
        elapsed = time.perf_counter() - start
        _SCALE_PEAKS[(workload, workers)] = run.worker_peak_mb
        _SCALE_CPU[(workload, workers)] = (time.process_time() - own, _children_cpu_s() - children)
        return elapsed
    finally:
        shutil.rmtree(folder, ignore_errors=True)


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
        cpu = (f"; CPU: this process {parent_cpu:.2f} s, workers {worker_cpu:.2f} s (serial share "
               f"{parent_cpu / (parent_cpu + worker_cpu):.1%})" if workers > 1 else "")
        peak = _SCALE_PEAKS.get((workload, workers)) if workers > 1 else None
        ok = efficiency >= target and (peak is None or peak <= WORKER_MEMORY_TARGET_MB)
        return _row(f"scale: {_workload_text(workload, options)}, {workers} worker(s)", elapsed, serial,
                    f"efficiency >= {target:.0%} (16-core target); worker <= "
                    f"{WORKER_MEMORY_TARGET_MB:.0f} MB", ok,
                    f"parallel efficiency {efficiency:.0%}; serial fraction (Karp-Flatt) {karp_flatt:.1%}; "
                    f"ratio = speed-up over 1 worker; {_available_cores()} cores; memory: the largest "
                    f"worker's peak RSS{cpu}", peak_mb=peak)

    figure.__name__ = f"figure_scale_{workload}_{workers}"
    return figure


def scale_dask_figure(workload: str) -> Figure:
    """A figure: the workload on a local dask cluster of single-thread worker processes, one per core,
    against the process pool on the same cores."""

    def figure(options: BenchOptions) -> dict[str, Any]:
        try:
            from dask.distributed import LocalCluster
        except ImportError:  # pragma: no cover - the optional extra
            return _row(f"scale: {_workload_text(workload, options)}, dask", float("nan"), None,
                        f"<= {DASK_RATIO_TARGET}x the process pool", False,
                        "dask.distributed is not installed (pip install 'nudgecli[cluster]')")
        cores = _available_cores()
        from dask.distributed import Client

        with LocalCluster(n_workers=cores, threads_per_worker=1, processes=True, dashboard_address=":0",
                          silence_logs=40) as cluster, Client(cluster) as client:
            client.run(_import_batch)  # start-up (imports in every worker) is not part of the figure
            elapsed = _time_batch(workload, options, scheduler=cluster.scheduler_address)
        pool = _SCALE_TIMES.get((workload + f":{cores}", repr(options)))
        if pool is None:
            pool = (_time_batch(workload, options, workers=cores) if cores > 1
                    else _serial_time(workload, options))
        ratio = elapsed / pool
        serial = _serial_time(workload, options)
        return _row(f"scale: {_workload_text(workload, options)}, dask ({cores} workers)", elapsed, pool,
                    f"<= {DASK_RATIO_TARGET}x the process pool", ratio <= DASK_RATIO_TARGET,
                    f"dask / process pool on {cores} cores = {ratio:.2f}x (ratio column: pool / dask); "
                    f"parallel efficiency {serial / (cores * elapsed):.0%}; cluster start-up and the "
                    "workers' imports excluded")

    figure.__name__ = f"figure_scale_{workload}_dask"
    return figure


def _import_batch() -> None:
    import nudgecli.runs.batch  # noqa: F401


def scale_figures() -> list[Figure]:
    """Both workloads on 1..cores local workers, then on a local dask cluster; then the end-to-end
    replication throughput."""
    figures: list[Figure] = []
    for workload in ("study", "sweep"):
        figures += [scale_figure(workload, w) for w in range(1, _available_cores() + 1)]
        figures.append(scale_dask_figure(workload))
    figures.append(figure_replicate_throughput)
    return figures


def select_figures(only: str = "all") -> list[Figure]:
    """The figures of one group.

    Parameters
    ----------
    only
        ``study`` (the figures in ``STUDY_FIGURES``), ``model`` (the others of ``FIGURES``),
        ``all`` (``FIGURES``) or ``analyze`` (``ANALYZE_FIGURES``, not part of ``all``: it takes
        about a minute).

    Raises
    ------
    ValueError
        For any other value.

    Returns
    -------
    list
        The figure functions, in ``FIGURES`` order (read at call time, so a patched list counts).
    """
    if only == "all":
        return list(FIGURES)
    if only == "scale":
        return scale_figures()
    if only == "analyze":
        return list(ANALYZE_FIGURES)
    if only not in ("model", "study"):
        raise ValueError(f"only must be 'model', 'study', 'scale', 'analyze' or 'all', got {only!r}")
    study = only == "study"
    return [figure for figure in FIGURES if (figure in STUDY_FIGURES) == study]


def _time_once(func: Callable[[], object]) -> float:
    start = time.perf_counter()
    func()
    return time.perf_counter() - start


def run_bench(options: BenchOptions | None = None,
              figures: list[Figure] | None = None,
              progress: Callable[[str], None] | None = None) -> list[dict[str, Any]]:
    """Measure every figure.

    Parameters
    ----------
    options
        Repeats and subset sizes (defaults when ``None``).
    figures
        The figure functions to run (``FIGURES`` when ``None``).
    progress
        Called with the name of each figure before it runs (e.g. to log to stderr); the
        whole-study figure's child process also logs its progress on stderr.

    Returns
    -------
    list of dict
        One row per figure with the keys of ``COLUMNS``.
    """
    options = options or BenchOptions()
    rows = []
    for figure in figures if figures is not None else FIGURES:
        if progress is not None:
            progress(f"bench: {figure.__name__.removeprefix('figure_')}")
        rows.append(figure(options))
    return rows


def _format_ratio(ratio: float | None) -> str:
    """``1,349x`` for large ratios, ``0.46x`` below 10 (where whole numbers would hide the size)."""
    if ratio is None:
        return "-"
    return f"{ratio:,.0f}x" if ratio >= 10 else f"{ratio:.2f}x"


def _format_seconds(seconds: float | None) -> str:
    if seconds is None:
        return "-"
    if seconds >= 1.0:
        return f"{seconds:.2f} s"
    if seconds >= 1e-3:
        return f"{seconds * 1e3:.2f} ms"
    return f"{seconds * 1e6:.1f} us"


def format_table(rows: list[dict[str, Any]]) -> str:
    """A plain-text table of bench rows (columns what, time, baseline, ratio, memory, target, ok),
    with each row's note on the line below it."""
    header = ("what", "time", "baseline", "ratio", "memory", "target", "ok")
    cells = [(row["what"], _format_seconds(row["time_s"]), _format_seconds(row["baseline_s"]),
              _format_ratio(row["ratio"]),
              "-" if row.get("peak_mb") is None else f"{row['peak_mb']:,.0f} MB", row["target"],
              "yes" if row["ok"] else "NO") for row in rows]
    widths = [max(len(header[k]), *(len(c[k]) for c in cells)) for k in range(len(header))]
    lines = ["  ".join(h.ljust(w) for h, w in zip(header, widths, strict=True)).rstrip(),
             "  ".join("-" * w for w in widths)]
    for row, cell in zip(rows, cells, strict=True):
        lines.append("  ".join(c.ljust(w) for c, w in zip(cell, widths, strict=True)).rstrip())
        if row.get("note"):
            lines.append(f"    {row['note']}")
    return "\n".join(lines)
