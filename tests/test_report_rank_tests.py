"""Kruskal-Wallis and Conover on arrays (nudgecli.report.rank_tests): the libraries' numbers bit
for bit, by hand on a small case, on every shipped plan's metrics and on random tables with ties;
the libraries where exactness is not guaranteed; and no library import before a test runs."""

from __future__ import annotations

import functools
import gc
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scikit_posthocs
import scipy.integrate
import scipy.stats
from hypothesis import given, settings
from hypothesis import strategies as st
from import_guard import run_refusing

from nudgecli.config import load_experiment
from nudgecli.report import rank_tests, stats
from nudgecli.report.plans import load_plan, plan_names
from nudgecli.runs.batch_tasks import metric_definitions, run_participant_task

ROOT = Path(__file__).resolve().parents[1]
SHIPPED_TABLES = ("results/paper/metrics.csv", "results/baselines/metrics.csv")


@pytest.fixture(autouse=True)
def _no_collection_per_adjustment(monkeypatch: pytest.MonkeyPatch) -> None:
    """statsmodels' Holm adjustment runs ``gc.collect()`` on every call (0.1-0.2 s each in a test
    session's heap); it changes no number, so these tests skip it."""
    monkeypatch.setattr(gc, "collect", lambda *args: 0)


def _same(a: float, b: float) -> bool:
    """Bit-for-bit equality of two floats (NaN equal to NaN)."""
    return (math.isnan(a) and math.isnan(b)) or a == b


def _library_kruskal(groups: list[np.ndarray]) -> tuple[float, float]:
    result = scipy.stats.kruskal(*groups)
    return float(result.statistic), float(result.pvalue)


def _library_conover(tidy: pd.DataFrame, p_adjust: str | None = None) -> pd.DataFrame:
    return scikit_posthocs.posthoc_conover(tidy, val_col="value", group_col="condition", sort=False,
                                           p_adjust=p_adjust)


def _assert_project_matches_libraries(data: pd.DataFrame, metric: str, conditions: list[str],
                                      p_adjust: str) -> None:
    """stats.kruskal_wallis and stats.conover against scipy and scikit-posthocs called directly."""
    tidy = stats.tidy_values(data, metric, conditions, "condition")
    groups = [g for g in (tidy.loc[tidy["condition"] == c, "value"].to_numpy() for c in conditions) if g.size]
    if len(groups) < 2 or np.unique(np.concatenate(groups)).size < 2:
        return
    ours = stats.kruskal_wallis(data, metric, conditions)
    h, p = _library_kruskal(groups)
    assert ours["statistic"] == h and ours["p"] == p, metric
    if len(tidy) <= len(groups):
        return
    raw = _library_conover(tidy)
    expected = _library_conover(tidy, None if p_adjust == "none" else p_adjust)
    upper = np.triu_indices(len(raw), 1)
    undefined = np.isnan(raw.to_numpy(dtype=float)[upper])
    if undefined.any() and not undefined.all() and p_adjust != "none":
        # a pair of equal mean ranks in groups of tied values is 0/0 (NaN); scikit-posthocs hands it
        # to statsmodels' multipletests, whose result is then undefined, where the project leaves an
        # undefined test out of the family (stats.adjust_p_values): adjusted by statsmodels alone
        from statsmodels.stats.multitest import multipletests

        matrix = raw.to_numpy(dtype=float, copy=True)
        family = matrix[upper]
        family[~undefined] = multipletests(family[~undefined], method=p_adjust)[1]
        matrix[upper] = family
        matrix.T[upper] = family
        expected = pd.DataFrame(matrix, index=raw.index, columns=raw.columns)
    for row in stats.conover(data, metric, conditions, p_adjust=p_adjust).itertuples():
        if row.a in expected.index and row.b in expected.index:
            assert _same(row.p, float(expected.loc[row.a, row.b])), (metric, row.a, row.b)
            assert _same(row.p_unadjusted, float(raw.loc[row.a, row.b])), (metric, row.a, row.b)


# --- by hand ------------------------------------------------------------------------------------

def _t_sf_by_quadrature(t: float, df: float) -> float:
    """P(T > t) for Student's t with ``df`` degrees of freedom, its density integrated numerically."""
    norm = math.gamma((df + 1) / 2) / (math.sqrt(df * math.pi) * math.gamma(df / 2))
    return scipy.integrate.quad(lambda x: norm * (1 + x * x / df) ** (-(df + 1) / 2), t, math.inf)[0]


def test_hand_solved_case_without_ties() -> None:
    # ranks 1..3 and 4..6: R = 6 and 15, H = 12/(6*7) (36/3 + 225/3) - 3*7 = 27/7 (no ties)
    h, p = rank_tests.kruskal_exact([np.array([1.0, 2.0, 3.0]), np.array([4.0, 5.0, 6.0])])
    assert h == pytest.approx(27 / 7, rel=1e-15)
    assert p == pytest.approx(math.erfc(math.sqrt(h / 2)), rel=1e-12)  # chi-squared, 1 df
    # Conover: S^2 = 6*7/12 = 3.5, mean ranks 2 and 5, D = (6 - 1 - 27/7) / (6 - 2) = 2/7,
    # t = 3 / sqrt(3.5 * (1/3 + 1/3) * 2/7) = 3 / sqrt(2/3)
    groups, matrix = rank_tests.conover_exact(np.array([4.0, 1, 5, 2, 6, 3]), np.array(list("babab" "a")))
    assert groups == ["b", "a"]  # the order of first appearance, as scikit-posthocs with sort=False
    t = 3 / math.sqrt(2 / 3)
    assert matrix[0, 1] == matrix[1, 0] == pytest.approx(2 * _t_sf_by_quadrature(t, 4), rel=1e-9)
    assert matrix[0, 0] == matrix[1, 1] == 1


def test_hand_solved_case_with_ties() -> None:
    # values 1 1 2 | 2 3 3: ranks 1.5 1.5 3.5 | 3.5 5.5 5.5, three pairs of ties (t^3 - t = 6 each)
    ranks, counts = rank_tests.average_ranks(np.array([1.0, 1, 2, 2, 3, 3]))
    assert ranks.tolist() == [1.5, 1.5, 3.5, 3.5, 5.5, 5.5] and counts.tolist() == [2, 2, 2]
    h, _ = rank_tests.kruskal_exact([np.array([1.0, 1, 2]), np.array([2.0, 3, 3])])
    raw = 12 / 42 * (6.5**2 / 3 + 14.5**2 / 3) - 21
    assert h == pytest.approx(raw / (1 - 18 / 210), rel=1e-14)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(-3, 3) | st.floats(-10, 10, allow_nan=False), min_size=1, max_size=60))
def test_average_ranks_are_rankdata(values: list[float]) -> None:
    array = np.array(values, dtype=float)
    ranks, counts = rank_tests.average_ranks(array)
    assert np.array_equal(ranks, scipy.stats.rankdata(array))
    assert np.array_equal(counts, np.unique(array, return_counts=True)[1])


# --- the libraries' bits ------------------------------------------------------------------------

@pytest.mark.parametrize("plan_name", plan_names())
def test_every_shipped_plan_gets_the_libraries_numbers(plan_name: str) -> None:
    """Each shipped plan's metrics, under its own definitions (a small smoke study) and in the
    shipped results' tables, tested as the plan tests them."""
    plan = load_plan(plan_name)
    config = load_experiment("smoke", ())
    simulated = pd.concat([run_participant_task(config, 5, i, metric_definitions(plan)).frame()
                           for i in range(config.study.participants)], ignore_index=True)
    tables = {"smoke": simulated} | {path: _shipped(path) for path in SHIPPED_TABLES}
    checked = 0
    for name, table in tables.items():
        conditions = stats.order_conditions(table["condition"], plan.conditions)
        for metric in plan.metrics.include:
            if metric in table.columns:
                case = (name, metric, tuple(conditions), plan.stats.p_adjust)
                if name == "smoke" or case not in _CHECKED:  # plans share the shipped tables' cases
                    _assert_project_matches_libraries(table, metric, conditions, plan.stats.p_adjust)
                    _CHECKED.add(case)
                checked += 1
    assert checked >= len(plan.metrics.include)


_CHECKED: set[tuple[str, str, tuple[str, ...], str]] = set()


@functools.cache
def _shipped(path: str) -> pd.DataFrame:
    return pd.read_csv(ROOT / path)


@st.composite
def tidy_frames(draw: st.DrawFn) -> pd.DataFrame:
    """A tidy table of 2-5 conditions, values from a few levels (many ties) or rounded floats."""
    k = draw(st.integers(2, 5))
    n = draw(st.integers(k + 1, 80))
    levels = draw(st.sampled_from([3, 6, 1000]))
    values = draw(st.lists(st.integers(0, levels - 1), min_size=n, max_size=n))
    scale = draw(st.sampled_from([1.0, 0.1, 7.3]))
    labels = draw(st.lists(st.sampled_from([f"c{i}" for i in range(k)]), min_size=n, max_size=n))
    return pd.DataFrame({"condition": labels, "value": np.array(values) * scale})


@settings(max_examples=60, deadline=None)
@given(tidy_frames(), st.sampled_from(["holm", "fdr_bh", "bonferroni", "none"]))
def test_random_tables_with_ties_get_the_libraries_numbers(tidy: pd.DataFrame, p_adjust: str) -> None:
    conditions = sorted(tidy["condition"].unique())
    _assert_project_matches_libraries(tidy, "value", conditions, p_adjust)
    if tidy["value"].nunique() >= 2 and tidy["condition"].nunique() >= 2:
        groups, matrix = rank_tests.conover_exact(tidy["value"].to_numpy(), tidy["condition"].to_numpy())
        expected = _library_conover(tidy)
        assert list(expected.index) == groups
        assert np.array_equal(expected.to_numpy(), matrix, equal_nan=True)


# --- where exactness is not guaranteed: the libraries -------------------------------------------

def test_beyond_the_exact_bound_the_libraries_are_called(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(3)
    tidy = pd.DataFrame({"condition": rng.choice(["a", "b", "c"], 40), "value": rng.integers(0, 5, 40) * 1.0})
    groups = [tidy.loc[tidy["condition"] == c, "value"].to_numpy() for c in "abc"]
    assert rank_tests.kruskal_exact(groups) is not None
    monkeypatch.setattr(rank_tests, "MAX_EXACT_OBSERVATIONS", 39)
    assert rank_tests.kruskal_exact(groups) is None
    assert rank_tests.conover_exact(tidy["value"].to_numpy(), tidy["condition"].to_numpy()) is None
    _assert_project_matches_libraries(tidy, "value", ["a", "b", "c"], "holm")


@pytest.mark.filterwarnings("ignore:divide by zero:RuntimeWarning", "ignore:invalid value:RuntimeWarning")
@pytest.mark.parametrize("p_adjust", ["holm", "fdr_bh", "hommel"])
def test_an_undefined_pair_is_left_out_of_the_adjusted_family(p_adjust: str) -> None:
    # groups of tied values, c0 and c2 of one mean rank: their Conover t is 0/0 (found by the
    # random tables above); the other pairs' adjusted p are those of a family of two
    tidy = pd.DataFrame({"condition": ["c0", "c1", "c2", "c0", "c1"], "value": [1.0, 2, 1, 1, 2]})
    _assert_project_matches_libraries(tidy, "value", ["c0", "c1", "c2"], p_adjust)
    rows = stats.conover(tidy, "value", ["c0", "c1", "c2"], p_adjust=p_adjust).set_index(["a", "b"])
    assert math.isnan(rows.loc[("c0", "c2"), "p"]) and not math.isnan(rows.loc[("c0", "c1"), "p"])


def test_infinite_values_go_to_the_libraries() -> None:
    groups = [np.array([1.0, 2.0, np.inf]), np.array([0.0, 3.0])]
    assert rank_tests.kruskal_exact(groups) is None
    assert rank_tests.conover_exact(np.concatenate(groups), np.array(list("aaabb"))) is None
    tidy = pd.DataFrame({"condition": list("aaabb"), "value": np.concatenate(groups)})
    _assert_project_matches_libraries(tidy, "value", ["a", "b"], "holm")


def test_an_inexact_cube_goes_to_the_libraries(monkeypatch: pytest.MonkeyPatch) -> None:
    """A vectorised power that missed an integer cube by a bit: the sums could differ, so no answer."""
    counts = np.array([1, 2, 3])
    assert rank_tests._exact_ties(counts) is not None
    real = rank_tests._float_cubes
    monkeypatch.setattr(rank_tests, "_float_cubes", lambda v: np.nextafter(real(v), np.inf))
    assert rank_tests._exact_ties(counts) is None


def test_the_statistics_module_loads_without_scipy_stats_or_scikit_posthocs() -> None:
    """The batch's parent imports the plans and statistics before its workers start: neither library
    may load there (about a second), and a test whose values are exact never needs them."""
    script = ("import numpy as np, pandas as pd\n"
              "from nudgecli.report import stats\n"
              "table = pd.DataFrame({'condition': list('aaabbbccc'), 'm': [1.0, 2, 2, 3, 4, 4, 9, 8, 7]})\n"
              "print(stats.kruskal_wallis(table, 'm', ['a', 'b', 'c'])['p'] > 0)\n"
              "print(stats.conover(table, 'm', ['a', 'b', 'c'], p_adjust='none')['p'].notna().all())\n")
    result = run_refusing(script, ["scipy.stats", "scikit_posthocs"])
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["True", "True"]


def test_every_fast_path_of_the_signed_rank_test_runs_without_scipy_stats() -> None:
    """A two-condition analysis (the paper's) never imports scipy.stats (about 0.5 s of CPU in the
    batch's parent, beside its workers): its Wilcoxon tests take the sign-flip (zeros or ties, n <=
    13), exact (n <= 50) or normal (the rest) path, each scipy's numbers (tests/test_report_stats.py)."""
    script = ("import numpy as np\n"
              "from nudgecli.report.participant_tests import signed_rank_test\n"
              "rng = np.random.default_rng(3)\n"
              "x = rng.normal(size=60)\n"
              "cases = [(np.array([1., 2, 2, 3, 0, 5]), np.zeros(6)), (x[:20], x[20:40]), (x[:55], x[5:])]\n"
              "print(all(0.0 <= signed_rank_test(a, b)[1] <= 1.0 for a, b in cases))\n")
    result = run_refusing(script, ["scipy.stats"])
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["True"]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 2), st.integers(-3, 3)), min_size=1, max_size=40), st.randoms())
def test_condition_mean_ranks_are_the_mean_of_scipys_ranks_whatever_the_order(
        rows: list[tuple[int, int]], shuffle: object) -> None:
    positions = np.array([p for p, _ in rows])
    values = np.array([float(v) for _, v in rows])
    means = rank_tests.condition_mean_ranks(values, positions, 4)  # condition 3 never has values
    ranks = scipy.stats.rankdata(values)
    for j in range(4):
        if (positions == j).any():
            assert means[j] == pytest.approx(ranks[positions == j].mean(), rel=1e-15)
        else:
            assert math.isnan(means[j])
    # every rank counted once: the rank sums add up to N (N + 1) / 2
    counts = np.bincount(positions, minlength=4)
    assert float(np.nansum(means * counts)) == pytest.approx(len(rows) * (len(rows) + 1) / 2)
    order = list(range(len(rows)))
    shuffle.shuffle(order)  # type: ignore[attr-defined]
    assert np.array_equal(rank_tests.condition_mean_ranks(values[order], positions[order], 4), means,
                          equal_nan=True)
