"""The figures of ``nudge replicate``, ``nudge power`` and ``nudge sweep``: drawing only.

Each takes the tidy tables of :mod:`nudgecli.report.replication` (which computes them) and returns
a :class:`~matplotlib.figure.Figure` with one panel per metric; each panel is its own function
taking ``ax=None`` (a new figure's axes when ``None``) so the panels compose. Writing them is
:func:`nudgecli.report.figures.output.save_figure`'s job.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from typing import Any, ParamSpec, TypeVar

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from nudgecli.report.figures.common import axes_or_new
from nudgecli.report.replication import POWER_TARGET, _percentiles
from nudgecli.report.style import TICK_FONT_PT, figure_style

#: Colours of a replication's interval by participant-level significance.
FOREST_COLOURS = {True: "#c0392b", False: "#7f8c8d"}
#: Size in inches of one panel: a panel drawn alone, and a cell of the grids of panels.
PANEL_FIGSIZE = (3.4, 2.6)
#: Values of a numeric axis (participant counts, a swept parameter's values) up to which each is
#: a tick of its own; more get the usual ticks.
MAX_VALUE_TICKS = 8
#: Height in inches of a row of one pair of conditions (forest, power grid): its 8 pt label's line.
PAIR_ROW_IN = 0.22


_P = ParamSpec("_P")
_R = TypeVar("_R")


def _styled(draw: Callable[_P, _R]) -> Callable[_P, _R]:
    """``draw`` inside :func:`~nudgecli.report.style.figure_style`: its figures, texts and ticks get
    the toolkit's print sizes (at least ``MIN_FONT_PT``), whoever calls it."""
    @functools.wraps(draw)
    def styled(*args: _P.args, **kwargs: _P.kwargs) -> _R:
        with figure_style():
            return draw(*args, **kwargs)
    return styled


def _grid(n: int, width: float = PANEL_FIGSIZE[0],
          height: float = PANEL_FIGSIZE[1]) -> tuple[Figure, list[Any]]:
    cols = min(3, max(1, n))
    rows_ = max(1, math.ceil(n / cols))
    fig = Figure(figsize=(width * cols, height * rows_), layout="constrained")
    axes = fig.subplots(rows_, cols, squeeze=False).ravel().tolist()
    for ax in axes[n:]:
        ax.set_visible(False)
    return fig, axes[:n]


#: Colour of the words written where a panel or row has no value ("not tested", "undefined").
NO_VALUE_COLOUR = "#7f8c8d"


def _say_no_value(ax: Axes, words: str, x: float = 0.5, y: float = 0.5, transform: Any = None, *,
                  ha: str = "center", va: str = "center") -> None:
    """``words`` written in the panel (axes fraction ``x``, ``y``; or at ``transform``'s ``x, y``;
    aligned there as ``ha``, ``va`` say) where there is no value to draw: blank axes read as a
    value of 0 or as a row left out."""
    ax.text(x, y, words, transform=ax.transAxes if transform is None else transform, ha=ha,
            va=va, fontstyle="italic", color=NO_VALUE_COLOUR)


def _no_value_axis(ax: Axes, axis: str = "y") -> None:
    """Hide the value axis' ticks of a panel with no value: a range around 0 would read as data."""
    (ax.set_yticks if axis == "y" else ax.set_xticks)([])


def _figure_legend(fig: Figure, axes: Sequence[Axes]) -> None:
    """The first panel's legend under the panels, in one row (inside a panel it covered data)."""
    if not axes:
        return
    handles, labels = axes[0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside lower center", ncols=len(handles))


def _pair_groups(table: pd.DataFrame) -> list[tuple[Any, Any, Any]]:
    """The ``(metric, a, b)`` of the table's rows in order of first appearance: one panel each (a
    table without ``a``, ``b`` columns has one pair: ``(metric, None, None)``)."""
    if "a" not in table.columns or "b" not in table.columns:
        return [(metric, None, None) for metric in dict.fromkeys(table["metric"])]
    return list(dict.fromkeys(zip(table["metric"], table["a"], table["b"], strict=True)))


def _one_pair_per_metric(table: pd.DataFrame) -> bool:
    """Whether the table compares one pair of conditions (two conditions: the panels keep their titles)."""
    return len(_pair_groups(table)) == table["metric"].nunique()


def _of(table: pd.DataFrame, metric: Any, a: Any, b: Any) -> pd.DataFrame:
    """The rows of one panel of :func:`_pair_groups`."""
    mask = table["metric"] == metric
    if a is not None:
        mask &= (table["a"] == a) & (table["b"] == b)
    return table[mask]


def _replication_intervals(ax: Axes, rows: pd.DataFrame, y: np.ndarray, *, ms: float, lw: float,
                           labelled: bool) -> None:
    """Each replication's difference of medians at height ``y`` with its bootstrap interval,
    non-significant then significant at the participant level (the forest panels' one drawing)."""
    for significant in (False, True):
        mask = rows["participant_significant"].astype(bool).to_numpy() == significant
        sub = rows[mask]
        diff = sub["difference"].astype(float).to_numpy()
        err = np.vstack([diff - sub["ci_low"].astype(float).to_numpy(),
                         sub["ci_high"].astype(float).to_numpy() - diff])
        name = "significant (participant level)" if significant else "not significant"
        label = name if labelled else None
        ax.errorbar(diff, y[mask], xerr=np.abs(err), fmt="o", ms=ms, lw=lw, color=FOREST_COLOURS[significant],
                    label=label)


@_styled
def forest_panel(group: pd.DataFrame, pooled: pd.Series, *, ax: Axes | None = None) -> Axes:
    """One metric's forest plot: every replication's difference of medians with its bootstrap
    interval, coloured by participant-level significance, and the pooled mean with its range; where
    the pooled mean is undefined though some replications have a difference (a replication that
    did not test the pair), the panel says so (``pooled: undefined (1 of 4 tested)``).

    Parameters
    ----------
    group
        The metric's rows of :func:`~nudgecli.report.replication.replication_rows`.
    pooled
        The metric's row of :func:`~nudgecli.report.replication.summarise`.
    ax
        Axes to draw on; default a new figure's.
    """
    ax = axes_or_new(ax, PANEL_FIGSIZE)
    group = group.sort_values("replication")
    y = np.arange(len(group))
    _replication_intervals(ax, group, y, ms=3, lw=0.8, labelled=True)
    ax.axvspan(pooled["difference_low"], pooled["difference_high"], color="#3498db", alpha=0.15)
    ax.axvline(pooled["difference"], color="#2c3e50", lw=1.2)
    ax.axvline(0, color="black", lw=0.6, ls=":")
    ax.set_title(str(pooled["metric"]))
    ax.set_xlabel(f"{pooled['a']} - {pooled['b']} (difference of medians)")
    ax.set_yticks(y, [str(r) for r in group["replication"]])
    ax.set_ylabel("replication")
    if not np.isfinite(group["difference"].astype(float)).any():
        _say_no_value(ax, _missing_words(pooled))
        _no_value_axis(ax, "x")
    elif not np.isfinite(float(pooled["difference"])):  # no line: say why, as sweep.png's "undefined at"
        _say_no_value(ax, _pooled_undefined_words(group, pooled), 0.02, 0.97, ha="left", va="top")
    return ax


def _missing_words(pooled: pd.Series) -> str:
    """What a pair without any difference is: "not tested" (no replication tested it: ``tested``
    of :func:`~nudgecli.report.replication.summarise` is 0), else "undefined"."""
    return "not tested" if "tested" in pooled and pooled["tested"] == 0 else "undefined"


def _pooled_undefined_words(group: pd.DataFrame, pooled: pd.Series) -> str:
    """Why a pair some replications have a difference for has no pooled mean (NaN:
    :func:`~nudgecli.report.replication.summarise` pools over all replications or none):
    "pooled: undefined (1 of 4 tested)", or "(3 of 4 defined)" where each tested the pair."""
    replications = len(group)
    tested = int(pooled["tested"]) if "tested" in pooled else replications
    if tested < replications:
        return f"pooled: undefined ({tested} of {replications} tested)"
    defined = int(np.isfinite(group["difference"].astype(float)).sum())
    return f"pooled: undefined ({defined} of {replications} defined)"


@_styled
def pairs_forest_panel(group: pd.DataFrame, pooled: pd.DataFrame, *, ax: Axes | None = None) -> Axes:
    """One metric's forest plot of every pair of conditions (a study of three or more): one row per
    pair ``a - b``, in it every replication's difference of medians with its bootstrap interval
    (coloured by the pair's participant-level significance, replications spread over the row) and
    the pooled mean (a dark tick) with its 2.5-97.5 % range (a band), or in the row's label why it
    is undefined (``a - b, pooled: undefined (1 of 4 tested)``).

    Parameters
    ----------
    group
        The metric's rows of :func:`~nudgecli.report.replication.replication_rows`.
    pooled
        The metric's rows of :func:`~nudgecli.report.replication.summarise` (one per pair).
    ax
        Axes to draw on; default a new figure's.
    """
    ax = axes_or_new(ax, PANEL_FIGSIZE)
    pairs = list(dict.fromkeys(zip(group["a"], group["b"], strict=True)))
    replications = sorted(group["replication"].unique())
    spread = {r: (i - (len(replications) - 1) / 2) * 0.7 / max(1, len(replications))
              for i, r in enumerate(replications)}
    labels = [f"{a} - {b}" for a, b in pairs]
    for row, (a, b) in enumerate(pairs):
        own = group[(group["a"] == a) & (group["b"] == b)]
        y = row + own["replication"].map(spread).to_numpy(dtype=float)
        _replication_intervals(ax, own, y, ms=2, lw=0.6, labelled=row == 0)
        summary = pooled[(pooled["a"] == a) & (pooled["b"] == b)]
        if not np.isfinite(own["difference"].astype(float)).any():  # an empty row reads as a row left out
            words = _missing_words(summary.iloc[0]) if not summary.empty else "undefined"
            _say_no_value(ax, words, 0.5, row, ax.get_yaxis_transform())
        elif not summary.empty and not np.isfinite(float(summary.iloc[0]["difference"])):
            # no tick: why, in the row's label (written in the row it would cover the replications)
            labels[row] += f"\n{_pooled_undefined_words(own, summary.iloc[0])}"
        if not summary.empty:
            first = summary.iloc[0]
            ax.fill_betweenx([row - 0.42, row + 0.42], first["difference_low"], first["difference_high"],
                             color="#3498db", alpha=0.15, linewidth=0)
            ax.plot([first["difference"]] * 2, [row - 0.42, row + 0.42], color="#2c3e50", lw=1.2)
    ax.axvline(0, color="black", lw=0.6, ls=":")
    ax.set_yticks(np.arange(len(pairs)), labels)
    ax.set_ylim(len(pairs) - 0.5, -0.5)  # the first pair on top
    ax.set_title(str(group["metric"].iloc[0]))
    ax.set_xlabel("a - b (difference of medians)")
    return ax


@_styled
def forest_figure(rows: pd.DataFrame, summary: pd.DataFrame) -> Figure:
    """The forest plots of a replication (``rows``: :func:`~nudgecli.report.replication.replication_rows`,
    ``summary``: :func:`~nudgecli.report.replication.summarise`): :func:`forest_panel` per metric
    for two conditions, :func:`pairs_forest_panel` per metric (a row per pair) for more."""
    if not _one_pair_per_metric(rows):
        metrics = list(dict.fromkeys(rows["metric"]))
        n_pairs = len(_pair_groups(rows)) / len(metrics)
        # a row per pair, high enough for its label (8 pt) and its replications spread over it
        height = max(2.4, n_pairs * max(PAIR_ROW_IN, 0.1 + 0.03 * rows["replication"].nunique()) + 1.0)
        fig, axes = _grid(len(metrics), width=4.0, height=height)
        for ax, metric in zip(axes, metrics, strict=True):
            pairs_forest_panel(rows[rows["metric"] == metric], summary[summary["metric"] == metric], ax=ax)
        _figure_legend(fig, axes)
        return fig
    panels = _pair_groups(rows)
    fig, axes = _grid(len(panels), height=max(2.4, 0.18 * rows["replication"].nunique() + 1.2))
    for ax, (metric, a, b) in zip(axes, panels, strict=True):
        forest_panel(_of(rows, metric, a, b), _of(summary, metric, a, b).iloc[0], ax=ax)
    _figure_legend(fig, axes)
    return fig


def _named_direction(direction: str, a: Any, b: Any) -> str:
    """A power test's direction with its conditions named (``a < b``: ``disambiguation < control``;
    ``either``: ``disambiguation - control, either direction``); as given without them."""
    if a is None or b is None:
        return f"({direction})"
    if direction in ("a > b", "a < b"):
        return f"{a} {direction[2]} {b}"
    return f"{a} - {b}, {direction} direction"


@_styled
def power_panel(power: pd.DataFrame, target: float = POWER_TARGET, *, ax: Axes | None = None) -> Axes:
    """One metric's power against participants: participant level solid, trial level dashed,
    with the Clopper-Pearson band, and the target line; the title names the pair and the
    direction tested (``completion_time``, ``disambiguation < control``).

    Parameters
    ----------
    power
        The metric's rows of :func:`~nudgecli.report.replication.power_table`.
    target
        The target power (a dotted line).
    ax
        Axes to draw on; default a new figure's.
    """
    ax = axes_or_new(ax, PANEL_FIGSIZE)
    counts = sorted(int(n) for n in power["participants"].unique())
    for k, (level, style) in enumerate((("participant", "-"), ("trial", "--"))):
        group = power[power["level"] == level].sort_values("participants")
        if len(counts) == 1:  # one count: a band of zero width would not show; the levels side by side
            x = group["participants"].to_numpy(dtype=float) + (k - 0.5) * 0.2
            power_ = group["power"].to_numpy(dtype=float)
            err = np.abs(np.vstack([power_ - group["low"].to_numpy(dtype=float),
                                    group["high"].to_numpy(dtype=float) - power_]))
            ax.errorbar(x, power_, yerr=err, fmt="o", ms=3, capsize=3, ls="none", label=f"{level} level")
            continue
        ax.plot(group["participants"], group["power"], style, marker="o", ms=3, label=f"{level} level")
        ax.fill_between(group["participants"], group["low"], group["high"], alpha=0.15)
    ax.axhline(target, color="black", lw=0.6, ls=":")
    first = power.iloc[0]
    named = _named_direction(str(first["direction"]), first.get("a"), first.get("b"))
    ax.set_title(f"{first['metric']}\n{named}")
    ax.set_ylim(-0.02, 1.02)
    if not np.isfinite(power["power"].astype(float)).any():
        _say_no_value(ax, "not tested")  # power_table's NaN: no replication tested the pair
    ax.set_xlabel("participants")
    ax.set_ylabel("power")
    if len(counts) <= MAX_VALUE_TICKS:  # the counts tried, not fractions between them
        ax.set_xticks(counts, [str(n) for n in counts])
    else:
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    if len(counts) == 1:
        ax.set_xlim(counts[0] - 1, counts[0] + 1)
    return ax


@_styled
def power_grid_panel(power: pd.DataFrame, level: str, target: float = POWER_TARGET, *,
                     ax: Axes | None = None) -> Axes:
    """The power of every metric and pair at one level of test as a grid (a study of three or more
    conditions): one row per (metric, pair), one column per participant count, each cell shaded
    by its power and labelled with it (bold where it reaches ``target``).

    Parameters
    ----------
    power
        :func:`~nudgecli.report.replication.power_table`'s table.
    level
        ``participant`` or ``trial``.
    target
        The target power.
    ax
        Axes to draw on; default a new figure's.
    """
    ax = axes_or_new(ax, PANEL_FIGSIZE)
    rows = power[power["level"] == level]
    panels = _pair_groups(rows)
    counts = sorted(rows["participants"].unique())
    grid = np.full((len(panels), len(counts)), np.nan)
    for i, (metric, a, b) in enumerate(panels):
        own = _of(rows, metric, a, b).set_index("participants")["power"]
        grid[i] = [own.get(n, np.nan) for n in counts]
    ax.imshow(grid, cmap="Blues", vmin=0.0, vmax=1.0, aspect="auto", interpolation="nearest")
    for (i, j), value in np.ndenumerate(grid):
        if np.isfinite(value):
            ax.text(j, i, f"{value:.2f}", ha="center", va="center", fontsize=TICK_FONT_PT,
                    color="white" if value > 0.6 else "black",
                    fontweight="bold" if value >= target else "normal")
        elif np.isfinite(grid[i]).any():  # power_table's NaN: no replication at this count tested the pair
            _say_no_value(ax, "n/a", j, i, ax.transData)
    for row in np.flatnonzero(~np.isfinite(grid).any(axis=1)):  # a blank row reads as a row left out
        _say_no_value(ax, "not tested", (len(counts) - 1) / 2, float(row), ax.transData)
    ax.set_xticks(np.arange(len(counts)), [str(int(n)) for n in counts])
    directions = {(m, a, b): d for m, a, b, d in zip(rows["metric"], rows["a"], rows["b"], rows["direction"],
                                                     strict=True)}
    ax.set_yticks(np.arange(len(panels)), [f"{m}: {a} - {b} ({directions[m, a, b]})" for m, a, b in panels])
    ax.set_xlabel("participants")
    ax.set_title(f"{level} level (bold: power >= {target:g})")
    return ax


@_styled
def power_figure(power: pd.DataFrame, target: float = POWER_TARGET) -> Figure:
    """The power curves of :func:`~nudgecli.report.replication.power_table`'s table: :func:`power_panel`
    per metric for two conditions; for more, :func:`power_grid_panel` at each level of test (one
    row per metric and pair)."""
    if not _one_pair_per_metric(power):
        n_rows = len(_pair_groups(power))
        fig = Figure(figsize=(8.0, max(2.6, PAIR_ROW_IN * n_rows + 1.0)), layout="constrained")
        for ax, level in zip(fig.subplots(1, 2, sharey=True), ("participant", "trial"), strict=True):
            power_grid_panel(power, level, target, ax=ax)
        return fig
    panels = _pair_groups(power)
    fig, axes = _grid(len(panels))
    for ax, (metric, a, b) in zip(axes, panels, strict=True):
        power_panel(_of(power, metric, a, b), target, ax=ax)
    _figure_legend(fig, axes)
    return fig


def sweep_values(group: pd.DataFrame, name: str) -> pd.DataFrame:
    """Per value of the swept parameter ``name``: the mean and the 2.5 and 97.5 percentiles of the
    differences of medians there, over the replications and (a grid of several parameters) over
    the other parameters' points at that value, pooled.

    Returns
    -------
    pd.DataFrame
        ``value, mean, low, high`` sorted by value; NaN where some replication's difference at that
        value is undefined, as in ``points.csv`` (:mod:`nudgecli.report.replication` owns the rule:
        a mean of the defined ones alone would stand on the replications that happened to be).
    """
    keys = group[name].map(lambda v: v if isinstance(v, int | float) else str(v))
    rows = [(value, *_percentiles(values)) for value, values in group["difference"].groupby(keys, sort=True)]
    return pd.DataFrame(rows, columns=["value", "mean", "low", "high"])


def _mark_undefined(ax: Axes, x: np.ndarray, labels: list[str]) -> None:
    """Open circles on the x axis at the values ``x`` whose difference is undefined, and a line
    naming them (``labels``) in the panel: a gap in the curve alone reads as a value left out."""
    if not len(x):
        return
    ax.plot(x, np.full(len(x), 0.04), ls="none", marker="o", mfc="none", mec="#7f8c8d", ms=5,
            transform=ax.get_xaxis_transform(), clip_on=False)
    named = ", ".join(labels) if len(labels) <= 4 else f"{len(labels)} values (open circles)"
    ax.text(0.02, 0.97, f"undefined at {named}", transform=ax.transAxes, ha="left", va="top")


@_styled
def sweep_panel(group: pd.DataFrame, name: str, *, ax: Axes | None = None) -> Axes:
    """One metric's difference of medians against one swept parameter (:func:`sweep_values`): the
    means per value joined by a line, with the 2.5-97.5 % band (values that are not numbers the
    same way, each at a tick of its own in sorted order); a parameter of one value, where a band
    would have no width, a point with that range as an error bar; the values where the difference
    is undefined as open circles on the x axis, named.

    Parameters
    ----------
    group
        The metric's rows of :func:`~nudgecli.report.replication.replication_rows` with the
        parameter columns.
    name
        The parameter.
    ax
        Axes to draw on; default a new figure's.
    """
    ax = axes_or_new(ax, PANEL_FIGSIZE)
    stats = sweep_values(group, name)
    numeric = pd.api.types.is_numeric_dtype(stats["value"])
    x = stats["value"].to_numpy() if numeric else np.arange(len(stats))
    mean, low, high = (stats[column].to_numpy(dtype=float) for column in ("mean", "low", "high"))
    if len(x) == 1:  # one value: a band of zero width would not show, the range as an error bar
        ax.errorbar(x, mean, yerr=np.abs(np.vstack([mean - low, high - mean])), fmt="o", ms=3, capsize=3)
    else:
        ax.plot(x, mean, marker="o", ms=3)
        ax.fill_between(x, low, high, alpha=0.2)
    ax.axhline(0, color="black", lw=0.5, ls=":")
    undefined = stats["mean"].isna().to_numpy()
    _mark_undefined(ax, x[undefined], [f"{v:g}" if numeric else str(v) for v in stats["value"][undefined]])
    if undefined.all():
        _no_value_axis(ax)
    if not numeric:
        ax.set_xticks(x, [str(v) for v in stats["value"]])
    elif len(x) <= MAX_VALUE_TICKS:  # the values swept (a grid's), not round numbers between them
        ax.set_xticks(x, [f"{v:g}" for v in x])
    ax.set_xlabel(name)
    return ax


@_styled
def sweep_figure(rows: pd.DataFrame, parameters: Sequence[str]) -> Figure:
    """:func:`sweep_panel` per metric and pair of conditions (rows, the pair named: ``a - b``) and
    swept parameter (columns)."""
    panels = _pair_groups(rows)
    fig = Figure(figsize=(3.0 * len(parameters), 2.3 * len(panels)), layout="constrained")
    axes = fig.subplots(len(panels), len(parameters), squeeze=False)
    for i, (metric, a, b) in enumerate(panels):
        group = _of(rows, metric, a, b)
        for j, name in enumerate(parameters):
            sweep_panel(group, name, ax=axes[i][j])
            if j == 0:
                pair = f"{a} - {b}" if a is not None else "a - b"
                axes[i][j].set_ylabel(f"{metric}\n({pair})")
    return fig


@_styled
def sensitivity_panel(indices: pd.DataFrame, *, ax: Axes | None = None, title: str | None = None) -> Axes:
    """Bars of one metric's sensitivity indices (S1, ST, mu*, sigma) with their 95 % intervals.

    Parameters
    ----------
    indices
        The rows of one metric and pair of conditions of
        :func:`~nudgecli.report.replication.sensitivity`.
    ax
        Axes to draw on; default a new figure's.
    title
        The panel's title; default the metric.
    """
    ax = axes_or_new(ax, PANEL_FIGSIZE)
    group = indices[indices["index"].isin(["S1", "ST", "mu_star", "sigma"])]
    names = list(dict.fromkeys(group["parameter"]))
    kinds = list(dict.fromkeys(group["index"]))
    width = 0.8 / max(1, len(kinds))
    for k, kind in enumerate(kinds):
        sub = group[group["index"] == kind].set_index("parameter").reindex(names)
        conf = sub["conf"].fillna(0).to_numpy()
        ax.bar(np.arange(len(names)) + k * width, sub["value"], width, yerr=conf, label=kind, capsize=2)
    ax.set_xticks(np.arange(len(names)) + width * (len(kinds) - 1) / 2, names, rotation=30, ha="right")
    ax.set_title(title or str(indices["metric"].iloc[0]))
    if not np.isfinite(group["value"].astype(float)).any():  # empty bars around 0 read as indices of 0
        used = indices["replications"].min() if "replications" in indices else math.nan
        _say_no_value(ax, "undefined (no replication defined\nat every point)" if used == 0
                      else "undefined (constant output)")
        _no_value_axis(ax)
    return ax


@_styled
def sensitivity_figure(indices: pd.DataFrame) -> Figure:
    """:func:`sensitivity_panel` per metric and pair of conditions of
    :func:`~nudgecli.report.replication.sensitivity`'s table (the pair in the title with more than
    two conditions)."""
    panels = _pair_groups(indices)
    show_pair = not _one_pair_per_metric(indices)
    fig, axes = _grid(len(panels))
    for ax, (metric, a, b) in zip(axes, panels, strict=True):
        sensitivity_panel(_of(indices, metric, a, b), ax=ax,
                          title=f"{metric} ({a} - {b})" if show_pair else None)
    _figure_legend(fig, axes)
    return fig


__all__ = ["FOREST_COLOURS", "forest_figure", "forest_panel", "pairs_forest_panel", "power_figure",
           "power_grid_panel", "power_panel",
           "sensitivity_figure", "sensitivity_panel", "sweep_figure", "sweep_panel", "sweep_values"]
