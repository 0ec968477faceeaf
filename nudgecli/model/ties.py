"""Maxima with ties: the one tie-tolerant argmax of the toolkit.

Values that are mathematically equal can differ in their last bits through summation order
(two goals with identical likelihood columns, turning by +180 or -180 degrees). Every "argmax,
first on ties" and every "which entries are tied for the maximum" in the model goes through
these functions, with one relative tolerance: an entry is tied with the maximum when it lies
within ``rtol * max(1, |max|)`` of it.
"""

from __future__ import annotations

import numpy as np

#: Relative tolerance within which two values count as tied.
DEFAULT_TIE_RTOL = 1e-9


def tied_with_max(values: np.ndarray, rtol: float = DEFAULT_TIE_RTOL,
                  valid: np.ndarray | None = None) -> np.ndarray:
    """Which entries are tied for the maximum along the last axis.

    Parameters
    ----------
    values
        ``(..., C)`` values.
    rtol
        Relative tie tolerance.
    valid
        ``(..., C)`` mask of entries that may be chosen (``None``: all); invalid entries are never tied.

    Returns
    -------
    np.ndarray
        ``(..., C)`` bool; every row with a valid entry has at least one ``True``.
    """
    v = np.asarray(values, dtype=float)
    if v.shape[-1] == 0:
        raise ValueError("no candidates to choose from")
    masked = v if valid is None else np.where(valid, v, -np.inf)
    best = _last_axis_max(masked)
    slack = rtol * np.maximum(1.0, np.abs(best))
    # inf - inf is NaN (nothing tied with an infinite maximum); near -max, the threshold rounds to -inf
    with np.errstate(invalid="ignore", over="ignore"):
        return masked >= best - slack


#: The longest last axis whose maximum :func:`_last_axis_max` takes column by column.
_COLUMNS_MAX = 8


def _last_axis_max(values: np.ndarray) -> np.ndarray:
    """``values.max(axis=-1, keepdims=True)`` of ``(..., C)`` values, ``(..., 1)``.

    Where the last axis is short and contiguous (a ``(G, S, 4)`` table of Q-values laid out
    action-last), numpy's reduction runs its inner loop once per row of ``C`` (0.5 ms a ``(3, 2400,
    4)`` table); there the maximum is taken as ``C - 1`` elementwise maxima of whole columns instead
    (0.03 ms). The same maximum of the same values (a NaN propagates in both; of a ``-0.0`` and a
    ``0.0`` either may come back, which the tie threshold does not tell apart).
    """
    n_columns = values.shape[-1]
    if values.ndim < 2 or n_columns > _COLUMNS_MAX or values.strides[-1] != values.itemsize:
        return values.max(axis=-1, keepdims=True)
    best = values[..., 0]
    for column in range(1, n_columns):
        best = np.maximum(best, values[..., column])
    return best[..., None]


def first_argmax(values: np.ndarray, rtol: float = DEFAULT_TIE_RTOL,
                 valid: np.ndarray | None = None) -> np.ndarray:
    """Index of the first entry tied for the maximum along the last axis.

    Parameters
    ----------
    values
        ``(..., C)`` values.
    rtol
        Relative tie tolerance.
    valid
        ``(..., C)`` mask of entries that may be chosen (``None``: all).

    Returns
    -------
    np.ndarray
        ``(...)`` int indices (a 0-d array for 1-d input; use ``int()``).
    """
    return np.argmax(tied_with_max(values, rtol, valid), axis=-1)


def tied_indices(values: np.ndarray | list[float], rtol: float = DEFAULT_TIE_RTOL) -> list[int]:
    """The indices of ``(C,)`` values tied for the maximum: :func:`tied_with_max`'s rule in plain
    floats (for a handful of goals, asked often), and none where a value is NaN (as there).

    ``tests/test_model_ties.py`` holds the two to each other.
    """
    items = np.asarray(values, dtype=float).tolist()
    if not items:
        raise ValueError("no candidates to choose from")
    if any(item != item for item in items):
        return []  # a NaN maximum ties nothing, as in tied_with_max
    best = max(items)
    threshold = best - rtol * max(1.0, abs(best))
    return [index for index, item in enumerate(items) if item >= threshold]


def unique_argmax(values: np.ndarray, rtol: float = DEFAULT_TIE_RTOL) -> int:
    """Index of the maximum of ``(C,)`` values, or -1 when two or more entries are tied for it.

    A rule blind to the order of the entries: permuting ``values`` permutes the answer, and a
    tie never resolves in favour of an index.
    """
    tied = tied_indices(values, rtol)  # the protocol asks after every belief update
    return tied[0] if len(tied) == 1 else -1
