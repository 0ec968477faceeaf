"""Which trial Fig. 5 shows (``nudgecli.report.trial_selection``): the trial's own true goal decides."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from nudgecli.errors import DataError
from nudgecli.report.trial_selection import (
    choose_figure5_trial,
    nudge_followup_changes,
    trial_groups,
    turn_changes,
)


def trial_steps(participant: int, trial: int, rises: dict[int, float], n_goals: int = 3,
                nudge: bool = True) -> pd.DataFrame:
    """Human turn (10 steps), autonomy turn (5 steps, a nudge at its start), human turn (10 steps).

    The belief is uniform until the second human turn, over which goal ``g`` gains ``rises[g]``
    (linearly; the others lose it evenly). Hand-made, so the changes are known exactly.
    """
    rows = []
    base = np.full(n_goals, 1.0 / n_goals)
    shift = np.zeros(n_goals)
    for g, amount in rises.items():
        shift[g] += amount
        shift[[h for h in range(n_goals) if h != g]] -= amount / (n_goals - 1)
    turns = ["human"] * 10 + ["autonomy"] * 5 + ["human"] * 10
    for k, turn in enumerate(turns):
        fraction = (k - 14) / 10 if k >= 15 else 0.0
        belief = base + fraction * shift
        rows.append({"participant": participant, "trial": trial, "step": k, "t": 0.1 * k, "turn": turn,
                     "belief": list(belief), "event": "nudge" if (nudge and k == 10) else ""})
    return pd.DataFrame(rows)


def test_followup_change_is_the_change_over_the_next_human_turn() -> None:
    steps = trial_steps(0, 0, {2: 0.3})
    # The belief at the turn's last step (fraction 1) minus the one handed over (fraction 0).
    assert nudge_followup_changes(steps, 2) == [pytest.approx(0.3)]
    assert nudge_followup_changes(steps, 0) == [pytest.approx(-0.15)]
    assert nudge_followup_changes(steps, 5) == []
    assert turn_changes(steps, 2) == [pytest.approx(0.0), pytest.approx(0.3)]
    assert nudge_followup_changes(steps.assign(event=""), 2) == []


def test_the_choice_uses_each_trials_own_true_goal() -> None:
    # Trial (0, 0): true goal 2 rises by 0.4 (goal 0 falls). Trial (0, 1): true goal 0 rises by 0.3.
    # Taking goal 0 as the true goal everywhere would pick (0, 1).
    steps = pd.concat([trial_steps(0, 0, {2: 0.4}), trial_steps(0, 1, {0: 0.3})], ignore_index=True)
    trials = pd.DataFrame({"participant": [0, 0], "trial": [0, 1], "condition": ["disambiguation"] * 2,
                           "true_goal": [2, 0], "success": [True, True]})
    assert choose_figure5_trial(steps, trials) == (0, 0)
    assert choose_figure5_trial(steps, trials.assign(true_goal=[0, 0])) == (0, 1)
    # Without nudges the same rule applies to every human turn.
    assert choose_figure5_trial(steps.assign(event=""), trials) == (0, 0)


def test_condition_success_and_ties() -> None:
    steps = pd.concat([trial_steps(0, 0, {1: 0.2}), trial_steps(0, 1, {1: 0.5}), trial_steps(1, 2, {1: 0.3}),
                       trial_steps(1, 3, {1: 0.6})], ignore_index=True)
    trials = pd.DataFrame({"participant": [0, 0, 1, 1], "trial": [0, 1, 2, 3],
                           "condition": ["disambiguation", "disambiguation", "disambiguation", "control"],
                           "true_goal": [1, 1, 1, 1], "success": [True, True, True, True]})
    assert choose_figure5_trial(steps, trials) == (0, 1)  # (1, 3) rises more but is a Control trial
    trials.loc[1, "success"] = False
    assert choose_figure5_trial(steps, trials) == (1, 2)  # successful trials first
    mapping = {k: df for k, df in steps.groupby(["participant", "trial"])}
    assert choose_figure5_trial(mapping, trials) == (1, 2)
    tied = pd.concat([trial_steps(3, 7, {1: 0.2}), trial_steps(2, 9, {1: 0.2})], ignore_index=True)
    tied_trials = pd.DataFrame({"participant": [3, 2], "trial": [7, 9], "condition": ["disambiguation"] * 2,
                                "true_goal": [1, 1]})
    assert choose_figure5_trial(tied, tied_trials) == (2, 9)  # ties: the smallest (participant, trial)


def test_the_true_goal_column_is_required() -> None:
    trials = pd.DataFrame({"participant": [0], "trial": [0], "condition": ["disambiguation"]})
    with pytest.raises(DataError, match="true_goal"):
        choose_figure5_trial(trial_steps(0, 0, {1: 0.2}), trials)
    with pytest.raises(DataError, match="no steps"):
        choose_figure5_trial({}, trials.assign(true_goal=0))


def test_the_choice_reads_interleaved_rows_as_it_reads_trials_in_stretches() -> None:
    # a log written trial by trial gives each trial's rows as one slice; rows of trials interleaved
    # (a table assembled by hand) are gathered: the same trial either way
    steps = pd.concat([trial_steps(0, 0, {1: 0.2}), trial_steps(0, 1, {1: 0.5}), trial_steps(1, 2, {1: 0.3})],
                      ignore_index=True)
    trials = pd.DataFrame({"participant": [0, 0, 1], "trial": [0, 1, 2], "condition": ["disambiguation"] * 3,
                           "true_goal": [1, 1, 1]})
    interleaved = steps.iloc[np.argsort(steps["step"].to_numpy(), kind="stable")]
    assert choose_figure5_trial(steps, trials) == choose_figure5_trial(interleaved, trials) == (0, 1)
    # within a trial the rows are put in step order first
    assert choose_figure5_trial(steps.iloc[::-1], trials) == (0, 1)
    for table in (steps, interleaved, steps.iloc[::-1]):  # each trial's rows as pandas' grouping gives them
        expected = {(int(p), int(t)): df for (p, t), df in table.groupby(["participant", "trial"], sort=True)}
        got = dict(trial_groups(table))
        assert list(got) == list(expected)
        for key, frame in expected.items():
            pd.testing.assert_frame_equal(got[key], frame)
