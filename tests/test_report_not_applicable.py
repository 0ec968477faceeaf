"""Metrics "not applicable" to some conditions: left out of every test of the metric (checked against
scipy and scikit-posthocs on the other conditions alone), shown as n/a in stats.json (null), stats.csv
(empty), the printed table, summary.md and the box plots; the run folder's mapping from the model's
conditions; a condition without values treated the same way."""

from __future__ import annotations

import io
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
from matplotlib.text import Annotation
from run_builders import synthetic_run

from nudgecli.cli import main
from nudgecli.model.conditions import not_applicable_metrics
from nudgecli.report.analysis import analyze
from nudgecli.report.figures.boxplots import metric_boxplot
from nudgecli.report.not_applicable import NO_TEST_NOTE, not_applicable_reasons
from nudgecli.report.participant_tests import rank_biserial
from nudgecli.report.plans import AnalysisPlan
from nudgecli.report.stats import ComparisonOptions
from nudgecli.report.stats_document import compare_conditions, json_ready, stats_csv, stats_table
from nudgecli.report.summary import format_summary, format_table

FOUR = ["w", "x", "y", "z"]
FEW = ComparisonOptions(bootstrap_resamples=200)


def four_groups(seed: int = 8, participants: int = 7, trials: int = 5) -> pd.DataFrame:
    """Trials of four conditions, rounded (ties) with a participant effect; ``z`` is constant 1.0, as a
    metric made constant by a condition's policy."""
    rng = np.random.default_rng(seed)
    rows = []
    for p in range(participants):
        person = rng.normal(0, 0.6)
        for condition, shift in zip(FOUR, (0.0, 0.8, 1.9, 0.0), strict=True):
            for t in range(trials):
                value = 1.0 if condition == "z" else round(5 + person + shift + rng.normal(0, 1), 1)
                rows.append({"participant": p, "condition": condition, "trial": t, "value": value})
    return pd.DataFrame(rows)


def hand_holm(p_values: list[float]) -> list[float]:
    m = len(p_values)
    order = sorted(range(m), key=lambda i: p_values[i])
    adjusted, running = [0.0] * m, 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p_values[i]))
        adjusted[i] = running
    return adjusted


def test_a_condition_left_out_is_out_of_every_test_of_the_metric() -> None:
    data = four_groups()
    stats = json_ready(compare_conditions(data, ["value"], FOUR, FEW, not_applicable={"value": ["z"]}))
    entry = stats["metrics"][0]
    kept = ["w", "x", "y"]
    groups = [data.loc[data["condition"] == c, "value"].to_numpy() for c in kept]
    # Kruskal-Wallis and epsilon-squared over the three others (H / (n - 1), n their trials)
    kruskal = scipy.stats.kruskal(*groups)
    assert entry["kruskal"]["statistic"] == pytest.approx(kruskal.statistic)
    assert entry["kruskal"]["p"] == pytest.approx(kruskal.pvalue)
    assert entry["effect_size"]["kruskal_epsilon_squared"] == pytest.approx(kruskal.statistic / (3 * 35 - 1))
    # Conover and its Holm family of three pairs, not six
    reference = scikit_posthocs.posthoc_conover(data[data["condition"] != "z"], val_col="value",
                                                group_col="condition", p_adjust="holm")
    for row in entry["conover"]:
        if "z" in (row["a"], row["b"]):
            assert row["p"] is None and row["p_unadjusted"] is None
        else:
            assert row["p"] == pytest.approx(reference.loc[row["a"], row["b"]])
    assert [(s["a"], s["b"]) for s in entry["stars"] if s["stars"] is None] == [
        ("w", "z"), ("x", "z"), ("y", "z")]
    # Friedman, Kendall's W and the pairwise Wilcoxon tests on the three others' participant medians
    medians = data.groupby(["participant", "condition"])["value"].median().unstack()
    friedman = scipy.stats.friedmanchisquare(*(medians[c] for c in kept))
    assert entry["participant_level"]["p"] == pytest.approx(friedman.pvalue)
    assert entry["effect_size"]["value"] == pytest.approx(friedman.statistic / (7 * 2))
    raw = {pair: scipy.stats.wilcoxon(medians[pair[0]], medians[pair[1]]).pvalue
           for pair in itertools.combinations(kept, 2)}
    holm = dict(zip(raw, hand_holm(list(raw.values())), strict=True))
    for row, size in zip(entry["participant_level"]["pairs"], entry["effect_size"]["pairs"], strict=True):
        pair = (row["a"], row["b"])
        if "z" in pair:
            assert row["p"] is None and size["value"] is None and size["name"] == "none"
        else:
            assert row["p"] == pytest.approx(holm[pair])
            assert size["value"] == pytest.approx(rank_biserial(medians[pair[0]], medians[pair[1]]))
    # intervals of the three others' pairs only; z's descriptives are null, its reason recorded
    intervals = entry["ci"]["pairs"]
    assert [p["low"] is None for p in intervals] == ["z" in (p["a"], p["b"]) for p in intervals]
    assert all(entry[key]["z"] is None for key in ("n", "mean", "median", "q1", "q3", "mean_rank"))
    assert entry["n"]["w"] == 35
    # the mean ranks: the three others' trials ranked together, without z's
    ranks = scipy.stats.rankdata(np.concatenate(groups))
    assert [entry["mean_rank"][c] for c in kept] == pytest.approx(
        [ranks[35 * j:35 * (j + 1)].mean() for j in range(3)], rel=1e-15)
    assert entry["not_applicable"] == ["z"] and entry["not_applicable_reasons"] == {"z": "not applicable"}


def test_the_same_statistics_as_an_analysis_of_the_others_alone() -> None:
    data = four_groups()
    left_out = json_ready(compare_conditions(data, ["value"], FOUR, FEW, not_applicable={"value": ["x"]}))
    alone = json_ready(compare_conditions(data[data["condition"] != "x"], ["value"], ["w", "y", "z"], FEW))
    entry, other = left_out["metrics"][0], alone["metrics"][0]
    assert entry["kruskal"] == other["kruskal"]
    assert entry["participant_level"]["statistic"] == other["participant_level"]["statistic"]
    for key in ("conover", "stars"):
        assert [r for r in entry[key] if "x" not in (r["a"], r["b"])] == other[key]
    kept_intervals = [r for r in entry["ci"]["pairs"] if "x" not in (r["a"], r["b"])]
    assert kept_intervals == other["ci"]["pairs"]  # the same participants resampled the same way


def test_two_left_with_more_conditions_get_their_pairs_wilcoxon() -> None:
    data = four_groups()
    stats = json_ready(compare_conditions(data, ["value"], FOUR, FEW,
                                          not_applicable={"value": ["x", "z"]}))
    entry = stats["metrics"][0]
    medians = data.groupby(["participant", "condition"])["value"].median().unstack()
    wilcoxon = scipy.stats.wilcoxon(medians["w"], medians["y"])
    (pair,) = [r for r in entry["participant_level"]["pairs"] if r["p"] is not None]
    assert (pair["a"], pair["b"]) == ("w", "y") and pair["p"] == pytest.approx(wilcoxon.pvalue)
    assert entry["participant_level"]["test"] == "wilcoxon"
    (size,) = [r for r in entry["effect_size"]["pairs"] if r["value"] is not None]
    assert size["value"] == pytest.approx(rank_biserial(medians["w"], medians["y"]))
    groups = [data.loc[data["condition"] == c, "value"] for c in ("w", "y")]
    assert entry["effect_size"]["kruskal_epsilon_squared"] == pytest.approx(
        scipy.stats.kruskal(*groups).statistic / (70 - 1))
    # the tidy table, stats.csv and the printed table carry the k-condition columns for every pair
    table = stats_table(stats)
    row = table[(table["a"] == "w") & (table["b"] == "y")]
    assert row["pairwise_p"].item() == pytest.approx(wilcoxon.pvalue)


def test_fewer_than_two_conditions_left_means_no_test() -> None:
    data = four_groups()
    stats = json_ready(compare_conditions(data, ["value"], FOUR, FEW,
                                          not_applicable={"value": ["w", "x", "y"]}))
    entry = stats["metrics"][0]
    assert entry["kruskal"] == {"statistic": None, "p": None}
    assert all(r["p"] is None for r in entry["conover"]) and len(entry["conover"]) == 6
    assert entry["participant_level"]["test"] == "none" and entry["participant_level"]["note"] == NO_TEST_NOTE
    assert entry["ci"]["method"] == "none" and all(r["difference"] is None for r in entry["ci"]["pairs"])
    assert entry["n"] == {"w": None, "x": None, "y": None, "z": 35} and entry["median"]["z"] == 1.0
    # two conditions, one left out: no test either
    two = json_ready(compare_conditions(data[data["condition"].isin(["w", "x"])], ["value"], ["w", "x"], FEW,
                                        not_applicable={"value": ["x"]}))["metrics"][0]
    assert two["kruskal"]["p"] is None
    assert two["conover"] == [{"a": "w", "b": "x", "p": None, "p_unadjusted": None}]
    summary = format_summary(stats_table(stats), FOUR, AnalysisPlan(), Path("t.csv"), n_trials=140,
                             n_participants=7, not_applicable={"value": entry["not_applicable_reasons"]})
    assert "No test: fewer than two conditions left to compare." in summary
    assert "Kruskal-Wallis H" not in summary


def test_a_condition_without_values_is_left_out_as_no_values() -> None:
    data = four_groups()
    data.loc[data["condition"] == "y", "value"] = math.nan
    stats = json_ready(compare_conditions(data, ["value"], FOUR, FEW, not_applicable={"value": ["z"]}))
    entry = stats["metrics"][0]
    assert entry["not_applicable"] == ["y", "z"]
    assert entry["not_applicable_reasons"] == {"y": "no values", "z": "not applicable"}
    groups = [data.loc[data["condition"] == c, "value"] for c in ("w", "x")]
    assert entry["kruskal"]["p"] == pytest.approx(scipy.stats.kruskal(*groups).pvalue)
    # by hand: counts 0 are "no values", listed ones "not applicable" whatever their count
    assert not_applicable_reasons({"a": 3, "b": 0, "c": 5}, ["a", "b", "c"], ["c"]) == {
        "b": "no values", "c": "not applicable"}
    assert not_applicable_reasons({"a": 3, "b": 1}, ["a", "b"]) == {}


def test_without_conditions_left_out_the_document_is_the_one_it_always_was() -> None:
    data = four_groups()
    plain = compare_conditions(data, ["value"], FOUR, FEW)
    assert json_ready(plain) == json_ready(compare_conditions(data, ["value"], FOUR, FEW,
                                                              not_applicable={"other_metric": ["z"]}))
    assert "not_applicable" not in plain["metrics"][0] and "not_applicable_reasons" not in plain["metrics"][0]


def test_stats_csv_printed_table_and_summary_show_n_a() -> None:
    data = four_groups()
    stats = json_ready(compare_conditions(data, ["value"], FOUR, FEW, not_applicable={"value": ["z"]}))
    table = stats_table(stats)
    csv = pd.read_csv(io.StringIO(stats_csv(table)), dtype=str, keep_default_na=False)
    held = csv[csv["b"] == "z"]
    assert len(held) == 3 and set(held["n_b"]) == {""} and set(held["conover_p"]) == {""}
    assert set(held["stars"]) == {""} and set(held["ci_low"]) == {""}
    assert set(csv.loc[csv["b"] == "y", "n_b"]) == {"35"}  # counts stay integers beside empty cells
    printed = format_table(table, FOUR)
    rows = [line for line in printed.splitlines() if " vs z" in line]
    # median, Conover, stars, the pair's own Wilcoxon p and r, CI
    assert len(rows) == 3 and all(line.count("n/a") == 6 for line in rows)
    summary = format_summary(table, FOUR, AnalysisPlan(), Path("t.csv"), n_trials=140, n_participants=7,
                             not_applicable={"value": stats["metrics"][0]["not_applicable_reasons"]})
    assert "Left out of the tests: z (not applicable)." in summary
    assert "| z | n/a | n/a | n/a | n/a |" in summary  # letters too: four conditions
    # two conditions, one without values: the pair's own participant-level test is n/a as well
    two = data[data["condition"].isin(["w", "x"])].copy()
    two.loc[two["condition"] == "x", "value"] = math.nan
    small = stats_table(json_ready(compare_conditions(two, ["value"], ["w", "x"], FEW)))
    (line,) = format_table(small, ["w", "x"]).splitlines()[2:]
    assert line.split()[4:] == ["n/a", "-", "n/a", "n/a", "n/a", "n/a", "n/a"]


# --- the run folder: the mapping comes from the model's conditions --------------------------------


def make_run(folder: Path) -> Path:
    return synthetic_run(folder, {"disambiguation": 0, "control": 15, "teleoperation": 30, "blending": 8},
                         n_participants=5, trials_per_condition=4, seed=6, max_steps=30,
                         switch_probability=lambda extra: 0.05 + extra / 200)


def test_a_run_folder_is_analysed_with_the_models_mapping(tmp_path: Path) -> None:
    run = make_run(tmp_path / "run")
    result = analyze(run, out=tmp_path / "out", bootstrap=100)
    expected = not_applicable_metrics(result.stats["conditions"])
    # what the model says of these, in the conditions' order (the paper's, then by name)
    assert expected["human_effort"] == ("blending", "teleoperation")
    for entry in result.stats["metrics"]:
        assert entry.get("not_applicable", []) == list(expected.get(entry["metric"], ()))
    # the same trials as a metrics table: no mapping (only conditions without values are left out)
    table = tmp_path / "metrics.csv"
    result.metrics.to_csv(table, index=False)
    from_table = analyze(table, out=tmp_path / "table-out", bootstrap=100)
    effort = next(e for e in from_table.stats["metrics"] if e["metric"] == "human_effort")
    assert "not_applicable" not in effort and effort["n"]["teleoperation"] == 20
    # an explicit mapping wins over the model's
    mine = analyze(run, out=tmp_path / "mine", bootstrap=100, not_applicable={"mode_switches": ["control"]})
    assert [e["metric"] for e in mine.stats["metrics"] if e.get("not_applicable")] == ["mode_switches"]


def test_analyze_prints_and_writes_n_a_in_every_format(tmp_path: Path) -> None:
    run = make_run(tmp_path / "run")
    runner = CliRunner()
    result = runner.invoke(main, ["analyze", str(run), "--bootstrap", "100", "--format", "json"])
    assert result.exit_code == 0, result.output
    printed = json.loads(result.stdout)
    effort = next(e for e in printed["metrics"] if e["metric"] == "human_effort")
    assert effort["median"]["teleoperation"] is None
    assert effort["not_applicable"] == ["blending", "teleoperation"]
    assert json.loads((run / "stats.json").read_text()) == printed
    result = runner.invoke(main, ["analyze", str(run), "--bootstrap", "100", "--format", "csv"])
    assert result.exit_code == 0, result.output
    rows = pd.read_csv(io.StringIO(result.stdout))
    held = rows[(rows["metric"] == "human_effort") & (rows["b"] == "teleoperation")]
    assert held["conover_p"].isna().all() and held["n_b"].isna().all()
    result = runner.invoke(main, ["analyze", str(run), "--bootstrap", "100"])
    assert result.exit_code == 0, result.output
    line = next(r for r in result.stdout.splitlines()
                if r.startswith("human_effort") and "vs teleoperation" in r)
    assert "n/a" in line
    summary = (run / "summary.md").read_text()
    assert "Left out of the tests: blending (not applicable), teleoperation (not applicable)." in summary


def test_the_box_plot_shows_n_a_and_no_box_in_the_slot(tmp_path: Path) -> None:
    data = four_groups()
    stats = json_ready(compare_conditions(data, ["value"], FOUR, FEW, not_applicable={"value": ["x"]}))
    drawn = metric_boxplot(data, "value", stats["metrics"][0], conditions=FOUR)
    assert set(drawn.boxes) == {"w", "y", "z"} and set(drawn.points) == {"w", "y", "z"}
    (mark,) = drawn.not_applicable
    assert mark.get_text() == "n/a" and mark.get_position() == (1.0, 0.5)  # x's slot, mid-height
    labels = [t.get_text() for t in drawn.ax.texts if isinstance(t, Annotation)]
    assert labels == ["n=35", "n/a", "n=35", "n=35"]
    # four conditions: letters for the three compared, none for x
    assert sorted(t.get_position()[0] for t in drawn.letters) == [0.0, 2.0, 3.0]
    # the slot is empty of data: nothing is drawn at x = 1
    for patch in drawn.ax.patches:
        x0, x1 = sorted(patch.get_path().vertices[:, 0])[::len(patch.get_path().vertices) - 1]
        assert not x0 <= 1.0 <= x1
