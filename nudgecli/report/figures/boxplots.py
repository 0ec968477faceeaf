"""Box plots of per-trial metrics (the paper's Fig. 3 and Fig. 4, and any other metric table).

Every trial is a dot, boxes show median and quartiles, and the significance brackets come from
the toolkit's own Kruskal-Wallis / Conover p-values (``stats.json``, :mod:`nudgecli.report.brackets`);
four or more conditions get a compact letter display instead, or the brackets of one reference
condition, and a condition a metric is not applicable to gets an "n/a" in its slot
(:mod:`nudgecli.report.figures.comparison_marks`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.collections import PathCollection
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.layout_engine import ConstrainedLayoutEngine
from matplotlib.ticker import MaxNLocator

from nudgecli.errors import DataError
from nudgecli.report.brackets import DEFAULT_STAR_RULE, bracket_levels, draw_brackets
from nudgecli.report.figures.common import (
    axes_or_new,
    jitter,
    panel_letter,
    resolve_conditions,
    stats_by_metric,
    wrap_label,
)
from nudgecli.report.figures.comparison_marks import (
    Comparisons,
    chosen_marks,
    mark_letters,
    mark_not_applicable,
)
from nudgecli.report.not_applicable import not_applicable_of
from nudgecli.report.plans import MetricDefinitions
from nudgecli.report.stats import ComparisonOptions
from nudgecli.report.style import (
    FULL_WIDTH_IN,
    TICK_FONT_PT,
    condition_colours,
    condition_display_names,
    figure_style,
)
from nudgecli.report.table_definitions import PLAN_DEFINED
from nudgecli.report.table_read import TABLE_READ_KEY
from nudgecli.report.trial_steps import require_columns

METRIC_FIGSIZE = (FULL_WIDTH_IN, 2.6)
#: Height of one row of panels of :func:`metrics_figure` (inches).
METRIC_ROW_HEIGHT_IN = 2.6
#: Panels per row of :func:`metrics_figure`.
METRIC_PANELS_PER_ROW = 3
#: Bracket levels a row of :func:`metrics_figure` holds at its base height; each further level
#: (many conditions, many significant pairs) adds :data:`BRACKET_LEVEL_HEIGHT_IN` to every row.
BRACKET_LEVELS_PER_ROW = 4
BRACKET_LEVEL_HEIGHT_IN = 0.2
BOX_WIDTH = 0.55

#: Dots in one panel above which they are drawn as an image (at the figure's dpi) inside a PDF or
#: SVG: every trial of a 3.5 M-row table as a vector mark made a 127 MB Fig. 3 that took minutes to
#: write and to open. A study's few thousand trials stay vector marks.
RASTER_DOTS_ABOVE = 20_000


@dataclass(frozen=True)
class MetricSpec:
    """How one metric column is shown.

    Attributes
    ----------
    column
        Column of the metrics table.
    label
        y-axis label, with its unit.
    scale
        Factor from the stored value to the shown value (fractions shown as percent: 100).
    integer
        A count: y ticks only at whole numbers.
    """

    column: str
    label: str
    scale: float = 1.0
    integer: bool = False


METRIC_SPECS: dict[str, MetricSpec] = {
    "assistance_engagement": MetricSpec("assistance_engagement", "Assistance engagement (% of human turn)",
                                        100.0),
    "assistance_strength": MetricSpec("assistance_strength", "Strength of assistance (mean α)"),
    "human_turns": MetricSpec("human_turns", "Human turns per trial", integer=True),
    "mode_switches": MetricSpec("mode_switches", "Mode switches per trial", integer=True),
    "human_effort": MetricSpec("human_effort", "Human effort (fraction of trial time)"),
    "completion_time": MetricSpec("completion_time", "Completion time (s)"),
    "success": MetricSpec("success", "Success (1 = reached the true goal)"),
    "wrong_goal": MetricSpec("wrong_goal", "Wrong goal (1 = ended at another goal)"),
}
#: The labels of the metrics whose study-software definition (a plan's ``[metrics]``,
#: :class:`~nudgecli.report.plans.MetricDefinitions`) measures something other than the paper's
#: label of :data:`METRIC_SPECS` says: ``(metric, definition) -> label``.
DEFINITION_LABELS: dict[tuple[str, str], str] = {
    ("assistance_engagement", "per_turn"): "Assistance engagement (mean % per human turn)",
    ("assistance_strength", "per_turn"): "Strength of assistance (mean α per human turn)",
    ("mode_switches", "human_turn"): "Mode switches in human turns per trial",
    ("success", "last_inferred_goal"): "Success (1 = last inferred goal is the true goal)",
}
FIGURE3_METRICS = ("assistance_engagement", "assistance_strength", "human_turns")
FIGURE4_METRICS = ("mode_switches", "human_effort", "completion_time")


def metric_spec(metric: str, definitions: MetricDefinitions | None = None) -> MetricSpec:
    """The known spec of ``metric``, else its name as the label: ``_`` as spaces and the first
    letter capitalised, the rest as written (``tlx_NASA_raw``: Tlx NASA raw). With the plan's
    ``definitions``, the label of the metric as the plan defines it (:data:`DEFINITION_LABELS`)."""
    if metric in METRIC_SPECS:
        spec = METRIC_SPECS[metric]
        field_name = PLAN_DEFINED.get(metric)
        chosen = getattr(definitions, field_name) if definitions is not None and field_name else None
        label = DEFINITION_LABELS.get((metric, str(chosen)))
        return spec if label is None else dataclasses.replace(spec, label=label)
    label = metric.replace("_", " ")
    return MetricSpec(metric, label[:1].upper() + label[1:])


def applied_definitions(stats: Mapping[str, Any] | None,
                        definitions: MetricDefinitions | None) -> MetricDefinitions | None:
    """The metric definitions the analysis in ``stats`` applied, of the plan's ``definitions``: those
    of a run folder's analysis; ``None`` (the paper's labels) for a metrics table's, which takes the
    table's own values of every metric :data:`DEFINITION_LABELS` names (the analysis's note says
    so: :func:`~nudgecli.report.table_definitions.apply_plan_definitions`), so that no label names
    a definition that was not applied."""
    if stats is not None and TABLE_READ_KEY in stats:
        return None
    return definitions


@dataclass
class BoxplotArtists:
    """What :func:`metric_boxplot` drew.

    Attributes
    ----------
    ax
        The axes drawn on.
    conditions
        The conditions, left to right.
    positions
        x position of each condition.
    boxes
        The box patch of each condition that has data (its face colour is the condition's).
    points
        The trial dots of each condition (``get_offsets()`` gives their ``(x, y)``).
    brackets
        Significance bracket artists (lines and star texts).
    n
        Number of trials with a value, per condition (0 for a condition the metric is not
        applicable to: none is drawn).
    letters
        The compact letter display's texts (four or more conditions), one per condition with letters.
    not_applicable
        The "n/a" texts of the conditions the metric is not applicable to.
    """

    ax: Axes
    conditions: list[str]
    positions: dict[str, float]
    boxes: dict[str, Any] = field(default_factory=dict)
    points: dict[str, PathCollection] = field(default_factory=dict)
    brackets: list[Any] = field(default_factory=list)
    n: dict[str, int] = field(default_factory=dict)
    letters: list[Any] = field(default_factory=list)
    not_applicable: list[Any] = field(default_factory=list)


def metric_boxplot(metrics: pd.DataFrame, metric: str, stats_entry: Mapping[str, Any] | None = None, *,
                   ax: Axes | None = None, conditions: Sequence[str] | None = None, seed: int = 0,
                   show_points: bool = True, show_n: bool = True, label: str | None = None,
                   star_rule: ComparisonOptions = DEFAULT_STAR_RULE, comparisons: Comparisons = "auto",
                   reference: str | None = None, definitions: MetricDefinitions | None = None
                   ) -> BoxplotArtists:
    """A box plot per condition with every trial as a jittered dot and significance brackets.

    Boxes show the median and quartiles, whiskers reach the furthest trial within 1.5 IQR of
    the box; no separate outlier markers are drawn because every trial is a dot. NaN values
    (e.g. strength of assistance in a trial without assistance) are left out and the number
    of trials drawn is printed under each condition.

    Parameters
    ----------
    metrics
        One row per trial with ``condition`` and the ``metric`` column.
    metric
        The metric column (a key of :data:`METRIC_SPECS` gets its label and unit scaling).
    stats_entry
        The metric's element of ``stats["metrics"]``; brackets are drawn for its significant
        comparisons only, letters for four or more conditions; its ``not_applicable`` conditions
        get no box and an "n/a". ``None``: no brackets.
    ax
        Axes to draw on; default a new figure's.
    conditions
        Conditions in drawing order; default :func:`~nudgecli.report.figures.common.resolve_conditions`.
    seed
        Seed of the horizontal jitter (the same seed gives the same dot positions).
    show_points
        Draw every trial as a dot.
    show_n
        Add ``n = ...`` under each condition name.
    label, definitions
        y-axis label; default :func:`metric_spec`'s of the plan's metric definitions (the paper's).
    star_rule
        The plan's star rule for entries without their own stars (see
        :func:`nudgecli.report.brackets.brackets_from_stats`).
    comparisons
        ``"auto"`` (brackets up to three conditions, letters from four), ``"brackets"`` or
        ``"letters"`` (:func:`~nudgecli.report.figures.comparison_marks.chosen_marks`).
    reference
        Draw only the brackets of this condition's pairs.

    Returns
    -------
    BoxplotArtists
        Axes, positions, boxes, dots, brackets, letters and "n/a" marks drawn.

    Raises
    ------
    ConfigError
        ``reference`` is not one of the conditions drawn.
    """
    require_columns(metrics, ["condition", metric], "metrics table")
    spec = metric_spec(metric, definitions)
    order = resolve_conditions(metrics, None, conditions)
    if len(order) == 0:
        raise DataError("metrics table: no conditions to plot")
    ax = axes_or_new(ax, (METRIC_FIGSIZE[0] / 3, METRIC_FIGSIZE[1]))
    values = pd.to_numeric(metrics[metric], errors="coerce").astype(float) * spec.scale
    condition_col = metrics["condition"].astype(str)
    colours = condition_colours(order)
    positions = {c: float(i) for i, c in enumerate(order)}
    out = BoxplotArtists(ax=ax, conditions=list(order), positions=positions)
    left_out = [c for c in not_applicable_of(stats_entry) if c in positions]

    with figure_style():
        data = _values_by_condition(values, condition_col, out, left_out)
        _draw_boxes(ax, data, out, colours)
        if show_points:
            _draw_points(ax, data, out, seed)
        _label_conditions(ax, out, show_n, left_out)
        ax.set_ylabel(wrap_label(label if label is not None else spec.label))
        _value_ticks(out, spec)
        ax.tick_params(axis="x", length=0)
        ax.margins(y=0.05)
        ax.autoscale_view()
        _mark(out, stats_entry, star_rule, comparisons, reference, left_out)
    return out


def _value_ticks(out: BoxplotArtists, spec: MetricSpec) -> None:
    """The y ticks: at whole numbers for a count; none in a panel without values (every condition
    n/a or empty: a range around 0 would read as data)."""
    if not any(out.n.values()):
        out.ax.set_yticks([])
    elif spec.integer:
        out.ax.yaxis.set_major_locator(MaxNLocator(integer=True))


def _mark(out: BoxplotArtists, stats_entry: Mapping[str, Any] | None, star_rule: ComparisonOptions,
          comparisons: Comparisons, reference: str | None, left_out: Sequence[str]) -> None:
    """The comparisons' brackets or letters above the boxes (of the conditions with values) and
    the "n/a" of the conditions ``left_out``; recorded in ``out``."""
    brackets, letters = chosen_marks(stats_entry, out.conditions, star_rule, comparisons, reference)
    out.brackets = draw_brackets(out.ax, out.positions, brackets)
    if letters:
        compared = [c for c in out.conditions if c not in left_out and out.n[c]]
        out.letters = mark_letters(out.ax, out.positions, stats_entry, compared, star_rule)
    out.not_applicable = mark_not_applicable(out.ax, out.positions, left_out)


def _values_by_condition(values: pd.Series, condition_col: pd.Series, out: BoxplotArtists,
                         left_out: Sequence[str]) -> list[np.ndarray]:
    """Each condition's finite values, in ``out.conditions``' order (none for those ``left_out``:
    the metric is not applicable to them); their counts recorded in ``out.n``."""
    data = []
    for c in out.conditions:
        v = values[condition_col == c].to_numpy()
        v = v[np.isfinite(v)] if c not in left_out else v[:0]
        data.append(v)
        out.n[c] = int(v.size)
    return data


def _draw_boxes(ax: Axes, data: list[np.ndarray], out: BoxplotArtists, colours: Mapping[str, str]) -> None:
    """The box of each condition with values (``data``: its values, in ``out.conditions``' order),
    filled in its colour; recorded in ``out.boxes``."""
    order, positions = out.conditions, out.positions
    drawable = [i for i, v in enumerate(data) if v.size]
    if not drawable:
        return
    bp = ax.boxplot([data[i] for i in drawable], positions=[positions[order[i]] for i in drawable],
                    widths=BOX_WIDTH, patch_artist=True, showfliers=False, whis=1.5,
                    medianprops={"color": "black", "linewidth": 1.8, "zorder": 4},
                    whiskerprops={"color": "black", "linewidth": 0.9},
                    capprops={"color": "black", "linewidth": 0.9},
                    boxprops={"edgecolor": "black", "linewidth": 0.9}, manage_ticks=False, zorder=2)
    for patch, i in zip(bp["boxes"], drawable, strict=True):
        patch.set_facecolor(to_rgba(colours[order[i]], 0.45))
        out.boxes[order[i]] = patch


def _draw_points(ax: Axes, data: list[np.ndarray], out: BoxplotArtists, seed: int) -> None:
    """Every trial as a dot, jittered sideways (seeded per condition); recorded in ``out.points``.
    A panel of more than :data:`RASTER_DOTS_ABOVE` dots has them drawn as one image in vector
    formats (the raster formats draw them the same either way)."""
    rasterized = sum(v.size for v in data) > RASTER_DOTS_ABOVE
    for c, v in zip(out.conditions, data, strict=True):
        if not v.size:
            continue
        x = out.positions[c] + jitter(seed, c, v.size)
        out.points[c] = ax.scatter(x, v, s=6, color="black", alpha=0.5, linewidths=0, zorder=3, label=None,
                                   rasterized=rasterized)


def _label_conditions(ax: Axes, out: BoxplotArtists, show_n: bool, left_out: Sequence[str] = ()) -> None:
    """The x axis: a tick per condition with its display name and (``show_n``) its number of trials
    ("n/a" for the conditions ``left_out``)."""
    order, positions = out.conditions, out.positions
    ax.set_xticks([positions[c] for c in order])
    shown = condition_display_names(order)
    names = [shown[c] for c in order]
    counts = {c: "n/a" if c in left_out else f"n = {out.n[c]}" for c in order}
    if len(order) <= 2:
        if show_n:
            names = [f"{name}\n({counts[c]})" for name, c in zip(names, order, strict=True)]
        ax.set_xticklabels(names)
    else:
        # Too narrow for horizontal names: rotate them, and keep the counts horizontal in a
        # row of their own just under the axis.
        ax.set_xticklabels(names, rotation=30, ha="right", rotation_mode="anchor")
        if show_n and len(order) <= 4:
            ax.tick_params(axis="x", pad=12)
            for c in order:
                ax.annotate(counts[c].replace(" ", ""), (positions[c], 0.0),
                            xycoords=("data", "axes fraction"),
                            xytext=(0, -2), textcoords="offset points", ha="center", va="top",
                            fontsize=TICK_FONT_PT)
    ax.set_xlim(-0.6, len(order) - 0.4)


def metrics_figure(metrics: pd.DataFrame, stats: Mapping[str, Any] | None, metric_names: Sequence[str], *,
                   conditions: Sequence[str] | None = None, seed: int = 0,
                   star_rule: ComparisonOptions = DEFAULT_STAR_RULE, comparisons: Comparisons = "auto",
                   reference: str | None = None, definitions: MetricDefinitions | None = None) -> Figure:
    """One box-plot panel per metric, lettered (a), (b), ..., up to three panels per row.

    Parameters
    ----------
    metrics
        One row per trial (``condition`` and the metric columns).
    stats
        ``stats.json`` dict; its significant Conover comparisons become brackets.
    metric_names
        The metric columns, in panel order (at least one).
    conditions
        Drawing order of the conditions; default
        :func:`~nudgecli.report.figures.common.resolve_conditions`.
    seed
        Jitter seed.
    star_rule
        The plan's star rule (for statistics entries without stars).
    comparisons, reference
        Which comparisons each panel marks (:func:`metric_boxplot`): by default brackets up to
        three conditions and letters from four; with ``reference`` its pairs' brackets.
    definitions
        The plan's metric definitions (the panels' labels; :func:`metric_spec`), where the analysis
        of ``stats`` applied them (:func:`applied_definitions`: not to a metrics table).

    Returns
    -------
    Figure
        ``ceil(M / 3)`` rows of panels, 2.4 in wide per column (7.2 in for three), 2.6 in per row
        (plus :data:`BRACKET_LEVEL_HEIGHT_IN` per bracket level above
        :data:`BRACKET_LEVELS_PER_ROW` that the most crowded panel needs).

    Raises
    ------
    ConfigError
        ``reference`` is not one of the conditions drawn.
    """
    if not metric_names:
        raise DataError("metrics table: no metric to plot")
    order = resolve_conditions(metrics, stats, conditions)
    entries = stats_by_metric(stats)
    definitions = applied_definitions(stats, definitions)
    n_cols = min(len(metric_names), METRIC_PANELS_PER_ROW)
    n_rows = math.ceil(len(metric_names) / METRIC_PANELS_PER_ROW)
    positions = {c: float(i) for i, c in enumerate(order)}
    levels = max(bracket_levels(positions, chosen_marks(entries.get(m), order, star_rule, comparisons,
                                                        reference)[0]) for m in metric_names)
    row_height = METRIC_ROW_HEIGHT_IN + max(0, levels - BRACKET_LEVELS_PER_ROW) * BRACKET_LEVEL_HEIGHT_IN
    with figure_style():
        layout = ConstrainedLayoutEngine(w_pad=0.04, h_pad=0.03, wspace=0.06)
        width = FULL_WIDTH_IN * (n_cols if n_rows == 1 else METRIC_PANELS_PER_ROW) / METRIC_PANELS_PER_ROW
        fig = Figure(figsize=(width, row_height * n_rows), layout=layout)
        axes = np.atleast_1d(fig.subplots(n_rows, METRIC_PANELS_PER_ROW if n_rows > 1 else n_cols)).ravel()
        for i, metric in enumerate(metric_names):
            metric_boxplot(metrics, metric, entries.get(metric), ax=axes[i], conditions=order, seed=seed,
                           star_rule=star_rule, comparisons=comparisons, reference=reference,
                           definitions=definitions)
            panel_letter(axes[i], i)
        for ax in axes[len(metric_names):]:
            ax.set_visible(False)
    return fig


def figure_3(metrics: pd.DataFrame, stats: Mapping[str, Any] | None = None, *,
             conditions: Sequence[str] | None = None, seed: int = 0,
             star_rule: ComparisonOptions = DEFAULT_STAR_RULE) -> Figure:
    """Fig. 3: (a) assistance engagement, (b) strength of assistance, (c) human turns.

    Parameters are those of :func:`metrics_figure` (without ``metric_names``).

    Returns
    -------
    Figure
        1 x 3 panels, 7.2 x 2.6 in.
    """
    return metrics_figure(metrics, stats, FIGURE3_METRICS, conditions=conditions, seed=seed,
                          star_rule=star_rule)


def figure_4(metrics: pd.DataFrame, stats: Mapping[str, Any] | None = None, *,
             conditions: Sequence[str] | None = None, seed: int = 0,
             star_rule: ComparisonOptions = DEFAULT_STAR_RULE) -> Figure:
    """Fig. 4: (a) mode switches, (b) human effort, (c) completion time.

    Parameters are those of :func:`metrics_figure` (without ``metric_names``).

    Returns
    -------
    Figure
        1 x 3 panels, 7.2 x 2.6 in.
    """
    return metrics_figure(metrics, stats, FIGURE4_METRICS, conditions=conditions, seed=seed,
                          star_rule=star_rule)


__all__ = ["DEFINITION_LABELS", "FIGURE3_METRICS", "FIGURE4_METRICS", "METRIC_SPECS", "BoxplotArtists",
           "MetricSpec", "applied_definitions", "figure_3", "figure_4", "metric_boxplot", "metric_spec",
           "metrics_figure"]
