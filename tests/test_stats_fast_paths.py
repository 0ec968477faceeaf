"""The statistics of a metric, read from its rows as arrays (``nudgecli.report.metric_rows``), are
the libraries' own numbers bit for bit: each entry of ``analyze_metric`` is computed here again,
independently, on the raw table (pandas' grouped descriptives and per-participant medians,
``scipy.stats`` ranks, Kruskal-Wallis, Wilcoxon and Friedman, ``scikit_posthocs.posthoc_conover``,
and the cluster bootstrap by replicating the drawn participants' trials), on random tables with
ties, missing values, unequal groups, signed zeros, dropped participants and constant conditions."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
import scikit_posthocs
import scipy.stats

from nudgecli.report.metric_rows import metric_rows, tidy_values
from nudgecli.report.stats import ComparisonOptions, order_conditions
from nudgecli.report.stats_document import analyze_metric, json_ready

OPTIONS = ComparisonOptions(bootstrap_resamples=40, seed=5)
SCENARIOS = ("ties", "gaps", "dropped", "constant", "signed_zero", "strings", "single", "categorical", "many")


def _table(scenario: str) -> tuple[pd.DataFrame, list[str]]:
    """A random trial table of the scenario: ``participant, condition, value``."""
    rng = np.random.default_rng(SCENARIOS.index(scenario))
    k = {"gaps": 3, "constant": 3, "strings": 4}.get(scenario, 2)
    conditions = [f"c{i}" for i in range(k)]
    n = 24 * k
    people = {"single": 1, "many": 200}.get(scenario, 6)  # (200: participant codes of two bytes)
    n = 2400 if scenario == "many" else n
    data = pd.DataFrame({"participant": rng.integers(0, people, n),
                         "condition": rng.choice([*conditions, "other"], n, p=[0.9 / k] * k + [0.1])})
    data["value"] = rng.integers(0, 5, n).astype(float)  # ties
    if scenario in ("gaps", "strings", "single", "categorical", "many"):
        data["value"] = rng.gamma(2.0, 3.0, n).round(1)
        data.loc[rng.random(n) < 0.25, "value"] = np.nan
    if scenario == "dropped":  # one participant without a value of c1, one with no row of it
        data.loc[(data["participant"] == 1) & (data["condition"] == "c1"), "value"] = np.nan
        data = data[~((data["participant"] == 2) & (data["condition"] == "c1"))]
    if scenario == "constant":
        data.loc[data["condition"] == "c2", "value"] = 7.0
    if scenario == "signed_zero":
        data["value"] = rng.choice([-0.0, 0.0, 1.0, -1.5], n)
    if scenario == "strings":
        data["participant"] = "p" + data["participant"].astype(str)
        data = data.sample(frac=1.0, random_state=1)
    if scenario == "categorical":
        data["condition"] = data["condition"].astype("category")
    return data.reset_index(drop=True), conditions


def _same(a: object, b: object) -> bool:
    """Equal values and types, NaN equal to NaN, floats bit for bit (signed zeros too)."""
    if isinstance(a, float) and isinstance(b, float):
        return (math.isnan(a) and math.isnan(b)) or (a == b and math.copysign(1, a) == math.copysign(1, b))
    return type(a) is type(b) and a == b


def _valued(data: pd.DataFrame, conditions: list[str]) -> pd.DataFrame:
    rows = data[data["condition"].astype(str).isin(conditions) & data["value"].notna()]
    return rows.assign(condition=rows["condition"].astype(str))


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_descriptives_and_mean_ranks_are_pandas_and_scipy(scenario):
    data, conditions = _table(scenario)
    entry = analyze_metric(data, "value", conditions, OPTIONS)
    valued = _valued(data, conditions)
    grouped = valued.groupby("condition")["value"]
    for column, result in (("n", grouped.size()), ("mean", grouped.mean()), ("median", grouped.median()),
                           ("q1", grouped.quantile(0.25)), ("q3", grouped.quantile(0.75))):
        for c in conditions:
            expected = result.get(c, 0 if column == "n" else math.nan)
            assert _same(entry[column][c], expected.item() if hasattr(expected, "item") else expected), \
                (column, c)
    ranks = scipy.stats.rankdata(valued["value"].to_numpy())
    for c in conditions:
        chosen = (valued["condition"] == c).to_numpy()
        assert _same(entry["mean_rank"][c], float(ranks[chosen].mean()) if chosen.any() else math.nan)


ROW_ORDERS = ("own", "condition", "condition_descending", "participant", "shuffled")
PLAN_ORDERS = (("disambiguation", "control"), ("control", "disambiguation"),
               ("control", "disambiguation", "blending"), ("blending", "disambiguation", "control"))


def _ordered(order: str, categories: tuple[str, ...] | None) -> pd.DataFrame:
    """A trial table of three conditions (values of full precision) with its rows in ``order``, its
    conditions plain labels or categorical with the given (not alphabetical) categories."""
    rng = np.random.default_rng(11)
    n = 900
    data = pd.DataFrame({"participant": rng.integers(0, 12, n),
                         "condition": rng.choice(["disambiguation", "control", "blending"], n),
                         "value": rng.gamma(2.0, 3.0, n)})
    if order == "condition":
        data = data.sort_values(["condition", "participant"], kind="stable")
    elif order == "condition_descending":
        data = data.sort_values(["condition", "participant"], ascending=[False, True], kind="stable")
    elif order == "participant":
        data = data.sort_values("participant", kind="stable")
    elif order == "shuffled":
        data = data.sample(frac=1.0, random_state=2)
    if categories is not None:
        data["condition"] = pd.Categorical(data["condition"], categories=categories)
    return data.reset_index(drop=True)


@pytest.mark.parametrize("categories", (None, ("disambiguation", "control", "blending"),
                                        ("control", "blending", "disambiguation")))
@pytest.mark.parametrize("order", ROW_ORDERS)
def test_means_are_pandas_grouping_of_the_labels_in_any_row_order(order, categories):
    """A condition's mean is pandas' grouped mean of the labels themselves (plain labels sorted,
    categories in their order) bit for bit, whatever the order of the rows and of the plan's
    conditions: the grouped sum takes another path (and other last digits) when the groups come
    in another order through the rows."""
    data = _ordered(order, categories)
    for conditions in PLAN_ORDERS:
        tidy = tidy_values(data, "value", conditions, "condition")
        expected = tidy.groupby("condition", observed=True)["value"].mean()
        entry = analyze_metric(data, "value", list(conditions), OPTIONS)
        for c in conditions:
            assert _same(entry["mean"][c], float(expected[c])), (conditions, c)


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_trial_level_tests_are_scipy_and_scikit_posthocs(scenario):
    data, conditions = _table(scenario)
    entry = analyze_metric(data, "value", conditions, OPTIONS)
    valued = _valued(data, conditions)
    groups = [valued.loc[valued["condition"] == c, "value"].to_numpy() for c in conditions]
    if valued["value"].nunique() < 2:
        assert math.isnan(entry["kruskal"]["p"])
        return
    expected = scipy.stats.kruskal(*groups)
    assert _same(entry["kruskal"]["statistic"], float(expected.statistic))
    assert _same(entry["kruskal"]["p"], float(expected.pvalue))
    frame = valued[["value", "condition"]].reset_index(drop=True)
    unadjusted = scikit_posthocs.posthoc_conover(frame, val_col="value", group_col="condition", sort=False)
    adjusted = scikit_posthocs.posthoc_conover(frame, val_col="value", group_col="condition", sort=False,
                                               p_adjust="holm")
    for row in entry["conover"]:
        assert _same(row["p_unadjusted"], float(unadjusted.loc[row["a"], row["b"]]))
        assert _same(row["p"], float(adjusted.loc[row["a"], row["b"]]))


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_participant_level_test_is_scipy_on_pandas_medians(scenario):
    data, conditions = _table(scenario)
    level = analyze_metric(data, "value", conditions, OPTIONS)["participant_level"]
    valued = _valued(data, conditions)
    medians = valued.groupby(["participant", "condition"])["value"].median()
    wide = medians.unstack().reindex(columns=conditions)
    complete = wide.dropna()
    rows = data[data["condition"].astype(str).isin(conditions)]
    missing = [p for p in pd.unique(rows["participant"]) if p not in set(complete.index)]
    assert level["dropped_participants"] == (sorted(missing) if len(complete) else missing)
    assert level["n_participants"] == len(complete)
    columns = [complete[c].to_numpy() for c in conditions]
    if len(conditions) == 2 and len(complete) and not np.all(columns[0] == columns[1]):
        expected = scipy.stats.wilcoxon(*columns)
        assert (level["statistic"], level["p"]) == (float(expected.statistic), float(expected.pvalue))
    elif len(conditions) > 2 and len(complete) >= 2:
        expected = scipy.stats.friedmanchisquare(*columns)
        assert _same(level["statistic"], float(expected.statistic))
        assert _same(level["p"], float(expected.pvalue))


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_bootstrap_is_the_replicated_trials_medians(scenario):
    data, conditions = _table(scenario)
    intervals = analyze_metric(data, "value", conditions, OPTIONS)["ci"]["pairs"]
    valued = _valued(data, conditions).reset_index(drop=True)
    codes, people = pd.factorize(valued["participant"])  # draws name participants in order of appearance
    draws = np.random.default_rng(OPTIONS.seed).integers(0, len(people), (OPTIONS.bootstrap_resamples,
                                                                          len(people)))
    by_person = [np.flatnonzero(codes == p) for p in range(len(people))]
    values, labels = valued["value"].to_numpy(), valued["condition"].to_numpy()
    medians = {c: [] for c in conditions}
    for drawn in draws:
        trials = np.concatenate([by_person[p] for p in drawn])  # each drawn participant's trials
        for c in conditions:
            chosen = values[trials][labels[trials] == c]
            medians[c].append(np.median(chosen) if chosen.size else math.nan)
    tail = (1.0 - OPTIONS.bootstrap_level) / 2.0
    for row in intervals:
        differences = np.array(medians[row["a"]]) - np.array(medians[row["b"]])
        differences = differences[np.isfinite(differences)]
        assert row["valid_resamples"] == differences.size
        if differences.size:
            low, high = np.quantile(differences, [tail, 1.0 - tail])
            assert (row["low"], row["high"]) == (float(low), float(high))


@pytest.mark.parametrize("missing", [None, math.nan, pd.NA])
def test_bootstrap_leaves_out_the_trials_without_a_participant(missing):
    """A trial whose participant is missing (the Python API takes such a table) is drawn with no
    one, as the participant-level test's medians leave it out; the observed difference is the
    trial medians' difference of every trial, as the descriptives'. It raised ValueError
    ('list' argument must have no negative elements)."""
    data, conditions = _table("gaps")
    data["participant"] = data["participant"].astype(object)
    data.loc[[2, 5, 9, 30], "participant"] = missing
    entry = analyze_metric(data, "value", conditions, OPTIONS)
    valued = _valued(data, conditions).reset_index(drop=True)
    known = valued[valued["participant"].notna()].reset_index(drop=True)
    codes, people = pd.factorize(known["participant"])
    draws = np.random.default_rng(OPTIONS.seed).integers(0, len(people), (OPTIONS.bootstrap_resamples,
                                                                          len(people)))
    values, labels = known["value"].to_numpy(), known["condition"].to_numpy()
    tail = (1.0 - OPTIONS.bootstrap_level) / 2.0
    for row in entry["ci"]["pairs"]:
        a, b = (valued.loc[valued["condition"] == c, "value"] for c in (row["a"], row["b"]))
        assert _same(row["difference"], float(np.median(a) - np.median(b)))
        differences = []
        for drawn in draws:
            trials = np.concatenate([np.flatnonzero(codes == p) for p in drawn])
            chosen = [values[trials][labels[trials] == c] for c in (row["a"], row["b"])]
            if chosen[0].size and chosen[1].size:
                differences.append(np.median(chosen[0]) - np.median(chosen[1]))
        assert row["valid_resamples"] == len(differences)
        expected = np.quantile(differences, [tail, 1.0 - tail])
        assert (row["low"], row["high"]) == (float(expected[0]), float(expected[1]))
    complete = known.groupby("participant")["condition"].nunique() == len(conditions)
    assert entry["participant_level"]["n_participants"] == int(complete.sum())  # (likewise)


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_metric_rows_are_the_tidy_rows(scenario):
    data, conditions = _table(scenario)
    tidy = tidy_values(data, "value", conditions, "condition", "participant")
    rows = metric_rows(data, "value", conditions, "condition", "participant")
    if rows.participant_codes is not None:  # in the smallest type that holds them
        assert rows.participant_codes.dtype == (np.int16 if scenario == "many" else np.int8)
    assert np.array_equal(rows.values, tidy["value"].to_numpy(), equal_nan=False)
    assert [conditions[j] for j in rows.positions] == tidy["condition"].astype(str).tolist()
    if rows.participant_codes is not None:
        assert list(rows.participant_labels.take(rows.participant_codes)) == tidy["participant"].tolist()
    kept = rows.among(conditions[1:])
    expected = tidy_values(data, "value", conditions[1:], "condition", "participant")
    assert np.array_equal(kept.values, expected["value"].to_numpy())
    assert [conditions[1:][j] for j in kept.positions] == expected["condition"].astype(str).tolist()


def test_order_of_string_labels_is_that_of_each_label():
    labels = pd.Series(["blending", None, "control", "zeta", "disambiguation", "alpha", "control", None] * 5)
    as_strings = labels.astype(str)
    assert isinstance(as_strings.dtype, pd.StringDtype)  # the path read distinct labels only
    expected = order_conditions(list(as_strings), ("zeta",))
    assert order_conditions(as_strings, ("zeta",)) == expected
    assert expected == ["disambiguation", "control", "zeta", "alpha", "blending"]


def test_json_ready_of_plain_and_numpy_values():
    document = {"a": [1.5, -0.0, math.nan, math.inf, -math.inf, True, 3, "x", None],
                "b": (np.float64(math.nan), np.float64(2.5), np.int64(4), np.bool_(False)), 7: {"c": np.inf}}
    ready = json_ready(document)
    assert ready == {"a": [1.5, -0.0, None, None, None, True, 3, "x", None], "b": [None, 2.5, 4, False],
                     "7": {"c": None}}
    assert [type(v) for v in ready["a"]] == [float, float, type(None), type(None), type(None), bool, int, str,
                                             type(None)]
    assert [type(v) for v in ready["b"]] == [type(None), float, int, bool]
    assert math.copysign(1, ready["a"][1]) == -1
