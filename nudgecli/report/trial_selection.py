"""Which trial the paper's Fig. 5 (and the trajectory) shows by default.

The paper shows a Disambiguation trial in which a nudge visibly helped: the true goal's
probability rose over the human turn that followed it. :func:`choose_figure5_trial` picks that
trial by a fixed rule; :func:`nudge_followup_changes` is its measure. The true goal is each
trial's own (the trials table's ``true_goal``), never assumed to be goal 0.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping

import numpy as np
import pandas as pd

from nudgecli.errors import DataError
from nudgecli.report.trial_steps import (
    TrialKey,
    belief_matrix,
    require_columns,
    runs,
    sorted_steps,
    true_goals,
)
from nudgecli.steplog import HUMAN_TURN, NUDGE, has_event


def _human_runs(steps: pd.DataFrame) -> list[tuple[int, int]]:
    """``(first, last)`` step index of every human turn of sorted steps."""
    return [(first, last) for turn, first, last in runs(steps["turn"].astype(str).to_numpy())
            if turn == HUMAN_TURN]


def _change_over(p: np.ndarray, first: int, last: int) -> float:
    """The belief at a turn's last step minus the belief handed over just before it began."""
    before = p[first - 1] if first > 0 else p[first]
    return float(p[last] - before)


def nudge_followup_changes(steps: pd.DataFrame, goal: int) -> list[float]:
    """The change in a goal's belief over the human turn that follows each nudge.

    For each step whose event contains ``nudge``, take the first human turn that starts after
    it; the change is the goal's belief at the last step of that turn minus its belief at the
    step just before the turn began (the belief handed over by the autonomy). Nudges with no
    human turn after them (or no belief) contribute nothing.

    Parameters
    ----------
    steps
        Steps of one trial (``turn``, ``belief``, ``event``).
    goal
        Goal index (the trial's true goal, from the trials table).

    Returns
    -------
    list[float]
        One signed change per nudge that has a following human turn, in time order.
    """
    if steps.empty or "event" not in steps.columns:
        return []
    steps = sorted_steps(steps)
    nudge_idx = np.flatnonzero(has_event(steps["event"], NUDGE))
    if nudge_idx.size == 0:
        return []
    p = belief_matrix(steps)
    if p.shape[1] <= goal:
        return []
    human = _human_runs(steps)
    changes = []
    for k in nudge_idx:
        following = next(((f, la) for f, la in human if f > k), None)
        if following is None:
            continue
        change = _change_over(p[:, goal], *following)
        if np.isfinite(change):
            changes.append(change)
    return changes


def turn_changes(steps: pd.DataFrame, goal: int) -> list[float]:
    """The change in a goal's belief over every human turn of a trial (no nudge required).

    Parameters
    ----------
    steps
        Steps of one trial (``turn``, ``belief``).
    goal
        Goal index.

    Returns
    -------
    list[float]
        One change per human turn with a finite change, in time order.
    """
    steps = sorted_steps(steps)
    p = belief_matrix(steps)
    if p.shape[1] <= goal:
        return []
    changes = [_change_over(p[:, goal], first, last) for first, last in _human_runs(steps)]
    return [c for c in changes if np.isfinite(c)]


def trial_groups(steps_all: pd.DataFrame | Mapping[TrialKey, pd.DataFrame]) -> Iterable[tuple[TrialKey,
                                                                                                pd.DataFrame]]:
    """``((participant, trial), steps of that trial)`` from one table or a mapping."""
    keys, steps_of = _trials_of(steps_all)
    for key in keys:
        yield key, steps_of(key)


def _trials_of(steps_all: pd.DataFrame | Mapping[TrialKey, pd.DataFrame]
               ) -> tuple[list[TrialKey], Callable[[TrialKey], pd.DataFrame]]:
    """The ``(participant, trial)`` keys with steps (in order), and the steps of one, made when
    asked: a run of 100 participants' 1.2 M steps split into every trial's table at once held the
    step log twice (0.5 GB), where the rule reads the Disambiguation trials one at a time."""
    if isinstance(steps_all, Mapping):  # (a mapping may read a trial's steps only when asked)
        keys = {(int(key[0]), int(key[1])): key for key in steps_all}
        return list(keys), lambda key: steps_all[keys[key]]
    require_columns(steps_all, ["participant", "trial"], "steps table")
    # the rows of each group, in table order: the rows (and index) groupby's iteration yields; a
    # trial's rows in one stretch (a run's log is written trial by trial) are a slice, not a copy
    positions = steps_all.groupby(["participant", "trial"], sort=True).indices
    rows: dict[TrialKey, slice | np.ndarray] = {}
    for (p, tr), where in positions.items():
        first, last = int(where[0]), int(where[-1])
        rows[int(p), int(tr)] = slice(first, last + 1) if last - first + 1 == where.size else where
    return list(rows), lambda key: steps_all.iloc[rows[key]]


def choose_figure5_trial(steps_all: pd.DataFrame | Mapping[TrialKey, pd.DataFrame], trials: pd.DataFrame,
                         *, condition: str = "disambiguation") -> TrialKey:
    """The trial Fig. 5 shows by default.

    Definition: among the trials of ``condition`` (Disambiguation), the one whose true-goal
    belief rose most over a human turn that followed a nudge, i.e. the largest value of
    :func:`nudge_followup_changes` of the trial's own true goal. When ``trials`` has a
    ``success`` column and any candidate succeeded, only successful trials are considered.
    Ties go to the smallest ``(participant, trial)``. If no trial of the condition has a nudge
    followed by a human turn, the same rule is applied to every human turn of those trials
    (:func:`turn_changes`); if the condition has no trials with steps, the first trial with
    steps of any condition is returned.

    Parameters
    ----------
    steps_all
        All steps (``participant``, ``trial``, ``turn``, ``belief``, ``event``), or a mapping
        ``(participant, trial) -> steps of that trial``.
    trials
        The trials table: one row per trial with ``participant``, ``trial``, ``condition``,
        ``true_goal`` and optionally ``success``.
    condition
        Condition to choose from (case-insensitive).

    Returns
    -------
    tuple[int, int]
        ``(participant, trial)``.

    Raises
    ------
    DataError
        There are no steps at all, or the trials table lacks a column.
    """
    require_columns(trials, ["participant", "trial", "condition", "true_goal"], "trials table")
    keys = list(zip(trials["participant"].astype(int), trials["trial"].astype(int), strict=True))
    cond_of = dict(zip(keys, trials["condition"].astype(str), strict=True))
    goal_of = true_goals(trials)
    success_of: dict[TrialKey, bool] = {}
    if "success" in trials.columns:
        success_of = {k: bool(s) for k, s in zip(keys, trials["success"], strict=True) if not pd.isna(s)}
    groups, steps_of = _trials_of(steps_all)
    if not groups:
        raise DataError("steps table: no steps to choose a Fig. 5 trial from; simulate a run first")
    candidates = sorted(k for k in groups if cond_of.get(k, "").lower() == condition.lower())
    if not candidates:
        return min(groups)
    if success_of and any(success_of.get(k, False) for k in candidates):
        candidates = [k for k in candidates if success_of.get(k, False)]

    for measure in (nudge_followup_changes, turn_changes):
        best: tuple[float, TrialKey] | None = None
        for key in candidates:
            changes = measure(steps_of(key), goal_of[key])
            if changes and (best is None or max(changes) > best[0]):
                best = (max(changes), key)
        if best is not None:
            return best[1]
    return candidates[0]


__all__ = ["choose_figure5_trial", "nudge_followup_changes", "trial_groups", "turn_changes"]
