"""What every ``nudge bench`` figure shares: its options, its row, and how it times.

Each figure is a function of :class:`BenchOptions` returning one row (:func:`row`, the keys of
:data:`COLUMNS`). Fast calls are looped in batches and the best (minimum) per-call time over
several batches is reported (:func:`best_call_time`); slow ones are timed whole
(:func:`time_once`), a child Python's whole run with :func:`best_child_time`.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nudgecli import command_defaults as defaults
from nudgecli.cores import available_cores as available_cores  # re-exported: the benches import it from here
from nudgecli.errors import WorkerLostError

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

    repeats: int = defaults.BENCH_REPEATS
    baseline_repeats: int = defaults.BENCH_BASELINE_REPEATS
    mc_states: int = 75
    study_experiment: str = "paper"
    study_participants: int | None = None
    study_workers: int = 2
    study_repeats: int = defaults.BENCH_STUDY_REPEATS
    scale_participants: int = defaults.BENCH_SCALE_PARTICIPANTS
    scale_studies: int = defaults.BENCH_SCALE_STUDIES
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


def time_once(func: Callable[[], object]) -> float:
    start = time.perf_counter()
    func()
    return time.perf_counter() - start


def row(what: str, time_s: float, baseline_s: float | None, target: str, ok: bool,
         note: str, peak_mb: float | None = None) -> dict[str, Any]:
    ratio = None if baseline_s is None else baseline_s / time_s
    return {"what": what, "time_s": time_s, "baseline_s": baseline_s, "ratio": ratio, "peak_mb": peak_mb,
            "target": target, "ok": bool(ok), "note": note}


def child_environment() -> dict[str, str]:
    """This environment with the folder holding ``nudgecli`` first on ``PYTHONPATH``."""
    env = dict(os.environ)
    package_parent = str(Path(__file__).resolve().parents[2])  # nudgecli/bench/common.py
    env["PYTHONPATH"] = os.pathsep.join(p for p in (package_parent, env.get("PYTHONPATH")) if p)
    return env


def uncompiled_modules_warning(package: Path, environ: Mapping[str, str]) -> str | None:
    """A warning where the child Pythons would compile ``package`` on every start, or ``None``.

    That is where their bytecode cache is off (``PYTHONDONTWRITEBYTECODE`` in ``environ``, which
    they inherit) and a module of the package has no cached bytecode: then every start-up figure
    carries the compile (0.4-0.5 s of the paper study's 2.3-2.7 s on a 2-core machine), which an
    installed package does not pay (pip compiles at install).
    """
    if not environ.get("PYTHONDONTWRITEBYTECODE"):
        return None
    sources = sorted(package.rglob("*.py"))
    missing = [p for p in sources if not Path(importlib.util.cache_from_source(str(p))).is_file()]
    if not missing:
        return None
    return (f"bench: warning: PYTHONDONTWRITEBYTECODE is set and {len(missing)} of {package.name}'s "
            f"{len(sources)} modules have no cached bytecode, so every child Python compiles them and "
            f"the start-up figures include it; run `python -m compileall -q {package}` first (as pip "
            "install does), or unset it")


def best_child_time(arguments: list[str], repeats: int, what: str) -> float:
    """The best wall time of ``repeats`` runs of a child Python with ``arguments`` (the checkout first
    on its path); the child must succeed (:func:`run_child`: the figure ``what``)."""
    best = float("inf")
    for _ in range(max(1, repeats)):
        start = time.perf_counter()
        run_child([sys.executable, *arguments], what, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        best = min(best, time.perf_counter() - start)
    return best


def child_failure(what: str, status: int) -> WorkerLostError:
    """The error of a bench child that exited with ``status`` (not 0) while timing ``what``: one
    line naming the figure and the status (a negative status is the signal that ended it)."""
    if status == -9:
        how = " (killed, perhaps for memory)"
    elif status < 0:
        how = f" (ended by signal {-status})"
    else:
        how = ""
    return WorkerLostError(f"bench: the {what} figure's child process failed with exit status {status}{how}, "
                           "so the figure was not measured; run nudge bench again (--only for fewer figures)")


def run_child(command: list[str], what: str, **streams: Any) -> subprocess.CompletedProcess[str]:
    """Run ``command`` (a child Python, the checkout first on its path) with ``streams`` (stdout,
    stderr) as text; it must succeed.

    Raises
    ------
    WorkerLostError
        The child exited with a status other than 0 (:func:`child_failure`: the figure ``what``).
    """
    completed = subprocess.run(command, text=True, env=child_environment(), check=False, **streams)
    if completed.returncode != 0:
        raise child_failure(what, completed.returncode)
    return completed


def run_child_script(script: str, arguments: list[str], what: str) -> tuple[float, dict[str, Any]]:
    """Run ``script`` in a child Python with ``arguments``: its wall time (start-up included) and the
    JSON report it prints as its last line of stdout.

    Raises
    ------
    WorkerLostError
        The child failed (:func:`child_failure`: its exit status, with ``what`` it was).
    """
    start = time.perf_counter()
    completed = run_child([sys.executable, "-c", script, *arguments], what, stdout=subprocess.PIPE,
                          stderr=None)
    seconds = time.perf_counter() - start
    return seconds, json.loads(completed.stdout.strip().splitlines()[-1])


def format_seconds(seconds: float | None) -> str:
    if seconds is None:
        return "-"
    if seconds >= 1.0:
        return f"{seconds:.2f} s"
    if seconds >= 1e-3:
        return f"{seconds * 1e3:.2f} ms"
    return f"{seconds * 1e6:.1f} us"
