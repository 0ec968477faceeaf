"""Compact letter display of all pairwise comparisons (H.-P. Piepho, "An algorithm for a
letter-based representation of all-pairwise comparisons", *J. Comput. Graph. Statist.* 13(2),
456-466, 2004).

Each condition gets one or more letters; two conditions share a letter exactly when their pair
is *not* significantly different. With k conditions that is k short labels instead of
k (k - 1) / 2 brackets, which is what keeps a figure of many conditions readable.

The letters come from Piepho's insert-and-absorb algorithm followed by his sweep:

1. *insert*: start with one letter (a column) shared by every condition; for each significantly
   different pair ``(i, j)``, every column holding both is duplicated, ``i`` is deleted from the
   one copy and ``j`` from the other;
2. *absorb* (after each insertion): a column whose conditions are all in another column is
   deleted (it tells nothing the other does not);
3. *sweep*: a condition's letter is deleted where every condition it shares that letter with
   also shares another letter with it, and the condition keeps at least one letter.

After step 2 the columns are exactly the maximal sets of mutually non-different conditions (the
maximal cliques of the "not different" graph); the sweep then drops the letters no pair needs.
What the algorithm guarantees, and the tests check, is this minimality: no letter's conditions
are a subset of another letter's, and no condition's letter can be removed without two
non-different conditions losing their only common letter (or a condition losing its last
letter). It does not promise the fewest letters possible (finding those is NP-hard).

R's ``multcompView::multcompLetters`` implements insert-and-absorb without the sweep, and the
``cld`` package (``GegznaV/cld``, ``make_cld``) reads letters the same way: groups sharing a
letter are not significantly different.

Letters are named in the order of the conditions: the column holding the earliest condition is
``a``, and so on (``a``-``z``, then ``A``-``Z``).
"""

from __future__ import annotations

import string
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from nudgecli.errors import ConfigError
from nudgecli.report.brackets import DEFAULT_STAR_RULE, brackets_from_stats
from nudgecli.report.stats import ComparisonOptions

#: The letter names, in order.
LETTER_NAMES = string.ascii_lowercase + string.ascii_uppercase

#: One column of the display: the positions (in the conditions' order) of the conditions that
#: share its letter.
Column = frozenset[int]


def _pair_positions(conditions: Sequence[str], different: Iterable[tuple[str, str]]) -> list[tuple[int, int]]:
    """The significantly different pairs as ``(i, j)`` positions, ``i < j``, in the pairs' order,
    each once.

    Raises
    ------
    ValueError
        A pair names a condition not in ``conditions``, or a condition twice.
    """
    position = {c: i for i, c in enumerate(conditions)}
    if len(position) != len(conditions):
        raise ValueError(f"conditions must be distinct, got {list(conditions)}")
    seen: list[tuple[int, int]] = []
    for a, b in different:
        if a not in position or b not in position:
            raise ValueError(f"pair ({a!r}, {b!r}) names a condition not among {list(conditions)}")
        if a == b:
            raise ValueError(f"pair ({a!r}, {b!r}): a condition is never different from itself")
        pair = (min(position[a], position[b]), max(position[a], position[b]))
        if pair not in seen:
            seen.append(pair)
    return sorted(seen)


def _absorb(columns: Sequence[Column]) -> list[Column]:
    """``columns`` without those strictly inside another. (No two are ever equal: the two halves of
    a split differ in whether they hold ``i``, and a half equal to another column would have been
    inside its parent, which absorbing already excluded.)"""
    return [column for column in columns if not any(column < other for other in columns)]


def insert_and_absorb(conditions: Sequence[str], different: Iterable[tuple[str, str]]) -> list[Column]:
    """The columns of Piepho's insert-and-absorb algorithm (steps 1 and 2, no sweep).

    Parameters
    ----------
    conditions
        The ``k`` conditions, distinct, in order.
    different
        The significantly different pairs (either order; repeats ignored), processed in the order
        of the conditions.

    Returns
    -------
    list[frozenset[int]]
        Each column as the positions of its conditions: the maximal sets of conditions no two of
        which are different. One column of every position when nothing differs; none for no
        conditions.
    """
    if not conditions:
        return []
    columns: list[Column] = [frozenset(range(len(conditions)))]
    for i, j in _pair_positions(conditions, different):
        split: list[Column] = []
        for column in columns:
            if i in column and j in column:
                split += [column - {i}, column - {j}]
            else:
                split.append(column)
        columns = _absorb(split)
    return columns


def _connected_elsewhere(columns: Sequence[set[int]], skip: int, t: int, u: int) -> bool:
    """Whether ``t`` and ``u`` share a column other than ``columns[skip]``."""
    return any(t in column and u in column for m, column in enumerate(columns) if m != skip)


def _sweep(columns: Sequence[Column]) -> list[Column]:
    """Piepho's sweep: delete each condition's letter that no pair needs (the condition keeps a
    letter), column by column in the order given, conditions in their order; empty columns go."""
    swept = [set(column) for column in columns]
    for m, column in enumerate(swept):
        for t in sorted(column):
            others = column - {t}
            keeps_a_letter = any(t in other for n, other in enumerate(swept) if n != m)
            if keeps_a_letter and all(_connected_elsewhere(swept, m, t, u) for u in others):
                column.discard(t)
    return [frozenset(column) for column in swept if column]


def _in_condition_order(columns: Iterable[Column]) -> list[Column]:
    """Columns sorted by their conditions' positions (the column of the earliest condition first)."""
    return sorted(columns, key=sorted)


def letter_columns(conditions: Sequence[str], different: Iterable[tuple[str, str]]) -> list[Column]:
    """The columns of the compact letter display: insert-and-absorb, then the sweep, in condition order.

    Parameters and the order of processing are those of :func:`insert_and_absorb`.

    Returns
    -------
    list[frozenset[int]]
        Column ``n`` is the letter :data:`LETTER_NAMES` ``[n]``: the positions of its conditions.
    """
    return _in_condition_order(_sweep(_in_condition_order(insert_and_absorb(conditions, different))))


def compact_letter_display(conditions: Sequence[str], different: Iterable[tuple[str, str]]) -> dict[str, str]:
    """The letters of each condition: two conditions share a letter iff their pair is not different.

    Parameters
    ----------
    conditions
        The ``k`` conditions, distinct, in order (the earliest gets ``a``).
    different
        The significantly different pairs (either order).

    Returns
    -------
    dict[str, str]
        Condition -> its letters, in letter order (``"a"``, ``"ab"``, ...).

    Raises
    ------
    ConfigError
        More than 52 letters would be needed (use a reference condition instead).

    Examples
    --------
    Four conditions, ``A`` differs from ``C`` and ``D``, ``B`` from ``D``:
    ``{"A": "a", "B": "ab", "C": "bc", "D": "c"}``.
    """
    columns = letter_columns(conditions, different)
    if len(columns) > len(LETTER_NAMES):
        raise ConfigError(f"the comparisons of {len(conditions)} conditions need {len(columns)} letters, "
                          f"more than the {len(LETTER_NAMES)} available; compare against one condition "
                          "with --reference CONDITION")
    letters = {c: "" for c in conditions}
    for name, column in zip(LETTER_NAMES, columns, strict=False):
        for i in sorted(column):
            letters[conditions[i]] += name
    return letters


def different_pairs(stats_entry: Mapping[str, Any] | None,
                    options: ComparisonOptions = DEFAULT_STAR_RULE) -> list[tuple[str, str]]:
    """The pairs of one metric of ``stats.json`` that are significantly different: those that earn
    a star (:func:`nudgecli.report.brackets.brackets_from_stats`: the Holm-adjusted Conover p under
    the plan's star rule, only where Kruskal-Wallis is significant), the pairs a bracket would
    join."""
    return [(b.a, b.b) for b in brackets_from_stats(stats_entry, options) if b.stars]


def entry_letters(stats_entry: Mapping[str, Any] | None, conditions: Sequence[str],
                  options: ComparisonOptions = DEFAULT_STAR_RULE) -> dict[str, str]:
    """:func:`compact_letter_display` of one metric of ``stats.json`` over ``conditions`` (the ones
    compared; pairs naming another condition are ignored)."""
    present = set(conditions)
    different = [(a, b) for a, b in different_pairs(stats_entry, options) if a in present and b in present]
    return compact_letter_display(conditions, different)


__all__ = ["LETTER_NAMES", "compact_letter_display", "different_pairs", "entry_letters", "insert_and_absorb",
           "letter_columns"]
