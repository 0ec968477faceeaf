"""What a box plot marks above its boxes and in its empty slots: significance brackets, a compact
letter display, or "n/a".

Which comparisons are drawn (:func:`chosen_marks`) follows :mod:`nudgecli.report.pair_display`: up
to three conditions a bracket per significant pair; four or more the letters of
:mod:`nudgecli.report.letters`, drawn in one row above the data, so the boxes keep most of the
panel's height (15 brackets for six conditions left them the bottom third); with a reference
condition, the brackets of its k - 1 pairs only. A condition a metric is not applicable to
(``stats.json``'s ``not_applicable``) gets no box and an "n/a" in its slot (:func:`mark_not_applicable`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Literal

from matplotlib.axes import Axes
from matplotlib.text import Text
from matplotlib.transforms import blended_transform_factory

from nudgecli.report.brackets import Bracket, axes_height_pt, brackets_from_stats, top_of_data
from nudgecli.report.letters import entry_letters
from nudgecli.report.pair_display import check_reference, of_reference, pair_display
from nudgecli.report.stats import ComparisonOptions
from nudgecli.report.style import TICK_FONT_PT

#: ``"auto"``: as :func:`nudgecli.report.pair_display.pair_display` says for the number of conditions;
#: ``"brackets"``: every significant pair; ``"letters"``: a compact letter display.
Comparisons = Literal["auto", "brackets", "letters"]

#: Size of the letters (points).
LETTER_FONT_PT = 9.0
#: Grey of the "n/a" of a condition a metric is not applicable to.
NOT_APPLICABLE_COLOUR = "#6E6E6E"


def chosen_marks(stats_entry: Mapping[str, Any] | None, conditions: Sequence[str],
                 star_rule: ComparisonOptions, comparisons: Comparisons = "auto",
                 reference: str | None = None) -> tuple[list[Bracket], bool]:
    """The brackets to draw for one metric, and whether letters are drawn instead.

    Parameters
    ----------
    stats_entry
        The metric's entry of ``stats.json`` (``None``: nothing to mark).
    conditions
        The conditions drawn, in order (their number decides ``"auto"``).
    star_rule
        The plan's star rule (:func:`nudgecli.report.brackets.brackets_from_stats`).
    comparisons
        :data:`Comparisons`; ignored with ``reference``.
    reference
        Only this condition's pairs, as brackets.

    Returns
    -------
    (list[Bracket], bool)
        The comparisons to give :func:`~nudgecli.report.brackets.draw_brackets` (none when letters
        are drawn), and ``True`` for letters.

    Raises
    ------
    ConfigError
        ``reference`` is not one of ``conditions``.
    """
    check_reference(reference, conditions)
    brackets = brackets_from_stats(stats_entry, star_rule)
    if reference is not None:
        return [b for b in brackets if of_reference(reference, b.a, b.b)], False
    letters = comparisons == "letters" or (comparisons == "auto"
                                           and pair_display(len(conditions)) == "letters")
    return ([], True) if letters else (brackets, False)


def draw_letters(ax: Axes, positions: Mapping[str, float], letters: Mapping[str, str], *,
                 data_top: float | None = None, fontsize: float = LETTER_FONT_PT,
                 pad_frac: float = 0.03) -> list[Text]:
    """Draw each condition's letters centred above its box, in one row above the data, and raise
    the y-limits just enough to hold them.

    Parameters
    ----------
    ax
        The axes (linear y scale).
    positions
        x position of each condition.
    letters
        Condition -> its letters (conditions without letters are skipped).
    data_top
        The highest y value of the data; default the top of the axes' data limits.
    fontsize
        Size of the letters in points.
    pad_frac
        Gap between the data and the letters, as a fraction of the final axes height.

    Returns
    -------
    list[Text]
        One text per condition with letters, in the order of ``letters``.
    """
    shown = {c: text for c, text in letters.items() if text and c in positions}
    if not shown:
        return []
    lo, hi = ax.get_ylim()
    data_top = top_of_data(ax, data_top)
    # a line of text (1.2 em) above a small gap; at least what the axes already hold
    needed_frac = min(pad_frac + 1.2 * fontsize / axes_height_pt(ax) + 0.01, 0.5)
    span = data_top - lo if data_top > lo else max(abs(data_top), 1.0)
    total = max(hi - lo, span / (1.0 - needed_frac))
    y = data_top + pad_frac * total
    texts = [ax.text(positions[c], y, text, ha="center", va="bottom", fontsize=fontsize, clip_on=False)
             for c, text in shown.items()]
    ax.set_ylim(lo, lo + total)
    return texts


def mark_letters(ax: Axes, positions: Mapping[str, float], stats_entry: Mapping[str, Any] | None,
                 compared: Sequence[str], star_rule: ComparisonOptions) -> list[Text]:
    """:func:`draw_letters` of :func:`nudgecli.report.letters.entry_letters` over the compared conditions
    (none with fewer than two)."""
    if len(compared) < 2 or stats_entry is None:
        return []
    return draw_letters(ax, positions, entry_letters(stats_entry, compared, star_rule))


def mark_not_applicable(ax: Axes, positions: Mapping[str, float], conditions: Sequence[str]) -> list[Text]:
    """An "n/a" in the middle of each listed condition's slot (no box is drawn there); the data
    limits are left alone."""
    where = blended_transform_factory(ax.transData, ax.transAxes)
    return [ax.text(positions[c], 0.5, "n/a", transform=where, ha="center", va="center",
                    fontsize=TICK_FONT_PT, fontstyle="italic", color=NOT_APPLICABLE_COLOUR)
            for c in conditions if c in positions]


__all__ = ["LETTER_FONT_PT", "Comparisons", "chosen_marks", "draw_letters", "mark_letters",
           "mark_not_applicable"]
