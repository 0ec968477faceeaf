"""The step-log schema: the one definition of a run's ``steps`` table.

The protocol writes it (:mod:`nudgecli.sim.protocol`), the metrics and the figures read it
(:mod:`nudgecli.report.metrics`, :mod:`nudgecli.report.figures`), and a live session records it
the same way. Column names, turn names, event names and the event separator live here only.

One row per 10 Hz step (DESIGN section 4): the pose, cell and mode at the start of the step and
what happened during it. ``event`` holds zero or more event names joined with
:data:`EVENT_SEPARATOR`.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # pandas loads where frames are built: a worker simulates and computes metrics without it
    import pandas as pd

#: Turn names of the ``turn`` column.
HUMAN_TURN = "human"
AUTONOMY_TURN = "autonomy"
TURNS = (HUMAN_TURN, AUTONOMY_TURN)

#: Event names of the ``event`` column.
TRIAL_START = "trial_start"
HANDOVER_TO_HUMAN = "handover_to_human"
HANDOVER_TO_AUTONOMY = "handover_to_autonomy"
MODE_SWITCH_HUMAN = "mode_switch_human"
MODE_SWITCH_AUTONOMY = "mode_switch_autonomy"
NUDGE = "nudge"
STEP = "step"
#: The mode-switch policy's turn chose a mode (with MODE_SWITCH_AUTONOMY when it changed it).
MODE_SELECT = "mode_select"
EVENTS = (TRIAL_START, HANDOVER_TO_HUMAN, HANDOVER_TO_AUTONOMY, MODE_SWITCH_HUMAN,
          MODE_SWITCH_AUTONOMY, NUDGE, STEP, MODE_SELECT)

#: Joins the events of one step.
EVENT_SEPARATOR = "|"

#: ``inferred_goal`` when the agent names no goal (leaders tied, or no blending target).
NO_GOAL = -1

#: The columns of the step log, in order.
STEP_COLUMNS = (
    "participant", "trial", "step", "t", "turn", "x", "y", "theta", "mode", "cell_x", "cell_y",
    "heading", "phi_i", "pressure", "phi_m", "u_h_x", "u_h_y", "u_h_theta", "u_a_x", "u_a_y",
    "u_a_theta", "alpha", "inferred_goal", "belief", "entropy", "event",
)

#: The step log's numeric columns and their dtypes (the rest are text, and ``belief`` lists).
STEP_NUMERIC_DTYPES: dict[str, type[np.generic]] = {
    **dict.fromkeys(("participant", "trial", "step", "cell_x", "cell_y", "heading", "inferred_goal"),
                    np.int64),
    **dict.fromkeys(("t", "x", "y", "theta", "pressure", "u_h_x", "u_h_y", "u_h_theta", "u_a_x", "u_a_y",
                     "u_a_theta", "alpha", "entropy"), np.float64),
}


def wanted_step_columns(names: Collection[str]) -> list[str]:
    """The columns of :data:`STEP_COLUMNS` among ``names``, in the schema's order."""
    return [name for name in STEP_COLUMNS if name in names]


def step_arrays(columns: Mapping[str, list[Any] | np.ndarray]) -> dict[str, np.ndarray | list[Any]]:
    """The step log's ``columns`` (:data:`STEP_COLUMNS` -> ``(N,)`` lists of Python values) with each
    numeric column as one typed numpy array (:data:`STEP_NUMERIC_DTYPES`); text and ``belief`` columns
    stay lists.

    Numpy only, so a worker can build its step log without pandas. A column that already is an
    array of its dtype is kept as it is (no copy).
    """
    return {name: np.asarray(values, dtype=STEP_NUMERIC_DTYPES[name]) if name in STEP_NUMERIC_DTYPES
            else values for name, values in columns.items()}


def steps_frame(columns: Mapping[str, list[Any] | np.ndarray]) -> pd.DataFrame:
    """The step log's frame of ``columns`` (:data:`STEP_COLUMNS` -> ``(N,)`` lists of Python values,
    or the arrays of :func:`step_arrays`).

    Numeric columns go through one typed numpy array each (:func:`step_arrays`): the values and
    dtypes pandas would infer from the lists, without its per-element type checks (a tenth of
    building the frame).
    """
    import pandas as pd

    return pd.DataFrame(step_arrays(columns))


def join_events(events: Iterable[str]) -> str:
    """The ``event`` cell of a step with these events (empty string for none)."""
    return EVENT_SEPARATOR.join(events)


def event_tokens(cell: object) -> list[str]:
    """The event names in one ``event`` cell (a missing cell has none)."""
    if not isinstance(cell, str) or not cell:
        return []
    return [token.strip() for token in cell.split(EVENT_SEPARATOR)]


def event_counts(events: Iterable[object], name: str) -> np.ndarray:
    """Per cell, how many times the event ``name`` occurs in it (missing cells: none).

    Parameters
    ----------
    events
        ``(N,)`` ``event`` cells.
    name
        One event name, e.g. :data:`MODE_SWITCH_HUMAN`.

    Returns
    -------
    np.ndarray
        ``(N,)`` int64 counts.
    """
    # A step log holds a handful of distinct cells over thousands of rows: split each distinct
    # cell once, then look every row up (a missing cell, or anything but text, has no events).
    cells = events.tolist() if isinstance(events, np.ndarray) else list(events)
    per_cell = {cell: event_tokens(cell).count(name) for cell in set(cells)}
    return np.fromiter(map(per_cell.__getitem__, cells), dtype=np.int64, count=len(cells))


def count_event(events: pd.Series | Iterable[object], name: str) -> pd.Series:
    """:func:`event_counts` as a series, with the index of ``events`` (a fresh range index for a
    plain iterable)."""
    import pandas as pd

    series = events if isinstance(events, pd.Series) else pd.Series(list(events), dtype=object)
    return pd.Series(event_counts(series.to_numpy(dtype=object), name), index=series.index)


def has_event(events: pd.Series | Iterable[object], name: str) -> np.ndarray:
    """``(N,)`` bool: which ``event`` cells contain the event ``name`` exactly."""
    return (count_event(events, name) > 0).to_numpy(dtype=bool)


#: ``round(k dt, 10)`` for k = 0, 1, ... per dt, replaced whole (never grown in place) when too short.
_STEP_TIMES: dict[float, list[float]] = {}


def step_times(dt: float, last_step: int) -> list[float]:
    """The ``t`` column's values ``round(k dt, 10)`` of steps ``0..last_step`` at least: computed once
    per dt and process, then indexed (rounding every row of every trial was a tenth of formatting)."""
    times = _STEP_TIMES.get(dt)
    if times is None or len(times) <= last_step:
        times = _STEP_TIMES[dt] = [round(k * dt, 10) for k in range(max(2 * last_step + 1, 2048))]
    return times
