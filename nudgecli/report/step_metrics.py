"""The step-based metrics of every trial, from the step log's columns as arrays (numpy only).

The one computation behind :func:`nudgecli.report.metrics.trial_metrics` (which reads frames and
assembles the metrics table) and a batch's participant tasks (which run in workers that do not
import pandas). The definitions are those of :mod:`nudgecli.report.metrics`.

Steps are matched to their trial by ``(participant, trial)`` (steps of a trial not in the trial
table are left out) and put in step order within each trial (a stable sort, skipped where the
log is in that order already, as a participant task's is); each trial's sums are then taken over
its contiguous run of steps with ``np.add.reduceat``, in step order (the order pandas' grouped
sums use for such sorted groups, so the values are the ones the metrics table has always had).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Literal

import numpy as np

from nudgecli.errors import DataError
from nudgecli.model.interface import LABELS
from nudgecli.steplog import HUMAN_TURN, MODE_SWITCH_HUMAN, event_counts

#: The columns of the step log the metrics use.
METRIC_STEP_COLUMNS = ("participant", "trial", "step", "turn", "alpha", "inferred_goal", "event")
#: The columns of the step log the input measures use (``first_input_latency``,
#: ``active_input_fraction``); a log without them gets those two metrics missing.
INPUT_STEP_COLUMNS = ("t", "phi_m")
#: The columns of the trial table the step-based metrics use (``trials`` of :func:`step_metric_arrays`).
STEP_TRIAL_COLUMNS = ("participant", "trial", "true_goal")
#: The per-trial values :func:`step_metric_arrays` returns, in order.
STEP_METRIC_NAMES = ("assistance_engagement", "assistance_strength", "mode_switches", "human_effort",
                     "first_input_latency", "active_input_fraction", "last_inferred_goal")

#: The metric definitions (keywords of :func:`step_metric_arrays`) that the step-based metrics
#: depend on; ``success`` and ``completion_time`` are read from the trial table.
STEP_DEFINITIONS = ("engagement", "strength", "mode_switches")

#: One column: ``(N,)`` values, as a numpy array or a list.
Column = Sequence[Any] | np.ndarray

#: Decimals the ratio metrics are rounded to: sums over steps divided by counts carry
#: floating-point noise (0.8 * 3 / 3 != 0.8); rounding makes equal values equal again, so they
#: rank as ties in the tests.
RATIO_DECIMALS = 12


def trial_rows_of_steps(trial_participant: Column, trial_number: Column, step_participant: Column,
                        step_trial: Column) -> np.ndarray:
    """Each step's row in the trial table, matched by ``(participant, trial)``.

    Returns
    -------
    np.ndarray
        ``(N,)`` int64 row indices into the ``(T,)`` trial table; -1 for a step whose trial is
        not in the table.

    Raises
    ------
    DataError
        A ``(participant, trial)`` appears twice in the trial table.
    """
    rows: dict[tuple[Any, Any], int] = {}
    for row, key in enumerate(zip(_plain(trial_participant), _plain(trial_number), strict=True)):
        if key in rows:
            raise DataError(f"the trial table holds trial (participant, trial) = {key} more than "
                            "once; each trial must appear once")
        rows[key] = row
    participant, trial = np.asarray(step_participant), np.asarray(step_trial)
    if len(participant) != len(trial):
        raise ValueError(f"{len(participant)} step participants but {len(trial)} step trials")
    # a step log keeps each trial's steps together: look each run of one trial's steps up once
    starts = _run_starts(participant, trial)
    run_keys = zip(_plain(participant[starts]), _plain(trial[starts]), strict=True)
    found = [rows.get(key, -1) for key in run_keys]
    return np.repeat(np.array(found, dtype=np.int64), np.diff(np.r_[starts, len(participant)]))


def step_metric_arrays(
    trials: Mapping[str, Column],
    steps: Mapping[str, Column],
    *,
    engagement: Literal["per_step", "per_turn"] = "per_step",
    strength: Literal["per_step", "per_turn"] = "per_step",
    mode_switches: Literal["any_turn", "human_turn"] = "any_turn",
) -> dict[str, np.ndarray]:
    """The step-based metrics of every trial of the trial table.

    Parameters
    ----------
    trials
        :data:`STEP_TRIAL_COLUMNS` (``participant``, ``trial``, ``true_goal``): ``(T,)`` each, one
        trial per row.
    steps
        ``participant``, ``trial``, ``step``: ``(N,)`` each, any order of rows; ``turn`` (text),
        ``alpha`` (floats, no missing values), ``inferred_goal`` (-1 for none) and ``event``
        (event cells; missing cells have no events); and optionally ``t`` (floats) and ``phi_m``
        (text, ``""`` for no input) for the two input measures.
    engagement, strength, mode_switches
        The definitions of :func:`nudgecli.report.metrics.trial_metrics`.

    Returns
    -------
    dict
        :data:`STEP_METRIC_NAMES` -> ``(T,)`` float arrays in the trial table's order: NaN for a
        trial without steps (and where the metric has none: no human step, no assisted step, no
        command, no input columns, no inferred goal). ``mode_switches`` counts switches as
        floats; ``last_inferred_goal`` is the last ``inferred_goal >= 0`` of the trial's steps.
    """
    n_trials = len(trials["participant"])
    row, order = _steps_in_trial_order(trials, steps)
    per_trial = _PerTrial(row, n_trials)

    true_goal = np.asarray(trials["true_goal"])[row]
    alpha = _in_order(steps["alpha"], order, float)
    turn = _in_order(steps["turn"], order, object)
    is_human = turn == HUMAN_TURN
    inferred = _in_order(steps["inferred_goal"], order)
    assisted = is_human & (alpha > 0) & (inferred == true_goal)
    assisted_alpha = np.where(assisted, alpha, 0.0)
    # event_counts reads any sequence of cells: a column already in order is not made an array first
    events = steps["event"] if order is None else _in_order(steps["event"], order, object)
    switches = event_counts(events, MODE_SWITCH_HUMAN)
    if mode_switches == "human_turn":
        switches = np.where(is_human, switches, 0)

    n_steps = per_trial(np.ones(len(row), dtype=np.int64))
    human_steps = per_trial(is_human.astype(np.int64))
    assisted_steps = per_trial(assisted.astype(np.int64))
    with np.errstate(invalid="ignore", divide="ignore"):
        if engagement == "per_step" or strength == "per_step":
            engagement_values = assisted_steps / np.where(human_steps > 0, human_steps, np.nan)
            strength_values = per_trial(assisted_alpha) / np.where(assisted_steps > 0, assisted_steps, np.nan)
        if "per_turn" in (engagement, strength):
            turn_engagement, turn_strength = _per_human_turn(row, is_human, assisted, assisted_alpha, turn,
                                                              n_trials)
            if engagement == "per_turn":
                engagement_values = turn_engagement
            if strength == "per_turn":
                strength_values = turn_strength
        effort_values = human_steps / n_steps
        active_values, latency = _input_measures(steps, order, per_trial, n_steps)
    return {
        "assistance_engagement": np.round(engagement_values, RATIO_DECIMALS),
        "assistance_strength": np.round(strength_values, RATIO_DECIMALS),
        "mode_switches": per_trial(switches.astype(np.int64)),
        "human_effort": np.round(effort_values, RATIO_DECIMALS),
        "first_input_latency": latency,
        "active_input_fraction": np.round(active_values, RATIO_DECIMALS),
        "last_inferred_goal": _last_inferred_goal(row, inferred, n_trials),
    }


def _steps_in_trial_order(trials: Mapping[str, Column],
                          steps: Mapping[str, Column]) -> tuple[np.ndarray, np.ndarray | None]:
    """The steps of the trial table's trials, each trial's in step order (ties keep the log's order)
    and the trials in the table's order.

    Returns
    -------
    row : np.ndarray
        ``(M,)`` the steps' rows in the trial table, in that order.
    order : np.ndarray or None
        ``(M,)`` their indices in ``steps``; ``None`` where that is every step in the log's own
        order (a participant task's log: its trials in the table's order, each in step order), so
        the columns are read as they are, neither sorted nor copied.
    """
    row = trial_rows_of_steps(trials["participant"], trials["trial"], steps["participant"], steps["trial"])
    step = np.asarray(steps["step"])
    if _in_row_and_step_order(row, step):  # the stable sort below would give every index in order
        return row, None
    kept = np.flatnonzero(row >= 0)
    order = kept[np.lexsort((step[kept], row[kept]))]
    return row[order], order


def _in_row_and_step_order(row: np.ndarray, step: np.ndarray) -> bool:
    """Whether every step is of a trial in the table (``row >= 0``) and the ``(row, step)`` pairs
    never decrease (``(M,)`` each): the order ``np.lexsort((step, row))`` gives, unchanged."""
    if (row < 0).any():
        return False
    row_change = row[1:] - row[:-1]
    same_trial = row_change == 0
    return bool((row_change >= 0).all() and (step[1:][same_trial] >= step[:-1][same_trial]).all())


def _in_order(column: Column, order: np.ndarray | None, dtype: Any = None) -> np.ndarray:
    """``(M,)`` a step column as an array in the metrics' step order (``order``: as
    :func:`_steps_in_trial_order` gives it; ``None``: the column's own)."""
    values = np.asarray(column, dtype=dtype)
    return values if order is None else values[order]


class _PerTrial:
    """Reductions over each trial's contiguous steps (``row``: ``(M,)`` trial rows, each trial's
    steps together): ``(T,)`` floats, NaN for a trial without steps."""

    def __init__(self, row: np.ndarray, n_trials: int) -> None:
        self.starts = _run_starts(row)
        self.present = row[self.starts]
        self.n_trials = n_trials

    def __call__(self, values: np.ndarray, reduce: np.ufunc = np.add) -> np.ndarray:
        out = np.full(self.n_trials, np.nan)
        if len(self.starts):
            out[self.present] = reduce.reduceat(values, self.starts)
        return out


def _input_measures(steps: Mapping[str, Column], order: np.ndarray | None, per_trial: _PerTrial,
                    n_steps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per trial: the fraction of steps with any measured input and the time of the first command
    (``(T,)`` each; NaN without the input columns)."""
    if "t" not in steps or "phi_m" not in steps:
        return np.full(per_trial.n_trials, np.nan), np.full(per_trial.n_trials, np.nan)
    phi_m = _in_order(steps["phi_m"], order, object)
    active = per_trial((phi_m != "").astype(np.int64)) / n_steps
    command_t = np.where(np.isin(phi_m, LABELS), _in_order(steps["t"], order, float), np.nan)
    return active, per_trial(command_t, np.fmin)  # fmin: steps without a command (NaN) are skipped


def _last_inferred_goal(row: np.ndarray, inferred: np.ndarray, n_trials: int) -> np.ndarray:
    """Per trial: the last ``inferred_goal >= 0`` of its steps (in step order), NaN if none."""
    named_row, named_goal = row[inferred >= 0], inferred[inferred >= 0]
    out = np.full(n_trials, np.nan)
    if len(named_row):
        last = np.r_[_run_starts(named_row)[1:], len(named_row)] - 1
        out[named_row[last]] = named_goal[last]
    return out


def _per_human_turn(row: np.ndarray, is_human: np.ndarray, assisted: np.ndarray, assisted_alpha: np.ndarray,
                    turn: np.ndarray, n_trials: int) -> tuple[np.ndarray, np.ndarray]:
    """Per trial: the mean over its human turns of the per-turn engagement and strength.

    A turn is a maximal run of consecutive steps (in the trial's step order) with the same ``turn``
    value. The per-turn strength is the mean ``alpha`` over the turn's assisted steps, 0 when none.

    Returns
    -------
    tuple of np.ndarray
        ``(T,)`` engagement and strength; NaN for a trial without a human turn.
    """
    if not is_human.any():
        return np.full(n_trials, np.nan), np.full(n_trials, np.nan)
    # each row's turn: the runs of equal (trial, turn) in step order
    starts = _run_starts(row, turn)
    turn_id = np.repeat(np.arange(len(starts)), np.diff(np.r_[starts, len(row)]))[is_human]
    turn_starts = _run_starts(turn_id)
    steps = np.add.reduceat(np.ones(len(turn_id), dtype=np.int64), turn_starts)
    assisted_steps = np.add.reduceat(assisted[is_human].astype(np.int64), turn_starts)
    alpha_sums = np.add.reduceat(assisted_alpha[is_human], turn_starts)
    engagement = assisted_steps / steps
    strength = np.zeros(len(turn_starts))
    np.divide(alpha_sums, assisted_steps, out=strength, where=assisted_steps > 0)

    # the mean over each trial's turns (a trial's human turns are together, in step order)
    per_trial = _PerTrial(row[is_human][turn_starts], n_trials)
    turns = per_trial(np.ones(len(turn_starts), dtype=np.int64))
    return per_trial(engagement) / turns, per_trial(strength) / turns


def _run_starts(*keys: np.ndarray) -> np.ndarray:
    """Where each run of consecutive rows with equal ``keys`` starts.

    Parameters
    ----------
    *keys
        ``(M,)`` arrays each (numbers or objects).

    Returns
    -------
    np.ndarray
        ``(R,)`` int64 indices of the runs' first rows, ascending; empty for no rows.
    """
    if not len(keys[0]):
        return np.zeros(0, dtype=np.int64)
    changed = np.zeros(len(keys[0]) - 1, dtype=bool)
    for key in keys:
        changed |= key[1:] != key[:-1]
    return np.flatnonzero(np.r_[True, changed])


def _plain(values: Column) -> list[Any]:
    """Python values (``tolist`` of an array), so that keys of equal value hash alike."""
    return values.tolist() if isinstance(values, np.ndarray) else list(values)
