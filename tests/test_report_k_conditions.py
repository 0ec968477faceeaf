"""Studies of k >= 2 conditions: the statistics against independent computations (scipy,
scikit-posthocs, a hand Holm), the bracket layout for up to six conditions, and `nudge analyze`
and `nudge plot` end to end on run folders of three and four conditions."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scikit_posthocs
import scipy.stats
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.text import Annotation, Text
from matplotlib.transforms import Bbox
from run_builders import synthetic_run

from nudgecli.cli import main
from nudgecli.model.conditions import not_applicable_metrics
from nudgecli.report.brackets import Bracket, assign_levels, bracket_levels, draw_brackets
from nudgecli.report.figures.boxplots import (
    BRACKET_LEVEL_HEIGHT_IN,
    FIGURE4_METRICS,
    METRIC_ROW_HEIGHT_IN,
    metrics_figure,
)
from nudgecli.report.figures.replication import forest_figure, power_figure
from nudgecli.report.letters import entry_letters
from nudgecli.report.participant_tests import pairwise_wilcoxon, participant_level_test
from nudgecli.report.replication import power_table, replication_rows, summarise
from nudgecli.report.stats import (
    ComparisonOptions,
    adjust_p_values,
    conover,
    epsilon_squared,
    kruskal_wallis,
    order_conditions,
)
from nudgecli.report.stats_document import compare_conditions, json_ready, stats_csv, stats_table

THREE = ("x", "y", "z")
FEW_RESAMPLES = ComparisonOptions(bootstrap_resamples=100)


def three_group_table(seed: int = 4, participants: int = 9, trials: int = 5) -> pd.DataFrame:
    """Trials of three conditions with different centres, ties (values rounded) and a participant effect."""
    rng = np.random.default_rng(seed)
    rows = []
    for p in range(participants):
        person = rng.normal(0, 0.8)
        for condition, shift in zip(THREE, (0.0, 0.7, 2.0), strict=True):
            for t in range(trials):
                rows.append({"participant": p, "condition": condition, "trial": t,
                             "value": round(10 + person + shift + rng.normal(0, 1.0), 1)})
    return pd.DataFrame(rows)


def hand_holm(p_values: list[float]) -> list[float]:
    """Holm's step-down adjustment written out: the i-th smallest of m times (m - i), running max, cap 1."""
    m = len(p_values)
    order = sorted(range(m), key=lambda i: p_values[i])
    adjusted = [0.0] * m
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p_values[i]))
        adjusted[i] = running
    return adjusted


def hand_rank_biserial(x: np.ndarray, y: np.ndarray) -> float:
    """Matched-pairs rank-biserial r from the signed ranks, counted pair by pair (ranks by pandas)."""
    d = pd.Series(x - y)
    d = d[d != 0]
    ranks = d.abs().rank(method="average")
    return float((ranks[d > 0].sum() - ranks[d < 0].sum()) / ranks.sum())


# --- statistics against independent computations ----------------------------------------------


def test_holm_by_hand() -> None:
    # sorted 0.005, 0.01, 0.03, 0.04 times 4, 3, 2, 1 = 0.02, 0.03, 0.06, 0.04 -> running max 0.06
    assert adjust_p_values([0.01, 0.04, 0.03, 0.005], "holm") == pytest.approx([0.03, 0.06, 0.06, 0.02])
    assert adjust_p_values([0.5, 0.6], "holm") == pytest.approx([1.0, 1.0])  # capped at 1
    # an undefined test (NaN) is not part of the family: m = 2 here
    got = adjust_p_values([0.01, math.nan, 0.04], "holm")
    assert got[0] == pytest.approx(0.02) and math.isnan(got[1]) and got[2] == pytest.approx(0.04)
    assert adjust_p_values([0.2, 0.01], "none") == pytest.approx([0.2, 0.01])
    assert adjust_p_values([0.03], "holm") == pytest.approx([0.03])
    rng = np.random.default_rng(1)
    for _ in range(20):
        p = list(rng.uniform(0, 0.2, size=int(rng.integers(2, 16))))
        assert adjust_p_values(p, "holm") == pytest.approx(hand_holm(p))


def test_kruskal_and_conover_agree_with_scipy_and_scikit_posthocs() -> None:
    data = three_group_table()
    groups = [data.loc[data["condition"] == c, "value"].to_numpy() for c in THREE]
    expected = scipy.stats.kruskal(*groups)
    got = kruskal_wallis(data, "value", THREE)
    assert got["statistic"] == pytest.approx(expected.statistic, rel=1e-12)
    assert got["p"] == pytest.approx(expected.pvalue, rel=1e-9)
    reference = scikit_posthocs.posthoc_conover(data, val_col="value", group_col="condition", p_adjust="holm")
    unadjusted = scikit_posthocs.posthoc_conover(data, val_col="value", group_col="condition")
    table = conover(data, "value", THREE, p_adjust="holm")
    assert [(r.a, r.b) for r in table.itertuples()] == [("x", "y"), ("x", "z"), ("y", "z")]
    for row in table.itertuples():
        assert row.p == pytest.approx(reference.loc[row.a, row.b], rel=1e-9)
        assert row.p_unadjusted == pytest.approx(unadjusted.loc[row.a, row.b], rel=1e-9)
    # epsilon-squared: H / (n - 1)
    n = len(data)
    assert epsilon_squared(expected.statistic, n) == pytest.approx(expected.statistic / (n - 1))


def test_friedman_and_pairwise_wilcoxon_agree_with_scipy_and_a_hand_holm() -> None:
    data = three_group_table()
    medians = data.groupby(["participant", "condition"])["value"].median().unstack()
    friedman = scipy.stats.friedmanchisquare(*(medians[c] for c in THREE))
    raw = {(a, b): scipy.stats.wilcoxon(medians[a], medians[b]) for a, b in itertools.combinations(THREE, 2)}
    holm = dict(zip(raw, hand_holm([r.pvalue for r in raw.values()]), strict=True))

    level, effect = participant_level_test(data, "value", THREE)
    assert level["test"] == "friedman" and level["statistic"] == pytest.approx(friedman.statistic)
    assert level["p"] == pytest.approx(friedman.pvalue)
    assert level["pairwise_test"] == "wilcoxon" and level["p_adjust"] == "holm"
    assert [(r["a"], r["b"]) for r in level["pairs"]] == list(raw)
    for row, size in zip(level["pairs"], effect["pairs"], strict=True):
        pair = (row["a"], row["b"])
        assert row["statistic"] == pytest.approx(raw[pair].statistic)
        assert row["p_unadjusted"] == pytest.approx(raw[pair].pvalue)
        assert row["p"] == pytest.approx(holm[pair])
        assert (size["a"], size["b"], size["name"]) == (*pair, "rank_biserial")
        assert size["value"] == pytest.approx(hand_rank_biserial(medians[pair[0]].to_numpy(),
                                                                 medians[pair[1]].to_numpy()))
    # the tidy function gives the same table
    tidy = pairwise_wilcoxon(data, "value", THREE)
    assert list(tidy.columns) == ["a", "b", "n_participants", "statistic", "p", "p_unadjusted",
                                  "rank_biserial"]
    assert list(tidy["p"]) == pytest.approx([holm[p] for p in raw])
    assert set(tidy["n_participants"]) == {9}


def test_pairwise_wilcoxon_uses_the_participants_with_every_condition() -> None:
    data = three_group_table()
    data = data[~((data["participant"] == 0) & (data["condition"] == "z"))]  # participant 0 misses z
    medians = data.groupby(["participant", "condition"])["value"].median().unstack().dropna()
    tidy = pairwise_wilcoxon(data, "value", THREE, p_adjust="none")
    assert set(tidy["n_participants"]) == {8}
    expected = scipy.stats.wilcoxon(medians["x"], medians["y"]).pvalue
    assert tidy.loc[0, "p"] == pytest.approx(expected)


@pytest.mark.parametrize("method", ["none", "bonferroni"])
def test_pairwise_wilcoxon_adjusts_by_the_asked_method(method: str) -> None:
    data = three_group_table()
    medians = data.groupby(["participant", "condition"])["value"].median().unstack()
    raw = [scipy.stats.wilcoxon(medians[a], medians[b]).pvalue for a, b in itertools.combinations(THREE, 2)]
    expected = raw if method == "none" else [min(1.0, 3 * p) for p in raw]  # Bonferroni by hand
    tidy = pairwise_wilcoxon(data, "value", THREE, p_adjust=method)
    assert list(tidy["p_unadjusted"]) == pytest.approx(raw)
    assert list(tidy["p"]) == pytest.approx(expected)


def test_friedman_needs_two_complete_participants() -> None:
    # one participant with every condition (the others miss z): no test, a note
    data = three_group_table()
    data = data[(data["participant"] == 0) | (data["condition"] != "z")]
    level, effect = participant_level_test(data, "value", THREE)
    assert level["n_participants"] == 1
    assert math.isnan(level["statistic"]) and math.isnan(level["p"]) and math.isnan(effect["value"])
    assert "fewer than two participants" in level["note"]


def test_stats_document_of_three_conditions_holds_every_pair() -> None:
    data = three_group_table()
    stats = json_ready(compare_conditions(data, ["value"], list(THREE), FEW_RESAMPLES))
    entry = stats["metrics"][0]
    groups = [data.loc[data["condition"] == c, "value"].to_numpy() for c in THREE]
    h = scipy.stats.kruskal(*groups).statistic
    assert entry["effect_size"]["kruskal_epsilon_squared"] == pytest.approx(h / (len(data) - 1))
    assert len(entry["participant_level"]["pairs"]) == len(entry["effect_size"]["pairs"]) == 3
    table = stats_table(stats)
    for row in table.to_dict("records"):
        pair = (row["a"], row["b"])
        test = next(r for r in entry["participant_level"]["pairs"] if (r["a"], r["b"]) == pair)
        size = next(r for r in entry["effect_size"]["pairs"] if (r["a"], r["b"]) == pair)
        assert row["pairwise_p"] == test["p"] and row["pairwise_effect_size"] == size["value"]
        assert row["participant_p"] == entry["participant_level"]["p"]  # the omnibus test stays
    header = stats_csv(table).splitlines()[0].split(",")
    assert header[-7:] == ["pairwise_test", "pairwise_statistic", "pairwise_p", "pairwise_p_unadjusted",
                           "pairwise_effect_size_name", "pairwise_effect_size", "epsilon_squared"]


def test_two_conditions_keep_the_document_they_always_had() -> None:
    data = three_group_table()
    data = data[data["condition"] != "z"]
    stats = json_ready(compare_conditions(data, ["value"], ["x", "y"], FEW_RESAMPLES))
    entry = stats["metrics"][0]
    assert set(entry["participant_level"]) == {"test", "aggregate", "statistic", "p", "n_participants",
                                               "dropped_participants", "note"}
    assert set(entry["effect_size"]) == {"name", "value", "a", "b"}
    assert set(entry["kruskal"]) == {"statistic", "p"}
    assert "pairwise_p" not in stats_csv(stats_table(stats))


def test_order_of_conditions_puts_the_paper_first() -> None:
    assert order_conditions(["blending", "control", "teleoperation", "disambiguation"]) == [
        "disambiguation", "control", "blending", "teleoperation"]
    # then the plan's / the experiment's order, then the rest by name (not by row order)
    given = ["hindsight", "control", "blending", "zeta", "alpha"]
    assert order_conditions(given, ["hindsight", "blending"]) == [
        "control", "hindsight", "blending", "alpha", "zeta"]
    assert order_conditions(["b", "c", "a"]) == order_conditions(["a", "c", "b"]) == ["a", "b", "c"]


# --- replications report every pair -----------------------------------------------------------


def test_replication_rows_judge_each_pair_by_its_own_participant_test() -> None:
    from nudgecli.report.plans import AnalysisPlan

    data = three_group_table()
    stats = json_ready(compare_conditions(data, ["value"], list(THREE), FEW_RESAMPLES))
    entries = pd.DataFrame([{"point": 0, "replication": r, "seed": r, "participants": 9, "analysis": "s"}
                            for r in range(2)])
    rows = replication_rows(entries, {"s": stats}, AnalysisPlan())
    assert len(rows) == 6 and list(dict.fromkeys(zip(rows["a"], rows["b"], strict=True))) == [
        ("x", "y"), ("x", "z"), ("y", "z")]
    pairs = {(r["a"], r["b"]): r for r in stats["metrics"][0]["participant_level"]["pairs"]}
    sizes = {(r["a"], r["b"]): r["value"] for r in stats["metrics"][0]["effect_size"]["pairs"]}
    for row in rows.to_dict("records"):
        pair = (row["a"], row["b"])
        assert row["participant_p"] == pairs[pair]["p"] and row["effect_size_name"] == "rank_biserial"
        assert row["participant_significant"] == (pairs[pair]["p"] < 0.05)
        assert row["participant_direction"] == np.sign(sizes[pair])
    power = power_table(rows)
    assert len(power) == 3 * 2  # every pair, at both levels
    # in the order of the conditions, not by name
    reordered = power_table(pd.concat([rows[rows["a"] == "y"], rows[rows["a"] == "x"]]))
    assert list(dict.fromkeys(zip(reordered["a"], reordered["b"], strict=True))) == [
        ("y", "z"), ("x", "y"), ("x", "z")]
    # power: a grid per level of test, a row per pair holding its power
    grids = power_figure(power).get_axes()
    assert [ax.get_title().split(" ")[0] for ax in grids] == ["participant", "trial"]
    labels = [t.get_text() for t in grids[0].get_yticklabels()]  # the rows are shared by both grids
    assert [label.split(" (")[0] for label in labels] == ["value: x - y", "value: x - z", "value: y - z"]
    for ax in grids:
        level = ax.get_title().split(" ")[0]
        cells = [float(t.get_text()) for t in ax.texts]
        assert cells == list(power.loc[power["level"] == level, "power"])
    # forest: a panel per metric, a row per pair with every replication and the pooled mean
    (forest,) = forest_figure(rows, summarise(rows)).get_axes()
    assert [t.get_text() for t in forest.get_yticklabels()] == ["x - y", "x - z", "y - z"]
    dots = np.concatenate([np.asarray(line.get_ydata()) for line in forest.lines if line.get_marker() == "o"])
    assert len(dots) == len(rows) and set(np.round(dots).astype(int)) == {0, 1, 2}


# --- brackets for up to six conditions ---------------------------------------------------------


def _segments(line: Line2D, ax) -> list[Bbox]:
    """The display-space boxes of a bracket's three segments (legs and bar)."""
    xy = ax.transData.transform(np.column_stack([line.get_xdata(), line.get_ydata()]))
    return [Bbox(np.array([np.minimum(p, q), np.maximum(p, q)])) for p, q in itertools.pairwise(xy)]


@st.composite
def comparisons(draw) -> tuple[int, list[tuple[int, int]]]:
    k = draw(st.integers(2, 6))
    all_pairs = list(itertools.combinations(range(k), 2))
    chosen = draw(st.lists(st.sampled_from(all_pairs), min_size=1, max_size=len(all_pairs), unique=True))
    return k, chosen


@settings(max_examples=40, deadline=None)
@given(comparisons(), st.sampled_from(["*", "**", "***"]))
def test_brackets_never_overlap_and_wider_spans_sit_higher(case: tuple[int, list[tuple[int, int]]],
                                                           stars: str) -> None:
    k, chosen = case
    spans = [(float(a), float(b)) for a, b in chosen]
    levels = assign_levels(spans)
    for i, j in itertools.combinations(range(len(spans)), 2):
        (l1, r1), (l2, r2) = spans[i], spans[j]
        if levels[i] == levels[j]:
            assert r1 < l2 or r2 < l1  # one level never holds overlapping or touching spans
        if l1 <= l2 and r2 <= r1 and (l1, r1) != (l2, r2):
            assert levels[i] > levels[j]  # a span holding another is drawn above it
        if l2 <= l1 and r1 <= r2 and (l1, r1) != (l2, r2):
            assert levels[j] > levels[i]
    # drawn: no star text touches another bracket's lines or stars, and all stay inside the figure
    fig = Figure(figsize=(2.4, 2.6))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    ax.scatter(np.repeat(np.arange(k), 5), np.random.default_rng(k).uniform(0, 10, 5 * k))
    names = [f"c{i}" for i in range(k)]
    positions = {c: float(i) for i, c in enumerate(names)}
    artists = draw_brackets(ax, positions, [Bracket(names[a], names[b], 0.001, stars) for a, b in chosen])
    assert bracket_levels(positions, [Bracket(names[a], names[b], 0.001, stars) for a, b in chosen]) == \
        max(levels) + 1
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    lines = [a for a in artists if isinstance(a, Line2D)]
    texts = [a for a in artists if isinstance(a, Text)]
    assert len(lines) == len(texts) == len(chosen)
    boxes = [t.get_window_extent(renderer) for t in texts]
    segments = [_segments(line, ax) for line in lines]
    for i, j in itertools.permutations(range(len(lines)), 2):
        assert not any(boxes[i].overlaps(s) for s in segments[j]), (chosen[i], chosen[j])
        assert not boxes[i].overlaps(boxes[j])
    top = ax.get_ylim()[1]
    assert all(max(line.get_ydata()) < top for line in lines)


def test_figure_rows_grow_with_the_bracket_levels() -> None:
    conditions = ["disambiguation", "control", "a", "b", "c", "d"]
    rng = np.random.default_rng(0)
    metrics = pd.DataFrame([{"condition": c, "completion_time": 20 + i + rng.normal()}
                            for i, c in enumerate(conditions) for _ in range(6)])
    every_pair = [{"a": a, "b": b, "p": 0.0001, "p_unadjusted": 0.0001}
                  for a, b in itertools.combinations(conditions, 2)]
    stats = {"conditions": conditions,
             "metrics": [{"metric": "completion_time", "kruskal": {"p": 1e-6}, "conover": every_pair}]}
    tall = metrics_figure(metrics, stats, ["completion_time"], comparisons="brackets")  # all 15 pairs
    plain = metrics_figure(metrics, None, ["completion_time"])
    assert plain.get_figheight() == METRIC_ROW_HEIGHT_IN
    assert tall.get_figheight() > METRIC_ROW_HEIGHT_IN
    # six conditions are lettered by default (one row of text, no levels); a reference condition's
    # five brackets all meet at it, five levels: one above the row's four
    assert metrics_figure(metrics, stats, ["completion_time"]).get_figheight() == METRIC_ROW_HEIGHT_IN
    assert metrics_figure(metrics, stats, ["completion_time"], reference="b").get_figheight() == \
        pytest.approx(METRIC_ROW_HEIGHT_IN + BRACKET_LEVEL_HEIGHT_IN)


# --- `nudge analyze` and `nudge plot` end to end -----------------------------------------------


def make_k_run(folder: Path, conditions: dict[str, int], n_participants: int = 6,
               trials_per_condition: int = 4, seed: int = 3) -> Path:
    """A small run folder of any conditions: ``conditions`` maps each condition to the steps it adds
    to every trial (and, per 200 of them, to its mode-switch rate)."""
    return synthetic_run(folder, conditions, n_participants=n_participants,
                         trials_per_condition=trials_per_condition, seed=seed, max_steps=30,
                         switch_probability=lambda extra: 0.05 + extra / 200)


@pytest.mark.parametrize("conditions, expected_order", [
    ({"teleoperation": 30, "control": 15, "disambiguation": 0},
     ["disambiguation", "control", "teleoperation"]),
    ({"mode-switch": 8, "hindsight": 20, "control": 15, "disambiguation": 0},
     ["disambiguation", "control", "hindsight", "mode-switch"]),
], ids=["three", "four"])
def test_analyze_and_plot_k_conditions_through_the_cli(tmp_path: Path, conditions: dict[str, int],
                                                       expected_order: list[str]) -> None:
    run = make_k_run(tmp_path / "run", conditions)
    runner = CliRunner()
    result = runner.invoke(main, ["analyze", str(run), "--format", "json", "--bootstrap", "200"])
    assert result.exit_code == 0, result.output
    stats = json.loads((run / "stats.json").read_text())
    assert stats["conditions"] == expected_order
    k = len(conditions)
    pairs = list(itertools.combinations(expected_order, 2))
    metrics = pd.read_csv(run / "metrics.csv")
    constant = not_applicable_metrics(expected_order)  # the model's table, what a run's analysis is given
    for entry in stats["metrics"]:
        assert [(r["a"], r["b"]) for r in entry["conover"]] == pairs
        name = entry["metric"]
        left_out = list(constant.get(name, ()))
        assert entry.get("not_applicable", []) == left_out
        assert all(entry["n"][c] is None and entry["median"][c] is None for c in left_out)
        compared = [c for c in expected_order if c not in left_out]
        compared_pairs = list(itertools.combinations(compared, 2))
        assert all(r["p"] is None for r in entry["conover"] if (r["a"], r["b"]) not in compared_pairs)
        values = metrics.dropna(subset=[name])
        values = values[values["condition"].isin(compared)]
        if values[name].nunique() < 2:
            continue
        groups = [values.loc[values["condition"] == c, name].astype(float) for c in compared]
        assert entry["kruskal"]["p"] == pytest.approx(scipy.stats.kruskal(*groups).pvalue)
        medians = values.groupby(["participant", "condition"])[name].median().unstack()
        medians = medians[compared].dropna()
        raw = [scipy.stats.wilcoxon(medians[a], medians[b]).pvalue if not np.all(medians[a] == medians[b])
               else math.nan for a, b in compared_pairs]
        defined = [p for p in raw if not math.isnan(p)]
        holm = iter(hand_holm(defined))
        expected = [next(holm) if not math.isnan(p) else None for p in raw]
        got = {(r["a"], r["b"]): r["p"] for r in entry["participant_level"]["pairs"]}
        assert [got[pair] for pair in compared_pairs] == pytest.approx(expected, nan_ok=True)
    completion = next(e for e in stats["metrics"] if e["metric"] == "completion_time")
    assert all(s["stars"] for s in completion["stars"][:k - 1])  # disambiguation is faster than each other
    summary = (run / "summary.md").read_text()
    assert "Friedman, then Wilcoxon signed-rank for every pair (holm adjustment)" in summary
    # up to three conditions a table of every pair per metric; four get a letter per condition
    assert summary.count("| Wilcoxon p (holm) | effect |") == (len(stats["metrics"]) if k <= 3 else 0)
    assert summary.count("| mean | letters |") == (0 if k <= 3 else len(stats["metrics"]))
    assert len(pd.read_csv(run / "stats.csv")) == len(stats["metrics"]) * len(pairs)

    result = runner.invoke(main, ["plot", str(run), "--formats", "png"])
    assert result.exit_code == 0, result.output
    assert (run / "figures" / "fig4.png").is_file()
    # the figure of the analysis: k slots in each panel, a box where the metric applies, "n/a" where it
    # does not; one bracket per starred pair (three conditions) or the letters of the pairs (four)
    fig = metrics_figure(metrics, stats, FIGURE4_METRICS)
    for ax, name in zip(fig.get_axes(), FIGURE4_METRICS, strict=True):
        entry = next(e for e in stats["metrics"] if e["metric"] == name)
        assert [t.get_text().split("\n")[0] for t in ax.get_xticklabels()][:1] == ["Disambiguation"]
        assert len(ax.get_xticks()) == k
        left_out = entry.get("not_applicable", [])
        marks = [t for t in ax.texts if not isinstance(t, Annotation)]  # not the "n=..." counts
        assert sorted(t.get_position()[0] for t in marks if t.get_text() == "n/a") == \
            [float(expected_order.index(c)) for c in left_out]
        starred = sorted(s["stars"] for s in entry["stars"] if s["stars"])
        stars_drawn = sorted(t.get_text() for t in marks if "*" in t.get_text())
        if k <= 3:
            assert stars_drawn == starred
            continue
        assert stars_drawn == []
        compared = [c for c in expected_order if c not in left_out]
        letters = entry_letters(entry, compared)
        assert {t.get_position()[0]: t.get_text() for t in marks if t.get_text() != "n/a"} == {
            float(expected_order.index(c)): letters[c] for c in compared}
    # with a reference condition: brackets of its pairs only
    if k > 3:
        referenced = metrics_figure(metrics, stats, FIGURE4_METRICS, reference="control")
        for ax, name in zip(referenced.get_axes(), FIGURE4_METRICS, strict=True):
            entry = next(e for e in stats["metrics"] if e["metric"] == name)
            expected_stars = sorted(s["stars"] for s in entry["stars"]
                                    if s["stars"] and "control" in (s["a"], s["b"]))
            assert sorted(t.get_text() for t in ax.texts if "*" in t.get_text()) == expected_stars


def test_analyze_orders_conditions_as_the_experiment_lists_them(tmp_path: Path) -> None:
    run = make_k_run(tmp_path / "run", {"teleoperation": 30, "blending": 10, "hindsight": 20})
    listed = ["teleoperation", "hindsight", "blending"]
    (run / "manifest.json").write_text(json.dumps(
        {"experiment": "baselines", "config": {"study": {"conditions": listed}}}))
    result = CliRunner().invoke(main, ["analyze", str(run), "--plan", "paper", "--bootstrap", "100"])
    assert result.exit_code == 0, result.output
    assert json.loads((run / "stats.json").read_text())["conditions"] == listed


def test_compare_real_and_simulated_tables_of_four_conditions(tmp_path: Path) -> None:
    rng = np.random.default_rng(7)
    names = ["teleoperation", "control", "blending", "disambiguation"]  # the real table's row order

    def table(offset: float) -> pd.DataFrame:
        return pd.DataFrame([{"participant": f"p{p}", "condition": c, "trial": t,
                              "completion_time": 20 + 3 * i + offset + rng.normal()}
                             for p in range(4) for i, c in enumerate(names) for t in range(3)])

    table(0.0).to_csv(tmp_path / "sim.csv", index=False)
    real = table(1.0)
    real.to_csv(tmp_path / "real.csv", index=False)
    result = CliRunner().invoke(main, ["compare", str(tmp_path / "sim.csv"), str(tmp_path / "real.csv"),
                                       "--format", "json", "--resamples", "100",
                                       "--out", str(tmp_path / "cmp"), "--formats", "png"])
    assert result.exit_code == 0, result.output
    document = json.loads((tmp_path / "cmp" / "compare.json").read_text())
    # the paper's conditions first, then the real table's order
    assert document["conditions"] == ["disambiguation", "control", "teleoperation", "blending"]
    rows = document["comparison"]
    assert [r["condition"] for r in rows] == document["conditions"]
    for row in rows:
        own = real[real["condition"] == row["condition"]]["completion_time"]
        assert row["n_real"] == len(own) and row["median_real"] == pytest.approx(own.median())
    assert (tmp_path / "cmp" / "compare.png").is_file()
    # the figure: one column per condition, the distances under each condition's name (narrow panels)
    from nudgecli.report.compare import CompareOptions, compare_sources
    from nudgecli.report.compare_figure import build_compare_figure

    compared = compare_sources(tmp_path / "sim.csv", tmp_path / "real.csv",
                               options=CompareOptions(resamples=20))
    axes = build_compare_figure(compared.trials, compared.table, compared.medians).get_axes()
    titles = [ax.get_title(loc="left") for ax in axes]
    assert [t.split("\n")[0] for t in titles] == document["conditions"]
    assert all(t.split("\n")[1].startswith("KS ") for t in titles)
