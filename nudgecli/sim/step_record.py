"""A trial's steps, kept raw while it runs and put into the step log's columns once.

:class:`~nudgecli.sim.protocol.TrialSession` appends one tuple per step (:data:`ROW_FIELDS`);
formatting every step as it happened was a fifth of the trial loop, so the columns of
:data:`~nudgecli.steplog.STEP_COLUMNS` are built here, once per trial.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from nudgecli.model import interface
from nudgecli.model.interface import LABELS
from nudgecli.model.world import MODE_NAMES
from nudgecli.steplog import STEP_COLUMNS, command_columns, join_events, step_times

#: The step log's ``phi_m`` of a measured code (no input: empty).
STREAM_LABEL = {**dict(enumerate(LABELS)), interface.PUFF_DEADBAND: interface.PUFF_DEADBAND_LABEL,
                interface.SIP_DEADBAND: interface.SIP_DEADBAND_LABEL}

#: The fields of one raw step row, in order (the pose, cell and mode at the start of the step).
ROW_FIELDS = ("step", "turn", "x", "y", "theta", "mode", "state", "intended", "pressure", "measured",
              "u_h", "u_a", "alpha", "inferred", "belief", "entropy", "events")


def step_columns(rows: Sequence[tuple[Any, ...]], participant: int, trial: int, dt: float,
                 cells: Callable[[int], tuple[int, int, int]]) -> dict[str, list[Any]]:
    """The step log's columns of one trial's raw rows.

    Parameters
    ----------
    rows
        ``(N,)`` tuples of :data:`ROW_FIELDS` (the belief an array never changed in place).
    participant, trial
        The trial's identifiers, repeated on every row.
    dt
        The step's length, s (the ``t`` column is ``round(step * dt, 10)``).
    cells
        The world's ``state -> (cell_x, cell_y, heading)``.

    Returns
    -------
    dict
        :data:`~nudgecli.steplog.STEP_COLUMNS` -> ``(N,)`` lists.
    """
    if not rows:
        return {c: [] for c in STEP_COLUMNS}
    (steps, turns, xs, ys, thetas, modes, states, intended, pressures, measured, u_h, u_a, alphas,
     inferred, beliefs, entropies, events) = (list(column) for column in zip(*rows, strict=True))
    n = len(steps)
    cells_of = {state: cells(state) for state in set(states)}  # a trial visits few states
    cell_x, cell_y, headings = zip(*(cells_of[state] for state in states), strict=True)
    human, autonomy = command_columns(u_h, n), command_columns(u_a, n)
    times = step_times(dt, max(steps))
    columns: dict[str, list[Any]] = {
        "participant": [participant] * n,
        "trial": [trial] * n,
        "step": steps,
        "t": [times[step] for step in steps],
        "turn": turns,
        "x": xs,
        "y": ys,
        "theta": thetas,
        "mode": [MODE_NAMES[m] for m in modes],
        "cell_x": list(cell_x),
        "cell_y": list(cell_y),
        "heading": list(headings),
        "phi_i": [LABELS[i] if i >= 0 else "" for i in intended],
        "pressure": pressures,
        "phi_m": [STREAM_LABEL.get(m, "") for m in measured],
        "u_h_x": human[0],
        "u_h_y": human[1],
        "u_h_theta": human[2],
        "u_a_x": autonomy[0],
        "u_a_y": autonomy[1],
        "u_a_theta": autonomy[2],
        "alpha": alphas,
        "inferred_goal": inferred,
        "belief": [belief.tolist() for belief in beliefs],
        "entropy": entropies,
        "event": [join_events(e) for e in events],
    }
    assert tuple(columns) == STEP_COLUMNS
    return columns

