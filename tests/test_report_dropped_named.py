"""Nothing is left out without a word: every participant the participant-level test leaves out is
named (one whose values of a condition are all blank too, and one who answered no questionnaire),
and a metrics table's blank cells are counted in a note."""

from __future__ import annotations

import numpy as np
import pandas as pd

from nudgecli.report.participant_tests import participant_level_test, participant_summaries
from nudgecli.report.stats_document import compare_conditions

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
