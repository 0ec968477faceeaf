"""``xlogy`` (the entropy terms) against an element-by-element loop over the C library's ``log`` and
against ``scipy.special.xlogy``, which it replaces in the model."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.special
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from nudgecli.model.log_terms import xlogy

SPECIAL = [0.0, -0.0, 1.0, -1.0, 0.5, 2.0, math.inf, -math.inf, math.nan, 5e-324, 1e-300, 1e300]


def libm_log(y: float) -> float:
    """The C library's log with its IEEE results where Python's math.log raises."""
    if math.isnan(y):
        return math.nan
    if y == 0:
        return -math.inf
    if y < 0:
        return math.nan
    return math.log(y)


def xlogy_loop(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``x log y``, 0 where ``x == 0`` and ``y`` is not NaN, one element at a time."""
    x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
    out = np.empty(x.shape)
    for index in np.ndindex(x.shape):
        xi, yi = float(x[index]), float(y[index])
        out[index] = 0.0 if xi == 0 and not math.isnan(yi) else xi * libm_log(yi)
    return out


def assert_same(actual: np.ndarray, expected: np.ndarray) -> None:
    """Bit for bit, signed zeros and NaN included: the logs are the C library's on every CPU (numpy's
    own SIMD log, on AVX-512, differs from it in the last bit now and then)."""
    actual, expected = np.broadcast_arrays(np.asarray(actual, dtype=float), np.asarray(expected, dtype=float))
    assert np.array_equal(np.isnan(actual), np.isnan(expected))
    numbers = ~np.isnan(expected)
    assert np.array_equal(np.signbit(actual[numbers]), np.signbit(expected[numbers]))
    assert np.array_equal(actual[numbers], expected[numbers])


floats = st.one_of(st.sampled_from(SPECIAL), st.floats(allow_nan=True, allow_infinity=True),
                   st.floats(0.0, 1.0))
arrays = hnp.arrays(np.float64, hnp.array_shapes(min_dims=0, max_dims=3, max_side=4), elements=floats)


def test_special_values_in_every_pairing():
    x, y = np.meshgrid(np.array(SPECIAL), np.array(SPECIAL), indexing="ij")
    with np.errstate(divide="ignore", invalid="ignore"):
        actual = xlogy(x, y)
    assert_same(actual, xlogy_loop(x, y))
    assert_same(actual, scipy.special.xlogy(x, y))
    assert xlogy(-0.0, 3.0) == 0.0 and not math.copysign(1.0, xlogy(-0.0, 3.0)) < 0  # +0, as scipy
    assert math.isnan(xlogy(0.0, math.nan)) and xlogy(0.0, math.inf) == 0.0 and xlogy(0.0, -1.0) == 0.0
    with np.errstate(divide="ignore"):  # numpy warns of the -inf (scipy does not)
        assert xlogy(2.0, 0.0) == -math.inf


@settings(max_examples=300, deadline=None)
@given(arrays, arrays)
def test_xlogy_is_the_loop_and_scipys_with_broadcasting(x, y):
    try:
        shape = np.broadcast_shapes(x.shape, y.shape)
    except ValueError:
        return
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        actual = xlogy(x, y)
        assert np.shape(actual) == shape
        assert_same(actual, xlogy_loop(x, y))
        assert_same(actual, scipy.special.xlogy(x, y))


@settings(max_examples=200, deadline=None)
@given(hnp.arrays(np.float64, hnp.array_shapes(min_dims=1, max_dims=3, max_side=5),
                  elements=st.one_of(st.just(0.0), st.floats(0.0, 1.0))))
def test_p_log_p_of_one_array_is_the_two_array_rule(p):
    # xlogy(p, p) takes its own path (no NaN test of y): the same values as two arrays
    actual = xlogy(p, p)
    assert_same(actual, xlogy(p, p.copy()))
    assert_same(actual, xlogy_loop(p, p))
    assert np.all(actual <= 0.0) and np.all(actual[p == 0] == 0.0)


@pytest.mark.parametrize(("x", "y"), [(2.0, 3.0), (0.0, 0.0), (np.float64(0.25), 0.5)])
def test_numbers_give_a_float(x, y):
    value = xlogy(x, y)
    assert type(value) is float
    assert value == (0.0 if x == 0 else float(x) * math.log(y))


def test_entropy_of_a_belief_in_nats():
    # H(uniform over 4) = log 4; a point mass has none (0 log 0 = 0)
    assert -xlogy(np.full(4, 0.25), np.full(4, 0.25)).sum() == pytest.approx(math.log(4), abs=1e-15)
    point = np.array([0.0, 1.0, 0.0])
    assert -xlogy(point, point).sum() == 0.0


@pytest.mark.parametrize(("shape", "axes"),
                         [((40, 30, 20), (2, 0, 1)), ((200, 5), (1, 0)), ((64, 9, 17), (1, 2, 0))])
def test_a_sum_over_p_log_p_adds_in_scipys_order_whatever_the_layout(shape, axes):
    # numpy sums pairwise along memory: an output laid out otherwise than scipy's ufunc lays it
    # out adds the same values in another order, and `nudge validate` moved in the last bit
    p = np.random.default_rng(3).uniform(size=shape).transpose(axes)  # not C-contiguous
    ours, scipys = xlogy(p, p), scipy.special.xlogy(p, p)
    assert ours.strides == scipys.strides
    for axis in range(p.ndim):
        assert np.array_equal(ours.sum(axis=axis), scipys.sum(axis=axis))
