"""Per-trial metrics from a run's trial table and 10 Hz step log (paper section 5.3).

Definitions (the paper's, DESIGN section 5), per trial:

- ``assistance_engagement``: fraction of the human's turn steps with ``alpha > 0`` and
  ``inferred_goal == true_goal``;
- ``assistance_strength``: mean ``alpha`` over the human's turn steps with ``alpha > 0`` and
  ``inferred_goal == true_goal`` (missing when there is none);
- ``mode_switches``: the human's mode switches (steps whose ``event`` holds
  ``mode_switch_human``), in either turn — a hard blow during the autonomy's turn still
  switches the mode;
- ``human_effort``: the human's turn time over the trial time (with the constant 10 Hz step,
  the fraction of the trial's steps that are human-turn steps);
- ``completion_time``: the trial's duration in seconds (``duration_s``);
- ``human_turns``: the number of human turns (``human_turns`` of the trial table);
- ``success``: the trial ended at the true goal (``success`` of the trial table);
- ``wrong_goal``: the trial ended at a goal that is not the true one (``reached_goal >= 0`` and
  ``reached_goal != true_goal`` of the trial table; a time-out, ``reached_goal == -1``, is neither
  a success nor a wrong goal). The same under every plan, whatever its ``success`` definition;
  missing for a trial table without ``reached_goal`` (a hand-made one: every run has it).

The measures the team checks against real people's teleoperation (the CIAA task), defined from
the step log the same way in every world:

- ``first_input_latency``: seconds from the trial's start to the first step whose measured label
  ``phi_m`` is a command (Hard/Soft Puff/Sip; deadbands and no input are not), i.e. the ``t`` of
  that step; missing when the trial had no command;
- ``active_input_fraction``: the fraction of the trial's steps with any measured input (a
  non-empty ``phi_m``: the four labels and the two deadbands), i.e. of the time the person was
  blowing or sipping. In the grid world this counts the whole trial, the autonomy's turns
  (without input) included.

Together with ``completion_time`` (``all_trials``), ``success`` and ``mode_switches`` these are
the ``ciaa-teleop`` analysis plan.

The study software's variants (study-software-notes section 7), chosen by keyword:

- ``engagement="per_turn"`` / ``strength="per_turn"``: the per-turn fraction / per-turn mean
  ``alpha`` (0 for a turn without assistance), averaged over the trial's human turns;
- ``mode_switches="human_turn"``: only switches inside the human's turns are counted;
- ``success="last_inferred_goal"``: the last inferred goal (``inferred_goal >= 0``) is the
  true goal;
- :func:`apply_filters`: a metric above its maximum becomes missing (the study dropped trials
  with more than 10 mode switches, more than 10 turns, or longer than 100 s, each from its own
  metric only).

The steps are only grouped (pandas ``groupby``), never looped over in Python.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, Literal

import numpy as np
import pandas as pd

from nudgecli.errors import DataError
from nudgecli.report.metric_names import METRIC_NAMES as METRIC_NAMES  # re-exported
from nudgecli.report.step_metrics import (
    INPUT_STEP_COLUMNS,
    METRIC_STEP_COLUMNS,
    STEP_METRIC_NAMES,
    STEP_TRIAL_COLUMNS,
    step_metric_arrays,
)

#: The columns of the trial table the metrics use (a run's trial table has them all).
TRIAL_COLUMNS = ("participant", "condition", "block", "trial", "true_goal", "success", "duration_s",
                 "human_turns", "reached_goal")
#: Those of :data:`TRIAL_COLUMNS` a trial table may lack: ``wrong_goal`` is then missing.
OPTIONAL_TRIAL_COLUMNS = ("reached_goal",)
#: Those of :data:`TRIAL_COLUMNS` a trial table must have.
_REQUIRED_TRIAL_COLUMNS = tuple(c for c in TRIAL_COLUMNS if c not in OPTIONAL_TRIAL_COLUMNS)
#: The columns identifying a trial in the metrics table, before the metric columns.
ID_COLUMNS = ("participant", "condition", "block", "trial")


def _require_columns(table: pd.DataFrame, columns: tuple[str, ...], what: str) -> None:
    missing = [c for c in columns if c not in table.columns]
    if missing:
        raise DataError(f"the {what} lacks the column(s) {', '.join(missing)}; it needs "
                        f"{', '.join(columns)} (re-run `nudge simulate` with this version of nudge)")


def trial_metrics(
    trials: pd.DataFrame,
    steps: pd.DataFrame,
    *,
    engagement: Literal["per_step", "per_turn"] = "per_step",
    strength: Literal["per_step", "per_turn"] = "per_step",
    mode_switches: Literal["any_turn", "human_turn"] = "any_turn",
    success: Literal["reached_goal", "last_inferred_goal"] = "reached_goal",
    completion_time: Literal["all_trials", "successful_trials"] = "all_trials",
) -> pd.DataFrame:
    """The metrics of every trial.

    Parameters
    ----------
    trials
        One row per trial with the columns :data:`TRIAL_COLUMNS` (those of
        :data:`OPTIONAL_TRIAL_COLUMNS` optional); ``(participant, trial)`` identifies a trial.
    steps
        One row per 10 Hz step with the columns :data:`METRIC_STEP_COLUMNS` (any order of rows), and
        :data:`INPUT_STEP_COLUMNS` for the two input measures (missing without them).
        ``turn`` is ``"human"`` or ``"autonomy"``; ``inferred_goal`` is -1 when there is none;
        ``event`` holds event names joined with ``"|"`` (empty when none).
    engagement, strength
        ``"per_step"`` (the paper) or ``"per_turn"`` (the study software's mean over human turns).
    mode_switches
        ``"any_turn"`` (every human mode switch) or ``"human_turn"`` (only inside human turns).
    success
        ``"reached_goal"`` (the trial table's verdict) or ``"last_inferred_goal"``.
    completion_time
        ``"all_trials"`` (the study software) or ``"successful_trials"`` (the paper: the time to
        complete the task successfully; missing for the other trials, judged by the trial table's
        own verdict whichever ``success`` is: a trial timed out is no completion under the proxy either).

    Returns
    -------
    pd.DataFrame
        One row per trial in the trial table's order: :data:`ID_COLUMNS` then
        :data:`METRIC_NAMES`. Step-based metrics of a trial without steps are missing; the
        counts are nullable integers, ``success`` is boolean.

    Raises
    ------
    DataError
        A required column is missing, or a trial appears twice in the trial table.
    """
    _require_columns(trials, _REQUIRED_TRIAL_COLUMNS, "trial table")
    _require_columns(steps, METRIC_STEP_COLUMNS, "step log")
    values = step_metric_arrays({name: trials[name].to_numpy() for name in STEP_TRIAL_COLUMNS},
                                step_metric_columns(steps), engagement=engagement, strength=strength,
                                mode_switches=mode_switches)
    return metrics_frame(trials, values, success=success, completion_time=completion_time)


def trial_metrics_by_participant(
    trials: pd.DataFrame,
    steps_of: Callable[[int], pd.DataFrame | None],
    **definitions: Any,
) -> pd.DataFrame:
    """:func:`trial_metrics` of a run whose step log is read one participant at a time.

    Each trial's metrics read its own steps only, so this is the same table with one
    participant's steps in memory (the step log of 300 paper participants was 0.8 GB at once).

    Parameters
    ----------
    trials
        As :func:`trial_metrics`'s.
    steps_of
        A participant (as in ``trials``) -> their steps (as :func:`trial_metrics`' ``steps``), or
        ``None`` where they have none (their trials' step metrics are then missing).
    **definitions
        :func:`trial_metrics`' keywords.
    """
    _require_columns(trials, _REQUIRED_TRIAL_COLUMNS, "trial table")
    arrays = {name: trials[name].to_numpy() for name in STEP_TRIAL_COLUMNS}
    values = {name: np.full(len(trials), np.nan) for name in STEP_METRIC_NAMES}
    outcome = {key: definitions.pop(key) for key in ("success", "completion_time") if key in definitions}
    for participant in pd.unique(arrays["participant"]):
        steps = steps_of(participant)
        if steps is None:
            continue
        _require_columns(steps, METRIC_STEP_COLUMNS, "step log")
        rows = np.flatnonzero(arrays["participant"] == participant)
        theirs = step_metric_arrays({name: column[rows] for name, column in arrays.items()},
                                    step_metric_columns(steps), **definitions)
        for name, column in theirs.items():
            values[name][rows] = column
    return metrics_frame(trials, values, **outcome)


def step_metric_columns(steps: pd.DataFrame) -> dict[str, np.ndarray]:
    """The step log's columns as :func:`~nudgecli.report.step_metrics.step_metric_arrays` takes
    them: ``alpha`` missing -> 0, ``turn`` as text, ``phi_m`` missing -> ``""`` (no input); the
    input columns only where the log has both."""
    columns = {
        "participant": steps["participant"].to_numpy(),
        "trial": steps["trial"].to_numpy(),
        "step": steps["step"].to_numpy(),
        "turn": _text_objects(steps["turn"], lambda labels: labels.astype(str)),
        "alpha": steps["alpha"].astype(float).fillna(0.0).to_numpy(dtype=float),
        "inferred_goal": steps["inferred_goal"].to_numpy(),
        "event": _text_objects(steps["event"], lambda labels: labels),
    }
    if all(c in steps.columns for c in INPUT_STEP_COLUMNS):
        columns["t"] = steps["t"].astype(float).to_numpy(dtype=float)
        columns["phi_m"] = _text_objects(steps["phi_m"], lambda labels: labels.fillna("").astype(str))
    return columns


def _text_objects(column: pd.Series, convert: Callable[[pd.Series], pd.Series]) -> np.ndarray:
    """``convert(column).to_numpy(dtype=object)``, converting each distinct value once: a step log's
    few labels then fill the ``(N,)`` array as shared objects, where one string a step was 0.4 GB
    for a 300-participant paper run's three text columns."""
    codes, distinct = pd.factorize(column)
    out = np.empty(len(column), dtype=object)
    present = codes >= 0
    if len(distinct):
        out[present] = convert(pd.Series(distinct, dtype=column.dtype)).to_numpy(dtype=object)[codes[present]]
    if not present.all():  # missing values (None, NaN or NA as they are) converted where they are
        out[~present] = convert(column[~present]).to_numpy(dtype=object)
    return out


def metrics_frame(trials: pd.DataFrame, values: Mapping[str, np.ndarray], *,
                  success: Literal["reached_goal", "last_inferred_goal"] = "reached_goal",
                  completion_time: Literal["all_trials", "successful_trials"] = "all_trials") -> pd.DataFrame:
    """The metrics table of :func:`trial_metrics`: the trial table's identifiers and columns with
    the step-based metrics ``values`` (:func:`~nudgecli.report.step_metrics.step_metric_arrays`
    of the same trials, in the same order).

    Returns
    -------
    pd.DataFrame
        One row per trial in the trial table's order: :data:`ID_COLUMNS` then :data:`METRIC_NAMES`;
        the counts are nullable integers, ``success`` is boolean.
    """
    if success == "reached_goal":
        reached = pd.array(trials["success"].astype(bool).to_numpy(), dtype="boolean")
    else:
        reached = pd.array(values["last_inferred_goal"] == trials["true_goal"].to_numpy(), dtype="boolean")
    duration = pd.to_numeric(trials["duration_s"]).astype(float).to_numpy()
    if completion_time == "successful_trials":
        # the paper's "time taken to complete the task successfully" is judged by the trial's own
        # verdict whichever success the plan reports: under the study's proxy a trial timed out
        # (reached_goal -1, its time the limit) whose last inferred goal was the true one completed nothing
        completed = reached if success == "reached_goal" else \
            pd.array(trials["success"].astype(bool).to_numpy(), dtype="boolean")
        duration = successful_only(duration, completed)
    # built in one go (a column at a time cost a block insertion each)
    columns: dict[str, Any] = {name: trials[name].array for name in ID_COLUMNS}
    columns.update({
        "assistance_engagement": values["assistance_engagement"],
        "assistance_strength": values["assistance_strength"],
        "mode_switches": pd.array(values["mode_switches"], dtype="Float64").astype("Int64"),
        "human_effort": values["human_effort"],
        "completion_time": duration,
        "human_turns": pd.array(pd.to_numeric(trials["human_turns"]).to_numpy(), dtype="Int64"),
        "success": reached,
        "first_input_latency": values["first_input_latency"],
        "active_input_fraction": values["active_input_fraction"],
        "wrong_goal": wrong_goal(trials),
    })
    return pd.DataFrame(columns)


def successful_only(times: np.ndarray, success: pd.arrays.BooleanArray) -> np.ndarray:
    """The paper's completion time (``completion_time = "successful_trials"``): a trial's time where
    it succeeded, missing elsewhere (a failed trial, or one whose success is unknown).

    The one place of the rule: a run's metrics (:func:`metrics_frame`) and a metrics table's
    (:mod:`nudgecli.report.table_definitions`) both go through it.

    Parameters
    ----------
    times
        ``(T,)`` float seconds.
    success
        ``(T,)`` nullable booleans.

    Returns
    -------
    np.ndarray
        ``(T,)`` float: ``times`` where ``success`` is True, NaN elsewhere.
    """
    return np.where(success.fillna(False).to_numpy(bool), times, np.nan)


def wrong_goal(trials: pd.DataFrame) -> pd.arrays.BooleanArray:
    """Whether each trial ended at a goal other than its true one.

    Parameters
    ----------
    trials
        ``(T,)`` rows with ``true_goal`` and ``reached_goal`` (the goal the trial ended at, -1 for
        none: a time-out).

    Returns
    -------
    pd.arrays.BooleanArray
        ``(T,)``: ``reached_goal >= 0 and reached_goal != true_goal``; missing where
        ``reached_goal`` is, and everywhere without the column.
    """
    if "reached_goal" not in trials.columns:
        return pd.array([pd.NA] * len(trials), dtype="boolean")
    reached = pd.to_numeric(trials["reached_goal"]).astype("Float64").to_numpy(dtype=float, na_value=np.nan)
    true_goal = pd.to_numeric(trials["true_goal"]).to_numpy(dtype=float)
    ended_elsewhere = (reached >= 0) & (reached != true_goal)
    return pd.arrays.BooleanArray(ended_elsewhere, np.isnan(reached))


def apply_filters(metrics: pd.DataFrame, filters: Mapping[str, float]) -> pd.DataFrame:
    """Set each filtered metric to missing where it exceeds its maximum (inclusive).

    Each filter acts on its own column only; the trial stays in the other metrics (the study
    software's rule).

    Parameters
    ----------
    metrics
        The metrics table.
    filters
        ``{metric: maximum}``, e.g. ``{"mode_switches": 10, "human_turns": 10,
        "completion_time": 100}``. Metrics not in the table are ignored.

    Returns
    -------
    pd.DataFrame
        A copy with the filtered values missing.
    """
    out = metrics.copy()
    for column, maximum in filters.items():
        if column not in out.columns:
            continue
        values = out[column]
        numeric = values.astype("Float64") if values.dtype == "boolean" or values.dtype == bool else values
        out[column] = values.mask((numeric > maximum).fillna(False).astype(bool))
    return out
