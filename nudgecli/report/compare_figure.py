"""The figure of ``nudge compare``: simulated and real distributions of each metric, side by side.

One panel per (metric, condition): the empirical CDFs of the trials of each source (simulated
solid blue, real dashed vermillion: line style and colour both tell them apart in grayscale), and
below the curves each participant's median as a dot, one row per source, so a reader sees both
the pooled distributions and the spread between people. The panel title carries the KS and
Wasserstein distances of :func:`nudgecli.report.compare.compare_tables`.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from nudgecli.report.compare import condition_pair
from nudgecli.report.figures.common import axes_or_new
from nudgecli.report.figures.output import save_figure
from nudgecli.report.style import COLUMN_WIDTH_IN, FULL_WIDTH_IN, OKABE_ITO, figure_style
from nudgecli.report.summary import format_value

#: File stem of the figure.
FIGURE_STEM = "compare"
#: Colour, line style and dot row (y position below the ECDF) of each source.
SOURCE_STYLE: dict[str, dict[str, Any]] = {
    "simulated": {"color": OKABE_ITO["blue"], "linestyle": "-", "row": -0.09, "marker": "o"},
    "real": {"color": OKABE_ITO["vermillion"], "linestyle": "--", "row": -0.19, "marker": "D"},
}


def _ecdf(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Step coordinates of the ECDF of ``values`` ``(n,)``: sorted values and ``(1..n) / n``."""
    ordered = np.sort(values)
    return ordered, np.arange(1, ordered.size + 1) / ordered.size


def compare_panel(trials: dict[str, pd.DataFrame], medians: pd.DataFrame, metric: str, condition: str,
                  comparison: pd.DataFrame | None = None, *, title: str = "", ax: Axes | None = None,
                  two_line_title: bool = False) -> Axes:
    """One metric and condition: each source's ECDF of the trials and its participants' medians
    as dots under it; the KS statistic and Wasserstein distance in the title.

    Parameters
    ----------
    trials
        ``{"simulated": table, "real": table}``: metrics tables (``condition`` and metric columns).
    medians
        :func:`nudgecli.report.compare.participant_medians`'s result.
    metric, condition
        The panel's metric and condition.
    comparison
        :func:`nudgecli.report.compare.compare_tables`'s result (its row of this metric and
        condition gives the distances in the title), or ``None``.
    title
        The title before the distances (the condition when the figure has several).
    ax
        Axes to draw on; default a new figure's.
    two_line_title
        Put the distances under the title instead of after it (narrow panels: three or more
        conditions side by side).
    """
    ax = axes_or_new(ax, (COLUMN_WIDTH_IN, 2.3))
    for source, style in SOURCE_STYLE.items():
        table = trials[source]
        subset = table[table["condition"].astype(str) == condition]
        values = pd.to_numeric(subset[metric].astype("Float64"), errors="coerce").to_numpy(
            dtype=float, na_value=np.nan)
        values = values[np.isfinite(values)]
        if values.size:
            x, y = _ecdf(values)
            ax.step(np.r_[x[0], x], np.r_[0.0, y], where="post", color=style["color"],
                    linestyle=style["linestyle"], label=f"{source} trials (ECDF)")
        own = medians[(medians["source"] == source) & (medians["metric"] == metric)
                      & (medians["condition"] == condition)]["median"].to_numpy(dtype=float)
        ax.scatter(own, np.full(own.size, style["row"]), s=10, color=style["color"],
                   marker=style["marker"], edgecolors="white", linewidths=0.3, zorder=3,
                   label=f"{source} participants' medians")
    ax.axhline(0.0, color="#8C8C8C", linewidth=0.5)
    ax.set_ylim(-0.27, 1.03)
    ax.set_yticks([0.0, 0.5, 1.0])
    ax.set_xlabel(metric.replace("_", " "))
    row = (comparison[(comparison["metric"] == metric) & (comparison["condition"] == condition)]
           if comparison is not None else pd.DataFrame())
    if not row.empty:
        ks, w1 = float(row["ks_statistic"].iloc[0]), float(row["wasserstein"].iloc[0])
        if math.isfinite(ks):
            separator = "\n" if two_line_title else ": "
            title = f"{title + separator if title else ''}KS {ks:.2f}, W {format_value(w1)}"
    ax.set_title(title, loc="left")
    return ax


def build_compare_figure(trials: dict[str, pd.DataFrame], comparison: pd.DataFrame,
                         medians: pd.DataFrame) -> Figure:
    """The comparison figure: :func:`compare_panel` per metric (rows) and condition (columns).

    Parameters
    ----------
    trials
        ``{"simulated": table, "real": table}``: metrics tables (``condition`` and metric columns).
    comparison
        :func:`nudgecli.report.compare.compare_tables`'s result (which panels, and their titles).
    medians
        :func:`nudgecli.report.compare.participant_medians`'s result.
    """
    metrics = list(dict.fromkeys(comparison["metric"]))
    conditions = list(dict.fromkeys(comparison["condition"]))
    n_rows, n_cols = len(metrics), len(conditions)
    # a condition --match paired is titled by both its names, even alone in the figure
    paired = comparison.get("simulated_condition", comparison["condition"]).astype(str)
    names = {str(c): condition_pair(s, str(c)) for c, s in zip(comparison["condition"], paired, strict=True)}
    titles = {c: name if n_cols > 1 or name != c else "" for c, name in names.items()}
    width = COLUMN_WIDTH_IN if n_cols == 1 else FULL_WIDTH_IN
    # the legend's two columns (simulated, real) are wider than one column's figure: there it
    # takes one column of four lines, and the figure grows by the two lines more
    legend_columns, legend_height = (2, 0.0) if n_cols > 1 else (1, 0.3)
    with figure_style():
        fig = Figure(figsize=(width, 1.9 * n_rows + 0.4 + legend_height), layout="constrained")
        FigureCanvasAgg(fig)
        axes = np.atleast_2d(fig.subplots(n_rows, n_cols, squeeze=False))
        for i, metric in enumerate(metrics):
            for j, condition in enumerate(conditions):
                ax = compare_panel(trials, medians, metric, condition, comparison,
                                   title=titles[str(condition)], ax=axes[i, j],
                                   two_line_title=n_cols > 2)
                if j == 0:
                    ax.set_ylabel("share of trials")
        handles, labels = axes[0, 0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside lower center", ncol=legend_columns)
    return fig


def plot_comparison(trials: dict[str, pd.DataFrame], comparison: pd.DataFrame, medians: pd.DataFrame,
                    out_dir: str | os.PathLike[str], formats: Sequence[str] = ("png", "pdf")) -> list[Path]:
    """Draw :func:`build_compare_figure` and write ``compare.<fmt>`` into ``out_dir``."""
    figure = build_compare_figure(trials, comparison, medians)
    return save_figure(figure, out_dir, FIGURE_STEM, formats)
