"""Holm and Bonferroni on arrays (nudgecli.report.p_adjust) against statsmodels' multipletests, bit
for bit: on hypothesis-drawn families with ties, NaNs and values near 1, on every shipped plan's
adjustment, and through Conover's test of four conditions."""

from __future__ import annotations

import gc
from unittest import mock

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from statsmodels.stats.multitest import multipletests

from nudgecli.report import p_adjust
from nudgecli.report.p_adjust import NATIVE_ADJUSTMENTS, bonferroni, holm
from nudgecli.report.plans import load_plan, plan_names
from nudgecli.report.stats import adjust_p_values, conover


def _statsmodels(values: np.ndarray, method: str) -> np.ndarray:
    """``multipletests`` over the defined values, NaN kept where it was (the family's rule); its
    ``gc.collect()`` skipped, which changes no number and took most of this file's time."""
    out = np.array(values, dtype=float)
    defined = np.isfinite(out)
    if defined.any():
        with mock.patch.object(gc, "collect", lambda: 0):
            out[defined] = multipletests(out[defined], method=method)[1]
    return out


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


# p-values as tests give them: a few repeated values (ties), exact 0 and 1, values just under 1
# whose multiples pass 1, and NaN for an undefined test
_p_value = st.one_of(
    st.sampled_from([0.0, 1e-12, 0.001, 0.01, 0.04, 0.05, 0.2, 0.25, 1 / 3, 0.5, 0.999999, 1.0]),
    st.floats(min_value=0.0, max_value=1.0, allow_nan=False),
    st.just(float("nan")),
)


@settings(max_examples=300, deadline=None)
@given(st.lists(_p_value, min_size=1, max_size=30), st.sampled_from(sorted(NATIVE_ADJUSTMENTS)))
def test_native_adjustments_are_statsmodels_bit_for_bit(values, method):
    family = np.array(values, dtype=float)
    assert _same_bits(adjust_p_values(family, method), _statsmodels(family, method))


def test_holm_by_hand_with_ties():
    # sorted 0.01, 0.02, 0.02, 0.5 times 4, 3, 2, 1 = 0.04, 0.06, 0.04, 0.5 -> running max 0.04,
    # 0.06, 0.06, 0.5: the two tied p-values share 0.06 (3 x 0.02, the larger multiplier)
    got = holm(np.array([0.02, 0.5, 0.01, 0.02]))
    assert got.tolist() == [3 * 0.02, 0.5, 4 * 0.01, 3 * 0.02]
    # sorted 0.1, 0.4, 0.45 times 3, 2, 1 = 0.3, 0.8, 0.45 -> running max 0.3, 0.8, 0.8
    assert holm(np.array([0.4, 0.1, 0.45])).tolist() == [0.8, 3 * 0.1, 0.8]
    # 0.6 x 2 = 1.2: the running maximum carries it to 0.7's place (not 0.7), both capped at 1
    assert holm(np.array([0.7, 0.6])).tolist() == [1.0, 1.0]


def test_bonferroni_by_hand():
    assert bonferroni(np.array([0.01, 0.3, 0.5])).tolist() == [0.03, 0.8999999999999999, 1.0]


@pytest.mark.parametrize("plan_name", plan_names())
def test_every_shipped_plans_adjustment_is_statsmodels(plan_name):
    method = load_plan(plan_name).stats.p_adjust
    rng = np.random.default_rng(39)
    for size in (1, 2, 3, 6, 10, 21):  # the pairs of 2 to 7 conditions, and one test
        # rounded to three decimals, so that the families have ties
        family = np.round(rng.uniform(0, 0.2, size=size), 3)
        assert _same_bits(adjust_p_values(family, method), _statsmodels(family, method))


def test_holm_does_not_collect_garbage(monkeypatch):
    # what made statsmodels' Holm slow: a gc.collect() per call, 0.1-0.2 s in a batch's process
    def refuse() -> int:
        raise AssertionError("gc.collect() called")

    monkeypatch.setattr(gc, "collect", refuse)
    assert adjust_p_values([0.01, 0.04, 0.03], "holm").tolist() == [0.03, 0.06, 0.06]


def test_conover_of_four_conditions_is_the_same_with_statsmodels_holm(monkeypatch):
    rng = np.random.default_rng(7)
    conditions = ["a", "b", "c", "d"]
    # rounded values: ties in the ranks, and several pairs with equal unadjusted p
    values = np.round(rng.normal(size=80) + np.repeat([0.0, 0.3, 0.3, 1.0], 20), 1)
    data = pd.DataFrame({"condition": np.repeat(conditions, 20), "value": values})
    native = conover(data, "value", conditions, p_adjust="holm")
    monkeypatch.setattr(p_adjust, "NATIVE_ADJUSTMENTS", {})
    monkeypatch.setattr("nudgecli.report.stats.NATIVE_ADJUSTMENTS", {})
    library = conover(data, "value", conditions, p_adjust="holm")
    assert _same_bits(native["p"].to_numpy(), library["p"].to_numpy())
    assert (native["p"] > native["p_unadjusted"]).any()  # the adjustment did something
