"""A metrics table analysed under a plan: the plan's definitions that a table's columns allow are
applied (completion time over successful trials, by its ``success`` column), the others are the
table's own and one ``Note:`` line (and a line of ``summary.md``) says so.

QA: ``nudge analyze metrics_two_conditions.csv --metric completion_time`` counted the times of the
table's 4 failed trials under the ``paper`` plan, which defines completion time over successful
trials only, and said nothing; ``nudge compare RUN REAL.csv`` set a run's successful-trial times
beside a table's all-trial times.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.cli import main
from nudgecli.report.analysis import analyze, load_source
from nudgecli.report.compare import compare_sources
from nudgecli.report.plans import load_plan
from nudgecli.report.table_definitions import apply_plan_definitions, trial_success

DATA = Path(__file__).with_name("data")
TWO_CONDITIONS = DATA / "metrics_two_conditions.csv"
REFERENCE = Path(__file__).parents[1] / "results" / "paper"


def _entry(stats: dict, metric: str) -> dict:
    return next(e for e in stats["metrics"] if e["metric"] == metric)


def test_paper_plan_counts_only_successful_trials_times_of_a_table(tmp_path: Path) -> None:
    raw = pd.read_csv(TWO_CONDITIONS)
    result = analyze(TWO_CONDITIONS, out=tmp_path / "a", metrics=["completion_time"], bootstrap=100)
    entry = _entry(result.stats, "completion_time")
    # independent: the successful rows of the raw table, per condition
    successful = raw[raw["success"]]
    for condition, rows in successful.groupby("condition"):
        assert entry["n"][condition] == len(rows) < (raw["condition"] == condition).sum()
        assert entry["median"][condition] == np.median(rows["completion_time"])
    # the table changed: the rows analysed are written, the failed trials' times empty
    assert result.stats["metrics_table"] == "metrics.csv"
    written = pd.read_csv(tmp_path / "a" / "metrics.csv")
    assert written["completion_time"].isna().to_numpy().tolist() == (~raw["success"]).to_numpy().tolist()
    assert "- definitions: completion_time over successful trials only" in result.summary
    assert "4 other trials' times left out" in result.summary


def test_cli_prints_one_note_naming_what_the_table_defines_itself(tmp_path: Path) -> None:
    out = tmp_path / "a"
    args = ["analyze", str(TWO_CONDITIONS), "--out", str(out), "--bootstrap", "100"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    lines = [line for line in result.stderr.splitlines() if str(TWO_CONDITIONS) in line]
    assert len(lines) == 1 and lines[0].startswith("Note: ")
    assert "the table's own definitions were used for mode_switches, success" in lines[0]
    assert "'any_turn'" in lines[0] and "'reached_goal'" in lines[0]
    summary = (out / "summary.md").read_text()
    assert "the table's own definitions were used for mode_switches, success" in summary


def test_study_code_keeps_every_trials_time_and_names_its_own_definitions(tmp_path: Path) -> None:
    raw = pd.read_csv(TWO_CONDITIONS)
    result = analyze(TWO_CONDITIONS, plan="study-code", out=tmp_path / "a", bootstrap=100)
    entry = _entry(result.stats, "completion_time")
    assert entry["n"] == raw.groupby("condition")["completion_time"].count().to_dict()  # all 24 per condition
    assert result.stats["metrics_table"] != "metrics.csv"  # analysed as it is (no filter bites either)
    (line,) = [n for n in result.notes if "own definitions" in n]
    assert "'human_turn'" in line and "'last_inferred_goal'" in line and "completion_time" not in line


def test_a_runs_own_metrics_csv_is_analysed_as_the_run_was(tmp_path: Path) -> None:
    """The rule is idempotent for a run's metrics.csv under the plan it was made with: nothing
    changes, no metrics.csv is written, and the statistics are the run's committed ones."""
    result = analyze(REFERENCE / "metrics.csv", plan="paper", out=tmp_path / "a", metrics=["completion_time"])
    assert result.stats["metrics_table"] != "metrics.csv" and not (tmp_path / "a" / "metrics.csv").exists()
    committed = json.loads((REFERENCE / "stats.json").read_text())
    assert _entry(result.stats, "completion_time") == _entry(committed, "completion_time")
    assert "(by its success column: 0 other trials' times left out)" in result.notes[0]


def test_all_trials_plan_says_a_tables_missing_failed_times_are_its_own(tmp_path: Path) -> None:
    """A run's metrics.csv made under paper, analysed with study-code: the failed trials' times are
    not in it, which the plan's all_trials cannot bring back."""
    table = pd.read_csv(REFERENCE / "metrics.csv")
    failed_without_time = int((~table["success"] & table["completion_time"].isna()).sum())
    assert failed_without_time > 0
    defined = apply_plan_definitions(table, load_plan("study-code"), ["completion_time"])
    assert defined.table is table and not defined.changed
    assert defined.line is not None and f"{failed_without_time} failed trials have no time" in defined.line


def _frame(success: list, times: list[float]) -> pd.DataFrame:
    return pd.DataFrame({"participant": range(len(times)), "condition": "a", "success": success,
                         "completion_time": times})


def test_success_as_numbers_and_blanks() -> None:
    table = _frame([1, 0, None, 1.0], [1.0, 2.0, 3.0, 4.0])
    table["success"] = table["success"].astype("Float64")
    defined = apply_plan_definitions(table, load_plan("paper"), ["completion_time"])
    assert np.array_equal(defined.table["completion_time"].to_numpy(), [1.0, np.nan, np.nan, 4.0],
                          equal_nan=True)
    assert defined.changed and "2 other trials' times left out" in str(defined.line)
    assert table["completion_time"].notna().all()  # the table given is left as it was


def test_a_success_column_that_is_not_a_trials_success_is_not_used() -> None:
    table = _frame([0.5, 1.0], [1.0, 2.0])  # a rate, not a trial's True/False
    assert trial_success(table) is None
    defined = apply_plan_definitions(table, load_plan("paper"), ["completion_time"])
    assert defined.table is table and not defined.changed
    assert "completion_time is the table's own: it has no success column" in str(defined.line)
    # under all_trials every time the table holds counts: nothing to say
    assert apply_plan_definitions(table, load_plan("study-code"), ["completion_time"]).line is None


def test_no_plan_defined_metric_analysed_says_nothing() -> None:
    table = _frame([True, False], [1.0, 2.0]).rename(columns={"completion_time": "score"})
    defined = apply_plan_definitions(table, load_plan("paper"), ["score"])
    assert defined.table is table and defined.line is None


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.sampled_from([True, False, None]),
                          st.one_of(st.none(), st.floats(0, 1e3))), min_size=1, max_size=30))
def test_the_rule_is_a_loop_over_trials_and_idempotent(rows: list) -> None:
    table = _frame([s for s, _ in rows], [np.nan if t is None else t for _, t in rows])
    table["success"] = table["success"].astype("boolean")
    plan = load_plan("paper")
    once = apply_plan_definitions(table, plan, ["completion_time"])
    expected = [t if s is True and t is not None else np.nan for s, t in rows]  # brute force
    assert np.array_equal(once.table["completion_time"].to_numpy(float), expected, equal_nan=True)
    twice = apply_plan_definitions(once.table, plan, ["completion_time"])
    assert twice.table is once.table and not twice.changed


def test_load_source_of_a_table_applies_the_plan_and_notes_it() -> None:
    notes: list[str] = []
    table, _, _ = load_source(TWO_CONDITIONS, load_plan("paper"), notes=notes)
    assert table["completion_time"].isna().sum() == 4
    assert len(notes) == 1 and notes[0].startswith(f"{TWO_CONDITIONS}: completion_time over successful")


def test_compare_sets_successful_times_beside_successful_times(tmp_path: Path) -> None:
    """A table compared under paper (a run's plan): the real table's failed trials' times are out."""
    simulated = tmp_path / "sim.csv"
    pd.read_csv(TWO_CONDITIONS).to_csv(simulated, index=False)
    notes: list[str] = []
    comparison = compare_sources(simulated, TWO_CONDITIONS, plan="paper", metrics=["completion_time"],
                                 notes=notes)
    real = comparison.trials["real"]
    raw = pd.read_csv(TWO_CONDITIONS)
    assert sorted(real["completion_time"].dropna()) == sorted(raw.loc[raw["success"], "completion_time"])
    assert sum("completion_time over successful trials only" in n for n in notes) == 2  # both sources
