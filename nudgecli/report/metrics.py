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
- ``success``: the trial ended at the true goal (``success`` of the trial table).

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

from collections.abc import Mapping
from typing import Literal

import numpy as np
import pandas as pd

from nudgecli.errors import DataError
from nudgecli.model.interface import LABELS
from nudgecli.steplog import HUMAN_TURN, MODE_SWITCH_HUMAN, count_event

METRIC_NAMES = (
    "assistance_engagement",
    "assistance_strength",
    "mode_switches",
    "human_effort",
    "completion_time",
    "human_turns",
    "success",
    "first_input_latency",
    "active_input_fraction",
)

#: The columns of the trial table the metrics use.
TRIAL_COLUMNS = ("participant", "condition", "block", "trial", "true_goal", "success", "duration_s",
                 "human_turns")
#: The columns of the step log the metrics use.
METRIC_STEP_COLUMNS = ("participant", "trial", "step", "turn", "alpha", "inferred_goal", "event")
#: The columns of the step log the input measures use (``first_input_latency``,
#: ``active_input_fraction``); a log without them gets those two metrics missing.
INPUT_STEP_COLUMNS = ("t", "phi_m")
#: The columns identifying a trial in the metrics table, before the metric columns.
ID_COLUMNS = ("participant", "condition", "block", "trial")

_TRIAL_KEY = ["participant", "trial"]
_DECIMALS = 12


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
        One row per trial with the columns :data:`TRIAL_COLUMNS`; ``(participant, trial)``
        identifies a trial.
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
        complete the task successfully; missing for the other trials, judged by ``success``).

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
    s, has_input = _trial_steps(trials, steps)
    frame = _step_indicators(s, has_input, mode_switches)
    per_trial = frame.groupby(_TRIAL_KEY, sort=False).agg(
        steps=("human", "size"),
        human_steps=("human", "sum"),
        assisted_steps=("assisted", "sum"),
        assisted_alpha=("assisted_alpha", "sum"),
        switches=("switches", "sum"),
        active_steps=("active", "sum"),
        first_command_t=("command_t", "min"),
    )
    ratios = _trial_ratios(s, frame, per_trial, engagement, strength)
    return _metrics_table(trials, s, per_trial, ratios, has_input, success, completion_time)


def _trial_steps(trials: pd.DataFrame, steps: pd.DataFrame) -> tuple[pd.DataFrame, bool]:
    """The checked step log with each step's true goal, sorted by trial and step, and whether it
    has the input columns (:data:`INPUT_STEP_COLUMNS`)."""
    _require_columns(trials, TRIAL_COLUMNS, "trial table")
    _require_columns(steps, METRIC_STEP_COLUMNS, "step log")
    if trials.duplicated(_TRIAL_KEY).any():
        first = trials.loc[trials.duplicated(_TRIAL_KEY), _TRIAL_KEY].iloc[0].tolist()
        raise DataError(f"the trial table holds trial (participant, trial) = {tuple(first)} more than "
                        "once; each trial must appear once")

    trial_goal = trials[[*_TRIAL_KEY, "true_goal"]]
    has_input = all(c in steps.columns for c in INPUT_STEP_COLUMNS)
    columns = [*METRIC_STEP_COLUMNS, *INPUT_STEP_COLUMNS] if has_input else list(METRIC_STEP_COLUMNS)
    s = steps[columns].merge(trial_goal, on=_TRIAL_KEY, how="inner", validate="many_to_one")
    s = s.sort_values([*_TRIAL_KEY, "step"], kind="stable").reset_index(drop=True)
    return s, has_input


def _step_indicators(s: pd.DataFrame, has_input: bool, mode_switches: str) -> pd.DataFrame:
    """Per step: human turn, assisted (``alpha > 0`` towards the true goal) and its ``alpha``,
    the human's mode switches, any measured input, and the time of a command (NaN otherwise)."""
    alpha = s["alpha"].astype(float).fillna(0.0)
    is_human = (s["turn"].astype(str) == HUMAN_TURN).to_numpy()
    correct_goal = s["inferred_goal"].to_numpy() == s["true_goal"].to_numpy()
    assisted = is_human & (alpha.to_numpy() > 0) & correct_goal
    return pd.DataFrame({
        "participant": s["participant"],
        "trial": s["trial"],
        "human": is_human.astype(np.int64),
        "assisted": assisted.astype(np.int64),
        "assisted_alpha": np.where(assisted, alpha.to_numpy(), 0.0),
        "switches": _human_mode_switches_per_step(s, only_human_turns=mode_switches == "human_turn"),
        "active": ((s["phi_m"].fillna("").astype(str) != "").to_numpy(np.int64) if has_input
                   else np.zeros(len(s), dtype=np.int64)),
        "command_t": (s["t"].astype(float).where(s["phi_m"].isin(LABELS)).to_numpy() if has_input
                      else np.full(len(s), np.nan)),
    })


def _trial_ratios(s: pd.DataFrame, frame: pd.DataFrame, per_trial: pd.DataFrame, engagement: str,
                  strength: str) -> dict[str, pd.Series]:
    """Per trial: assistance engagement and strength (per step or per turn), human effort and the
    active input fraction, rounded to :data:`_DECIMALS`."""
    with np.errstate(invalid="ignore", divide="ignore"):
        if engagement == "per_step":
            engagement_values = per_trial["assisted_steps"] / per_trial["human_steps"].where(
                per_trial["human_steps"] > 0)
        if strength == "per_step":
            strength_values = per_trial["assisted_alpha"] / per_trial["assisted_steps"].where(
                per_trial["assisted_steps"] > 0)
        if "per_turn" in (engagement, strength):
            per_turn = _per_human_turn(s, frame)
            if engagement == "per_turn":
                engagement_values = per_turn["engagement"]
            if strength == "per_turn":
                strength_values = per_turn["strength"]
        effort_values = per_trial["human_steps"] / per_trial["steps"]
        active_values = per_trial["active_steps"] / per_trial["steps"]

    # Sums over steps divided by counts carry floating-point noise (0.8 * 3 / 3 != 0.8); rounding
    # to 12 decimals makes equal values equal again, so they rank as ties in the tests.
    engagement_values = engagement_values.round(_DECIMALS)
    strength_values = strength_values.round(_DECIMALS)
    effort_values = effort_values.round(_DECIMALS)
    active_values = active_values.round(_DECIMALS)
    return {"engagement": engagement_values, "strength": strength_values, "effort": effort_values,
            "active": active_values}


def _metrics_table(trials: pd.DataFrame, s: pd.DataFrame, per_trial: pd.DataFrame,
                   ratios: dict[str, pd.Series], has_input: bool, success: str,
                   completion_time: str) -> pd.DataFrame:
    """The metrics table: one row per trial in the trial table's order (see :func:`trial_metrics`)."""
    engagement_values, strength_values = ratios["engagement"], ratios["strength"]
    effort_values, active_values = ratios["effort"], ratios["active"]
    out = trials[list(ID_COLUMNS)].copy()
    key = pd.MultiIndex.from_frame(trials[_TRIAL_KEY])
    out["assistance_engagement"] = engagement_values.reindex(key).to_numpy(dtype=float)
    out["assistance_strength"] = strength_values.reindex(key).to_numpy(dtype=float)
    out["mode_switches"] = pd.array(per_trial["switches"].reindex(key).to_numpy(dtype=float),
                                   dtype="Float64").astype("Int64")
    out["human_effort"] = effort_values.reindex(key).to_numpy(dtype=float)
    out["completion_time"] = pd.to_numeric(trials["duration_s"]).astype(float).to_numpy()
    out["human_turns"] = pd.array(pd.to_numeric(trials["human_turns"]).to_numpy(), dtype="Int64")
    if success == "reached_goal":
        out["success"] = pd.array(trials["success"].astype(bool).to_numpy(), dtype="boolean")
    else:
        last_goal = _last_inferred_goal(s).reindex(key)
        reached = last_goal.to_numpy() == trials["true_goal"].to_numpy()
        out["success"] = pd.array(reached, dtype="boolean")
    out["first_input_latency"] = per_trial["first_command_t"].reindex(key).to_numpy(dtype=float)
    out["active_input_fraction"] = active_values.reindex(key).to_numpy(dtype=float)
    if not has_input:
        out["active_input_fraction"] = np.nan
    if completion_time == "successful_trials":
        out["completion_time"] = out["completion_time"].where(out["success"].fillna(False).to_numpy(bool))
    return out.reset_index(drop=True)


def _per_human_turn(s: pd.DataFrame, frame: pd.DataFrame) -> pd.DataFrame:
    """Per trial: the mean over human turns of the per-turn engagement and strength.

    A turn is a maximal run of consecutive steps with the same ``turn`` value within a trial.
    The per-turn strength is the mean ``alpha`` over the turn's assisted steps, 0 when none.
    """
    new_trial = (s["participant"] != s["participant"].shift()) | (s["trial"] != s["trial"].shift())
    new_turn = new_trial | (s["turn"] != s["turn"].shift())
    human = frame.assign(turn_id=new_turn.cumsum().to_numpy())
    human = human[human["human"] == 1]
    turns = human.groupby([*_TRIAL_KEY, "turn_id"], sort=False).agg(
        steps=("human", "size"), assisted_steps=("assisted", "sum"), assisted_alpha=("assisted_alpha", "sum"))
    turns["engagement"] = turns["assisted_steps"] / turns["steps"]
    turns["strength"] = (turns["assisted_alpha"] / turns["assisted_steps"].where(turns["assisted_steps"] > 0)
                         ).fillna(0.0)
    return turns.groupby(level=_TRIAL_KEY, sort=False)[["engagement", "strength"]].mean()


def _human_mode_switches_per_step(s: pd.DataFrame, only_human_turns: bool) -> np.ndarray:
    """Per step: the number of ``mode_switch_human`` events (optionally 0 outside human turns).

    Returns
    -------
    np.ndarray
        ``(len(s),)`` integer counts aligned with the rows of ``s``.
    """
    counts = count_event(s["event"], MODE_SWITCH_HUMAN).to_numpy(dtype=np.int64)
    if only_human_turns:
        counts = np.where(s["turn"].astype(str).to_numpy() == HUMAN_TURN, counts, 0)
    return counts


def _last_inferred_goal(s: pd.DataFrame) -> pd.Series:
    """Per trial: the last inferred goal (``inferred_goal >= 0``), -1 when there was none."""
    inferred = s.loc[s["inferred_goal"] >= 0, [*_TRIAL_KEY, "inferred_goal"]]
    return inferred.groupby(_TRIAL_KEY, sort=False)["inferred_goal"].last()


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
