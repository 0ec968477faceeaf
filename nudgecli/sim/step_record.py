"""A trial's steps, kept raw while it runs and put into the step log's columns once.

:class:`~nudgecli.sim.protocol.TrialSession` appends one tuple per step (:data:`ROW_FIELDS`);
formatting every step as it happened was a fifth of the trial loop, so the columns of
:data:`~nudgecli.steplog.STEP_COLUMNS` are built here, once per trial.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence
from functools import cache
from typing import Any

from nudgecli.model import interface
from nudgecli.model.interface import LABELS
from nudgecli.model.world import MODE_NAMES
from nudgecli.steplog import STEP_COLUMNS, command_columns, join_events, step_times, wanted_step_columns

#: The step log's ``phi_m`` of a measured code (no input: empty).
STREAM_LABEL = {**dict(enumerate(LABELS)), interface.PUFF_DEADBAND: interface.PUFF_DEADBAND_LABEL,
                interface.SIP_DEADBAND: interface.SIP_DEADBAND_LABEL}

#: The fields of one raw step row, in order (the pose, cell and mode at the start of the step).
ROW_FIELDS = ("step", "turn", "x", "y", "theta", "mode", "state", "intended", "pressure", "measured",
              "u_h", "u_a", "alpha", "inferred", "belief", "entropy", "events")


def step_columns(rows: Sequence[tuple[Any, ...]], participant: int, trial: int, dt: float,
                 cells: Callable[[int], tuple[int, int, int]],
                 names: Collection[str] = STEP_COLUMNS) -> dict[str, list[Any]]:
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
    names
        The columns wanted (all of them by default; the metrics need a third of them, and the
        others, the beliefs above all, are most of the formatting).

    Returns
    -------
    dict
        The wanted columns of :data:`~nudgecli.steplog.STEP_COLUMNS`, in its order -> ``(N,)`` lists.
    """
    wanted = wanted_step_columns(names)
    if not rows:
        return {name: [] for name in wanted}
    field = dict(zip(ROW_FIELDS, zip(*rows, strict=True), strict=True))
    n = len(rows)

    @cache
    def cell_columns() -> tuple[tuple[int, ...], ...]:
        cells_of = {state: cells(state) for state in set(field["state"])}  # a trial visits few states
        return tuple(zip(*(cells_of[state] for state in field["state"]), strict=True))

    @cache
    def human() -> list[list[float]]:
        return command_columns(list(field["u_h"]), n)

    @cache
    def autonomy() -> list[list[float]]:
        return command_columns(list(field["u_a"]), n)

    def times() -> list[float]:
        table = step_times(dt, max(field["step"]))
        return [table[step] for step in field["step"]]

    build: dict[str, Callable[[], list[Any]]] = {
        "participant": lambda: [participant] * n,
        "trial": lambda: [trial] * n,
        "step": lambda: list(field["step"]),
        "t": times,
        "turn": lambda: list(field["turn"]),
        "x": lambda: list(field["x"]),
        "y": lambda: list(field["y"]),
        "theta": lambda: list(field["theta"]),
        "mode": lambda: [MODE_NAMES[m] for m in field["mode"]],
        "cell_x": lambda: list(cell_columns()[0]),
        "cell_y": lambda: list(cell_columns()[1]),
        "heading": lambda: list(cell_columns()[2]),
        "phi_i": lambda: [LABELS[i] if i >= 0 else "" for i in field["intended"]],
        "pressure": lambda: list(field["pressure"]),
        "phi_m": lambda: [STREAM_LABEL.get(m, "") for m in field["measured"]],
        "u_h_x": lambda: human()[0],
        "u_h_y": lambda: human()[1],
        "u_h_theta": lambda: human()[2],
        "u_a_x": lambda: autonomy()[0],
        "u_a_y": lambda: autonomy()[1],
        "u_a_theta": lambda: autonomy()[2],
        "alpha": lambda: list(field["alpha"]),
        "inferred_goal": lambda: list(field["inferred"]),
        "belief": lambda: [belief.tolist() for belief in field["belief"]],
        "entropy": lambda: list(field["entropy"]),
        "event": lambda: [join_events(e) for e in field["events"]],
    }
    assert tuple(build) == STEP_COLUMNS
    return {name: build[name]() for name in wanted}
