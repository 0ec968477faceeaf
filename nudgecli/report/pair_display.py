"""How the pairwise comparisons of k conditions are shown in ``summary.md`` and the box plots.

- up to three conditions: every pair (a bracket per significant pair; a table row per pair), as
  the paper shows its two conditions;
- four or more: a compact letter display (:mod:`nudgecli.report.letters`), since k (k - 1) / 2
  brackets would squeeze the boxes into the bottom of each panel (15 for six conditions);
- with a reference condition (``--reference``), at any k: only the k - 1 pairs of that condition.

``stats.json`` and ``stats.csv`` always hold every pair; only what is drawn and summarised changes.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

from nudgecli.errors import ConfigError, did_you_mean

#: The fewest conditions shown by letters rather than by every pair (without a reference).
LETTERS_FROM_CONDITIONS = 4

#: ``"pairs"``: every pair; ``"letters"``: a compact letter display; ``"reference"``: the pairs of
#: the reference condition.
PairDisplay = Literal["pairs", "letters", "reference"]


def pair_display(n_conditions: int, reference: str | None = None) -> PairDisplay:
    """How the comparisons of ``n_conditions`` conditions are shown (``reference``: ``--reference``)."""
    if reference is not None:
        return "reference"
    return "letters" if n_conditions >= LETTERS_FROM_CONDITIONS else "pairs"


def check_reference(reference: str | None, conditions: Sequence[str]) -> None:
    """Refuse a ``--reference`` that is not one of the compared conditions.

    Raises
    ------
    ConfigError
        Naming the conditions, with a "did you mean" for a near miss.
    """
    if reference is not None and reference not in conditions:
        raise ConfigError(f"--reference {reference!r} is not a condition of this analysis"
                          f"{did_you_mean(reference, conditions)}; the conditions: {', '.join(conditions)}")


def of_reference(reference: str, a: str, b: str) -> bool:
    """Whether the pair ``(a, b)`` is one of the reference condition's."""
    return reference in (a, b)


__all__ = ["LETTERS_FROM_CONDITIONS", "PairDisplay", "check_reference", "of_reference", "pair_display"]
