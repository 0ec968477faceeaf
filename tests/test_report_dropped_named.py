"""Nothing is left out without a word: every participant the participant-level test leaves out is
named (one whose values of a condition are all blank too, and one who answered no questionnaire),
and a metrics table's blank cells are counted in a note."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from nudgecli.report.analysis import analyze
from nudgecli.report.participant_tests import participant_level_test, participant_summaries
from nudgecli.report.plans import load_plan
from nudgecli.report.stats_document import compare_conditions
from nudgecli.report.table_definitions import apply_plan_definitions

CONDITIONS = ["control", "disambiguation", "Blend-30"]


def _trials() -> pd.DataFrame:
    """Three participants, two trials in each of three conditions; P3 only ran control."""
    rows = [{"participant": p, "condition": c, "trial": t, "completion_time": 30.0 + i + t + 2 * j}
            for i, p in enumerate(["P1", "P2", "P3", "P4"]) for j, c in enumerate(CONDITIONS)
            for t in (1, 2) if p != "P3" or c == "control"]
    return pd.DataFrame(rows)


def test_a_participant_with_only_blank_values_of_a_condition_is_named_dropped() -> None:
    trials = _trials()
    trials.loc[(trials["participant"] == "P2") & (trials["condition"] == "disambiguation"),
               "completion_time"] = np.nan
    wide, dropped = participant_summaries(trials, "completion_time", CONDITIONS)
    assert list(wide.index) == ["P1", "P4"]
    assert dropped == ["P2", "P3"]
    level, _ = participant_level_test(trials, "completion_time", CONDITIONS)
    assert level["n_participants"] == 2
    assert level["dropped_participants"] == ["P2", "P3"]
    assert level["note"].startswith("2 participant(s) without a value in every condition dropped: P2, P3")


def test_a_participant_every_value_of_whom_is_blank_is_named_dropped() -> None:
    trials = _trials()
    trials.loc[trials["participant"] == "P1", "completion_time"] = np.nan
    level = compare_conditions(trials, ["completion_time"], CONDITIONS)["metrics"][0]["participant_level"]
    assert (level["n_participants"], level["dropped_participants"]) == (2, ["P1", "P3"])


def test_a_participant_without_questionnaire_answers_is_named_dropped() -> None:
    trials = _trials()
    scores = trials.drop_duplicates(["participant", "condition"])[["participant", "condition"]]
    scores = scores[scores["participant"] != "P4"].assign(tlx_raw=[50.0, 40.0, 30.0, 55.0, 45.0, 20.0, 60.0])
    document = compare_conditions(scores, ["tlx_raw"], CONDITIONS, roster=trials)
    level = document["metrics"][0]["participant_level"]
    assert (level["n_participants"], level["dropped_participants"]) == (2, ["P3", "P4"])
    # without the trials, only the scores' own participants are known
    alone = compare_conditions(scores, ["tlx_raw"], CONDITIONS)["metrics"][0]["participant_level"]
    assert alone["dropped_participants"] == ["P3"]


def _trials_with_blanks() -> pd.DataFrame:
    """Trials with a success column: P1's first control trial succeeded with no time, P2's failed
    (no time, as the paper defines it), P4's second disambiguation trial has no mode_switches."""
    trials = _trials().assign(success=1, mode_switches=3.0)
    first_control = (trials["condition"] == "control") & (trials["trial"] == 1)
    trials.loc[first_control & (trials["participant"] == "P1"), "completion_time"] = np.nan
    failed = first_control & (trials["participant"] == "P2")
    trials.loc[failed, ["completion_time", "success"]] = [np.nan, 0]
    trials.loc[(trials["participant"] == "P4") & (trials["condition"] == "disambiguation")
               & (trials["trial"] == 2), "mode_switches"] = np.nan
    return trials


def test_blank_cells_are_counted_once_and_named() -> None:
    trials = _trials_with_blanks()
    trials["human_effort"] = np.where(trials["condition"] == "control", np.nan, 1.0)  # not measured there
    for plan in ("paper", "study-code"):  # failed trials' times: left out, or the table's own
        defined = apply_plan_definitions(trials, load_plan(plan), ["completion_time", "mode_switches",
                                                                   "human_effort"])
        assert defined.blanks == ("blank cells left out: completion_time 1 of a trial not failed "
                                  "(P1 control trial 1), mode_switches 1 (P4 disambiguation trial 2); "
                                  "each trial stays in its other metrics")
    defined = apply_plan_definitions(trials.drop(columns="success"), load_plan("paper"), ["completion_time"])
    assert defined.blanks is not None and "completion_time 2 (P1 control trial 1; P2 control trial 1)" \
        in defined.blanks  # no success column: every blank time is one
    assert apply_plan_definitions(_trials(), load_plan("paper"), ["completion_time"]).blanks is None


def test_analyze_says_a_tables_blank_cells(tmp_path: Path) -> None:
    table = tmp_path / "study.csv"
    _trials_with_blanks().to_csv(table, index=False)
    result = analyze(table, out=tmp_path / "out", metrics=["completion_time", "mode_switches"], bootstrap=100)
    blanks = [n for n in result.notes if "blank cells left out" in n]
    assert blanks == [f"{table}: blank cells left out: completion_time 1 of a trial not failed "
                      "(P1 control trial 1), mode_switches 1 (P4 disambiguation trial 2); "
                      "each trial stays in its other metrics"]


def test_summary_md_says_a_tables_blank_cells(tmp_path: Path) -> None:
    """The Note's line is in summary.md too, where a reader of the analysis alone meets it."""
    table = tmp_path / "study.csv"
    _trials_with_blanks().to_csv(table, index=False)
    analyze(table, out=tmp_path / "out", metrics=["completion_time", "mode_switches"], bootstrap=100)
    summary = (tmp_path / "out" / "summary.md").read_text(encoding="utf-8").splitlines()
    assert ("- blank cells left out: completion_time 1 of a trial not failed (P1 control trial 1), "
            "mode_switches 1 (P4 disambiguation trial 2); each trial stays in its other metrics") in summary
    one = tmp_path / "one.csv"  # a single condition's summary (descriptives only) says it as well
    _trials_with_blanks().query("condition == 'control'").to_csv(one, index=False)
    analyze(one, out=tmp_path / "one", metrics=["completion_time"], bootstrap=100)
    assert any(line.startswith("- blank cells left out: completion_time 1")
               for line in (tmp_path / "one" / "summary.md").read_text(encoding="utf-8").splitlines())
    plain = tmp_path / "plain.csv"  # none blank: no line
    _trials().to_csv(plain, index=False)
    analyze(plain, out=tmp_path / "plain", metrics=["completion_time"], bootstrap=100)
    assert "blank cells" not in (tmp_path / "plain" / "summary.md").read_text(encoding="utf-8")
