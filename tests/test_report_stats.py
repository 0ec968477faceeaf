"""Statistics against textbook formulas and constructed data with known answers."""

from __future__ import annotations

import itertools
import math
import re
import statistics
from typing import Any

import numpy as np
import pandas as pd
import pytest
import scipy.stats
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from nudgecli.report import participant_tests
from nudgecli.report.cluster_bootstrap import _weighted_medians, bootstrap_median_differences
from nudgecli.report.participant_tests import (
    kendalls_w,
    participant_level_test,
    rank_biserial,
    sign_flip_rank_sums,
    signed_rank_test,
)
from nudgecli.report.stats import (
    ComparisonOptions,
    conover,
    describe,
    is_significant,
    kruskal_wallis,
    order_conditions,
    significance_stars,
)
from nudgecli.report.stats_document import (
    analyze_metric,
    compare_conditions,
    condition_table,
    json_ready,
    stats_table,
)
from nudgecli.report.summary import format_p, format_table, format_value

# Groups with many ties (within and across groups).
GROUPS = {
    "a": [1, 2, 2, 3, 5, 5, 5, 8],
    "b": [2, 3, 3, 4, 6, 7, 9, 9, 10],
    "c": [1, 1, 4, 5, 6, 6, 11],
}


def _average_ranks(values: np.ndarray) -> np.ndarray:
    """Ranks 1..N with tied values given the mean of the ranks they span (written out by hand)."""
    order = np.argsort(values, kind="stable")
    ranks = np.empty(len(values))
    position = 0
    while position < len(values):
        end = position
        while end + 1 < len(values) and values[order[end + 1]] == values[order[position]]:
            end += 1
        ranks[order[position:end + 1]] = (position + 1 + end + 1) / 2.0
        position = end + 1
    return ranks


def textbook_kruskal_conover(groups: dict[str, list[float]]) -> tuple[float, float, dict, dict]:
    """Kruskal-Wallis T and Conover's pairwise p from Conover, *Practical Nonparametric Statistics*,
    3rd ed. (Wiley, 1999), section 5.2.

    T = (1 / S^2) (sum_i R_i^2 / n_i - N (N + 1)^2 / 4), S^2 = (1 / (N - 1)) (sum of all R^2 -
    N (N + 1)^2 / 4) (the tie-corrected statistic), p from chi-square with k - 1 df; the multiple
    comparisons: t = |R_i / n_i - R_j / n_j| / sqrt(S^2 (N - 1 - T) / (N - k) (1 / n_i + 1 / n_j)),
    two-sided p from Student's t with N - k df. Holm's step-down adjustment on top.
    """
    names = list(groups)
    values = np.concatenate([np.asarray(groups[n], dtype=float) for n in names])
    labels = np.concatenate([[n] * len(groups[n]) for n in names])
    ranks = _average_ranks(values)
    big_n, k = len(values), len(names)
    rank_sums = {n: ranks[labels == n].sum() for n in names}
    sizes = {n: int((labels == n).sum()) for n in names}
    s2 = (np.sum(ranks**2) - big_n * (big_n + 1) ** 2 / 4) / (big_n - 1)
    t_stat = (sum(rank_sums[n] ** 2 / sizes[n] for n in names) - big_n * (big_n + 1) ** 2 / 4) / s2
    p_kw = scipy.stats.chi2.sf(t_stat, k - 1)
    raw = {}
    for a, b in itertools.combinations(names, 2):
        difference = abs(rank_sums[a] / sizes[a] - rank_sums[b] / sizes[b])
        scale = math.sqrt(s2 * (big_n - 1 - t_stat) / (big_n - k) * (1 / sizes[a] + 1 / sizes[b]))
        raw[a, b] = 2 * scipy.stats.t.sf(difference / scale, big_n - k)
    # Holm: sort ascending, multiply the i-th smallest (0-based) by m - i, running maximum, cap 1.
    ordered = sorted(raw, key=raw.get)
    holm, running = {}, 0.0
    for i, pair in enumerate(ordered):
        running = max(running, min(1.0, (len(raw) - i) * raw[pair]))
        holm[pair] = running
    return t_stat, p_kw, raw, holm


def _tidy(groups: dict[str, list[float]]) -> pd.DataFrame:
    rows = [{"participant": i % 3, "condition": name, "value": v}
            for name, values in groups.items() for i, v in enumerate(values)]
    return pd.DataFrame(rows)


@pytest.mark.parametrize("names", [("a", "b"), ("a", "b", "c")])
def test_kruskal_and_conover_match_the_textbook(names: tuple[str, ...]) -> None:
    groups = {n: GROUPS[n] for n in names}
    t_stat, p_kw, raw, holm = textbook_kruskal_conover(groups)
    data = _tidy(groups)
    kruskal = kruskal_wallis(data, "value", list(names))
    assert kruskal["statistic"] == pytest.approx(t_stat, rel=1e-12)
    assert kruskal["p"] == pytest.approx(p_kw, rel=1e-10)
    table = conover(data, "value", list(names), p_adjust="holm")
    assert [(r.a, r.b) for r in table.itertuples()] == list(itertools.combinations(names, 2))
    for row in table.itertuples():
        assert row.p_unadjusted == pytest.approx(raw[row.a, row.b], rel=1e-10)
        assert row.p == pytest.approx(holm[row.a, row.b], rel=1e-10)


def test_conover_adjusts_whatever_the_order_of_the_rows() -> None:
    # the table lists the conditions c, b, a; the pairs asked for are (a, b), (a, c), (b, c)
    _, _, raw, holm = textbook_kruskal_conover(GROUPS)
    reversed_rows = _tidy({name: GROUPS[name] for name in ("c", "b", "a")})
    table = conover(reversed_rows, "value", ["a", "b", "c"], p_adjust="holm")
    assert [(r.a, r.b) for r in table.itertuples()] == [("a", "b"), ("a", "c"), ("b", "c")]
    for row in table.itertuples():
        assert row.p_unadjusted == pytest.approx(raw[row.a, row.b], rel=1e-10)
        assert row.p == pytest.approx(holm[row.a, row.b], rel=1e-10)


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_conover_without_degrees_of_freedom_is_nan_without_a_warning() -> None:
    # one value per condition: n - k = 0 leaves Conover's t statistic no degrees of freedom
    table = conover(_tidy({"a": [1.0], "b": [2.0], "c": [5.0]}), "value", ["a", "b", "c"])
    assert table[["p", "p_unadjusted"]].isna().all().all()
    # one more value gives it one, and the test runs
    assert table.shape == (3, 4)
    assert np.isfinite(conover(_tidy({"a": [1.0, 1.5], "b": [2.0], "c": [5.0]}), "value",
                               ["a", "b", "c"])["p_unadjusted"]).all()


def test_conover_without_adjustment_reports_raw_p_twice() -> None:
    data = _tidy(GROUPS)
    table = conover(data, "value", ["a", "b", "c"], p_adjust="none")
    assert np.allclose(table["p"], table["p_unadjusted"])


def test_degenerate_groups_give_nan_not_errors() -> None:
    data = pd.DataFrame({"participant": [1, 1, 2, 2], "condition": ["a", "b", "a", "b"],
                         "value": [3.0, 3.0, 3.0, 3.0]})
    assert math.isnan(kruskal_wallis(data, "value", ["a", "b"])["p"])
    assert conover(data, "value", ["a", "b"])["p"].isna().all()


@pytest.mark.parametrize(("p", "comparison", "expected"), [
    (0.2, "<", ""), (0.05, "<", ""), (0.05, "<=", "*"), (0.049, "<", "*"), (0.01, "<", "*"),
    (0.01, "<=", "**"), (0.0099, "<", "**"), (0.001, "<", "**"), (0.001, "<=", "***"),
    (1e-9, "<", "***"), (math.nan, "<", ""),
])
def test_stars(p: float, comparison: str, expected: str) -> None:
    assert significance_stars(p, (0.05, 0.01, 0.001), comparison) == expected


def test_stars_only_when_kruskal_wallis_is_significant() -> None:
    data = _tidy({"a": list(range(10)), "b": list(range(20, 30))})
    entry = analyze_metric(data, "value", ["a", "b"], ComparisonOptions(bootstrap_resamples=100))
    assert entry["kruskal"]["p"] < 0.001 and entry["stars"] == [{"a": "a", "b": "b", "stars": "***"}]
    gated = analyze_metric(data, "value", ["a", "b"], ComparisonOptions(kruskal_alpha=1e-20,
                                                                     bootstrap_resamples=100))
    assert gated["conover"][0]["p"] < 0.001 and gated["stars"][0]["stars"] == ""
    assert is_significant(0.05, 0.05, "<=") and not is_significant(0.05, 0.05, "<")


@pytest.mark.parametrize(("comparison", "stars"), [("<", ""), ("<=", "***")])
def test_the_kruskal_gate_uses_the_star_comparison(comparison: str, stars: str) -> None:
    # alpha set to the Kruskal-Wallis p itself: p <= alpha passes the gate, p < alpha does not
    data = _tidy({"a": list(range(10)), "b": list(range(20, 30))})
    p = kruskal_wallis(data, "value", ["a", "b"])["p"]
    options = ComparisonOptions(kruskal_alpha=p, star_comparison=comparison, bootstrap_resamples=100)
    entry = analyze_metric(data, "value", ["a", "b"], options)
    assert entry["conover"][0]["p"] < 0.001 and entry["stars"][0]["stars"] == stars


def test_describe_per_condition() -> None:
    data = _tidy({"a": [1, 2, 3, 4, 100], "b": [5.0, 6.0]})
    table = describe(data, "value", ["b", "a"]).set_index("condition")
    assert list(table.index) == ["b", "a"]
    assert table.loc["a", "n"] == 5 and table.loc["a", "median"] == 3
    assert table.loc["a", "q1"] == 2 and table.loc["a", "q3"] == 4 and table.loc["a", "mean"] == 22


def test_describe_quartiles_are_linear_quantiles() -> None:
    # four values: the linear rule puts q1 a quarter of the way from 1 to 2 (numpy's default)
    data = _tidy({"a": [1.0, 2.0, 3.0, 4.0], "b": [10.0, 0.0, 5.0, 7.0, 1.0, 2.0]})
    table = describe(data, "value", ["a", "b"]).set_index("condition")
    assert table.loc["a", "q1"] == pytest.approx(1.75) and table.loc["a", "q3"] == pytest.approx(3.25)
    for name, values in (("a", [1.0, 2.0, 3.0, 4.0]), ("b", [10.0, 0.0, 5.0, 7.0, 1.0, 2.0])):
        q1, median, q3 = np.quantile(values, [0.25, 0.5, 0.75])
        assert (table.loc[name, "q1"], table.loc[name, "median"], table.loc[name, "q3"]) == pytest.approx(
            (q1, median, q3))


def test_rank_biserial_hand_case() -> None:
    # differences 1, -2, 3, 0: zero dropped, ranks of |d| 1, 2, 3 -> (1 + 3 - 2) / 6
    assert rank_biserial(np.array([2, 0, 5, 4]), np.array([1, 2, 2, 4])) == pytest.approx(1 / 3)
    assert rank_biserial(np.array([1.0]), np.array([1.0])) == 0.0
    assert math.isnan(rank_biserial(np.array([]), np.array([])))


def _shifted(n_participants: int = 8, shift: float = 2.0) -> pd.DataFrame:
    """Every trial of condition a is its twin in b plus ``shift``; participants differ in level."""
    rng = np.random.default_rng(3)
    rows = []
    for p in range(n_participants):
        base = rng.normal(10, 3, size=5)
        rows += [{"participant": p, "condition": "b", "value": v} for v in base]
        rows += [{"participant": p, "condition": "a", "value": v + shift} for v in base]
    return pd.DataFrame(rows)


def test_constant_shift_gives_rank_biserial_one_and_exact_interval() -> None:
    data = _shifted(shift=2.0)
    level, effect = participant_level_test(data, "value", ["a", "b"])
    assert level["test"] == "wilcoxon" and level["n_participants"] == 8
    assert level["dropped_participants"] == []
    assert effect == {"name": "rank_biserial", "value": 1.0, "a": "a", "b": "b"}
    assert level["p"] == pytest.approx(2 / 2**8)  # exact two-sided signed-rank p, all 8 positive
    reverse, _ = participant_level_test(data, "value", ["b", "a"])
    assert reverse["p"] == pytest.approx(level["p"])
    ci = bootstrap_median_differences(data, "value", ["a", "b"], resamples=500, seed=1)
    row = ci.iloc[0]
    assert row["difference"] == pytest.approx(2.0)
    assert row["low"] == pytest.approx(2.0) and row["high"] == pytest.approx(2.0)


def test_bootstrap_is_seeded_and_covers_the_true_shift() -> None:
    rng = np.random.default_rng(11)
    rows = []
    for p in range(12):
        level = rng.normal(0, 2)
        for _ in range(6):
            rows.append({"participant": p, "condition": "a", "value": level + 1.5 + rng.normal(0, 1)})
            rows.append({"participant": p, "condition": "b", "value": level + rng.normal(0, 1)})
    data = pd.DataFrame(rows)
    first = bootstrap_median_differences(data, "value", ["a", "b"], resamples=1000, seed=5)
    again = bootstrap_median_differences(data, "value", ["a", "b"], resamples=1000, seed=5)
    other = bootstrap_median_differences(data, "value", ["a", "b"], resamples=1000, seed=6)
    pd.testing.assert_frame_equal(first, again)
    assert not first[["low", "high"]].equals(other[["low", "high"]])
    row = first.iloc[0]
    assert row["low"] < 1.5 < row["high"]
    assert row["low"] <= row["difference"] <= row["high"]
    assert row["valid_resamples"] == 1000


def test_weighted_medians_equal_medians_of_replicated_samples() -> None:
    rng = np.random.default_rng(0)
    values = np.sort(rng.integers(0, 20, size=15).astype(float))
    owners = rng.integers(0, 5, size=15)
    weights = rng.integers(0, 3, size=(50, 5))
    weights[0] = 0  # an empty resample
    fast = _weighted_medians(values, owners, weights)
    assert math.isnan(fast[0])
    for r in range(1, 50):
        replicated = np.repeat(values, weights[r, owners])
        expected = np.median(replicated) if replicated.size else math.nan
        assert fast[r] == pytest.approx(expected, nan_ok=True)


@pytest.mark.parametrize("aggregate", ["median", "mean"])
def test_participant_level_test_summarises_by_the_chosen_aggregate(aggregate: str) -> None:
    # skewed trials: a participant's mean and median differ, and so do the paired differences
    trials = {0: ([1, 2, 9], [2, 2, 2]), 1: ([3, 4, 20], [5, 5, 6]), 2: ([0, 1, 2], [1, 1, 4]),
              3: ([6, 7, 30], [7, 8, 8]), 4: ([2, 2, 3], [4, 4, 4]), 5: ([5, 6, 40], [6, 7, 7])}
    rows = [{"participant": p, "condition": c, "value": float(v)}
            for p, pair in trials.items() for c, values in zip("ab", pair, strict=True) for v in values]
    summarise = statistics.mean if aggregate == "mean" else statistics.median
    a = [summarise(pair[0]) for pair in trials.values()]
    b = [summarise(pair[1]) for pair in trials.values()]
    level, effect = participant_level_test(pd.DataFrame(rows), "value", ["a", "b"], aggregate=aggregate)
    expected = scipy.stats.wilcoxon(a, b)
    assert level["aggregate"] == aggregate
    assert (level["statistic"], level["p"]) == pytest.approx((expected.statistic, expected.pvalue))
    assert effect["value"] == pytest.approx(rank_biserial(np.array(a), np.array(b)))


def test_participants_missing_a_condition_are_dropped_with_a_note() -> None:
    data = pd.concat([_shifted(n_participants=6),
                      pd.DataFrame({"participant": [99], "condition": ["a"], "value": [1.0]})])
    level, _ = participant_level_test(data, "value", ["a", "b"])
    assert level["n_participants"] == 6 and level["dropped_participants"] == [99]
    assert "99" in level["note"]


def test_three_conditions_use_friedman_and_kendalls_w() -> None:
    rows = []
    for p in range(6):
        for condition, offset in (("x", 0.0), ("y", 1.0), ("z", 2.0)):
            rows += [{"participant": p, "condition": condition, "value": p + offset + t / 10}
                     for t in range(3)]
    data = pd.DataFrame(rows)
    level, effect = participant_level_test(data, "value", ["x", "y", "z"])
    medians = data.groupby(["participant", "condition"])["value"].median().unstack()
    expected = scipy.stats.friedmanchisquare(medians["x"], medians["y"], medians["z"])
    assert level["test"] == "friedman"
    assert level["statistic"] == pytest.approx(expected.statistic)
    assert level["p"] == pytest.approx(expected.pvalue)
    assert effect["name"] == "kendall_w" and effect["value"] == pytest.approx(1.0)  # perfect agreement
    assert kendalls_w(6.0, 6, 3) == pytest.approx(0.5)


def test_stats_document_schema_and_tidy_table() -> None:
    data = _tidy(GROUPS).rename(columns={"value": "score"})
    data["other"] = data["score"] * 2
    stats = json_ready(compare_conditions(data, ["score", "other"], ["a", "b", "c"],
                                          ComparisonOptions(bootstrap_resamples=200)))
    assert list(stats) == ["conditions", "metrics"] and stats["conditions"] == ["a", "b", "c"]
    entry = stats["metrics"][0]
    assert list(entry) == ["metric", "n", "mean", "median", "q1", "q3", "mean_rank", "kruskal", "conover",
                           "p_adjust", "stars", "star_rule", "participant_level", "effect_size", "ci"]
    assert entry["star_rule"] == {"kruskal_alpha": 0.05, "thresholds": [0.05, 0.01, 0.001], "comparison": "<"}
    assert entry["n"] == {"a": 8, "b": 9, "c": 7}
    # the mean ranks of all trials ranked together (scipy's average ranks), each condition's mean
    pooled = np.concatenate([np.asarray(GROUPS[c], dtype=float) for c in ("a", "b", "c")])
    ranks = scipy.stats.rankdata(pooled)
    ends = np.cumsum([len(GROUPS[c]) for c in ("a", "b", "c")])
    expected = [ranks[start:end].mean() for start, end in zip([0, *ends[:-1]], ends, strict=True)]
    assert [entry["mean_rank"][c] for c in ("a", "b", "c")] == pytest.approx(expected, rel=1e-15)
    assert set(entry["kruskal"]) == {"statistic", "p"}
    assert all(set(r) == {"a", "b", "p", "p_unadjusted"} for r in entry["conover"])
    assert len(entry["ci"]["pairs"]) == 3
    table = stats_table(stats)
    assert len(table) == 6 and list(table["metric"]) == ["score"] * 3 + ["other"] * 3


def test_json_ready_turns_nan_into_null() -> None:
    assert json_ready({"x": [math.nan, np.float64(1.5), np.int64(2)], "y": {1: math.inf}}) == {
        "x": [None, 1.5, 2], "y": {"1": None}}


def test_order_conditions_prefers_the_plan_order() -> None:
    assert order_conditions(["control", "disambiguation", "x"], ["disambiguation", "control"]) == [
        "disambiguation", "control", "x"]
    assert order_conditions(["b", "a"]) == ["a", "b"]


def _printed_rows(text: str) -> tuple[list[str], list[list[str]]]:
    """Header and cells of :func:`format_table`'s text, cut at the columns its dash line marks."""
    lines = text.splitlines()
    starts = [m.start() for m in re.finditer(r"-+", lines[1])]
    bounds = [*starts[1:], None]

    def cut(line: str) -> list[str]:
        return [line[s:e].strip() for s, e in zip(starts, bounds, strict=True)]

    body = [line for line in lines[2:] if not line.startswith("(")]
    return cut(lines[0]), [cut(line) for line in body]


def _same(x: object, y: object) -> bool:
    """Equal, with missing (None or NaN) equal to missing."""
    def missing(v: object) -> bool:
        return v is None or (isinstance(v, float) and math.isnan(v))
    return (missing(x) and missing(y)) or x == y


@pytest.mark.parametrize("conditions", [["a"], ["a", "b"], ["a", "b", "c"]])
def test_tidy_table_round_trips_every_number_of_the_printed_table(conditions: list[str]) -> None:
    data = _tidy({c: GROUPS[c] for c in conditions}).rename(columns={"value": "score"})
    data["half"] = data["score"] / 2
    data["first_only"] = np.where(data["condition"] == conditions[0], data["score"], np.nan)
    metrics = ["score", "half", "first_only"]
    stats = json_ready(compare_conditions(data, metrics, conditions,
                                          ComparisonOptions(bootstrap_resamples=100)))
    table = stats_table(stats)
    header, rows = _printed_rows(format_table(table, conditions))
    # every printed cell from stats.json indexed here by hand, and the same value in the tidy table
    entries = {e["metric"]: e for e in stats["metrics"]}
    if len(conditions) == 1:
        assert header == ["metric", "n", "a median [q1, q3]", "mean"]
        assert [r[0] for r in rows] == metrics
        for row, tidy in zip(rows, table.to_dict("records"), strict=True):
            e = entries[row[0]]
            assert row[1] == str(e["n"]["a"]) and tidy["n_a"] == e["n"]["a"]
            assert row[2] == (f"{format_value(e['median']['a'])} [{format_value(e['q1']['a'])}, "
                              f"{format_value(e['q3']['a'])}]")
            assert row[3] == format_value(e["mean"]["a"])
            for key in ("median", "q1", "q3", "mean"):
                assert _same(tidy[f"{key}_a"], e[key]["a"])
        return
    expected_pairs = [(e["metric"], p["a"], p["b"]) for e in stats["metrics"] for p in e["ci"]["pairs"]]
    n_pairs = len(conditions) * (len(conditions) - 1) // 2
    assert len(rows) == len(table) == len(expected_pairs) == len(metrics) * n_pairs
    offset = 0 if len(conditions) == 2 else 1
    for row, tidy, (metric, a, b) in zip(rows, table.to_dict("records"), expected_pairs, strict=True):
        e = entries[metric]
        assert row[0] == metric and (offset == 0 or row[1] == f"{a} vs {b}")
        assert (tidy["metric"], tidy["a"], tidy["b"]) == (metric, a, b)
        for column, side in ((1, a), (2, b)):
            # a condition without values ("first_only") is left out of the metric: n/a
            assert row[offset + column] == ("n/a" if e["n"][side] is None else (
                f"{format_value(e['median'][side])} "
                f"[{format_value(e['q1'][side])}, {format_value(e['q3'][side])}]"))
        conover_p = next(r["p"] for r in e["conover"] if (r["a"], r["b"]) == (a, b))
        stars = next(r["stars"] for r in e["stars"] if (r["a"], r["b"]) == (a, b))
        pair = next(p for p in e["ci"]["pairs"] if (p["a"], p["b"]) == (a, b))
        if len(conditions) == 2:  # the participant-level test is the pair's
            level_p, effect = e["participant_level"]["p"], f"r={format_value(e['effect_size']['value'])}"
        else:  # the pair's own Wilcoxon test and rank-biserial r, not the omnibus Friedman p and W
            level = next(r for r in e["participant_level"]["pairs"] if (r["a"], r["b"]) == (a, b))
            size = next(r for r in e["effect_size"]["pairs"] if (r["a"], r["b"]) == (a, b))
            level_p, effect = level["p"], f"r={format_value(size['value'])}"
        own = [format_p(conover_p), stars or "ns", format_p(level_p), effect,
               f"{format_value(pair['difference'])} "
               f"[{format_value(pair['low'])}, {format_value(pair['high'])}]"]
        if e["n"][a] is None or e["n"][b] is None:  # the pair's own statistics are n/a
            own = ["n/a"] * 5
        assert row[offset + 3:] == [format_p(e["kruskal"]["p"]), *own]
        # the tidy table holds the same numbers, not only the same text
        for key, value in [("median_a", e["median"][a]), ("q1_a", e["q1"][a]), ("q3_a", e["q3"][a]),
                           ("median_b", e["median"][b]), ("q1_b", e["q1"][b]), ("q3_b", e["q3"][b]),
                           ("kruskal_p", e["kruskal"]["p"]), ("conover_p", conover_p), ("stars", stars),
                           ("participant_p", e["participant_level"]["p"]),
                           ("effect_size", e["effect_size"]["value"]), ("difference", pair["difference"]),
                           ("ci_low", pair["low"]), ("ci_high", pair["high"]),
                           ("ci_level", e["ci"]["level"])]:
            assert _same(tidy[key], value), key
    assert header[-1] == f"a-b [{stats['metrics'][0]['ci']['level']:.0%} CI]"
    # summary.md's per-condition rows: every condition of every metric, in stats.json's order
    per_condition = condition_table(table)
    assert list(zip(per_condition["metric"], per_condition["condition"], strict=True)) == [
        (m, c) for m in metrics for c in conditions]
    for row in per_condition.to_dict("records"):
        for key in ("n", "median", "q1", "q3", "mean"):
            assert _same(row[key], entries[row["metric"]][key][row["condition"]]), key


# --- Wilcoxon's signed-rank test with its exact sign-flip test vectorised --------------------------


def _brute_force_r_plus(d: list[float]) -> float:
    """R+ by loops: each positive difference's average rank among the nonzero |d| (a hand rule)."""
    magnitudes = [abs(v) for v in d if v != 0]
    total = 0.0
    for v in d:
        if v > 0:
            below = sum(1 for m in magnitudes if m < abs(v))
            tied = sum(1 for m in magnitudes if m == abs(v))
            total += below + (tied + 1) / 2  # ranks below+1 .. below+tied, averaged
    return total


@settings(max_examples=150, deadline=None)
@given(st.lists(st.integers(-3, 3), min_size=1, max_size=8))
def test_each_sign_flips_rank_sum_is_the_hand_rule(d: list[int]) -> None:
    values = [float(v) for v in d]
    # flip k negates the values whose bit is set in k: flip 0 is d itself, the last -d
    expected = [_brute_force_r_plus([-v if k >> i & 1 else v for i, v in enumerate(values)])
                for k in range(2 ** len(values))]
    assert sign_flip_rank_sums(np.array(values)).tolist() == expected


@settings(max_examples=120, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 4), st.integers(0, 4)), min_size=1, max_size=9),
       st.sampled_from([1.0, 0.5, 0.1]))
def test_signed_rank_test_is_scipys_wilcoxon_bit_for_bit(pairs_: list[tuple[int, int]], scale: float) -> None:
    # small integer scores: zeros and ties in most draws (scipy's exact sign-flip test), none in some
    x = np.array([a * scale for a, _ in pairs_])
    y = np.array([b * scale for _, b in pairs_])
    assume(not np.all(x == y))  # the callers leave that case out (scipy's test is undefined there)
    expected = scipy.stats.wilcoxon(x, y)
    assert np.array_equal(signed_rank_test(x, y), (float(expected.statistic), float(expected.pvalue)),
                          equal_nan=True)


@pytest.mark.parametrize("n", [13, 14])
def test_signed_rank_test_at_scipys_size_limit_of_the_sign_flip_test(n: int) -> None:
    # 13 differences with ties: the sign-flip test (2^13 flips); 14: scipy's normal approximation
    x = np.arange(n, dtype=float) % 5
    y = np.zeros(n)
    y[::3] = 1.0
    expected = scipy.stats.wilcoxon(x, y)
    assert signed_rank_test(x, y) == (float(expected.statistic), float(expected.pvalue))


def _signed_rank_cases() -> list[tuple[np.ndarray, np.ndarray]]:
    """Pairs for each of signed_rank_test's fast paths: ties among 7 (the sign-flip test), 20
    distinct nonzero differences (the exact test), ties among 60 (the normal approximation)."""
    rng = np.random.default_rng(3)
    tied = np.arange(7.0) % 3
    distinct = rng.permutation(np.arange(1.0, 21.0)) * rng.choice([-1.0, 1.0], 20)
    many = np.arange(60.0) % 7 - 2.0
    return [(tied, np.ones(7)), (distinct, np.zeros(20)), (many, np.zeros(60))]


def test_signed_rank_test_runs_scipys_wilcoxon_itself_on_an_unchecked_scipy(monkeypatch) -> None:
    wilcoxon = scipy.stats.wilcoxon
    calls: list[Any] = []

    def spy(x: np.ndarray, y: np.ndarray) -> Any:
        calls.append(wilcoxon(x, y))
        return calls[-1]

    monkeypatch.setattr(scipy.stats, "wilcoxon", spy)
    cases = _signed_rank_cases()
    # a checked series (add a new one to CHECKED_SCIPY_VERSIONS only after reading its source):
    # the fast paths run, scipy's wilcoxon does not
    monkeypatch.setattr(participant_tests, "installed_scipy_version", lambda: "1.17")
    fast = [signed_rank_test(x, y) for x, y in cases]
    assert calls == []
    monkeypatch.setattr(participant_tests, "installed_scipy_version", lambda: "1.14")
    unchecked = [signed_rank_test(x, y) for x, y in cases]
    assert len(calls) == len(cases)
    assert unchecked == [(float(r.statistic), float(r.pvalue)) for r in calls] == fast


@pytest.mark.parametrize(("version", "series"), [("1.17.1", "1.17"), ("1.17.2rc1", "1.17"),
                                                 ("1.16.0", "1.16"), ("2.0.0.dev0+git1234", "2.0")])
def test_the_scipy_series_is_major_and_minor(monkeypatch, version: str, series: str) -> None:
    import scipy

    monkeypatch.setattr(scipy, "__version__", version)
    assert participant_tests.installed_scipy_version() == series
