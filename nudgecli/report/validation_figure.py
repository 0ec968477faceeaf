"""The figure of ``nudge validate``: match rate by |G| and the Monte-Carlo convergence curves.

Three panels drawn from the JSON summary of :mod:`nudgecli.sim.validation` (so a saved
``validation.json`` can be re-plotted): (a) the match rate of D(s) (lambda = 0) against the
ground truth per number of goals, with the rate excluding near-ties, the share of queries whose
choice is optimal for the ground truth, the lambda = 1 variant and the paper's reported 100%;
(b) the mean absolute error of the study's Monte-Carlo estimate against the exact mutual
information versus the number of samples; (c) how often its argmax is an exact maximiser.
Both estimator variants are shown (the study's unweighted KL mean and the belief-weighted
one); the unweighted variant's ``N -> infinity`` limit is drawn as a dotted line.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from nudgecli.report.figures.common import axes_or_new
from nudgecli.report.figures.output import save_figure
from nudgecli.report.style import FULL_WIDTH_IN, OKABE_ITO, PANEL_LETTER_PT, figure_style

#: File stem of the figure.
FIGURE_STEM = "validation"
#: Colour and line style of each estimator variant.
VARIANT_STYLE: dict[str, dict[str, Any]] = {
    "unweighted": {"color": OKABE_ITO["vermillion"], "linestyle": "-", "marker": "o",
                   "label": "unweighted (study)"},
    "belief": {"color": OKABE_ITO["blue"], "linestyle": "--", "marker": "s",
               "label": "belief-weighted (Eq. 14)"},
}


def _panel_letter(ax: Axes, letter: str) -> None:
    ax.text(-0.16, 1.04, letter, transform=ax.transAxes, fontsize=PANEL_LETTER_PT, fontweight="bold",
            va="bottom", ha="left")


def _as_float(value: Any) -> float:
    return float("nan") if value is None else float(value)


def match_rate_panel(summary: dict[str, Any], *, ax: Axes | None = None) -> Axes:
    """The match rate of s* against the ground truth by |G| (and the variants reported beside it).

    Parameters
    ----------
    summary
        :meth:`nudgecli.sim.validation.ValidationResult.summary` (or a loaded validation.json).
    ax
        Axes to draw on; default a new 7.2 x 2.6 in figure's.

    Returns
    -------
    Axes
        The axes drawn on.
    """
    ax = axes_or_new(ax, (FULL_WIDTH_IN, 2.6))
    with figure_style():
        _draw_match(ax, summary)
    return ax


def _draw_match(ax: Axes, summary: dict[str, Any]) -> None:
    by_goals = summary["by_goals"]
    goals = np.array([int(k) for k in by_goals])
    series = (
        ("match_rate", "match", OKABE_ITO["black"], "-", "o"),
        ("match_rate_excluding_near_ties", "match, near-ties excluded", OKABE_ITO["bluish_green"], "--", "^"),
        ("truth_optimal_rate", "choice optimal for the ground truth", OKABE_ITO["sky_blue"], "-.", "D"),
        ("regularised_match_rate", r"match, $\lambda = 1$", OKABE_ITO["orange"], ":", "v"),
    )
    for key, label, colour, style, marker in series:
        values = np.array([_as_float(by_goals[str(g)][key]) for g in goals]) * 100.0
        ax.plot(goals, values, color=colour, linestyle=style, marker=marker, markersize=2.5, label=label)
    ax.axhline(100.0, color="#8C8C8C", linewidth=0.8, linestyle=(0, (4, 2)))
    ax.text(goals.min(), 101.5, "paper: 100%", color="#606060", fontsize=8.0, va="bottom", ha="left")
    ax.set_xlabel("number of goals |G|")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))  # |G| is a count: no ticks at 3.2, 3.4
    ax.set_ylabel("queries (%)")
    ax.set_ylim(0.0, 140.0)
    ax.set_yticks(np.arange(0.0, 101.0, 20.0))
    reading = summary.get("reading", "dirichlet")
    ax.set_title(f"D(s) vs ground truth, reading {reading} ({summary['queries']} queries, overall match "
                 f"{100.0 * _as_float(summary['match_rate']):.1f}%)", loc="left")
    ax.legend(loc="upper right", ncol=2)


def _variant_curves(summary: dict[str, Any], key: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    curves: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for variant in VARIANT_STYLE:
        rows = [r for r in summary["convergence"] if r["variant"] == variant]
        if rows:
            curves[variant] = (np.array([r["n_samples"] for r in rows], dtype=float),
                               np.array([_as_float(r[key]) for r in rows]))
    return curves


def convergence_panel(summary: dict[str, Any], key: str, *, percent: bool = False,
                      ax: Axes | None = None) -> Axes:
    """One measure of the Monte-Carlo convergence study against the sample count, per variant.

    Parameters
    ----------
    summary
        The validation summary (with ``convergence`` rows).
    key
        ``"mae"`` or ``"argmax_agreement"`` (a column of the convergence rows).
    percent
        Show the measure in percent.
    ax
        Axes to draw on; default a new 3.6 x 2.4 in figure's.

    Returns
    -------
    Axes
        The axes drawn on.
    """
    ax = axes_or_new(ax, (FULL_WIDTH_IN / 2, 2.4))
    with figure_style():
        _draw_convergence(ax, summary, key, percent)
    return ax


def _draw_convergence(ax: Axes, summary: dict[str, Any], key: str, percent: bool) -> None:
    scale = 100.0 if percent else 1.0
    for variant, (n, values) in _variant_curves(summary, key).items():
        style = VARIANT_STYLE[variant]
        ax.plot(n, values * scale, color=style["color"], linestyle=style["linestyle"],
                marker=style["marker"], markersize=2.5, label=style["label"])
    limit = summary.get("convergence_limit", {}).get("unweighted")
    if limit is not None:
        ax.axhline(_as_float(limit[key]) * scale, color=VARIANT_STYLE["unweighted"]["color"],
                   linestyle=":", linewidth=0.9, label=r"unweighted, $N \to \infty$")
    ax.set_xscale("log")
    ax.set_xlabel("Monte-Carlo samples per state N")


def build_validation_figure(summary: dict[str, Any]) -> Figure:
    """The validation figure as a :class:`matplotlib.figure.Figure` (no pyplot).

    Parameters
    ----------
    summary
        :meth:`nudgecli.sim.validation.ValidationResult.summary` (or a loaded validation.json).

    Returns
    -------
    Figure
        One panel (match by |G|) when the summary has no convergence rows, three otherwise.
    """
    has_mc = bool(summary.get("convergence"))
    with figure_style():
        fig = Figure(figsize=(FULL_WIDTH_IN, 4.6 if has_mc else 2.6), layout="constrained")
        FigureCanvasAgg(fig)
        if has_mc:
            grid = fig.add_gridspec(2, 2, height_ratios=(1.0, 0.9))
            ax_match = fig.add_subplot(grid[0, :])
            ax_mae = fig.add_subplot(grid[1, 0])
            ax_agree = fig.add_subplot(grid[1, 1])
        else:
            ax_match = fig.add_subplot(1, 1, 1)
        _draw_match(ax_match, summary)
        _panel_letter(ax_match, "a")
        if has_mc:
            first = summary["convergence"][0]
            _draw_convergence(ax_mae, summary, "mae", percent=False)
            ax_mae.set_yscale("log")
            ax_mae.set_ylabel("mean absolute error (nats)")
            ax_mae.set_title(f"MC estimate vs exact I(s) ({first['queries']} queries)", loc="left")
            ax_mae.legend(loc="lower left")
            _panel_letter(ax_mae, "b")
            _draw_convergence(ax_agree, summary, "argmax_agreement", percent=True)
            ax_agree.set_ylim(0.0, 105.0)
            ax_agree.set_ylabel("exact-optimal argmax (%)")
            ax_agree.set_title("argmax agreement within the window", loc="left")
            ax_agree.legend(loc="lower right")
            _panel_letter(ax_agree, "c")
    return fig


def plot_validation(summary: dict[str, Any], out_dir: str | os.PathLike[str],
                    formats: Sequence[str] = ("png", "pdf")) -> list[Path]:
    """Write ``validation.<fmt>`` for each format into ``out_dir``, atomically.

    Parameters
    ----------
    summary
        The validation summary.
    out_dir
        Existing or new folder.
    formats
        Matplotlib formats (``png``, ``pdf``, ``svg``).

    Returns
    -------
    list[Path]
        The files written.
    """
    return save_figure(build_validation_figure(summary), out_dir, FIGURE_STEM, formats)
