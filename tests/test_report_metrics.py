"""Metric definitions on hand-built step logs whose answers can be counted by hand."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from nudgecli.errors import DataError
from nudgecli.report.metrics import METRIC_NAMES, apply_filters, trial_metrics

H, A = "human", "autonomy"

# Trial 1, ten steps: human 0-4, autonomy 5-7, human 8-9. True goal 0.
#   human steps: 0, 1, 2, 3, 4, 8, 9 (7 of 10 -> effort 0.7)
#   assisted (human, alpha > 0, inferred 0): 1 (0.5), 4 (0.8), 8 (0.8); step 2 infers goal 1, step 5 is
#   the autonomy's turn -> engagement 3/7, strength (0.5 + 0.8 + 0.8) / 3 = 0.7
#   per turn: (2/5 + 1/2) / 2 = 0.45 and ((0.5 + 0.8) / 2 + 0.8) / 2 = 0.725
#   human mode switches: step 2 (human turn), step 6 (autonomy turn), step 8 (human turn) -> 3 in
#   any turn, 2 in human turns; mode_switch_autonomy and nudge do not count
TRIAL_1 = {
    "turn": [H, H, H, H, H, A, A, A, H, H],
    "alpha": [0.0, 0.5, 0.5, 0.0, 0.8, 0.8, 0.0, 0.0, 0.8, 0.0],
    "inferred_goal": [-1, 0, 1, 0, 0, 0, 0, 0, 0, 0],
    "event": ["", "", "mode_switch_human", "", "", "nudge|mode_switch_autonomy",
              "mode_switch_human|nudge", "", "handover|mode_switch_human", ""],
}
# Trial 2, seven steps: human 0-2 (no assistance), autonomy 3-4, human 5-6 (alpha 0.6; step 5 infers
# goal 0, step 6 goal 2).
#   engagement 1/5 = 0.2, strength 0.6; per turn (0 + 1/2) / 2 = 0.25 and (0 + 0.6) / 2 = 0.3
#   last inferred goal: 2 -> study-code success False
TRIAL_2 = {
    "turn": [H, H, H, A, A, H, H],
    "alpha": [0.0, 0.0, 0.0, 0.0, 0.0, 0.6, 0.6],
    "inferred_goal": [-1, -1, 1, 1, 1, 0, 2],
    "event": ["", "mode_switch_humanoid", "", "", "", "", ""],
}


def _steps(participant: int, trial: int, columns: dict[str, list]) -> pd.DataFrame:
    n = len(columns["turn"])
    return pd.DataFrame({"participant": participant, "trial": trial, "step": np.arange(n),
                         "t": np.arange(n) * 0.1, **columns})


def _log() -> tuple[pd.DataFrame, pd.DataFrame]:
    trials = pd.DataFrame({
        "participant": [1, 1, 1], "condition": ["disambiguation", "control", "control"],
        "block": [0, 1, 1], "trial": [0, 1, 2], "true_goal": [0, 0, 0],
        "success": [False, True, True], "duration_s": [1.0, 0.7, 3.0], "human_turns": [2, 2, 1],
    })
    steps = pd.concat([_steps(1, 0, TRIAL_1), _steps(1, 1, TRIAL_2)], ignore_index=True)
    # trial 2 of the table has no steps; rows are shuffled to show order does not matter
    return trials, steps.sample(frac=1.0, random_state=4).reset_index(drop=True)


def test_paper_definitions_on_a_hand_counted_log() -> None:
    trials, steps = _log()
    metrics = trial_metrics(trials, steps)
    assert list(metrics.columns) == ["participant", "condition", "block", "trial", *METRIC_NAMES]
    first, second = metrics.iloc[0], metrics.iloc[1]
    assert first["assistance_engagement"] == pytest.approx(3 / 7)
    assert first["assistance_strength"] == pytest.approx(0.7)
    assert first["mode_switches"] == 3
    assert first["human_effort"] == pytest.approx(0.7)
    assert first["completion_time"] == 1.0 and first["human_turns"] == 2 and not first["success"]
    assert second["assistance_engagement"] == pytest.approx(0.2)
    assert second["assistance_strength"] == pytest.approx(0.6)
    assert second["mode_switches"] == 0  # "mode_switch_humanoid" is another event
    assert second["human_effort"] == pytest.approx(5 / 7)
    assert second["success"]


def test_study_code_definitions_on_a_hand_counted_log() -> None:
    trials, steps = _log()
    metrics = trial_metrics(trials, steps, engagement="per_turn", strength="per_turn",
                            mode_switches="human_turn", success="last_inferred_goal")
    first, second = metrics.iloc[0], metrics.iloc[1]
    assert first["assistance_engagement"] == pytest.approx(0.45)
    assert first["assistance_strength"] == pytest.approx(0.725)
    assert first["mode_switches"] == 2
    assert bool(first["success"])  # last inferred goal (step 9) is goal 0
    assert second["assistance_engagement"] == pytest.approx(0.25)
    assert second["assistance_strength"] == pytest.approx(0.3)
    assert not bool(second["success"])  # last inferred goal is 2


def test_a_trial_without_steps_has_missing_step_metrics() -> None:
    trials, steps = _log()
    third = trial_metrics(trials, steps).iloc[2]
    for name in ("assistance_engagement", "assistance_strength", "human_effort"):
        assert math.isnan(third[name])
    assert pd.isna(third["mode_switches"])
    assert third["completion_time"] == 3.0 and third["human_turns"] == 1


def test_strength_is_missing_without_assistance_and_equal_alphas_stay_equal() -> None:
    trials = pd.DataFrame({"participant": [1, 1], "condition": ["a", "b"], "block": [0, 0], "trial": [0, 1],
                           "true_goal": [0, 0], "success": [True, True], "duration_s": [0.3, 0.3],
                           "human_turns": [1, 1]})
    steps = pd.concat([
        _steps(1, 0, {"turn": [H] * 3, "alpha": [0.0] * 3, "inferred_goal": [0] * 3, "event": [""] * 3}),
        _steps(1, 1, {"turn": [H] * 3, "alpha": [0.8] * 3, "inferred_goal": [0] * 3, "event": [""] * 3}),
    ])
    metrics = trial_metrics(trials, steps)
    assert math.isnan(metrics.loc[0, "assistance_strength"]) and metrics.loc[0, "assistance_engagement"] == 0
    assert metrics.loc[1, "assistance_strength"] == 0.8  # exactly, not 0.8000000000000002


def test_filters_act_on_their_own_metric_only() -> None:
    trials, steps = _log()
    metrics = trial_metrics(trials, steps)
    filtered = apply_filters(metrics, {"mode_switches": 2, "completion_time": 0.9, "not_here": 1})
    assert pd.isna(filtered.loc[0, "mode_switches"]) and filtered.loc[1, "mode_switches"] == 0
    assert math.isnan(filtered.loc[0, "completion_time"]) and filtered.loc[1, "completion_time"] == 0.7
    assert filtered.loc[0, "assistance_engagement"] == pytest.approx(3 / 7)
    assert metrics.loc[0, "mode_switches"] == 3  # the input is untouched


def test_a_filter_keeps_a_value_equal_to_its_maximum() -> None:
    # "above its maximum" (inclusive maximum): 0.7 s stays under a 0.7 s limit, 1.0 s goes
    trials, steps = _log()
    filtered = apply_filters(trial_metrics(trials, steps), {"completion_time": 0.7, "mode_switches": 3})
    assert math.isnan(filtered.loc[0, "completion_time"]) and filtered.loc[1, "completion_time"] == 0.7
    assert filtered.loc[0, "mode_switches"] == 3


def test_study_success_is_the_last_inferred_goal_not_the_first() -> None:
    # inferred goals 2, none, 0, none: the last one (0) is the true goal; the first (2) is not
    trials = pd.DataFrame({"participant": [1], "condition": ["a"], "block": [0], "trial": [0],
                           "true_goal": [0], "success": [False], "duration_s": [0.4], "human_turns": [1]})
    steps = _steps(1, 0, {"turn": [H] * 4, "alpha": [0.0] * 4, "inferred_goal": [2, -1, 0, -1],
                          "event": [""] * 4})
    assert bool(trial_metrics(trials, steps, success="last_inferred_goal").loc[0, "success"])
    steps["inferred_goal"] = [0, -1, 2, -1]
    assert not bool(trial_metrics(trials, steps, success="last_inferred_goal").loc[0, "success"])


def test_missing_columns_and_duplicate_trials_are_refused() -> None:
    trials, steps = _log()
    with pytest.raises(DataError, match="step log lacks the column"):
        trial_metrics(trials, steps.drop(columns="event"))
    with pytest.raises(DataError, match="trial table lacks the column"):
        trial_metrics(trials.drop(columns="true_goal"), steps)
    with pytest.raises(DataError, match="more than once"):
        trial_metrics(pd.concat([trials, trials.iloc[[0]]]), steps)


def test_the_metrics_table_keeps_the_trial_tables_identifiers_and_types_its_metrics() -> None:
    # the parts of every batch and `nudge analyze` are written with these types: counts are
    # nullable integers, success is boolean, the identifiers keep the trial table's dtypes
    trials, steps = _log()
    trials["participant"] = trials["participant"].astype("Int64")  # e.g. a real study's table
    trials.index = [7, 8, 9]
    metrics = trial_metrics(trials, steps)
    assert [str(t) for t in metrics.dtypes] == [
        "Int64", str(trials["condition"].dtype), "int64", "int64", "float64", "float64", "Int64", "float64",
        "float64", "Int64", "boolean", "float64", "float64", "boolean"]
    assert list(metrics.index) == [0, 1, 2]
    assert metrics["condition"].tolist() == trials["condition"].tolist()
    # trial 2 has no steps: its count is missing (not 0, not NaN in a float column)
    assert metrics["mode_switches"].iloc[2] is pd.NA
    assert metrics["success"].tolist() == [False, True, True]


def test_completion_time_of_successful_trials_only_follows_the_paper():
    trials = pd.DataFrame({
        "participant": [0, 0], "condition": ["a", "a"], "block": [0, 0], "trial": [0, 1],
        "true_goal": [0, 0], "success": [True, False], "duration_s": [12.5, 30.0], "human_turns": [2, 3],
    })
    steps = pd.DataFrame({
        "participant": [0, 0], "trial": [0, 1], "step": [0, 0], "turn": ["human", "human"],
        "alpha": [0.0, 0.0], "inferred_goal": [0, 0], "event": ["", ""],
    })
    every = trial_metrics(trials, steps)
    paper = trial_metrics(trials, steps, completion_time="successful_trials")
    assert every["completion_time"].tolist() == [12.5, 30.0]
    assert paper["completion_time"].iloc[0] == 12.5 and pd.isna(paper["completion_time"].iloc[1])


def test_wrong_goal_is_an_arrival_at_another_goal_not_a_time_out() -> None:
    # true goal 1 in every trial; reached: 1 (success), 0 (another goal), -1 (time-out: neither),
    # 2 (another goal), missing (unknown)
    trials = pd.DataFrame({
        "participant": [0] * 5, "condition": ["a"] * 5, "block": [0] * 5, "trial": list(range(5)),
        "true_goal": [1] * 5, "reached_goal": pd.array([1, 0, -1, 2, None], dtype="Int64"),
        "success": [True, False, False, False, False], "duration_s": [1.0] * 5, "human_turns": [1] * 5,
    })
    steps = pd.concat([_steps(0, t, {"turn": [H], "alpha": [0.0], "inferred_goal": [1], "event": [""]})
                       for t in range(5)])
    got = trial_metrics(trials, steps)["wrong_goal"]
    assert got.dtype == "boolean" and got.tolist() == [False, True, False, True, pd.NA]
    # the trial table's outcome under every plan, whatever success means there
    study = trial_metrics(trials, steps, success="last_inferred_goal")
    assert study["wrong_goal"].tolist() == got.tolist() and study["success"].all()
    # a hand-made trial table without the column: missing, not False
    assert trial_metrics(trials.drop(columns="reached_goal"), steps)["wrong_goal"].isna().all()


def test_wrong_goal_is_in_the_baselines_plan_beside_success_not_in_the_papers() -> None:
    from nudgecli.report.plans import load_plan

    baselines = list(load_plan("baselines").metrics.include)
    assert baselines[baselines.index("success") + 1] == "wrong_goal"
    assert "wrong_goal" not in load_plan("paper").metrics.include
    assert "wrong_goal" not in load_plan("study-code").metrics.include


@pytest.mark.parametrize("definitions", [
    {},  # the paper's
    {"engagement": "per_turn", "strength": "per_turn", "mode_switches": "human_turn",
     "success": "last_inferred_goal", "completion_time": "successful_trials"},  # the study code's
])
def test_metrics_read_a_participant_at_a_time_are_the_whole_logs(tmp_path, definitions) -> None:
    from nudgecli.config import load_experiment
    from nudgecli.report.metrics import trial_metrics_by_participant
    from nudgecli.runs.study import run_study
    from nudgecli.store import RunFolder

    run = RunFolder(run_study(load_experiment("smoke"), tmp_path / "run", participants=3).path)
    trials, steps = run.read_trials(), run.read_steps()
    by_participant = dict(tuple(steps.groupby("participant")))
    parts = trial_metrics_by_participant(trials, by_participant.get, **definitions)
    pd.testing.assert_frame_equal(parts, trial_metrics(trials, steps, **definitions))
    # a participant without steps: their trials' step metrics missing, as in a log without them
    without = steps[steps["participant"] != 1]
    del by_participant[1]
    pd.testing.assert_frame_equal(trial_metrics_by_participant(trials, by_participant.get, **definitions),
                                  trial_metrics(trials, without, **definitions))
