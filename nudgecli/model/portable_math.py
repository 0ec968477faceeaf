"""The model's logs, exponentials and sums of products, computed the same way on every CPU.

numpy chooses a ufunc's inner loop by the CPU it runs on: ``np.log``, ``np.exp``, ``np.expm1`` and
``np.log2`` have AVX-512 loops that differ from the C library's functions in the last bit now and
then (about 1 value in 450 for ``log``, 1 in 20 for ``exp``). And ``@`` hands its products to
OpenBLAS, which picks its kernel, with its own order of additions and fused multiply-adds, per
CPU. Both made one seed's tables differ between machines: the beliefs and entropies of every
preset in the last bit, and, under the baselines preset, the robot's path (2026-11-28: an AVX-512
machine against the same one running OpenBLAS' Haswell kernels).

So every quantity that a simulated table depends on takes its logs and exponentials from the C
library, element by element (as Python's ``math`` and numpy's random generators do), and its
sums of products from numpy's own multiply and add loops, whose order of additions is fixed by
the shapes alone. What remains machine-dependent is the C library itself: glibc's ``log`` and
``exp`` take a fused multiply-add path on CPUs that have one, which every x86-64 CPU made since
2013 has (docs/run-folders.md).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import overload

import numpy as np

_NAN = math.nan


def _log_one(value: float) -> float:
    """``log`` of one number with numpy's answers outside the domain: ``-inf`` at 0, NaN below."""
    if value > 0.0:
        return math.log(value)
    return -math.inf if value == 0.0 else _NAN


def _log2_one(value: float) -> float:
    """``log2`` of one number with numpy's answers outside the domain (see :func:`_log_one`)."""
    if value > 0.0:
        return math.log2(value)
    return -math.inf if value == 0.0 else _NAN


def _exp_one(value: float) -> float:
    """``exp`` of one number; ``inf`` where it overflows (``math.exp`` raises there)."""
    try:
        return math.exp(value)
    except OverflowError:
        return math.inf


def _expm1_one(value: float) -> float:
    """``exp(x) - 1`` of one number; ``inf`` where it overflows."""
    try:
        return math.expm1(value)
    except OverflowError:
        return math.inf


def _positive(array: np.ndarray) -> bool:
    """Whether every element is a positive number (NaN is not): the logs' own domain."""
    return bool(array.min() > 0.0)


def _not_overflowing(array: np.ndarray) -> bool:
    """Whether no element is NaN or overflows ``exp`` (``e ** 709.78`` is the largest float's)."""
    return bool(array.max() < 709.0)


def _elementwise(one: Callable[[float], float], library: Callable[[float], float],
                 in_domain: Callable[[np.ndarray], bool], values: np.ndarray | float) -> np.ndarray | float:
    """``one`` of every element of ``values``, in its shape; a float for a number.

    Where every element is ``in_domain``, ``library`` (the C library's function itself, which
    gives ``one``'s values there) is mapped over them without a Python call per element.
    """
    if isinstance(values, float):  # a person's delay, drawn hundreds of times a trial set
        return one(values)
    array = np.asarray(values, dtype=float)
    if array.ndim == 0:
        return one(float(array))
    flat = array.ravel().tolist()
    results = map(library, flat) if array.size and in_domain(array) else map(one, flat)
    return np.fromiter(results, dtype=float, count=len(flat)).reshape(array.shape)


@overload
def log(values: float) -> float: ...
@overload
def log(values: np.ndarray) -> np.ndarray: ...


def log(values: np.ndarray | float) -> np.ndarray | float:
    """Natural log, elementwise, from the C library.

    Parameters
    ----------
    values
        ``(...)`` numbers; 0 gives ``-inf`` and a negative number NaN, as ``np.log`` (without
        its warnings).

    Returns
    -------
    np.ndarray or float
        ``(...)``; a float for a number or a 0-d array.
    """
    return _elementwise(_log_one, math.log, _positive, values)


@overload
def log2(values: float) -> float: ...
@overload
def log2(values: np.ndarray) -> np.ndarray: ...


def log2(values: np.ndarray | float) -> np.ndarray | float:
    """Base-2 log, elementwise, from the C library (:func:`log`'s conventions)."""
    return _elementwise(_log2_one, math.log2, _positive, values)


@overload
def exp(values: float) -> float: ...
@overload
def exp(values: np.ndarray) -> np.ndarray: ...


def exp(values: np.ndarray | float) -> np.ndarray | float:
    """``e ** x``, elementwise, from the C library; ``inf`` where it overflows, as ``np.exp``."""
    return _elementwise(_exp_one, math.exp, _not_overflowing, values)


@overload
def expm1(values: float) -> float: ...
@overload
def expm1(values: np.ndarray) -> np.ndarray: ...


def expm1(values: np.ndarray | float) -> np.ndarray | float:
    """``e ** x - 1``, elementwise, from the C library; ``inf`` where it overflows."""
    return _elementwise(_expm1_one, math.expm1, _not_overflowing, values)


def matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` without BLAS: numpy's multiply, then its add over the contracted axis.

    The additions' order depends on the shapes only, never on the CPU: over the last axis it is
    numpy's pairwise sum (the elements in turn below 8), over any other axis the elements in turn.
    A stacked product is each of its matrices' own product, whatever else is stacked with it.

    Parameters
    ----------
    a
        ``(K,)`` or ``(..., N, K)``.
    b
        ``(K,)`` or ``(..., K, M)``; leading axes broadcast with ``a``'s, as ``np.matmul``'s.

    Returns
    -------
    np.ndarray
        The shape of ``a @ b``.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.ndim == 0 or b.ndim == 0:
        raise ValueError("matmul needs arrays of at least one dimension, as np.matmul")
    if a.shape[-1] != b.shape[-2 if b.ndim > 1 else -1]:
        raise ValueError(f"matmul: shapes {a.shape} and {b.shape} do not share the contracted axis")
    if b.ndim == 1:
        return (a * b).sum(axis=-1)
    if a.ndim == 1:
        return (a[:, None] * b).sum(axis=-2)
    return (a[..., :, :, None] * b[..., None, :, :]).sum(axis=-2)
