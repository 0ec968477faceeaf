"""``nudge bench``: the performance figures of DESIGN section 8, measured in one run.

Each figure is a function returning one row (a dict with the keys of
:data:`~nudgecli.bench.common.COLUMNS`); ``FIGURES`` lists them in report order, so adding a
figure is adding a function to that list. Times are in seconds; ratios are ``baseline / time``
(how many times faster than the baseline measured in the same run). Timings use
``time.perf_counter``: fast calls are looped in batches and the best (minimum) per-call time over
several batches is reported, the slow baselines are timed whole and the best of a few runs is
reported. The minimum is the usual estimate of a computation's own cost on a machine shared with
other work (other processes only ever add time); both sides of a ratio use it, so the ratio is
not flattered by load on one side.

The figures come in groups (``nudge bench --only model|study|scale``), one module each: the model
figures (:mod:`~nudgecli.bench.model`, a few seconds), the scale figures
(:mod:`~nudgecli.bench.scale`: batches of studies on 1..cores workers and on a local dask cluster:
parallel efficiency and serial fraction; not part of ``all``) and the study figures
(:mod:`~nudgecli.bench.study`, ``STUDY_FIGURES``, about 10-15 s at the paper scale), which
simulate the study itself: the plan's value iteration, one participant's trials in this process,
and the whole study with worker processes in a child Python process so that its peak memory is
measured apart from this one's. A third group runs only when asked (``--only analyze``,
``ANALYZE_FIGURES``, :mod:`~nudgecli.bench.analyze`, a minute or so): ``nudge analyze`` of a
large synthetic metrics table; another (``--only pipeline``, :mod:`~nudgecli.bench.pipeline`)
measures ``nudge replicate`` end to end against the trial loop's own speed (the pipeline
efficiency), and ``nudge power`` against its wall-time target. What each figure must meet is in
:mod:`~nudgecli.bench.targets`;
what they share (options, row, timing) in :mod:`~nudgecli.bench.common`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from nudgecli.bench.analyze import figure_analyze
from nudgecli.bench.common import BenchOptions, Figure, format_seconds
from nudgecli.bench.model import figure_grid, figure_value_iteration, figure_window
from nudgecli.bench.pipeline import pipeline_figures
from nudgecli.bench.scale import scale_figures
from nudgecli.bench.study import (
    figure_cli_startup,
    figure_pool_ready,
    figure_study,
    figure_study_setup,
    figure_trials,
    figure_worker_ready,
)

ANALYZE_FIGURES: list[Figure] = [
    figure_analyze,
]

STUDY_FIGURES: list[Figure] = [
    figure_study_setup,
    figure_trials,
    figure_study,
    figure_cli_startup,
    figure_pool_ready,
    figure_worker_ready,
]

FIGURES: list[Figure] = [
    figure_window,
    figure_grid,
    figure_value_iteration,
    *STUDY_FIGURES,
]


def select_figures(only: str = "all", scale_workers: Sequence[int] | None = None) -> list[Figure]:
    """The figures of one group.

    Parameters
    ----------
    only
        ``study`` (the figures in ``STUDY_FIGURES``), ``model`` (the others of ``FIGURES``),
        ``all`` (``FIGURES``), ``scale``, ``pipeline`` (:mod:`~nudgecli.bench.pipeline`: batches
        end to end against the trial loop, and a power analysis: about three and a half minutes) or
        ``analyze``
        (``ANALYZE_FIGURES``, about a minute); the last three are not part of ``all``.
    scale_workers
        ``scale`` only: the worker counts to time (``None``: 1 to the cores; see
        :func:`~nudgecli.bench.scale.scale_worker_counts`).

    Raises
    ------
    ValueError
        For any other value of ``only``.
    NudgeError
        For a worker count below 1 or above the cores.

    Returns
    -------
    list
        The figure functions, in ``FIGURES`` order (read at call time, so a patched list counts).
    """
    if only == "all":
        return list(FIGURES)
    if only == "scale":
        return scale_figures(scale_workers)
    if only == "analyze":
        return list(ANALYZE_FIGURES)
    if only == "pipeline":
        return pipeline_figures()
    if only not in ("model", "study"):
        raise ValueError(f"only must be 'model', 'study', 'scale', 'pipeline', 'analyze' or 'all', "
                         f"got {only!r}")
    study = only == "study"
    return [figure for figure in FIGURES if (figure in STUDY_FIGURES) == study]


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


def format_table(rows: list[dict[str, Any]]) -> str:
    """A plain-text table of bench rows (columns what, time, baseline, ratio, memory, target, ok),
    with each row's note on the line below it."""
    header = ("what", "time", "baseline", "ratio", "memory", "target", "ok")
    cells = [(row["what"], format_seconds(row["time_s"]), format_seconds(row["baseline_s"]),
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
