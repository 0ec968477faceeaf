"""A plan's metric definitions applied to a metrics table, as far as the table's own columns allow.

A run folder's metrics are computed with the plan's definitions (:mod:`nudgecli.report.metrics`);
a metrics table (real study data, or a run's ``metrics.csv``) holds values somebody already
computed. Of a plan's ``[metrics]`` definitions, one can be applied from a table's columns:

- ``completion_time = "successful_trials"`` (the paper: "total time taken to complete the task
  successfully"): a trial's time is kept where the table's ``success`` column says it succeeded,
  missing elsewhere (:func:`nudgecli.report.metrics.successful_only`, the rule a run's metrics
  go through). A run's ``metrics.csv`` made under such a plan already holds no time for a failed
  trial, so applying it again changes nothing: the analysis of a run and of its own
  ``metrics.csv`` stay the same.

The others cannot: ``engagement``, ``strength`` and ``mode_switches`` are computed from a run's
step log, ``success`` from its trial table (the goal reached, or the last inferred one), and
``completion_time = "all_trials"`` cannot bring back the times a table left out. For the analysed
metrics they define, the table's own values are taken as they are, and one line says so (a
``Note:`` on stderr, and in ``summary.md``), naming the plan's definitions it could not apply.

The analysed metrics' blank cells, which every statistic leaves out, are counted in a line of
their own (:func:`blank_values_line`, a ``Note:`` on stderr): a failed trial's blank time is the
definition above, not counted there, but a successful trial's missing time, or a missing
``mode_switches``, is no longer left out unseen.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from nudgecli.report.metrics import successful_only
from nudgecli.report.plans import AnalysisPlan

#: The metrics whose definition a plan chooses -> their key in the plan's ``[metrics]``.
PLAN_DEFINED = {"assistance_engagement": "engagement", "assistance_strength": "strength",
                "mode_switches": "mode_switches", "success": "success", "completion_time": "completion_time"}


@dataclass(frozen=True)
class TableDefinitions:
    """A metrics table under a plan's definitions (:func:`apply_plan_definitions`).

    Attributes
    ----------
    table
        The table, ``completion_time`` of failed trials missing where the plan says so.
    changed
        Whether a value of the table became missing (then it differs from the source).
    line
        What was applied and what is the table's own, one line (``None``: nothing to say).
    blanks
        The table's blank cells of the analysed metrics, left out of them, one line
        (:func:`blank_values_line`; ``None``: none).
    """

    table: pd.DataFrame
    changed: bool
    line: str | None
    blanks: str | None = None


#: How many of a metric's trials with a blank cell its note names (the first, in the table's order).
NAMED_BLANKS = 3

#: The columns that name a trial in a note, those of them the table has.
TRIAL_KEY = ("participant", "condition", "block", "trial")


def blank_values_line(table: pd.DataFrame, analysed: Sequence[str],
                      success: pd.arrays.BooleanArray | None) -> str | None:
    """``blank cells left out: completion_time 1 of a trial not failed (P01 control block 1
    trial 2), ...``: the analysed metrics' blank cells, which every statistic leaves out.

    Not counted: a failed trial's blank ``completion_time`` (by the ``success`` column; the
    definitions' line says what becomes of failed trials' times, so nothing is counted twice),
    and a condition with no value of the metric at all (said as ``no values`` of the metric in
    ``summary.md`` and ``stats.json``, a metric not measured there rather than cells left blank).

    Returns
    -------
    str or None
        One line, each metric with its count and its first :data:`NAMED_BLANKS` trials;
        ``None`` when no analysed metric has a blank cell.
    """
    key = [c for c in TRIAL_KEY if c in table.columns]
    failed = None if success is None else ~success.fillna(True).to_numpy(bool)
    parts = []
    for metric in (m for m in analysed if m in table.columns):
        values = table[metric]
        measured = table["condition"].isin(table.loc[values.notna(), "condition"].unique())
        blank = (values.isna() & measured).to_numpy(bool)
        if metric == "completion_time" and failed is not None:
            blank = blank & ~failed
        positions = np.flatnonzero(blank)
        if positions.size == 0:
            continue
        named = "; ".join(" ".join(f"{c} {v}" if c in ("block", "trial") else str(v)
                                   for c, v in zip(key, table[key].iloc[p], strict=True))
                          for p in positions[:NAMED_BLANKS])
        more = ", ..." if positions.size > NAMED_BLANKS else ""
        which = " of a trial not failed" if metric == "completion_time" and failed is not None else ""
        parts.append(f"{metric} {positions.size}{which} ({named}{more})")
    if not parts:
        return None
    return f"blank cells left out: {', '.join(parts)}; each trial stays in its other metrics"


def trial_success(table: pd.DataFrame) -> pd.arrays.BooleanArray | None:
    """The table's ``success`` column as ``(T,)`` nullable booleans (blank: unknown), or ``None``
    when it has none or holds other values than True/False or 1/0 (not a trial's success)."""
    if "success" not in table.columns:
        return None
    column = table["success"]
    if pd.api.types.is_bool_dtype(column):
        return pd.array(column, dtype="boolean")
    if not pd.api.types.is_numeric_dtype(column):
        return None
    values = pd.to_numeric(column).astype("Float64")
    if not values.dropna().isin([0.0, 1.0]).all():
        return None
    return pd.array(values == 1.0, dtype="boolean")


def apply_plan_definitions(table: pd.DataFrame, plan: AnalysisPlan,
                           analysed: Sequence[str]) -> TableDefinitions:
    """Apply what ``plan``'s metric definitions can from ``table``'s own columns.

    Parameters
    ----------
    table
        A checked metrics table, one row per trial (``validate_metrics_table``'s).
    plan
        The analysis plan.
    analysed
        The table's metric columns to be analysed: only their definitions are named.

    Returns
    -------
    TableDefinitions
        ``table`` unchanged (the same object) unless a failed trial's time was left out; its
        ``blanks``: the blank cells of ``table`` as given (:func:`blank_values_line`).
    """
    definitions = plan.metrics
    original = table  # its blank cells are the table's own, not the failed trials' times made blank
    success = trial_success(table)
    parts: list[str] = []
    caveat: str | None = None  # why completion_time is the table's own, where it is
    changed = False
    if "completion_time" in analysed and "completion_time" in table.columns:
        times = pd.to_numeric(table["completion_time"]).astype("Float64").to_numpy(float, na_value=np.nan)
        wanted = f"plan {plan.label}'s completion_time = {definitions.completion_time!r}"
        if definitions.completion_time == "successful_trials" and success is None:
            caveat = (f"completion_time is the table's own: it has no success column of True/False (or 1/0) "
                      f"to keep successful trials' times only by, as {wanted} does")
        elif definitions.completion_time == "successful_trials" and success is not None:
            kept = successful_only(times, success)
            dropped = int(np.count_nonzero(np.isnan(kept) & ~np.isnan(times)))
            parts.append(f"completion_time over successful trials only (by its success column: "
                         f"{dropped} other trials' times left out), as plan {plan.label} defines it")
            if dropped:
                table = table.copy(deep=False)  # a new column, the others shared: no copy of a large table
                table["completion_time"] = kept
                changed = True
        elif success is not None:  # all_trials: the times of failed trials must be there
            missing = int(np.count_nonzero(np.isnan(times[~success.fillna(True).to_numpy(bool)])))
            if missing:
                caveat = (f"completion_time is the table's own: {missing} failed trials have no time in it, "
                          f"and {wanted} counts them (analyse the run folder for those times)")
    own = [m for m in PLAN_DEFINED if m in analysed and m != "completion_time"]
    if own:
        names = ", ".join(f"{m} = {getattr(definitions, PLAN_DEFINED[m])!r}" for m in own)
        parts.append(f"the table's own definitions were used for {', '.join(own)} (plan {plan.label}'s "
                     f"{names} are computed from a run folder's trials and steps)")
    parts += [caveat] if caveat else []
    blanks = blank_values_line(original, analysed, success)
    return TableDefinitions(table, changed, "; ".join(parts) if parts else None, blanks)
