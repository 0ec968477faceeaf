"""A trial's steps, kept raw while it runs and put into the step log's columns once.

:class:`~nudgecli.sim.protocol.TrialSession` appends one tuple per step (:data:`ROW_FIELDS`);
formatting every step as it happened was a fifth of the trial loop, so the columns of
:data:`~nudgecli.steplog.STEP_COLUMNS` are built here: each trial's rows into typed arrays as it
ends (:meth:`StepRecording.of_rows`), then all of a participant's trials at once
(:func:`step_columns`: the arrays concatenated, each coded column looked up once per distinct code).
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterator, Sequence
from dataclasses import dataclass
from functools import cache
from itertools import chain
from typing import Any

import numpy as np

from nudgecli.model import interface
from nudgecli.model.interface import LABELS
from nudgecli.model.world import MODE_NAMES
from nudgecli.steplog import STEP_COLUMNS, STEP_NUMERIC_DTYPES, join_events, step_times, wanted_step_columns

#: The step log's ``phi_m`` of a measured code (no input: empty).
STREAM_LABEL = {**dict(enumerate(LABELS)), interface.PUFF_DEADBAND: interface.PUFF_DEADBAND_LABEL,
                interface.SIP_DEADBAND: interface.SIP_DEADBAND_LABEL}

#: The fields of one raw step row, in order (the pose, cell and mode at the start of the step).
ROW_FIELDS = ("step", "turn", "x", "y", "theta", "mode", "state", "intended", "pressure", "measured",
              "u_h", "u_a", "alpha", "inferred", "belief", "entropy", "events")

#: The step-log column each plain field becomes, value for value (the rest are derived from fields).
_PLAIN_FIELDS = {"step": "step", "turn": "turn", "x": "x", "y": "y", "theta": "theta", "pressure": "pressure",
                 "alpha": "alpha", "inferred_goal": "inferred", "entropy": "entropy"}
#: The command columns: the field and the axis of each.
_COMMAND_COLUMNS = {f"{field}_{axis}": (field, k) for field in ("u_h", "u_a")
                    for k, axis in enumerate(("x", "y", "theta"))}
#: The cell columns, in the order of a world's ``cells(state)``.
_CELL_COLUMNS = ("cell_x", "cell_y", "heading")
#: The fields each derived column is made of (a plain column: its field; ``participant`` and
#: ``trial``: none).
_COLUMN_FIELDS: dict[str, tuple[str, ...]] = {
    **{column: (field,) for column, field in _PLAIN_FIELDS.items()},
    **{column: (field,) for column, (field, _) in _COMMAND_COLUMNS.items()},
    **dict.fromkeys(_CELL_COLUMNS, ("state",)),
    "participant": (), "trial": (), "t": ("step",), "mode": ("mode",), "phi_i": ("intended",),
    "phi_m": ("measured",), "belief": ("belief",), "event": ("events",),
}
#: The fields a recording keeps as typed arrays, and their dtypes (the step log's, or integer codes).
_FIELD_DTYPES: dict[str, type[np.generic]] = {
    **{field: STEP_NUMERIC_DTYPES[column] for column, field in _PLAIN_FIELDS.items()
       if column in STEP_NUMERIC_DTYPES},
    **dict.fromkeys(("mode", "state", "intended", "measured"), np.int64),
    **{field: STEP_NUMERIC_DTYPES[f"{field}_x"] for field in ("u_h", "u_a")},
}


@dataclass(frozen=True)
class StepRecording:
    """One trial's raw steps, field by field, and what the step log needs besides them.

    Attributes
    ----------
    fields
        :data:`ROW_FIELDS` -> ``(N,)`` the steps' values: typed arrays of the numeric fields
        (``u_h`` and ``u_a`` ``(3N,)``, each command's ``(vx, vy, omega)`` in turn), tuples of
        the text and of the beliefs (arrays never changed in place); ``events`` holds each step's
        ``event`` cell (its event names joined). Only the fields of the step log's wanted columns
        are kept. Arrays are no work for the garbage collector, and
        the tuples it visits once (a tuple per step, or a list of events, was one more object to
        visit for each step).
    participant, trial
        The trial's identifiers, repeated on every row.
    dt
        The step's length, s (the ``t`` column is ``round(step * dt, 10)``).
    cells
        The trial's world's ``state -> (cell_x, cell_y, heading)``.
    """

    fields: dict[str, np.ndarray | tuple[Any, ...]]
    participant: int
    trial: int
    dt: float
    cells: Callable[[int], tuple[int, int, int]]

    @classmethod
    def of_rows(cls, rows: Sequence[tuple[Any, ...]], participant: int, trial: int, dt: float,
                cells: Callable[[int], tuple[int, int, int]],
                names: Collection[str] = STEP_COLUMNS) -> StepRecording:
        """The recording of ``(N,)`` raw rows (tuples of :data:`ROW_FIELDS`), keeping the fields the
        step log's columns ``names`` are made of (and ``step``)."""
        n = len(rows)
        raw = (dict(zip(ROW_FIELDS, zip(*rows, strict=True), strict=True)) if rows
               else dict.fromkeys(ROW_FIELDS, ()))
        fields: dict[str, np.ndarray | tuple[Any, ...]] = {}
        for field in _kept_fields(frozenset(names)):
            values = raw[field]
            if field == "events":  # a list comprehension: a generator's resumptions cost more
                fields[field] = tuple([join_events(events) if events else "" for events in values])
            elif field in ("u_h", "u_a"):  # (vx, vy, omega) tuples, or hindsight's arrays
                flat = chain.from_iterable(values)
                fields[field] = np.fromiter(flat, dtype=_FIELD_DTYPES[field], count=3 * n)
            elif field in _FIELD_DTYPES:
                fields[field] = np.fromiter(values, dtype=_FIELD_DTYPES[field], count=n)
            else:
                fields[field] = values
        return cls(fields, participant, trial, dt, cells)

    def __len__(self) -> int:
        return len(self.fields["step"])


@cache
def _kept_fields(names: frozenset[str]) -> tuple[str, ...]:
    """The fields of :data:`ROW_FIELDS` (in its order) the step log's columns ``names`` are made of,
    and ``step``: asked once per set of columns, not at every trial's end."""
    kept = {"step", *(field for name in wanted_step_columns(names) for field in _COLUMN_FIELDS[name])}
    return tuple(field for field in ROW_FIELDS if field in kept)


#: :func:`mapped_codes` finds the distinct codes of at least :data:`_DENSE_MIN_CODES` codes by a
#: table over their range when the range is at most this many times the number of codes (a step
#: log's codes: a few labels, modes or states); fewer codes are sorted (as fast there).
_DENSE_RANGE_PER_CODE = 4
_DENSE_MIN_CODES = 1024


def mapped_codes(codes: np.ndarray, value_of: Callable[[int], Any], dtype: Any = object) -> np.ndarray:
    """``value_of(code)`` for every code, asked once per distinct code (a log has few of them).

    Parameters
    ----------
    codes
        ``(N,)`` integer codes.
    value_of
        The value of one code (given a Python ``int``): a scalar, or a ``K``-tuple. Asked in
        increasing order of the codes.
    dtype
        The values' dtype (object: text).

    Returns
    -------
    np.ndarray
        ``(N,)`` the values, or ``(N, K)`` where each is a ``K``-tuple.
    """
    distinct, position = _distinct_codes(np.asarray(codes).reshape(-1))
    table = np.array([value_of(code) for code in distinct.tolist()], dtype=dtype)
    return table[position]


def _distinct_codes(codes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(codes, return_inverse=True)`` of ``(N,)`` integer codes: the ``(D,)`` sorted
    distinct codes and ``(N,)`` each code's position among them.

    Many codes within a short range (:data:`_DENSE_RANGE_PER_CODE`) are marked in a table over the
    range instead of sorted: a participant's 13,000 measured labels took 1.5 ms through
    ``np.unique``'s sort. ``tests/test_sim_step_record.py`` holds the two equal.
    """
    if codes.size < _DENSE_MIN_CODES or codes.dtype.kind not in "iu":
        distinct, position = np.unique(codes, return_inverse=True)
        return distinct, position.reshape(-1)
    low, high = int(codes.min()), int(codes.max())
    if high - low >= _DENSE_RANGE_PER_CODE * codes.size:
        distinct, position = np.unique(codes, return_inverse=True)
        return distinct, position.reshape(-1)
    offsets = codes - low
    present = np.zeros(high - low + 1, dtype=bool)
    present[offsets] = True
    offsets_present = np.flatnonzero(present)
    rank = np.zeros(high - low + 1, dtype=np.intp)
    rank[offsets_present] = np.arange(offsets_present.size)
    return (offsets_present + low).astype(codes.dtype), rank[offsets]


class _Columns:
    """The step log's columns of recordings, each made on first use (some share their work)."""

    def __init__(self, recordings: Sequence[StepRecording]) -> None:
        self.recordings = recordings
        self.lengths = np.array([len(recording) for recording in recordings], dtype=np.int64)
        self.n = int(self.lengths.sum())
        ends = np.cumsum(self.lengths)
        self.spans = list(zip((ends - self.lengths).tolist(), ends.tolist(), recordings, strict=True))
        self.made: dict[tuple[str, ...], np.ndarray] = {}  # what several columns share, made once

    def values(self, field: str) -> Iterator[Any]:
        """The field's values, trial after trial."""
        return chain.from_iterable(recording.fields[field] for recording in self.recordings)

    def numeric(self, field: str) -> np.ndarray:
        """A numeric field's values, trial after trial (:data:`_FIELD_DTYPES`)."""
        key = ("numeric", field)
        if key not in self.made:
            arrays = [recording.fields[field] for recording in self.recordings]
            self.made[key] = np.concatenate(arrays) if arrays else np.empty(0, dtype=_FIELD_DTYPES[field])
        return self.made[key]

    def per_trial(self, value_of: Callable[[StepRecording], int]) -> np.ndarray:
        ids = np.array([value_of(recording) for recording in self.recordings], dtype=np.int64)
        return np.repeat(ids, self.lengths)

    def cells(self) -> np.ndarray:
        """``(3, N)``: cell_x, cell_y and heading."""
        if ("cells",) in self.made:
            return self.made[("cells",)]
        cells = np.empty((self.n, 3), dtype=np.int64)
        state = self.numeric("state")
        for start, end, recording in self.spans:  # each trial's world says what its states' cells are
            if end > start:
                cells[start:end] = mapped_codes(state[start:end], recording.cells, np.int64)
        made = self.made[("cells",)] = cells.T.copy()
        return made

    def times(self) -> np.ndarray:
        step = self.numeric("step")
        last = int(step.max()) if self.n else 0
        tables = {dt: np.array(step_times(dt, last), dtype=np.float64)  # one table a step length
                  for dt in {recording.dt for recording in self.recordings}}
        t = np.empty(self.n, dtype=np.float64)
        for start, end, recording in self.spans:
            t[start:end] = tables[recording.dt][step[start:end]]
        return t

    def commands(self, field: str) -> np.ndarray:
        """``(3, N)``: the x, y and theta components of the field's commands."""
        key = ("commands", field)
        if key not in self.made:
            self.made[key] = self.numeric(field).reshape(self.n, 3).T.copy()
        return self.made[key]

    def beliefs(self) -> list[list[float]]:
        # a belief is replaced, never changed, at an update (a few hundred a participant): the steps
        # between two updates hold one array, and their cells one list of it
        out: list[list[float]] = []
        last, cell = None, []
        for belief in self.values("belief"):
            if belief is not last:
                last, cell = belief, belief.tolist()
            out.append(cell)
        return out

    def labels(self, field: str, value_of: Callable[[int], str]) -> list[str]:
        return mapped_codes(self.numeric(field), value_of).tolist()

    def column(self, name: str) -> np.ndarray | list[Any]:
        """The step log's column ``name`` (:data:`~nudgecli.steplog.STEP_COLUMNS`)."""
        if name in _PLAIN_FIELDS:
            field = _PLAIN_FIELDS[name]
            return self.numeric(field) if field in _FIELD_DTYPES else list(self.values(field))
        if name in _COMMAND_COLUMNS:
            field, axis = _COMMAND_COLUMNS[name]
            return self.commands(field)[axis]
        if name in _CELL_COLUMNS:
            return self.cells()[_CELL_COLUMNS.index(name)]
        others: dict[str, Callable[[], np.ndarray | list[Any]]] = {
            "participant": lambda: self.per_trial(lambda recording: recording.participant),
            "trial": lambda: self.per_trial(lambda recording: recording.trial),
            "t": self.times,
            "mode": lambda: self.labels("mode", MODE_NAMES.__getitem__),
            "phi_i": lambda: self.labels("intended", lambda code: LABELS[code] if code >= 0 else ""),
            "phi_m": lambda: self.labels("measured", lambda code: STREAM_LABEL.get(code, "")),
            "belief": self.beliefs,
            "event": lambda: list(self.values("events")),
        }
        return others[name]()


def step_columns(recordings: Sequence[StepRecording],
                 names: Collection[str] = STEP_COLUMNS) -> dict[str, np.ndarray | list[Any]]:
    """The step log's columns of the trials' raw rows, one after another.

    Parameters
    ----------
    recordings
        The trials' recordings, in the log's order.
    names
        The columns wanted (all of them by default; the metrics need a third of them, and the
        others, the beliefs above all, are most of the formatting).

    Returns
    -------
    dict
        The wanted columns of :data:`~nudgecli.steplog.STEP_COLUMNS`, in its order -> ``(N,)``
        columns: each numeric one a typed array (:data:`~nudgecli.steplog.STEP_NUMERIC_DTYPES`),
        text and ``belief`` (a list of floats a step) lists, as
        :func:`~nudgecli.steplog.step_arrays` gives them. The steps between two belief updates
        share one list (a cell is read, never changed in place).
    """
    columns = _Columns(recordings)
    return {name: columns.column(name) for name in wanted_step_columns(names)}
