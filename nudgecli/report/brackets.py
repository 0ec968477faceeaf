"""Significance brackets drawn from the toolkit's own p-values (no seaborn).

A bracket joins two groups drawn at x positions ``positions[a]`` and ``positions[b]`` with
a horizontal bar above the data, short legs down towards the groups and the stars centred
over the bar. Brackets whose spans overlap (or touch) are stacked on separate levels, the
narrowest lowest, so any number of pairwise comparisons of three or more conditions stay
legible. The y-limits are raised so every bracket and its stars are inside the axes.

The stars are those of :mod:`nudgecli.report.stats` (their one owner): the ``stars`` that
``stats.json`` holds for each comparison, or, for a statistics entry without them, the stars
:func:`nudgecli.report.stats.significance_stars` gives under the analysis plan's thresholds and
``<``/``<=`` comparison, shown only when the omnibus (Kruskal-Wallis) test is significant.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from nudgecli.errors import DataError
from nudgecli.report.stats import ComparisonOptions, is_significant, significance_stars

if TYPE_CHECKING:  # matplotlib loads where brackets are drawn: an analysis (summary.md's letters) needs none
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.text import Text

#: The paper's star rule (stars at p < .05/.01/.001, Kruskal-Wallis gate at .05).
DEFAULT_STAR_RULE = ComparisonOptions()


@dataclass(frozen=True)
class Bracket:
    """One pairwise comparison to draw.

    Attributes
    ----------
    a, b
        The two conditions compared (keys of the ``positions`` given to :func:`draw_brackets`).
    p
        The (adjusted) p-value of the comparison; informative only, the stars decide drawing.
    stars
        ``"*"``, ``"**"``, ``"***"`` when significant, ``""`` when not (not drawn by default).
    """

    a: str
    b: str
    p: float
    stars: str


def brackets_from_stats(stats_entry: Mapping[str, Any] | None,
                        options: ComparisonOptions = DEFAULT_STAR_RULE) -> list[Bracket]:
    """The pairwise comparisons of one metric of ``stats.json`` as :class:`Bracket` s.

    The stars are taken from the entry's ``"stars"`` (the ``stats.json`` list of ``{"a", "b", "stars"}``,
    or a mapping with keys ``"<a>|<b>"``, either order) when it has the pair; otherwise they are
    :func:`nudgecli.report.stats.significance_stars` of the Conover p-value under ``options``
    (thresholds and comparison), and only when the Kruskal-Wallis p-value is significant at
    ``options.kruskal_alpha`` under the same comparison (:func:`nudgecli.report.stats.is_significant`).

    Parameters
    ----------
    stats_entry
        One element of ``stats["metrics"]`` (or ``None``: no comparisons).
    options
        The plan's star rule (``kruskal_alpha``, ``star_thresholds``, ``star_comparison``).

    Returns
    -------
    list[Bracket]
        One per Conover comparison, in the entry's order; ``stars == ""`` where not significant.
    """
    if not stats_entry:
        return []
    kruskal = stats_entry.get("kruskal") or {}
    omnibus_p = kruskal.get("p")
    omnibus_ok = omnibus_p is not None and is_significant(float(omnibus_p), options.kruskal_alpha,
                                                          options.star_comparison)
    given = _given_stars(stats_entry.get("stars"))
    brackets = []
    for row in stats_entry.get("conover") or []:
        a, b = str(row["a"]), str(row["b"])
        p = row.get("p", float("nan"))
        p = float("nan") if p is None else float(p)
        key, rev = f"{a}|{b}", f"{b}|{a}"
        if key in given or rev in given:
            stars = str(given.get(key, given.get(rev)) or "")
        else:
            stars = (significance_stars(p, options.star_thresholds, options.star_comparison)
                     if omnibus_ok else "")
        brackets.append(Bracket(a=a, b=b, p=p, stars=stars))
    return brackets


def _given_stars(stars: Any) -> dict[str, str]:
    """``stats.json``'s stars (a list of ``{"a", "b", "stars"}``, or a ``"a|b"`` mapping) as a mapping."""
    if not stars:
        return {}
    if isinstance(stars, Mapping):
        return {str(k): str(v or "") for k, v in stars.items()}
    return {f"{row['a']}|{row['b']}": str(row.get("stars") or "") for row in stars}


def assign_levels(spans: Sequence[tuple[float, float]]) -> list[int]:
    """Stack intervals: the lowest level on which an interval overlaps no other.

    Intervals that overlap or merely touch (share an end point) go on different levels.
    Narrower intervals are placed first, so they end up lower (closer to the data).

    Parameters
    ----------
    spans
        ``(left, right)`` x-intervals, in any order.

    Returns
    -------
    list[int]
        The level of each interval (0 = lowest), in the order given.
    """
    order = sorted(range(len(spans)), key=lambda i: (spans[i][1] - spans[i][0], spans[i][0], spans[i][1]))
    occupied: list[list[tuple[float, float]]] = []
    levels = [0] * len(spans)
    for i in order:
        left, right = spans[i]
        level = 0
        while level < len(occupied) and any(
            left <= r and l_ <= right for l_, r in occupied[level]
        ):
            level += 1
        if level == len(occupied):
            occupied.append([])
        occupied[level].append((left, right))
        levels[i] = level
    return levels


def _drawn_spans(positions: Mapping[str, float], comparisons: Iterable[Bracket],
                 show_ns: bool) -> list[tuple[float, float, str]]:
    """``(left, right, label)`` of each comparison :func:`draw_brackets` draws, in the given order.

    Raises
    ------
    DataError
        A drawn comparison names a group that is not in ``positions``.
    """
    drawn: list[tuple[float, float, str]] = []
    for comp in comparisons:
        label = comp.stars or ("n.s." if show_ns else "")
        if not label:
            continue
        for cond in (comp.a, comp.b):
            if cond not in positions:
                raise DataError(
                    f"significance bracket {comp.a!r} vs {comp.b!r}: condition {cond!r} is not plotted "
                    f"(plotted: {', '.join(map(repr, positions))}); check the stats and the metrics "
                    "table name the same conditions"
                )
        x1, x2 = sorted((float(positions[comp.a]), float(positions[comp.b])))
        drawn.append((x1, x2, label))
    return drawn


def bracket_levels(positions: Mapping[str, float], comparisons: Iterable[Bracket], *,
                   show_ns: bool = False) -> int:
    """How many stacked levels :func:`draw_brackets` needs for these comparisons (0 for none).

    Lets a figure make room before drawing: with many conditions and many significant pairs the
    brackets would otherwise squeeze the data into the bottom of the axes.
    """
    drawn = _drawn_spans(positions, comparisons, show_ns)
    return max(assign_levels([(x1, x2) for x1, x2, _ in drawn])) + 1 if drawn else 0


def _root_figure(ax: Axes) -> Figure:
    """The top-level figure holding ``ax`` (through any subfigures)."""
    from matplotlib.figure import Figure, SubFigure

    fig: Any = ax.get_figure()
    while isinstance(fig, SubFigure):
        fig = fig.get_figure()
    if not isinstance(fig, Figure):
        raise ValueError("draw_brackets: the axes belong to no figure")
    return fig


def axes_height_pt(ax: Axes) -> float:
    """The axes' height in points at the figure's size (a lower bound after layout)."""
    height_pt = ax.bbox.height * 72.0 / _root_figure(ax).dpi
    # A layout engine (constrained layout) shrinks the axes a little for labels and titles;
    # assume it does, so the reserved room for the stars errs on the generous side.
    return max(height_pt * 0.9, 1.0)



def top_of_data(ax: Axes, data_top: float | None = None) -> float:
    """Where marks above the data start: ``data_top``, or the top of the axes' data limits (the
    axes' top when they hold no data), never below the axes' bottom."""
    lo, hi = ax.get_ylim()
    if data_top is None:
        y1 = ax.dataLim.y1
        data_top = float(y1) if np.isfinite(y1) and ax.dataLim.height >= 0 else float(hi)
    return max(float(data_top), lo)

def draw_brackets(ax: Axes, positions: Mapping[str, float], comparisons: Iterable[Bracket], *,
                  data_top: float | None = None, fontsize: float | None = None, color: str = "black",
                  linewidth: float = 0.8, show_ns: bool = False, pad_frac: float = 0.03,
                  tick_frac: float = 0.025, gap_frac: float = 0.015) -> list[Artist]:
    """Draw significance brackets above the data and make room for them.

    Parameters
    ----------
    ax
        The axes (linear y scale) holding the groups.
    positions
        x position of each group, by condition.
    comparisons
        The comparisons; only those with non-empty ``stars`` are drawn (all of them, marked
        ``n.s.``, if ``show_ns``).
    data_top
        The highest y value of the data; default the top of the axes' data limits.
    fontsize
        Size of the stars in points (default :data:`nudgecli.report.style.STAR_FONT_PT`).
    color, linewidth
        Bracket colour and line width.
    show_ns
        Also draw non-significant comparisons, labelled ``n.s.``.
    pad_frac, tick_frac, gap_frac
        Gap above the data, leg length and gap between stacked brackets, as fractions of the
        final axes height.

    Returns
    -------
    list[Artist]
        For each drawn bracket, its :class:`~matplotlib.lines.Line2D` then its
        :class:`~matplotlib.text.Text`, lowest level first.

    Raises
    ------
    DataError
        A comparison names a group that is not in ``positions``.
    """
    from nudgecli.report.style import STAR_FONT_PT

    fontsize = STAR_FONT_PT if fontsize is None else fontsize
    drawn = _drawn_spans(positions, comparisons, show_ns)
    if not drawn:
        return []

    lo, hi = ax.get_ylim()
    data_top = top_of_data(ax, data_top)
    levels = assign_levels([(x1, x2) for x1, x2, _ in drawn])
    n_levels = max(levels) + 1

    # Height of the label above its bar: asterisks are drawn pulled down onto the bar (they sit
    # high in their line box), so they need less than a full line; "n.s." needs a line.
    text_em = 0.75 if all(label != "n.s." for *_, label in drawn) else 1.1
    text_frac = fontsize * text_em / axes_height_pt(ax)
    step_frac = max(text_frac, tick_frac) + gap_frac
    needed_frac = pad_frac + tick_frac + (n_levels - 1) * step_frac + text_frac + 0.01
    needed_frac = min(needed_frac, 0.8)
    span = data_top - lo
    if span <= 0:
        span = max(abs(data_top), 1.0)
    total = max(hi - lo, span / (1.0 - needed_frac))

    artists: list[Artist] = []
    for level, (x1, x2, label) in sorted(zip(levels, drawn, strict=True), key=lambda item: item[0]):
        y = data_top + (pad_frac + tick_frac + level * step_frac) * total
        artists.extend(_draw_bracket(ax, x1, x2, y, tick_frac * total, label, fontsize=fontsize, color=color,
                                     linewidth=linewidth))
    ax.set_ylim(lo, lo + total)
    return artists


def _draw_bracket(ax: Axes, x1: float, x2: float, y: float, leg: float, label: str, *, fontsize: float,
                  color: str, linewidth: float) -> tuple[Line2D, Text]:
    """One bracket from ``x1`` to ``x2`` with its bar at ``y`` and legs ``leg`` long (data units),
    its label centred on the bar: stars pulled down onto it, ``n.s.`` smaller, just above it."""
    from matplotlib.lines import Line2D
    from matplotlib.transforms import offset_copy

    line = Line2D([x1, x1, x2, x2], [y - leg, y, y, y - leg], color=color, linewidth=linewidth,
                  solid_joinstyle="miter", clip_on=False)
    ax.add_line(line)
    if label == "n.s.":
        text = ax.text((x1 + x2) / 2.0, y, label, ha="center", va="bottom", color=color,
                       fontsize=fontsize * 0.8, clip_on=False)
    else:
        # The asterisk glyph sits high above its baseline; dropping the baseline 0.15 em
        # below the bar leaves the stars just clear of it.
        shifted = offset_copy(ax.transData, fig=_root_figure(ax), y=-0.15 * fontsize, units="points")
        text = ax.text((x1 + x2) / 2.0, y, label, ha="center", va="baseline", color=color,
                       fontsize=fontsize, clip_on=False, transform=shifted)
    return line, text
