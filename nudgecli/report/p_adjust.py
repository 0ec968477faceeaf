"""Holm's and Bonferroni's p-value adjustments on arrays, as ``statsmodels`` computes them.

``statsmodels.stats.multitest.multipletests`` (statsmodels 0.15, function ``multipletests``,
branches ``"holm"`` and ``"bonferroni"``) sorts the p-values with ``np.argsort``, multiplies the
``i``-th smallest by ``m - i + 1`` (Holm) or every one by ``m`` (Bonferroni), takes the running
maximum (Holm), sets what exceeds 1 to 1 and puts the values back in the given order. Its Holm
branch also runs ``gc.collect()`` on every call, 0.1-0.2 s in a process that holds a batch's
tables: for a plan of three or more conditions that was most of an analysis. The functions here
do the same float64 operations in the same order (one multiplication by an exact integer, a
maximum, a comparison), so their results are statsmodels' bit for bit; every analysis plan the
project ships uses Holm. The other ``multipletests`` methods stay with statsmodels
(:func:`nudgecli.report.stats.adjust_p_values`).

Holm, S. (1979), "A simple sequentially rejective multiple test procedure", *Scandinavian
Journal of Statistics* 6, 65-70.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def holm(p_values: np.ndarray) -> np.ndarray:
    """Holm's step-down adjusted p-values.

    Parameters
    ----------
    p_values
        ``(m,)`` p-values of one family, all defined (no NaN).

    Returns
    -------
    np.ndarray
        ``(m,)`` float64 adjusted p-values in the given order: the ``i``-th smallest times
        ``m - i + 1``, made non-decreasing in the sorted order, capped at 1. Tied p-values get
        equal adjusted values, whichever order the sort leaves them in.
    """
    values = np.asarray(p_values, dtype=float)
    order = np.argsort(values)  # statsmodels' sort (the default kind)
    multipliers = np.arange(len(values), 0, -1)  # m, m - 1, ..., 1
    adjusted_sorted = np.maximum.accumulate(values[order] * multipliers)
    adjusted_sorted[adjusted_sorted > 1] = 1
    adjusted = np.empty_like(adjusted_sorted)
    adjusted[order] = adjusted_sorted
    return adjusted


def bonferroni(p_values: np.ndarray) -> np.ndarray:
    """Bonferroni's adjusted p-values: each times the family's size ``m``, capped at 1.

    Parameters
    ----------
    p_values
        ``(m,)`` p-values of one family, all defined (no NaN).

    Returns
    -------
    np.ndarray
        ``(m,)`` float64 adjusted p-values in the given order.
    """
    values = np.asarray(p_values, dtype=float)
    adjusted = values * float(len(values))
    adjusted[adjusted > 1] = 1
    return adjusted


#: The adjustments computed here, by their ``multipletests`` name.
NATIVE_ADJUSTMENTS: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "holm": holm,
    "bonferroni": bonferroni,
}


__all__ = ["NATIVE_ADJUSTMENTS", "bonferroni", "holm"]
