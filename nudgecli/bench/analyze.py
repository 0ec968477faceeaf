"""The analyze figure of ``nudge bench`` (``--only analyze``, not part of ``all``: a minute or so):
``nudge analyze`` of a large synthetic metrics table in a child Python."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from nudgecli.bench.common import BENCH_SEED, BenchOptions, available_cores, row, run_child_script
from nudgecli.bench.targets import ANALYZE_MEMORY_TARGET_MB, ANALYZE_WALL_TARGET_S

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
    metrics have the types and ranges of real ones (fractions, counts, seconds, booleans). A failed
    trial has no completion time, as in the table ``nudge analyze`` writes of a run under the paper
    plan (whose completion time counts successful trials only), so the plan leaves it as it is.

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
    table = pd.DataFrame({
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
    table["completion_time"] = table["completion_time"].where(table["success"])
    return table


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
        process_s, report = run_child_script(_ANALYZE_SCRIPT, [str(source), str(folder / "out")], "analyze")
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    peak = report["self_kib"] / 1024.0
    ok = process_s <= ANALYZE_WALL_TARGET_S and peak <= ANALYZE_MEMORY_TARGET_MB
    return row(f"analyze, {options.analyze_rows:,}-row metrics table", process_s, None,
               f"<= {ANALYZE_WALL_TARGET_S:.0f} s on 2 cores, <= {ANALYZE_MEMORY_TARGET_MB:.0f} MB", ok,
               f"time: the child Python end to end (start-up, imports, analyze {report['wall_s']:.2f} s) on "
               f"{available_cores()} cores; {options.analyze_participants} participants, 2 conditions, "
               f"7 metrics, CSV of {size_mb:,.0f} MB, 2000 bootstrap resamples (paper plan); "
               "peak_mb = the analyze process's peak resident memory (VmHWM)", peak_mb=peak)
