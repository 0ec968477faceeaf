"""The shared look of the toolkit's figures: print sizes, fonts, colour-blind-safe colours.

Everything here is applied through :func:`figure_style`, a context manager around
:func:`matplotlib.rc_context`, so no drawing call leaves the global ``rcParams`` changed.
Figures are built with :class:`matplotlib.figure.Figure` directly (never ``pyplot``), so no
GUI backend, figure registry or ``plt.show`` is involved.

Colours are the Okabe-Ito palette (safe for the common colour-vision deficiencies). Where a
colour alone tells groups apart (grouped bars, lines), a second channel that survives grayscale
printing (hatching, line style) is added by the drawing code.
"""

from __future__ import annotations

import contextlib
import re
from collections.abc import Iterator, Sequence
from typing import Any, cast

import matplotlib as mpl

#: Width of a two-column figure in a typical conference paper (inches).
FULL_WIDTH_IN = 7.2
#: Width of a one-column figure (inches).
COLUMN_WIDTH_IN = 3.5

#: Smallest font size used anywhere at the saved size (points).
MIN_FONT_PT = 8.0
BASE_FONT_PT = 8.5
LABEL_FONT_PT = 8.5
TICK_FONT_PT = 8.0
LEGEND_FONT_PT = 8.0
PANEL_LETTER_PT = 10.0
STAR_FONT_PT = 10.0

#: Okabe & Ito (2008) colour-blind-safe palette.
OKABE_ITO: dict[str, str] = {
    "orange": "#E69F00",
    "sky_blue": "#56B4E9",
    "bluish_green": "#009E73",
    "yellow": "#F0E442",
    "blue": "#0072B2",
    "vermillion": "#D55E00",
    "reddish_purple": "#CC79A7",
    "black": "#000000",
}

#: Condition colours, in condition order (the first condition gets the first colour).
CONDITION_COLOURS: tuple[str, ...] = (
    OKABE_ITO["blue"],
    OKABE_ITO["orange"],
    OKABE_ITO["bluish_green"],
    OKABE_ITO["reddish_purple"],
    OKABE_ITO["sky_blue"],
    OKABE_ITO["vermillion"],
    OKABE_ITO["yellow"],
)
#: Hatches that tell conditions apart in grayscale (grouped bars), in condition order.
CONDITION_HATCHES: tuple[str, ...] = ("", "////", "....", "xxxx", "\\\\\\\\", "++++", "oo")

#: Goal colours: the first (red, as in the paper) for the true goal, the others for the other
#: goals in index order (see :func:`goal_style`).
GOAL_COLOURS: tuple[str, ...] = (
    OKABE_ITO["vermillion"],
    OKABE_ITO["blue"],
    OKABE_ITO["bluish_green"],
    OKABE_ITO["reddish_purple"],
    OKABE_ITO["sky_blue"],
    OKABE_ITO["orange"],
    OKABE_ITO["black"],
)
#: Goal line styles (a second channel for grayscale printing), the true goal solid.
GOAL_LINESTYLES: tuple[Any, ...] = ("-", "--", "-.", ":", (0, (5, 1, 1, 1, 1, 1)), (0, (1, 2)), (0, (8, 2)))

#: Who drove the robot: human black and solid, autonomy gray and dashed.
HUMAN_COLOUR = "#000000"
AUTONOMY_COLOUR = "#8C8C8C"
HUMAN_TURN_SHADE = "#E3E3E3"

#: Known condition display names; any other is prettified (see :func:`condition_display_names`).
CONDITION_DISPLAY_NAMES: dict[str, str] = {
    "disambiguation": "Disambiguation",
    "control": "Control",
}

RC: dict[str, Any] = {
    "font.family": "DejaVu Sans",
    "font.size": BASE_FONT_PT,
    "axes.labelsize": LABEL_FONT_PT,
    "axes.titlesize": LABEL_FONT_PT,
    "axes.linewidth": 0.8,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "xtick.labelsize": TICK_FONT_PT,
    "ytick.labelsize": TICK_FONT_PT,
    "xtick.major.width": 0.8,
    "ytick.major.width": 0.8,
    "legend.fontsize": LEGEND_FONT_PT,
    "legend.frameon": False,
    "lines.linewidth": 1.2,
    "hatch.linewidth": 0.6,
    "pdf.fonttype": 42,
    "ps.fonttype": 42,
    "svg.fonttype": "none",
    "svg.hashsalt": "nudge",
    "savefig.dpi": 300,
    "figure.dpi": 100,
}


@contextlib.contextmanager
def figure_style(overrides: dict[str, Any] | None = None) -> Iterator[None]:
    """Apply the toolkit's figure style for the duration of a ``with`` block.

    Parameters
    ----------
    overrides
        Extra ``rcParams`` applied on top of :data:`RC`.

    Yields
    ------
    None
        The global ``rcParams`` are restored on exit, also after an exception.
    """
    params = dict(RC)
    if overrides:
        params.update(overrides)
    with mpl.rc_context(cast(Any, params)):
        yield


#: A ``-`` that is a sign, not a word break: at the start or after a break, before a digit or a point.
_SIGN_MINUS = re.compile(r"(?<![^\s_-])-(?=[\d.])")


def _prettified(condition: str) -> str:
    """``condition`` with ``_`` and ``-`` as spaces and each word in lower case capitalised; a word
    with a capital kept as written, and a minus sign kept (``gain_-5``: Gain -5, not Gain  5)."""
    key = condition.strip().lower()
    if key in CONDITION_DISPLAY_NAMES:
        return CONDITION_DISPLAY_NAMES[key]
    words = _SIGN_MINUS.sub("\0", condition).replace("_", " ").replace("-", " ").replace("\0", "-").split(" ")
    return " ".join(word[:1].upper() + word[1:] if word.islower() else word for word in words)


def _looks_alike(name: str) -> str:
    """What two shown names are compared by: a reader tells no case or run of spaces apart."""
    return " ".join(name.split()).casefold()


def condition_display_names(conditions: Sequence[str]) -> dict[str, str]:
    """The name shown for each of ``conditions``, the conditions of one figure or table.

    Known names as in the paper (``disambiguation``: Disambiguation); a researcher's own names
    prettified (``turn-taking``: Turn Taking, ``NASA-TLX``: NASA TLX, ``iPad`` kept) where that
    keeps them apart and keeps a leading sign, else shown as written: ``-10`` and ``10`` stay
    ``-10`` and ``10``, ``offset-10`` and ``offset_10`` stay so rather than both Offset 10.

    Parameters
    ----------
    conditions
        The conditions shown together (each once).

    Returns
    -------
    dict
        ``condition -> shown name``, every shown name distinct.
    """
    names = [str(c) for c in conditions]
    shown = {c: _prettified(c) for c in names}
    for c in names:
        if c[:1] in "+-" and not shown[c].startswith(c[:1]):
            shown[c] = c
    # Shown as written where names look alike; repeated, since a name shown as written may now look
    # like another's prettified name (names as written differ, so this ends).
    while True:
        seen: dict[str, list[str]] = {}
        for c in names:
            seen.setdefault(_looks_alike(shown[c]), []).append(c)
        alike = [c for group in seen.values() if len(group) > 1 for c in group if shown[c] != c]
        if not alike:
            return shown
        shown.update({c: c for c in alike})


def condition_display_name(condition: str, conditions: Sequence[str] = ()) -> str:
    """The name shown for ``condition`` among ``conditions`` (the others shown with it; see
    :func:`condition_display_names`)."""
    together = list(dict.fromkeys([*map(str, conditions), str(condition)]))
    return condition_display_names(together)[str(condition)]


def condition_colours(conditions: Sequence[str]) -> dict[str, str]:
    """One colour per condition, by position in ``conditions`` (cycled after seven)."""
    return {c: CONDITION_COLOURS[i % len(CONDITION_COLOURS)] for i, c in enumerate(conditions)}


def condition_hatches(conditions: Sequence[str]) -> dict[str, str]:
    """One hatch pattern per condition, by position in ``conditions`` (cycled after seven)."""
    return {c: CONDITION_HATCHES[i % len(CONDITION_HATCHES)] for i, c in enumerate(conditions)}


def goal_style(goal: int, true_goal: int) -> tuple[str, Any]:
    """Colour and line style of goal ``goal`` in a trial whose true goal is ``true_goal``.

    The true goal is red and solid (the paper's Fig. 5); the other goals take the next colours
    and line styles in index order, so the same trial always gets the same styles.

    Parameters
    ----------
    goal
        Goal index.
    true_goal
        The trial's true goal index.

    Returns
    -------
    tuple
        ``(colour, linestyle)``.
    """
    slot = 0 if goal == true_goal else 1 + goal - (1 if goal > true_goal else 0)
    return (GOAL_COLOURS[slot % len(GOAL_COLOURS)], GOAL_LINESTYLES[slot % len(GOAL_LINESTYLES)])
