"""A metric's statistics read its rows once (``tidy_values``, passed down by ``analyze_metric``):
every number is the libraries' (scipy, scikit-posthocs, pandas) on the raw values, bit for bit,
with ties, missing values, conditions left out, and two to four conditions."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
import scikit_posthocs
import scipy.stats
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from nudgecli.report.cluster_bootstrap import bootstrap_median_differences, median_difference_intervals
from nudgecli.report.metric_rows import metric_rows
from nudgecli.report.participant_tests import (
    EXACT_MAX_N,
    SIGN_FLIP_MAX_N,
    _median_array,
    pairwise_wilcoxon,
    participant_level_test,
    participant_summaries,
    rank_biserial,
    signed_rank_test,
)
from nudgecli.report.stats import (
    ComparisonOptions,
    conover,
    conover_rows,
    describe,
    kruskal_wallis,
    tidy_values,
)
from nudgecli.report.stats_document import analyze_metric

OPTIONS = ComparisonOptions(bootstrap_resamples=200, seed=3)


def _trials(n_conditions: int, seed: int, *, categorical: bool = False) -> tuple[pd.DataFrame, list[str]]:
    """Trials of 6 participants: ``ties`` (few values), ``gaps`` (a third missing), ``flag`` (bool),
    ``partial`` (no value in the last condition)."""
    rng = np.random.default_rng(seed)
    conditions = [f"c{i}" for i in range(n_conditions)]
    n = 40 * n_conditions
    data = pd.DataFrame({"participant": rng.integers(0, 6, n), "condition": rng.choice(conditions, n)})
    data["ties"] = rng.integers(0, 5, n).astype(float) + (data["condition"] == conditions[0]).to_numpy()
    data["gaps"] = np.where(rng.random(n) < 0.3, np.nan, rng.gamma(2.0, 3.0, n).round(1))
    data["flag"] = rng.random(n) < 0.4
    data["partial"] = np.where(data["condition"] == conditions[-1], np.nan, rng.normal(size=n))
    if categorical:
        data["condition"] = data["condition"].astype("category")
    return data, conditions


def _same(a: object, b: object) -> bool:
    """Equal values and types, NaN equal to NaN, floats bit for bit."""
    if isinstance(a, dict) and isinstance(b, dict):
        return list(a) == list(b) and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list | tuple) and type(a) is type(b):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return type(a) is type(b) and a == b


@pytest.mark.parametrize("n_conditions", [2, 4])
@pytest.mark.parametrize("metric", ["ties", "gaps", "flag", "partial"])
def test_trial_level_tests_are_the_libraries_on_the_raw_values(n_conditions, metric):
    data, conditions = _trials(n_conditions, seed=n_conditions)
    kept = data[data[metric].notna()]
    groups = [kept.loc[kept["condition"] == c, metric].to_numpy(dtype=float) for c in conditions]
    if metric == "partial" and n_conditions == 2:  # a single condition with values: nothing to test
        assert math.isnan(kruskal_wallis(data, metric, conditions)["p"])
        assert all(math.isnan(r["p"]) for r in conover_rows(data, metric, conditions))
        return
    groups = [g for g in groups if g.size]
    kruskal = kruskal_wallis(data, metric, conditions)
    expected = scipy.stats.kruskal(*groups)
    assert (kruskal["statistic"], kruskal["p"]) == (float(expected.statistic), float(expected.pvalue))
    # the rows in the table's order, the groups in order of first appearance (as the analysis calls it)
    frame = pd.DataFrame({"value": kept[metric].to_numpy(dtype=float), "group": kept["condition"]})
    unadjusted = scikit_posthocs.posthoc_conover(frame, val_col="value", group_col="group", sort=False)
    adjusted = scikit_posthocs.posthoc_conover(frame, val_col="value", group_col="group", sort=False,
                                               p_adjust="holm")
    for row in conover_rows(data, metric, conditions):
        if row["b"] not in unadjusted:  # the condition without values
            assert math.isnan(row["p"]) and math.isnan(row["p_unadjusted"])
            continue
        assert row["p_unadjusted"] == unadjusted.loc[row["a"], row["b"]]
        assert row["p"] == adjusted.loc[row["a"], row["b"]]
    # the bootstrap's observed difference: the difference of the trial medians
    for row in median_difference_intervals(data, metric, conditions, resamples=100):
        a, b = (np.median(kept.loc[kept["condition"] == c, metric].to_numpy(dtype=float)) if (
            kept["condition"] == c).any() else math.nan for c in (row["a"], row["b"]))
        assert _same(row["difference"], float(a - b))


@pytest.mark.parametrize("n_conditions", [2, 3, 4])
@pytest.mark.parametrize("categorical", [False, True])
def test_every_statistic_is_the_same_from_the_shared_rows(n_conditions, categorical):
    data, conditions = _trials(n_conditions, seed=10 + n_conditions, categorical=categorical)
    for metric in ("ties", "gaps", "flag", "partial"):
        tidy = tidy_values(data, metric, conditions, "condition", "participant")
        assert kruskal_wallis(data, metric, conditions, tidy=tidy) == kruskal_wallis(data, metric, conditions)
        assert conover(data, metric, conditions, tidy=tidy).equals(conover(data, metric, conditions))
        assert _same(conover_rows(data, metric, conditions, tidy=tidy),
                     conover(data, metric, conditions).to_dict("records"))
        assert _same(participant_level_test(data, metric, conditions, tidy=tidy),
                     participant_level_test(data, metric, conditions))
        if n_conditions > 2:  # the document's pairs are the post-hoc table's rows, types and bits
            level, effect = participant_level_test(data, metric, conditions, tidy=tidy)
            rows = pairwise_wilcoxon(data, metric, conditions).to_dict("records")
            assert _same(level["pairs"], [{k: r[k] for k in ("a", "b", "statistic", "p", "p_unadjusted")}
                                          for r in rows])
            assert _same([p["value"] for p in effect["pairs"]], [r["rank_biserial"] for r in rows])
        table = bootstrap_median_differences(data, metric, conditions, resamples=150, seed=2)
        assert table.equals(bootstrap_median_differences(data, metric, conditions, resamples=150, seed=2,
                                                         tidy=tidy))
        assert _same(median_difference_intervals(data, metric, conditions, resamples=150, seed=2, tidy=tidy),
                     table.to_dict("records"))


@pytest.mark.parametrize("n_conditions", [3, 4])
def test_a_condition_left_out_leaves_the_others_as_if_it_were_absent(n_conditions):
    data, conditions = _trials(n_conditions, seed=20 + n_conditions)
    left_out = conditions[-1]
    entry = analyze_metric(data, "gaps", conditions, OPTIONS, not_applicable=[left_out])
    # the compared conditions' statistics are those of the table without the condition left out
    alone = analyze_metric(data[data["condition"] != left_out], "gaps", conditions[:-1], OPTIONS)
    for key in ("kruskal", "conover", "stars", "participant_level", "effect_size", "ci"):
        # (the entry adds the pairs of the condition left out, and the keys saying why)
        assert _same(_without(entry[key], left_out, alone[key]), alone[key]), key


def _without(value: object, condition: str, like: object) -> object:
    """``value`` without the pairs holding ``condition``, with the keys of ``like`` only."""
    if isinstance(value, dict) and isinstance(like, dict):
        return {k: _without(value[k], condition, like[k]) for k in like}
    if isinstance(value, list) and isinstance(like, list):
        kept = [v for v in value if not (isinstance(v, dict) and condition in (v.get("a"), v.get("b")))]
        return [_without(v, condition, w) for v, w in zip(kept, like, strict=False)] + kept[len(like):]
    return value


def _rank_biserial_by_scipy(x: np.ndarray, y: np.ndarray) -> float:
    """Kerby's formula on ``scipy.stats.rankdata`` of the nonzero ``|x - y|``."""
    d = np.asarray(x, dtype=float) - np.asarray(y, dtype=float)
    if d.size == 0:
        return math.nan
    d = d[d != 0]
    if d.size == 0:
        return 0.0
    ranks = scipy.stats.rankdata(np.abs(d))
    return float((ranks[d > 0].sum() - ranks[d < 0].sum()) / ranks.sum())


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(st.sampled_from([-2.0, -0.5, 0.0, 0.5, 1.0, 3.0, math.inf, math.nan]),
                          st.sampled_from([-1.0, 0.0, 0.5, 2.0])), max_size=14), st.floats(0.01, 100))
def test_rank_biserial_is_kerbys_formula_on_scipys_ranks(pairs_, scale):
    x = np.array([a * scale for a, _ in pairs_])
    y = np.array([b * scale for _, b in pairs_])
    with np.errstate(invalid="ignore"):
        expected = _rank_biserial_by_scipy(x, y)
        assert _same(rank_biserial(x, y), expected)


def test_importing_the_analysis_does_not_import_scipy_stats():
    # scipy.stats costs about 0.6 s of CPU: imported where a test runs, not by importing the modules
    code = ("import sys, nudgecli.report.replication, nudgecli.report.stats_document; "
            "print('scipy.stats' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def _grouped_medians(tidy: pd.DataFrame, conditions: list[str]) -> pd.DataFrame:
    """pandas' table of per-participant medians (the computation ``_median_array`` replaces)."""
    grouped = tidy.groupby(["participant", "condition"], observed=True)["value"]
    return grouped.median().unstack("condition").reindex(columns=conditions)


@pytest.mark.parametrize("participants", ["int", "str", "float", "missing"])
@pytest.mark.parametrize("values", ["ties", "normal", "gaps", "infinite", "huge"])
def test_median_array_is_pandas_grouped_median_bit_for_bit(participants, values):
    rng = np.random.default_rng(len(participants) * 7 + len(values))
    conditions = ["a", "b", "c"]
    n = 90
    codes = pd.Series(rng.integers(0, 7, n))
    data = pd.DataFrame({"condition": rng.choice([*conditions, "x"], n)})
    data["participant"] = {"int": codes, "float": codes * 1.5, "str": codes.map(lambda p: f"p{p}"),
                           "missing": codes.map(lambda p: None if p == 2 else f"p{p}")}[participants]
    data["value"] = {"ties": rng.integers(0, 3, n).astype(float), "normal": rng.normal(size=n),
                     "gaps": np.where(rng.random(n) < 0.5, np.nan, rng.normal(size=n)),
                     "infinite": rng.choice([0.0, 1.0, np.inf, -np.inf], n),
                     # (x + x) / 2 of a middle value would overflow: an odd group's median is x itself
                     "huge": rng.choice([1.6e308, 1.7e308, -1.7e308], n)}[values]
    tidy = tidy_values(data, "value", conditions, "condition", "participant")
    rows = metric_rows(data, "value", conditions, "condition", "participant")
    medians = _median_array(rows)
    assert medians is not None
    array, who = medians
    table = pd.DataFrame(array, index=pd.Index(rows.participant_labels.take(who), name="participant"),
                         columns=pd.Index(conditions, name="condition"))
    expected = _grouped_medians(tidy, conditions)
    pd.testing.assert_frame_equal(table, expected, check_exact=True)
    assert np.array_equal(np.signbit(table.to_numpy()), np.signbit(expected.to_numpy()))
    # and what the participant-level tests read: the participants with a value in every condition
    wide, _ = participant_summaries(data, "value", conditions)
    complete = expected.dropna()
    pd.testing.assert_frame_equal(wide, complete, check_exact=True)
    assert np.array_equal(np.signbit(wide.to_numpy()), np.signbit(complete.to_numpy()))


def test_median_array_leaves_signed_zeros_and_categorical_participants_to_pandas():
    # pandas' selection returns -0.0 here, a sort would give 0.0: the table is pandas'
    values = [1.0, -0.0, -0.0, 1.0, -0.0, 0.0, -0.0]
    data = pd.DataFrame({"participant": 0, "condition": "a", "value": values})
    tidy = tidy_values(data, "value", ["a"], "condition", "participant")
    assert _median_array(metric_rows(data, "value", ["a"], "condition", "participant")) is None
    wide, _ = participant_summaries(data, "value", ["a"])
    assert np.signbit(wide.iloc[0, 0]) == np.signbit(_grouped_medians(tidy, ["a"]).iloc[0, 0])
    data["participant"] = data["participant"].astype("category")
    data["value"] = np.abs(data["value"])
    assert _median_array(metric_rows(data, "value", ["a"], "condition", "participant")) is None
    wide, _ = participant_summaries(data, "value", ["a"])
    pd.testing.assert_frame_equal(wide, _grouped_medians(tidy_values(data, "value", ["a"], "condition",
                                                                     "participant"), ["a"]), check_exact=True)


def _describe_by_pandas(data: pd.DataFrame, metric: str, conditions: list[str]) -> pd.DataFrame:
    """The descriptives as one grouped table reindexed to the conditions (the computation
    ``descriptive_columns`` places without the table)."""
    grouped = tidy_values(data, metric, conditions, "condition").groupby("condition", observed=True)["value"]
    table = pd.DataFrame({"n": grouped.size(), "mean": grouped.mean(), "median": grouped.median(),
                          "q1": grouped.quantile(0.25), "q3": grouped.quantile(0.75)}).reindex(conditions)
    table["n"] = table["n"].fillna(0).astype(int)
    return table.rename_axis("condition").reset_index()


@pytest.mark.parametrize("n_conditions", [2, 4])
@pytest.mark.parametrize("categorical", [False, True])
def test_describe_is_the_grouped_table_bit_for_bit(n_conditions, categorical):
    data, conditions = _trials(n_conditions, seed=30 + n_conditions, categorical=categorical)
    data["empty"] = np.nan
    conditions = conditions[::-1]  # not in sorted order
    for metric in ("ties", "gaps", "flag", "partial", "empty"):
        pd.testing.assert_frame_equal(describe(data, metric, conditions),
                                      _describe_by_pandas(data, metric, conditions), check_exact=True)


@settings(max_examples=200, deadline=None)
@given(st.integers(1, EXACT_MAX_N + 3), st.integers(0, 2**32 - 1), st.sampled_from([1.0, 0.37, 1e-3, 13.1]))
def test_signed_rank_test_without_zeros_or_ties_is_scipys_exact_wilcoxon_bit_for_bit(n, seed, scale):
    # distinct nonzero magnitudes, any mix of signs: scipy's exact null distribution (n <= 50),
    # its normal approximation above
    rng = np.random.default_rng(seed)
    magnitudes = rng.permutation(np.arange(1, 3 * n + 1))[:n] * scale
    signs = np.where(rng.random(n) < rng.random(), -1.0, 1.0)
    y = rng.normal(size=n).round(2)
    x = y + magnitudes * signs
    d = x - y
    assume(np.unique(np.abs(d)).size == n and np.all(d != 0))  # (x - y may round a magnitude)
    expected = scipy.stats.wilcoxon(x, y)
    assert signed_rank_test(x, y) == (float(expected.statistic), float(expected.pvalue))


@settings(max_examples=200, deadline=None)
@given(st.integers(SIGN_FLIP_MAX_N + 1, 90), st.integers(0, 2**32 - 1),
       st.sampled_from(["zeros and ties", "distinct", "rounded", "scaled"]))
def test_signed_rank_test_with_zeros_ties_or_many_is_scipys_normal_approximation(n, seed, kind):
    rng = np.random.default_rng(seed)
    d = {"zeros and ties": rng.integers(-4, 5, n).astype(float), "distinct": rng.normal(size=n),
         "rounded": rng.normal(size=n).round(1), "scaled": rng.integers(-30, 31, n) * 0.37}[kind]
    y = rng.normal(size=n).round(3)
    x = y + d
    assume(not np.all(x == y))
    expected = scipy.stats.wilcoxon(x, y)
    assert signed_rank_test(x, y) == (float(expected.statistic), float(expected.pvalue))
