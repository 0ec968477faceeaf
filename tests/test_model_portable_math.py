"""nudgecli.model.portable_math: the C library's functions element by element, sums of products in
an order set by the shapes alone, and nothing on the model's path that lets the CPU choose."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from nudgecli.model import portable_math

ROOT = Path(__file__).resolve().parents[1]

finite = st.floats(min_value=-800.0, max_value=800.0, allow_nan=False)
positive = st.floats(min_value=1e-300, max_value=1e300, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(hnp.arrays(float, hnp.array_shapes(min_dims=1, max_dims=3, max_side=5), elements=positive))
def test_logs_are_the_c_librarys_element_by_element(values: np.ndarray) -> None:
    logs, logs2 = portable_math.log(values), portable_math.log2(values)
    assert logs.shape == logs2.shape == values.shape
    for value, log, log2 in zip(values.ravel().tolist(), logs.ravel().tolist(), logs2.ravel().tolist(),
                                strict=True):
        assert log == math.log(value) and log2 == math.log2(value)


@settings(max_examples=60, deadline=None)
@given(hnp.arrays(float, hnp.array_shapes(min_dims=1, max_dims=3, max_side=5), elements=finite))
def test_exponentials_are_the_c_librarys_and_overflow_to_infinity(values: np.ndarray) -> None:
    exps, exps_m1 = portable_math.exp(values), portable_math.expm1(values)
    for value, e, e_m1 in zip(values.ravel().tolist(), exps.ravel().tolist(), exps_m1.ravel().tolist(),
                              strict=True):
        if value > 709.79:  # math.exp raises OverflowError there; numpy gives inf
            assert e == e_m1 == math.inf
        else:
            assert e == math.exp(value) and e_m1 == math.expm1(value)


def test_outside_the_domain_as_numpy() -> None:
    values = np.array([0.0, -0.0, -1.0, np.nan, np.inf])
    with np.errstate(divide="ignore", invalid="ignore"):
        np.testing.assert_array_equal(portable_math.log(values), np.log(values))
        np.testing.assert_array_equal(portable_math.log2(values), np.log2(values))
    np.testing.assert_array_equal(portable_math.exp(np.array([-np.inf, np.nan, 1e4])), [0.0, np.nan, np.inf])
    assert portable_math.expm1(1e4) == math.inf and portable_math.expm1(-np.inf) == -1.0


def test_numbers_give_floats_and_arrays_keep_their_shape() -> None:
    assert type(portable_math.log(2.0)) is float and portable_math.log(2.0) == math.log(2.0)
    assert type(portable_math.exp(np.float64(0.5))) is float
    assert type(portable_math.log(np.array(3.0))) is float
    assert portable_math.log(np.empty((0, 3))).shape == (0, 3)


shapes = st.tuples(st.integers(1, 3), st.integers(1, 7), st.integers(1, 4), st.integers(1, 3))


def _sequential(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` for 2-D arrays by loops: each entry's products added in turn (an independent
    rule: numpy's own order for fewer than 8 terms)."""
    out = np.zeros((a.shape[0], b.shape[1]))
    for i in range(a.shape[0]):
        for j in range(b.shape[1]):
            total = a[i, 0] * b[0, j]
            for k in range(1, a.shape[1]):
                total += a[i, k] * b[k, j]
            out[i, j] = total
    return out


@settings(max_examples=60, deadline=None)
@given(shapes, st.integers(0, 2**32 - 1))
def test_matmul_adds_fewer_than_eight_products_in_turn(shape: tuple[int, int, int, int], seed: int) -> None:
    stack, n, k, m = shape
    rng = np.random.default_rng(seed)
    a, b = rng.random((stack, n, k)), rng.random((stack, k, m))
    product = portable_math.matmul(a, b)
    assert product.shape == (stack, n, m)
    for s in range(stack):  # each stacked product is its own, bit for bit
        np.testing.assert_array_equal(product[s], _sequential(a[s], b[s]))
        np.testing.assert_array_equal(portable_math.matmul(a[s], b[s]), product[s])
    vector = rng.random(k)
    expected = _sequential(a[0], vector[:, None])[:, 0]
    np.testing.assert_array_equal(portable_math.matmul(a[0], vector), expected)
    np.testing.assert_array_equal(portable_math.matmul(vector, b[0]), _sequential(vector[None], b[0])[0])


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 40), st.integers(1, 30), st.integers(0, 2**32 - 1))
def test_matmul_is_numpys_product_to_rounding(k: int, m: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    a, b = rng.random((3, k)), rng.random((k, m))
    np.testing.assert_allclose(portable_math.matmul(a, b), a @ b, rtol=1e-13, atol=0)
    np.testing.assert_allclose(portable_math.matmul(a[0], b), a[0] @ b, rtol=1e-13, atol=0)
    np.testing.assert_allclose(portable_math.matmul(a, b[:, 0]), a @ b[:, 0], rtol=1e-13, atol=0)


def test_matmul_refuses_what_numpy_refuses() -> None:
    with pytest.raises(ValueError, match="contracted axis"):
        portable_math.matmul(np.ones((2, 3)), np.ones((2, 3)))
    with pytest.raises(ValueError, match="at least one dimension"):
        portable_math.matmul(np.float64(2.0), np.ones(3))


#: numpy functions with loops chosen by the CPU (AVX-512 versions that differ from the C library)
#: or handed to BLAS; the simulation's code takes them from portable_math instead.
_CPU_CHOSEN = {"log", "log2", "log10", "log1p", "exp", "exp2", "expm1", "power", "float_power", "arctan2",
               "arctan", "arcsin", "arccos", "tan", "tanh", "sinh", "cosh", "cbrt", "matmul", "dot",
               "tensordot", "inner", "vdot", "linalg"}
_SIMULATION = ("nudgecli/model", "nudgecli/sim", "nudgecli/runs")


def _cpu_chosen_uses(path: Path) -> list[str]:
    uses = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        where = f"{path.relative_to(ROOT)}:{getattr(node, 'lineno', 0)}"
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.MatMult):
            uses.append(f"{where} @")
        elif isinstance(node, ast.Attribute) and node.attr == "dot":
            uses.append(f"{where} .dot")
        elif (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "np"
              and node.attr in _CPU_CHOSEN - {"linalg"}):
            uses.append(f"{where} np.{node.attr}")
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            keywords = {keyword.arg for keyword in node.keywords}
            owner = node.func.value
            if (isinstance(owner, ast.Attribute) and owner.attr == "linalg"
                    and not (node.func.attr == "norm" and "axis" in keywords)):
                uses.append(f"{where} np.linalg.{node.func.attr}")  # a norm along an axis is numpy's sum
            elif node.func.attr == "einsum" and "optimize" in keywords:
                uses.append(f"{where} einsum(optimize=...)")  # an optimised einsum calls BLAS
    return uses


def test_the_simulation_takes_no_function_the_cpu_chooses() -> None:
    uses = [use for folder in _SIMULATION for path in sorted((ROOT / folder).rglob("*.py"))
            if path.name != "portable_math.py" for use in _cpu_chosen_uses(path)]
    assert uses == [], "use nudgecli.model.portable_math for these: " + ", ".join(uses)
