"""One trial's step table as arrays: its order, its turns and its beliefs.

Shared by the figures (:mod:`nudgecli.report.figures`) and the choice of the trial they show
(:mod:`nudgecli.report.trial_selection`); the column names are those of the step log
(:mod:`nudgecli.steplog`, DESIGN section 4).
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from typing import Any

import numpy as np
import pandas as pd

from nudgecli.errors import DataError

TrialKey = tuple[int, int]
"""A trial's identity: ``(participant, trial)``."""


def require_columns(df: pd.DataFrame, columns: Iterable[str], what: str) -> None:
    """Raise a :class:`DataError` naming the columns of ``columns`` that ``df`` lacks."""
    missing = [c for c in columns if c not in df.columns]
    if missing:
        raise DataError(
            f"{what}: missing column(s) {', '.join(missing)} (has: {', '.join(map(str, df.columns))}); "
            "produce it with `nudge simulate` / `nudge analyze` or add the columns"
        )


def sorted_steps(steps: pd.DataFrame) -> pd.DataFrame:
    """The steps in time order (by ``step``, else by ``t``), re-indexed from 0."""
    key = "step" if "step" in steps.columns else "t"
    return steps.sort_values(key, kind="stable").reset_index(drop=True)


def runs(labels: np.ndarray) -> list[tuple[Any, int, int]]:
    """Maximal runs of equal labels: ``(label, first index, last index)``.

    Parameters
    ----------
    labels
        ``(T,)`` labels (e.g. the ``turn`` of each step).
    """
    out: list[tuple[Any, int, int]] = []
    start = 0
    for i in range(1, len(labels) + 1):
        if i == len(labels) or labels[i] != labels[start]:
            out.append((labels[start], start, i - 1))
            start = i
    return out


def as_vector(value: Any) -> np.ndarray:
    """A belief or pose cell of a table (list, array or JSON text) as a flat float array."""
    if isinstance(value, str):
        value = json.loads(value) if value.strip() else []
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return np.empty(0)
    return np.asarray(value, dtype=float).ravel()


def belief_matrix(steps: pd.DataFrame, n_goals: int | None = None) -> np.ndarray:
    """The goal beliefs of a trial's steps as one array.

    Parameters
    ----------
    steps
        Steps of one trial, in order, with a ``belief`` column of per-row sequences (lists,
        arrays or JSON strings).
    n_goals
        Expected number of goals; default the longest belief.

    Returns
    -------
    np.ndarray
        ``(T, G)``; rows with no belief are NaN.

    Raises
    ------
    DataError
        A belief has another length than ``n_goals``.
    """
    require_columns(steps, ["belief"], "steps table")
    cells = steps["belief"].tolist()
    # a run's log (Parquet lists: one float array a step, all of a trial's of one length) is stacked
    # at once; every other cell goes through as_vector
    if cells and all(type(c) is np.ndarray and c.dtype == np.float64 and c.ndim == 1 for c in cells):
        sizes = {cell.size for cell in cells}
        if len(sizes) == 1 and (size := sizes.pop()) and (n_goals is None or size == n_goals):
            return np.stack(cells)
    rows = [as_vector(v) for v in cells]
    lengths = {r.size for r in rows if r.size}
    if n_goals is None:
        n_goals = max(lengths) if lengths else 0
    bad = sorted(n for n in lengths if n != n_goals)
    if bad:
        raise DataError(f"steps table: belief vectors of length {bad[0]} but the trial has {n_goals} goals; "
                        "pass the trial's own layout")
    out = np.full((len(rows), n_goals), np.nan)
    for i, r in enumerate(rows):
        if r.size:
            out[i] = r
    return out


def true_goals(trials: pd.DataFrame) -> dict[TrialKey, int]:
    """``(participant, trial) -> true goal index`` from a trials table's ``true_goal`` column.

    Raises
    ------
    DataError
        The table has no ``participant``, ``trial`` or ``true_goal`` column, or a true goal is
        missing.
    """
    require_columns(trials, ["participant", "trial", "true_goal"], "trials table")
    if trials["true_goal"].isna().any():
        raise DataError("trials table: `true_goal` is empty in some rows; every trial needs its true goal")
    return {(int(p), int(t)): int(g) for p, t, g in
            zip(trials["participant"], trials["trial"], trials["true_goal"], strict=True)}


__all__ = ["TrialKey", "as_vector", "belief_matrix", "require_columns", "runs", "sorted_steps", "true_goals"]
