"""A metric's rows as every test of it reads them: the values of the compared conditions with their
conditions (and participants), as a table (:func:`tidy_values`) and as arrays (:class:`MetricRows`).

The arrays are made once per metric from each row's condition and participant as integers, found once
per table (:class:`TableKeys`): the tests then select a condition's or a participant's values by
comparing integers (``np.bincount``, ``np.lexsort``), not by indexing, grouping or matching labels of a
table again (that was most of a study's analysis time). The table is made only where a library that
reads one runs (:meth:`MetricRows.table`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, TypeAlias

import numpy as np
import pandas as pd


def _numeric(series: pd.Series) -> pd.Series:
    """A float Series (bool -> 0/1, nullable types -> NaN for missing)."""
    return pd.Series(series.to_numpy(dtype=float, na_value=np.nan), index=series.index)


def tidy_values(data: pd.DataFrame, metric: str, conditions: Sequence[str], condition: str,
                participant: str | None = None) -> pd.DataFrame:
    """A metric's values as every test reads them: ``condition``, ``value`` (and ``participant``)
    rows of the given conditions with a value."""
    columns = {"condition": _condition_labels(data[condition]), "value": _numeric(data[metric])}
    if participant is not None:
        columns["participant"] = data[participant]
    tidy = pd.DataFrame(columns)
    keep = (tidy["condition"].isin(conditions) & tidy["value"].notna()).to_numpy()
    if keep.all():  # the usual case: no copy of a large table
        return tidy.reset_index(drop=True)
    return tidy[keep].reset_index(drop=True)


def _condition_labels(labels: pd.Series) -> pd.Series:
    """The condition labels as strings (categories renamed: no string copy of a large table)."""
    if isinstance(labels.dtype, pd.CategoricalDtype):
        return labels.cat.rename_categories([str(c) for c in labels.cat.categories])
    return labels.astype(str)


def compared_participants(data: pd.DataFrame, conditions: Sequence[str], condition: str,
                          participant: str) -> pd.Index:
    """Every participant with a row in one of the given conditions, a value of the metric or not
    (:func:`tidy_values` keeps only the rows with a value: a participant all of whose values of
    a condition are missing is not in it, yet is one the participant-level test leaves out)."""
    rows = _condition_labels(data[condition]).isin(conditions).to_numpy()
    return pd.Index(pd.unique(data[participant][rows].dropna()))


@dataclass(frozen=True, eq=False)
class TableKeys:
    """Each row's condition and participant as integers, found once per table for all its metrics.

    Attributes
    ----------
    conditions
        The conditions, in order.
    positions
        ``(N,)`` :func:`condition_positions` of the table's condition labels (as :func:`tidy_values`
        reads them).
    participant_codes
        ``(N,)`` each row's participant as its position in ``participant_labels`` (``pd.factorize``
        with ``sort=True``, -1 where missing); None without participants (or their column), or
        where they are read from a table (categorical, or not sortable).
    participant_labels
        The distinct participants, sorted.
    group_order
        ``(k,)`` :func:`condition_group_order` of the table's condition labels.
    """

    conditions: tuple[str, ...]
    positions: np.ndarray
    participant_codes: np.ndarray | None = None
    participant_labels: pd.Index | None = None
    group_order: np.ndarray | None = None


def table_keys(data: pd.DataFrame, conditions: Sequence[str], condition: str,
               participant: str | None = None) -> TableKeys:
    """:class:`TableKeys` of a table (one match of its labels, however many metrics read it)."""
    condition_labels = _condition_labels(data[condition])
    positions = condition_positions(condition_labels, conditions)
    codes = labels = None
    if participant is not None and participant in data and \
            not isinstance(data[participant].dtype, pd.CategoricalDtype):
        try:
            codes, labels = pd.factorize(data[participant], sort=True)
        except TypeError:  # participants that do not sort: the tests read them from the table
            codes = labels = None
    # the smallest integers that hold them: a large table's rows cost a byte or two each, not eight
    if codes is not None and labels is not None:
        codes = narrow_codes(codes, len(labels))
    return TableKeys(tuple(conditions), narrow_codes(positions, len(conditions)), codes, labels,
                     condition_group_order(condition_labels, conditions))


def narrow_codes(codes: np.ndarray, count: int) -> np.ndarray:
    """``codes`` (``-1 .. count - 1``) in the smallest signed integer type that holds them (int8 for
    a few conditions, int16 for up to 32,767 participants); every use of them that computes with
    them (a key, an index) widens them first."""
    for dtype in (np.int8, np.int16, np.int32):
        if count <= np.iinfo(dtype).max:
            return codes.astype(dtype, copy=False)
    return codes


class MetricRows:
    """:func:`tidy_values`' rows of a metric as arrays: what every test of the metric reads, made
    once (:func:`metric_rows`), so that no test indexes, groups or matches a table's labels again.

    Attributes
    ----------
    values
        ``(n,)`` float64, the metric's values (none missing), in the table's order.
    positions
        ``(n,)`` intp, each value's condition as its position in ``conditions``.
    conditions
        The conditions, in order.
    participant_codes
        ``(n,)`` intp, each value's participant as its position in ``participant_labels`` (sorted;
        -1 where missing); None where the tests read the participants from :meth:`table`
        (categorical participants, or none asked for).
    participant_labels
        The table's distinct participants, sorted.
    group_order
        ``(k,)`` each condition's place in the order pandas groups the table's labels in
        (:func:`condition_group_order`; the given order where None).
    """

    def __init__(self, values: np.ndarray, positions: np.ndarray, conditions: Sequence[str], *,
                 participant_codes: np.ndarray | None = None, participant_labels: pd.Index | None = None,
                 table: pd.DataFrame | None = None, source: tuple[Any, ...] | None = None,
                 keys: TableKeys | None = None, group_order: np.ndarray | None = None) -> None:
        self.values, self.positions, self.conditions = values, positions, list(conditions)
        self.participant_codes, self.participant_labels = participant_codes, participant_labels
        self._table, self._source, self._keys = table, source, keys
        self.group_order = group_order

    def table(self, *, participants: bool = True) -> pd.DataFrame:
        """:func:`tidy_values`' table of these rows: the one given, or made anew for a library that
        reads a table (kept by no one: a large table's rows are not held twice), with the
        participants or (``participants=False``) without them."""
        if self._table is not None:
            return self._table
        assert self._source is not None
        data, metric, condition, participant = self._source
        return tidy_values(data, metric, self.conditions, condition, participant if participants else None)

    def everyone(self) -> np.ndarray | None:
        """The sorted codes of every participant with a row (a value or not) of these conditions in
        the table (:func:`compared_participants`); None where the codes are not known."""
        keys = self._keys
        if keys is None or keys.participant_codes is None:
            return None
        chosen = [keys.conditions.index(c) for c in self.conditions]
        codes = keys.participant_codes[np.isin(keys.positions, chosen)]
        assert keys.participant_labels is not None
        # a count per participant (no sorted copy of a large table's codes)
        return np.flatnonzero(np.bincount(codes[codes >= 0], minlength=len(keys.participant_labels)))

    def among(self, compared: Sequence[str]) -> MetricRows:
        """The rows of the ``compared`` conditions (a subset of :attr:`conditions`, in its order):
        :func:`tidy_values` of them."""
        remap = np.full(len(self.conditions) + 1, -1, dtype=np.intp)  # (the last: position -1)
        for j, c in enumerate(compared):
            remap[self.conditions.index(c)] = j
        positions = narrow_codes(remap[self.positions], len(compared))
        kept = positions >= 0
        table = None if self._table is None else self._table[kept].reset_index(drop=True)
        codes = None if self.participant_codes is None else self.participant_codes[kept]
        order = None
        if self.group_order is not None:  # the compared conditions' places, in the same order
            order = np.argsort(np.argsort(self.group_order[[self.conditions.index(c) for c in compared]]))
        return MetricRows(self.values[kept], positions[kept], compared, participant_codes=codes,
                          participant_labels=self.participant_labels, table=table, source=self._source,
                          keys=self._keys, group_order=order)


def metric_rows(data: pd.DataFrame, metric: str, conditions: Sequence[str], condition: str,
                participant: str | None = None, *, keys: TableKeys | None = None) -> MetricRows:
    """:class:`MetricRows` of a metric: :func:`tidy_values`' rows, from the table's :class:`TableKeys`
    (``keys``, made here when not given or of other conditions)."""
    if keys is None or keys.conditions != tuple(conditions):
        keys = table_keys(data, conditions, condition, participant)
    values = data[metric].to_numpy(dtype=float, na_value=np.nan)  # as _numeric
    keep = (keys.positions >= 0) & ~np.isnan(values)
    everything = bool(keep.all())  # the usual case: no copies
    codes = keys.participant_codes if participant is not None else None
    if codes is not None and not everything:
        codes = codes[keep]
    return MetricRows(values if everything else values[keep],
                      keys.positions if everything else keys.positions[keep], conditions,
                      participant_codes=codes, participant_labels=keys.participant_labels,
                      source=(data, metric, condition, participant), keys=keys, group_order=keys.group_order)


def rows_of_tidy(tidy: pd.DataFrame, conditions: Sequence[str]) -> MetricRows:
    """:class:`MetricRows` of :func:`tidy_values`' table (a caller that holds the table)."""
    codes = labels = None
    if "participant" in tidy and not isinstance(tidy["participant"].dtype, pd.CategoricalDtype):
        try:
            codes, labels = pd.factorize(tidy["participant"], sort=True)
        except TypeError:
            codes = labels = None
    return MetricRows(tidy["value"].to_numpy(dtype=float), condition_positions(tidy["condition"], conditions),
                      conditions, participant_codes=codes, participant_labels=labels, table=tidy,
                      group_order=condition_group_order(tidy["condition"], conditions))


#: What a test takes as the rows it reads: :func:`tidy_values`' table, or its :class:`MetricRows`.
TidyRows: TypeAlias = "pd.DataFrame | MetricRows"


def rows_for(data: pd.DataFrame, metric: str, conditions: Sequence[str], condition: str,
             participant: str | None, tidy: TidyRows | None) -> MetricRows:
    """The rows a test reads: ``tidy`` as :class:`MetricRows` (a table given, or the rows
    themselves), else :func:`metric_rows` of ``data``."""
    if isinstance(tidy, MetricRows):
        return tidy
    if tidy is not None:
        return rows_of_tidy(tidy, conditions)
    return metric_rows(data, metric, conditions, condition, participant)


def condition_positions(labels: pd.Series, conditions: Sequence[str]) -> np.ndarray:
    """Each row's condition as its position in ``conditions``: ``labels == conditions[j]`` is
    ``positions == j`` (-1 where the label is none of them, or missing).

    A categorical column's codes are mapped through its categories (a 3.5 M-row table's labels
    as objects took 0.2 s to make and 1 s to sort, each time a test read them); other labels
    are matched by equality, as ``==`` matches them.

    Parameters
    ----------
    labels
        ``(n,)`` condition labels (:func:`tidy_values`' ``condition``).
    conditions
        The conditions, in order.

    Returns
    -------
    np.ndarray
        ``(n,)`` intp.
    """
    distinct = list(dict.fromkeys(conditions))  # an index's entries are distinct
    # a distinct condition's position in conditions, and -1 (the last entry) for none of them
    lookup = np.array([conditions.index(c) for c in distinct] + [-1], dtype=np.intp)
    index = pd.Index(distinct, dtype=object)
    if isinstance(labels.dtype, pd.CategoricalDtype):  # each category matched once, then its codes
        by_code = np.append(lookup[index.get_indexer(labels.cat.categories)], -1)  # (code -1: missing)
        return by_code[labels.cat.codes.to_numpy()]
    return lookup[index.get_indexer(labels)]


def condition_group_order(labels: pd.Series, conditions: Sequence[str]) -> np.ndarray:
    """Each condition's place in the order ``labels.groupby`` groups them: a categorical column's
    categories in their order, other labels sorted as strings.

    A grouped mean is a sum in the rows' order whose path (and so its last digits) depends on
    whether the group numbers rise through the rows; grouping by these places, not by the
    conditions' positions, gives the means of grouping the labels themselves, bit for bit.

    Parameters
    ----------
    labels
        ``(n,)`` condition labels (:func:`tidy_values`' ``condition``).
    conditions
        The conditions, in order.

    Returns
    -------
    np.ndarray
        ``(k,)`` intp, a permutation of ``0 .. k - 1``: the conditions' ranks in that order (a
        condition that is not a category after the categories, in the given order).
    """
    if isinstance(labels.dtype, pd.CategoricalDtype):
        places = pd.Index([str(c) for c in labels.cat.categories]).get_indexer(list(conditions))
        places = np.where(places >= 0, places, len(labels.cat.categories) + np.arange(len(conditions)))
        return np.argsort(np.argsort(places, kind="stable")).astype(np.intp)
    return np.argsort(np.argsort(np.array(conditions, dtype=object), kind="stable")).astype(np.intp)
