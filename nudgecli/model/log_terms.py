"""``x log y`` with ``0 log y = 0``: the terms of every entropy and mutual information here.

numpy only. scipy.special's ``xlogy`` gives the same values, but importing scipy.special costs a
process about 0.2 s (it loads numpy.testing, numpy.f2py and numpy.ma through its array-API layer),
and a study's worker needs nothing else from it. The logs are the C library's
(:mod:`nudgecli.model.portable_math`), as scipy's are, so the values are scipy's bit for bit on
every CPU (tests hold the two equal).
"""

from __future__ import annotations

from typing import overload

import numpy as np

from nudgecli.model import portable_math


@overload
def xlogy(x: np.ndarray, y: np.ndarray | float) -> np.ndarray: ...
@overload
def xlogy(x: float, y: np.ndarray) -> np.ndarray: ...
@overload
def xlogy(x: float, y: float) -> float: ...


def xlogy(x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray | float:
    """``x * log(y)``, and ``0`` where ``x == 0`` (unless ``y`` is NaN), elementwise.

    Parameters
    ----------
    x, y
        Arrays (or numbers) that broadcast together; ``xlogy(p, p)`` is ``p log p``.

    Returns
    -------
    np.ndarray or float
        The broadcast shape of ``x`` and ``y``; a float where both are numbers (or 0-d arrays).
        ``+0.0`` where ``x == 0`` (also for ``x = -0.0``), ``-inf`` where ``x > 0`` and ``y == 0``,
        NaN where either is NaN or ``y < 0 != x``, as ``scipy.special.xlogy`` (which, unlike
        numpy, does not warn of the -inf and NaN).
    """
    same = y is x
    x = np.asarray(x, dtype=float)
    y = x if same else np.asarray(y, dtype=float)
    # log only where it is used: a zero x never meets log(0), and numpy warns of log(0) or log(-1)
    # only where the product is -inf or NaN
    if same and x.ndim and x.size and x.min() > 0.0:  # p log p of a belief or marginal without zeros
        out = np.empty_like(x)  # laid out as x, as below
        out[...] = portable_math.log(x)
        return np.multiply(x, out, out=out)
    used = x.astype(bool) if same else x.astype(bool) | np.isnan(y)  # x != 0 (NaN too), faster
    # equal shapes: the output laid out in memory as x is, as a ufunc's (scipy's) would be, so that
    # a sum over it adds in the same order (and np.broadcast_shapes, slow beside the small belief
    # of every update, is not needed)
    out = (np.zeros_like(x) if same or x.shape == y.shape
           else np.zeros(np.broadcast_shapes(x.shape, y.shape)))
    used = np.broadcast_to(used, out.shape)
    out[used] = portable_math.log(np.broadcast_to(y, out.shape)[used])
    np.multiply(x, out, out=out, where=used)
    return out if out.ndim else float(out)
