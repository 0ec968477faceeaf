"""Questionnaires (the paper's Fig. 6): NASA-TLX and Likert items, mean with SD per condition.

The wording of the study's Likert items is not the figures' business: it is part of the
analysis plan (``[questionnaires] labels``, :class:`nudgecli.report.plans.QuestionnaireSettings`)
and reaches these functions as ``item_labels``.
"""

from __future__ import annotations

import itertools
import textwrap
from collections.abc import Mapping, Sequence
from typing import Any, Literal

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from matplotlib.transforms import Bbox

from nudgecli.errors import DataError
from nudgecli.report.brackets import DEFAULT_STAR_RULE, draw_brackets
from nudgecli.report.figures.common import axes_or_new, panel_letter, resolve_conditions, stats_by_metric
from nudgecli.report.figures.comparison_marks import chosen_marks, draw_letters
from nudgecli.report.letters import entry_letters
from nudgecli.report.stats import ComparisonOptions
from nudgecli.report.style import (
    FULL_WIDTH_IN,
    condition_colours,
    condition_display_names,
    condition_hatches,
    figure_style,
)
from nudgecli.report.trial_steps import require_columns

#: NASA-TLX scale names (column or ``scale`` values, without a ``tlx_`` prefix) and how they are
#: shown; ``tlx_raw`` and ``tlx_weighted`` are the scores of
#: :func:`nudgecli.report.questionnaires.questionnaire_scores`.
TLX_SCALE_NAMES: dict[str, str] = {
    "raw_tlx": "Raw TLX",
    "weighted_tlx": "Weighted TLX",
    "raw": "Raw TLX",
    "weighted": "Weighted TLX",
    "mental": "Mental",
    "physical": "Physical",
    "temporal": "Temporal",
    "performance": "Performance",
    "effort": "Effort",
    "frustration": "Frustration",
}
_ID_COLUMNS = {"participant", "condition", "block", "trial", "id", "subject"}
QUESTIONNAIRE_FIGSIZE = (FULL_WIDTH_IN, 3.0)
Kind = Literal["tlx", "likert"]
_COLUMNS: dict[str, tuple[str, str, str]] = {"tlx": ("scale", "score", "NASA-TLX table"),
                                             "likert": ("item", "response", "Likert table")}


def long_scores(df: pd.DataFrame, kind: Kind) -> pd.DataFrame:
    """``condition, <name>, <value>`` rows from a long or a wide questionnaire table.

    ``<name>, <value>`` are ``scale, score`` for the TLX and ``item, response`` for Likert.
    """
    name_col, value_col, what = _COLUMNS[kind]
    require_columns(df, ["condition"], what)
    if name_col in df.columns and value_col in df.columns:
        out = df[["condition", name_col, value_col]].copy()
    else:
        value_cols = [c for c in df.columns if str(c).lower() not in _ID_COLUMNS
                      and pd.api.types.is_numeric_dtype(df[c])]
        if not value_cols:
            raise DataError(f"{what}: no score columns (expected `{name_col}` and `{value_col}` columns, "
                            "or one numeric column per scale/item)")
        out = df.melt(id_vars=["condition"], value_vars=value_cols, var_name=name_col, value_name=value_col)
    out[value_col] = pd.to_numeric(out[value_col], errors="coerce")
    out[name_col] = out[name_col].astype(str)
    out["condition"] = out["condition"].astype(str)
    return out.dropna(subset=[value_col])


def group_label(name: str, item_labels: Mapping[str, str] | None = None) -> str:
    """How a questionnaire scale or item is named on the axis.

    ``item_labels`` wins (exact name, then case-insensitively without a ``tlx_``/``likert_``
    prefix); then the known TLX scales; otherwise the name without its prefix.
    """
    labels = dict(item_labels or {})
    if name in labels:
        return labels[name]
    key = name.lower()
    for prefix in ("tlx_", "likert_"):
        if key.startswith(prefix):
            key = key[len(prefix):]
            break
    folded = {k.lower(): v for k, v in labels.items()}
    if key in folded:
        return folded[key]
    if key in TLX_SCALE_NAMES:
        return TLX_SCALE_NAMES[key]
    bare = name[len(name) - len(key):]
    return bare.replace("_", " ") if not bare.isupper() else bare


def split_questionnaire_scores(scores: pd.DataFrame) -> tuple[pd.DataFrame | None, pd.DataFrame | None]:
    """Split a questionnaire scores table into its TLX and its Likert part.

    Parameters
    ----------
    scores
        The table of :func:`nudgecli.report.questionnaires.questionnaire_scores`:
        ``participant, condition`` (``block``), ``tlx_*`` and ``likert_*`` columns.

    Returns
    -------
    tuple
        ``(tlx, likert)`` wide tables with the id columns, ``None`` for a part without columns.
    """
    require_columns(scores, ["condition"], "questionnaire scores")
    ids = [c for c in scores.columns if str(c).lower() in _ID_COLUMNS]
    tlx = [c for c in scores.columns if str(c).lower().startswith("tlx_")]
    likert = [c for c in scores.columns if str(c).lower().startswith("likert_")]
    return (scores[ids + tlx] if tlx else None, scores[ids + likert] if likert else None)


#: Line widths (characters) tried in turn for the group labels under the bars, widest first.
LABEL_WRAP_WIDTHS = (13, 11, 9)
#: Type sizes (points) tried at the narrowest wrap when a word alone is too wide for its group.
LABEL_FONT_SIZES_PT = (7.0, 6.0, 5.0)
#: The least gap (pixels at the figure's dpi) kept between two texts of the figure.
LABEL_GAP_PX = 2.0


def _wrap_group_label(label: str, width: int = 13) -> str:
    """A group label on short lines, words kept whole; an item code (``Q3:``) gets a line of its own."""
    code, sep, text = label.partition(": ")
    if sep and len(code) <= 4:
        return code + "\n" + _wrap_words(text, width)
    return _wrap_words(label, width)


def _wrap_words(text: str, width: int) -> str:
    return "\n".join(textwrap.wrap(text, width, break_long_words=False, break_on_hyphens=False))


def questionnaire_bars(df: pd.DataFrame, kind: Kind, *, ax: Axes | None = None,
                       conditions: Sequence[str] | None = None, stats: Mapping[str, Any] | None = None,
                       item_labels: Mapping[str, str] | None = None,
                       star_rule: ComparisonOptions = DEFAULT_STAR_RULE) -> list[Any]:
    """One questionnaire panel: bars of mean with SD error bars, a group per scale or item.

    Likert responses on 1..7 are drawn from 1 (strongly disagree); responses on -3..+3 (the
    study software's coding) from 0 (neutral).

    Parameters
    ----------
    df
        A long or wide TLX or Likert table (see :func:`long_scores`).
    kind
        ``"tlx"`` or ``"likert"``.
    ax
        Axes to draw on; default a new figure's.
    conditions
        Drawing order; default the table's.
    stats
        Statistics of the scores (``stats.json`` dict or ``name -> entry``) for brackets (up to
        three conditions) or a compact letter display (four or more).
    item_labels
        Axis labels of scales/items (see :func:`group_label`).
    star_rule
        The plan's star rule for entries without stars.

    Returns
    -------
    list
        The bar containers (one per condition), then any bracket or letter artists.
    """
    name_col, value_col, _ = _COLUMNS[kind]
    scores = long_scores(df, kind)
    order = resolve_conditions(scores, None, conditions)
    ax = axes_or_new(ax, (FULL_WIDTH_IN / 2, QUESTIONNAIRE_FIGSIZE[1]))
    by_name = stats_by_metric(stats)
    groups = list(pd.unique(scores[name_col]))
    labels = {g: _wrap_group_label(group_label(g, item_labels)) for g in groups}
    coded = kind == "likert" and float(scores[value_col].min()) < 1.0
    baseline = 1.0 if kind == "likert" and not coded else 0.0
    n_cond = len(order)
    width = 0.8 / n_cond
    summary = scores.groupby([name_col, "condition"])[value_col].agg(["mean", "std", "count"])
    with figure_style():
        artists, tops = _draw_bars(ax, summary, groups, order, baseline, width)
        _label_axes(ax, kind, [labels[g] for g in groups], coded)
        for i, g in enumerate(groups):
            entry = by_name.get(g)
            if entry:
                positions = {c: i + (j - (n_cond - 1) / 2) * width for j, c in enumerate(order)}
                # four or more conditions: a compact letter display, as the box plots give, where
                # every pair's bracket would stack above the bars
                brackets, letters = chosen_marks(entry, order, star_rule)
                if letters:
                    artists.extend(draw_letters(ax, positions, entry_letters(entry, order, star_rule),
                                                data_top=max(tops.values(), default=None)))
                else:
                    artists.extend(draw_brackets(ax, positions, brackets, data_top=tops.get(g)))
    return artists


def _draw_bars(ax: Axes, summary: pd.DataFrame, groups: list[Any], order: list[str], baseline: float,
               width: float) -> tuple[list[Any], dict[str, float]]:
    """Per condition, a bar of the mean from ``baseline`` with an SD error bar in each group; the
    bar containers and each group's highest bar top (mean + SD)."""
    n_cond = len(order)
    colours, hatches = condition_colours(order), condition_hatches(order)
    names = condition_display_names(order)
    artists: list[Any] = []
    tops: dict[str, float] = {}
    for j, c in enumerate(order):
        xs, means, sds = [], [], []
        for i, g in enumerate(groups):
            if (g, c) not in summary.index:
                continue
            row = summary.loc[(g, c)]
            xs.append(i + (j - (n_cond - 1) / 2) * width)
            means.append(float(row["mean"]))
            sds.append(float(row["std"]) if row["count"] > 1 else 0.0)
            tops[g] = max(tops.get(g, baseline), means[-1] + sds[-1])
        if not xs:
            continue
        bars = ax.bar(xs, np.asarray(means) - baseline, width=width * 0.92, bottom=baseline,
                      color=to_rgba(colours[c], 0.75), edgecolor="black", linewidth=0.7, hatch=hatches[c],
                      label=names[c], zorder=2)
        ax.errorbar(xs, means, yerr=sds, fmt="none", ecolor="black", elinewidth=0.9, capsize=2.5,
                    capthick=0.9, zorder=3)
        artists.append(bars)
    return artists, tops


def _label_axes(ax: Axes, kind: Kind, group_labels: list[str], coded: bool) -> None:
    """The group labels under the bars and the score axis of ``kind`` (Likert: 1..7, or -3..+3
    when ``coded``)."""
    ax.set_xticks(range(len(group_labels)))
    ax.set_xticklabels(group_labels)
    ax.tick_params(axis="x", length=0)
    ax.set_xlim(-0.5, len(group_labels) - 0.5)
    if kind == "tlx":
        ax.set_ylabel("NASA-TLX score (0-100)")
        ax.set_ylim(0.0, max(ax.get_ylim()[1], 100.0))
    else:
        hi = ax.get_ylim()[1]
        ax.set_ylim(-3.0 if coded else 1.0, max(hi, 3.0 if coded else 7.0))
        ax.set_yticks(range(-3, 4) if coded else range(1, 8))
        if coded:
            ax.axhline(0.0, color="black", linewidth=0.8)
        low, high = ("-3", "+3") if coded else ("1", "7")
        ax.set_ylabel(f"Rating ({low} = strongly disagree,\n{high} = strongly agree)")


def questionnaire_figure(tlx_df: pd.DataFrame | None = None, likert_df: pd.DataFrame | None = None, *,
                         conditions: Sequence[str] | None = None,
                         stats: Mapping[str, Any] | None = None,
                         item_labels: Mapping[str, str] | None = None,
                         star_rule: ComparisonOptions = DEFAULT_STAR_RULE) -> Figure:
    """Questionnaires: NASA-TLX and Likert items, mean with SD per condition (the paper's Fig. 6).

    Tables may be long (``participant, condition, scale, score`` for the TLX and
    ``participant, condition, item, response`` for Likert) or wide (one numeric column per
    TLX scale or Likert item beside ``participant`` and ``condition``). Bars are the mean,
    error bars one standard deviation (n - 1); conditions differ in colour and hatching.

    Parameters
    ----------
    tlx_df
        NASA-TLX scores (0-100), e.g. ``raw_tlx`` per participant and condition.
    likert_df
        Likert responses per participant, condition and item.
    conditions
        Drawing order; default the tables' conditions.
    stats
        Optional statistics of the scores: a ``stats.json`` dict whose metrics are named like
        the scales/items, or ``name -> stats entry``; significant comparisons get brackets.
    item_labels
        Axis labels of scales/items: the analysis plan's ``[questionnaires] labels``.
    star_rule
        The plan's star rule for entries without stars.

    Returns
    -------
    Figure
        One panel per given table, full width.

    Raises
    ------
    DataError
        Neither table is given, or a table lacks ``condition`` or scores.
    """
    tables: list[tuple[Kind, pd.DataFrame]] = []
    if tlx_df is not None:
        tables.append(("tlx", tlx_df))
    if likert_df is not None:
        tables.append(("likert", likert_df))
    if not tables:
        raise DataError("questionnaires: give a NASA-TLX table, a Likert table or both")
    longs = [long_scores(df, kind) for kind, df in tables]
    order = resolve_conditions(pd.concat([df[["condition"]] for df in longs], ignore_index=True), None,
                               conditions)
    widths = [max(2, df.iloc[:, 1].nunique()) for df in longs]
    with figure_style():
        fig = Figure(figsize=QUESTIONNAIRE_FIGSIZE, layout="constrained")
        axes = np.atleast_1d(fig.subplots(1, len(tables), width_ratios=widths))
        for i, (ax, (kind, df)) in enumerate(zip(axes, tables, strict=True)):
            questionnaire_bars(df, kind, ax=ax, conditions=order, stats=stats, item_labels=item_labels,
                               star_rule=star_rule)
            if len(tables) > 1:
                panel_letter(ax, i)
        names = condition_display_names(order)
        fig.legend(handles=[Patch(facecolor=to_rgba(condition_colours(order)[c], 0.75), edgecolor="black",
                                  hatch=condition_hatches(order)[c], label=names[c])
                            for c in order], loc="outside upper center", ncols=len(order))
        group_labels = {ax: [group_label(g, item_labels) for g in pd.unique(df.iloc[:, 1])]
                        for ax, df in zip(axes, longs, strict=True)}
        fit_group_labels(fig, group_labels)
    return fig


def _overlap(a: Bbox, b: Bbox, gap: float) -> bool:
    """Whether two boxes (pixels) come closer than ``gap`` in both directions."""
    return a.x0 < b.x1 + gap and b.x0 < a.x1 + gap and a.y0 < b.y1 + gap and b.y0 < a.y1 + gap


def _crowded_axes(fig: Figure, axes: list[Axes]) -> list[Axes]:
    """The panels whose group labels touch one another (window extents from the renderer, after
    the constrained layout, which keeps each panel's texts clear of the other panels')."""
    fig.draw_without_rendering()  # the layout places the panels; the labels' extents follow

    def touching(ax: Axes) -> bool:
        boxes = [t.get_window_extent() for t in ax.get_xticklabels() if t.get_visible() and t.get_text()]
        return any(_overlap(a, b, LABEL_GAP_PX) for a, b in itertools.pairwise(boxes))

    return [ax for ax in axes if touching(ax)]


def fit_group_labels(fig: Figure, labels: Mapping[Axes, Sequence[str]]) -> None:
    """Wrap each panel's group labels (``labels``: unwrapped, in tick order) until no two touch:
    narrower lines first (:data:`LABEL_WRAP_WIDTHS`), then a smaller
    type (:data:`LABEL_FONT_SIZES_PT`) where one word alone is wider than its group. Panels whose
    labels fit keep the widest wrap; the last step is kept if nothing fits.
    """
    steps: list[tuple[int, float | None]] = [(width, None) for width in LABEL_WRAP_WIDTHS]
    steps += [(LABEL_WRAP_WIDTHS[-1], size) for size in LABEL_FONT_SIZES_PT]
    crowded = _crowded_axes(fig, list(labels))
    for width, size in steps[1:]:
        if not crowded:
            return
        for ax in crowded:
            ax.set_xticks(ax.get_xticks(), [_wrap_group_label(label, width) for label in labels[ax]])
            if size is not None:
                ax.tick_params(axis="x", labelsize=size)
        crowded = _crowded_axes(fig, list(labels))


__all__ = ["TLX_SCALE_NAMES", "fit_group_labels", "group_label", "long_scores", "questionnaire_bars",
           "questionnaire_figure", "split_questionnaire_scores"]
