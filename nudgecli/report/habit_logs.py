"""Reading a real log (``nudge habits LOG.csv``): a CSV of time-stamped labelled samples,
resampled by zero-order hold into HABITS.md's cells (:mod:`nudgecli.report.habit_cells`)."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd

from nudgecli.csv_rows import read_csv_whole_rows
from nudgecli.csv_text import decimal_comma_advice, header_delimiter, not_utf8_message
from nudgecli.errors import DataError, did_you_mean
from nudgecli.model.path_world import SNAP_TOLERANCE, PathLayout, path_gaps
from nudgecli.report.habit_cells import (
    HABIT_RATE_HZ,
    LOG_TURNS,
    TIME_SLACK,
    label_kinds,
    on_waypoints,
    pose_changes,
)

#: The columns of a real log (CSV): required, and optional with what they give.
LOG_REQUIRED = ("trial", "label", "x", "y", "theta", "mode_switch")
LOG_TIME_NAMES = ("t", "time")
#: The optional columns, matched in any case (a spreadsheet's ``Participant``).
LOG_OPTIONAL = ("participant", "layout", "turn")
#: The longest a trial may last (s): the CIAA task's trials stop at 50 s, so a longer one is a time
#: stamp out of place (milliseconds, a clock's epoch), whose cells would fill the memory (1e7 s is
#: 1e8 cells, gigabytes).
MAX_TRIAL_S = 3600.0
#: The most cells a log may hold in all (about 55 hours at 10 Hz; a log of 2 million cells takes about
#: half a gigabyte while it is measured): checked from the time stamps before any cell is built.
MAX_LOG_CELLS = 2_000_000
_FALSE_WORDS = {"", "0", "0.0", "false", "no", "none", "nan"}
#: Mode words of a real log's ``mode_switch`` column (the mode switched to) -> mode index.
MODE_WORDS = {"x": 0, "horizontal": 0, "y": 1, "vertical": 1, "t": 2, "theta": 2, "rotation": 2,
              "rotational": 2}


@dataclass(frozen=True)
class _Log:
    """A real log's columns, checked (one entry per row)."""

    path: Path
    frame: pd.DataFrame
    time: np.ndarray
    numbers: dict[str, np.ndarray]  # the time and pose columns (x, y, theta)
    kinds: np.ndarray
    participant: pd.Series
    trial: pd.Series
    switch: pd.Series
    switch_to: np.ndarray
    layout: pd.Series | None  # the CIAA trial index per row, None without a layout column
    person_turn: np.ndarray | None  # True in the person's turn per row, None without a turn column

    def row_name(self, i: int) -> str:
        return _row_name(self.path, i)


def _row_name(path: Path, i: int) -> str:
    """How an error names row ``i`` (0-based, after the header) of the log at ``path``."""
    return f"{path}, row {i + 2}"  # the header is line 1


def _names_log_columns(names: set[str]) -> bool:
    """Whether a header's column ``names`` hold a time column and every required one."""
    return bool(names & set(LOG_TIME_NAMES)) and names.issuperset(LOG_REQUIRED)


def _log_delimiter(path: Path) -> str:
    """The delimiter under which the header line names every column a log needs
    (:func:`~nudgecli.csv_text.header_delimiter`)."""
    with path.open(encoding="utf-8", newline="") as file:
        header = file.readline()
    return header_delimiter(header, _names_log_columns)


def _read_log_frame(path: Path) -> tuple[pd.DataFrame, str]:
    """The log as text, with its time column's name; a :class:`DataError` for an unreadable file,
    missing columns (naming those its header holds), a row with fewer or more fields than the
    header (a log cut off: its last sample would be read with no switch) or no rows."""
    try:
        delimiter = _log_delimiter(path)
        # the header first: one that lacks a column makes every row look long, and the column is the fix
        time_column = _log_time_column(path, pd.read_csv(path, sep=delimiter, nrows=0).columns)
        frame = read_csv_whole_rows(path, sep=delimiter, dtype=str, keep_default_na=False)
    except UnicodeDecodeError:
        raise DataError(not_utf8_message(path, reads_run_folders=True)) from None
    except (pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise DataError(f"{path}: not a readable CSV log ({str(exc).strip()})") from None
    frame.columns = _log_column_names(path, [str(c).strip() for c in frame.columns])
    if frame.empty:
        raise DataError(f"{path}: no rows; a real log needs at least two samples per trial")
    return frame, time_column


def _log_column_names(path: Path, columns: list[str]) -> list[str]:
    """The header's ``columns`` with the optional ones in lower case; a :class:`DataError` for an
    optional column written twice, or a column that is no log column but close to an optional one
    (a misspelt ``turn`` would count the autonomy's motion as the person's, a misspelt ``layout``
    leave stop -> switch unmeasured, a misspelt ``participant`` make the file one person)."""
    known = {*LOG_REQUIRED, *LOG_TIME_NAMES}
    for name in LOG_OPTIONAL:
        written = [c for c in columns if c.lower() == name]
        if len(written) > 1:
            raise DataError(f"{path}: the column {name!r} is written {len(written)} times "
                            f"({', '.join(repr(c) for c in written)}); keep one")
    for column in columns:
        if column in known or column.lower() in LOG_OPTIONAL:
            continue
        hint = did_you_mean(column.lower(), LOG_OPTIONAL)
        if hint:
            raise DataError(f"{path}: column {column!r} is not a log column{hint}; rename it (the optional "
                            "columns are participant, layout and turn), or remove it")
    return [c.lower() if c.lower() in LOG_OPTIONAL else c for c in columns]


def _log_time_column(path: Path, header: pd.Index) -> str:
    """The name of the time column of a log whose header holds ``header``; a :class:`DataError`
    naming the columns a log needs that it lacks, and those it holds."""
    columns = [str(c).strip() for c in header]
    time_column = next((c for c in LOG_TIME_NAMES if c in columns), None)
    needed = ["t (or time)"] if time_column is None else []
    needed += [c for c in LOG_REQUIRED if c not in columns]
    if needed or time_column is None:  # (no time column is always in needed)
        found = ", ".join(repr(c) for c in columns)
        plural = "" if len(columns) == 1 else "s"
        raise DataError(f"{path}: no {', '.join(needed)} column(s); its header holds {len(columns)} "
                        f"column{plural}, {found}; a real log needs t, trial, label, x, y, theta and "
                        "mode_switch (participant, layout and turn optional), separated by commas (or ;, tab "
                        "or |), one row per sample or event")
    return time_column


def _parse_log(path: Path, frame: pd.DataFrame, time_column: str) -> _Log:
    """The log's columns as values; a :class:`DataError` naming the row of a time or pose that is
    not a number, or of an unknown label."""
    row_name = partial(_row_name, path)
    numbers = {}
    for column in (time_column, "x", "y", "theta"):
        values = pd.to_numeric(frame[column].str.strip(), errors="coerce")
        bad = values.isna() | ~np.isfinite(values.to_numpy(dtype=float))
        if bad.any():
            i = int(np.flatnonzero(bad.to_numpy())[0])
            if np.isinf(values.iloc[i]):  # 'inf' is a number to pandas, but no time or place
                problem = "is infinite, and infinite values are not times or poses"
            else:  # a spreadsheet with a decimal comma writes 0,5 (and semicolons between the columns)
                advice = decimal_comma_advice(frame[column].iloc[i])
                problem = f"is not a number{f' ({advice})' if advice else ''}"
            raise DataError(f"{row_name(i)}: {column} {frame[column].iloc[i]!r} {problem}; every row needs "
                            "its time and the robot's pose")
        numbers[column] = values.to_numpy(dtype=float)
    kinds = label_kinds(frame["label"], row_name)
    participant = _log_participants(path, frame)
    trial = frame["trial"].str.strip()
    switch_word = frame["mode_switch"].str.strip().str.lower()
    switch = ~switch_word.isin(_FALSE_WORDS)
    switch_to = switch_word.map(MODE_WORDS).fillna(-1).to_numpy(dtype=int)
    layout = None
    if "layout" in frame.columns:
        layout = pd.to_numeric(frame["layout"].str.strip(), errors="coerce")
    return _Log(path=path, frame=frame, time=numbers[time_column], numbers=numbers, kinds=kinds,
                participant=participant, trial=trial, switch=switch, switch_to=switch_to, layout=layout,
                person_turn=_log_turns(path, frame))


def _log_turns(path: Path, frame: pd.DataFrame) -> np.ndarray | None:
    """Each row's turn as True in the person's (``human``) and False in the autonomy's, from the
    optional ``turn`` column (``None`` without it: every row is the person's); a :class:`DataError`
    naming the first row of another value."""
    if "turn" not in frame.columns:
        return None
    turn = frame["turn"].str.strip().str.lower()
    bad = ~turn.isin(LOG_TURNS)
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        allowed = " or ".join(LOG_TURNS)
        raise DataError(f"{_row_name(path, i)}: turn {frame['turn'].iloc[i]!r} is not {allowed}; give each "
                        "row whose turn it is (human: the person's input and motion; autonomy: the "
                        "assistance's), or leave the column out for a log of an unassisted study")
    return (turn == LOG_TURNS[0]).to_numpy(dtype=bool)


def _log_participants(path: Path, frame: pd.DataFrame) -> pd.Series:
    """Each row's participant: the ``participant`` column, or the file's name where the log has
    none or leaves it blank on every row; a :class:`DataError` naming the first blank cell of a
    column filled elsewhere (its rows would make a participant of no name)."""
    if "participant" not in frame.columns:
        return pd.Series(path.stem, index=frame.index)
    participant = frame["participant"].str.strip()
    blank = (participant == "").to_numpy()
    if blank.all():  # a column exported empty: the file is one person's, as without it
        return pd.Series(path.stem, index=frame.index)
    if blank.any():
        i = int(np.flatnonzero(blank)[0])
        named = participant.iloc[int(np.flatnonzero(~blank)[0])]
        raise DataError(f"{_row_name(path, i)}: participant is blank, where other rows name one ({named!r}); "
                        "give every row its participant, or leave the column out for a log of one person "
                        "(named after the file)")
    return participant


def _trial_starts(log: _Log) -> np.ndarray:
    """``(N,)`` True at each trial's first row; a :class:`DataError` for a trial whose rows are
    not together, or a time that goes back within a trial."""
    participant, trial, time, row_name = log.participant, log.trial, log.time, log.row_name
    group = (participant + "\x00" + trial).to_numpy()
    new_trial = np.concatenate(([True], group[1:] != group[:-1]))
    seen: set[str] = set()
    for first_row in np.flatnonzero(new_trial).tolist():
        if group[first_row] in seen:
            raise DataError(f"{row_name(first_row)}: trial {trial.iloc[first_row]!r} of participant "
                            f"{participant.iloc[first_row]!r} continues after other rows; write each trial's "
                            "rows together, in time order")
        seen.add(group[first_row])
    back = np.flatnonzero(~new_trial[1:] & (np.diff(time) < 0)) + 1
    if back.size:
        i = int(back[0])
        raise DataError(f"{row_name(i)}: time {time[i]:g} s comes before the previous row's "
                        f"{time[i - 1]:g} s; sort each trial's rows by time")
    return new_trial


def _trial_spans(time: np.ndarray, new_trial: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each trial's first and last row ``(T,)`` and its duration ``(T,)`` (s, last minus first)."""
    firsts = np.flatnonzero(new_trial)
    lasts = np.append(firsts[1:], len(time)) - 1
    return firsts, lasts, time[lasts] - time[firsts]


def trial_cell_counts(time: np.ndarray, new_trial: np.ndarray, rate_hz: float) -> np.ndarray:
    """``(T,)`` how many cells each trial of a log holds, from its time stamps alone (no cell built).

    Parameters
    ----------
    time
        ``(N,)`` the rows' time stamps (s), in order within each trial.
    new_trial
        ``(N,)`` True at each trial's first row.
    rate_hz
        Cells per second.

    Returns
    -------
    np.ndarray
        ``(T,)`` float: a trial is read every ``1 / rate_hz`` s from its first row up to its last,
        ``floor(duration * rate + slack) + 1`` reads as :func:`_trial_cells` counts them, and holds a
        cell between two reads; floats, so a far time stamp is counted without overflow.
    """
    _, _, duration = _trial_spans(time, new_trial)
    return np.floor(duration / (1.0 / rate_hz) + TIME_SLACK)


def _check_log_size(log: _Log, new_trial: np.ndarray, rate_hz: float) -> None:
    """Refuse, before any cell is built, a trial longer than :data:`MAX_TRIAL_S` or a log of more
    than :data:`MAX_LOG_CELLS` cells, naming the row whose time stamp passes the limit."""
    firsts, lasts, duration = _trial_spans(log.time, new_trial)
    too_long = np.flatnonzero(duration > MAX_TRIAL_S)
    if too_long.size:
        k = int(too_long[0])
        first, last = int(firsts[k]), int(lasts[k])
        trial = f"trial {log.trial.iloc[first]!r} of participant {log.participant.iloc[first]!r}"
        raise DataError(f"{log.row_name(last)}: time {log.time[last]:g} s is {duration[k]:g} s after the "
                        f"start of {trial} from row {first + 2} ({log.time[first]:g} s); a trial may last at "
                        f"most {MAX_TRIAL_S:g} s ({MAX_TRIAL_S * rate_hz:.0f} cells at {rate_hz:g} Hz): "
                        "check that the time stamps are seconds from one clock")
    total = np.cumsum(trial_cell_counts(log.time, new_trial, rate_hz))
    past = np.flatnonzero(total > MAX_LOG_CELLS)
    if past.size:
        k = int(past[0])
        raise DataError(f"{log.row_name(int(lasts[k]))}: the log holds {total[k]:.0f} cells at {rate_hz:g} "
                        f"Hz up to this row, more than the {MAX_LOG_CELLS} a log may hold; measure it in "
                        "parts (a file per participant or per session)")


def _check_layouts(log: _Log, new_trial: np.ndarray, indices: set[int]) -> None:
    """Refuse a ``layout`` that is not one of the CIAA task's trial ``indices`` (empty, not a
    number, fractional, out of range) or that changes within a trial, naming its row: every row of
    a trial holds the trial's one layout."""
    if log.layout is None:
        return
    values = log.layout.to_numpy(dtype=float)
    valid = np.isin(values, list(indices))  # a NaN or a fraction is no index
    trial_first = np.flatnonzero(new_trial)[np.cumsum(new_trial) - 1]  # each row's trial's first row
    bad = ~valid | (values != values[trial_first])
    if not bad.any():
        return
    i = int(np.flatnonzero(bad)[0])
    first = int(trial_first[i])
    word = log.frame["layout"].iloc[i]
    fix = (f"give each row the CIAA task's trial index (a whole number, {min(indices)}-{max(indices)}) of "
           "the layout its trial runs on")
    if valid[i]:  # a known index, but not the trial's (whose first row is a known one)
        trials = log.frame["layout"].iloc[first]
        raise DataError(f"{log.row_name(i)}: layout {word!r} differs from the {trials!r} of row {first + 2}, "
                        f"where trial {log.trial.iloc[i]!r} of participant {log.participant.iloc[i]!r} "
                        f"starts; a trial runs on one layout: {fix}")
    raise DataError(f"{log.row_name(i)}: layout {word!r} is not a trial index of the CIAA task; {fix}")


def _check_poses_on_layouts(log: _Log, new_trial: np.ndarray, task: Mapping[int, PathLayout]) -> None:
    """Refuse a row whose position is not on its layout's path, or a trial whose first row is not
    at its layout's start, both within the world's snap tolerance (its waypoints' and path's
    own): the layout named is not the one the trial ran on, and its waypoints would mark other stops."""
    if log.layout is None:
        return
    layouts = log.layout.to_numpy(dtype=int)  # one known index per trial (_check_layouts)
    position = np.column_stack((log.numbers["x"], log.numbers["y"]))
    bad = np.zeros(len(layouts), dtype=bool)
    for index in np.unique(layouts).tolist():
        rows = layouts == index
        waypoints = task[index].waypoints
        start = np.abs(position[rows] - waypoints[0]).max(axis=1) > SNAP_TOLERANCE
        bad[rows] = (new_trial[rows] & start) | (path_gaps(position[rows], waypoints) > SNAP_TOLERANCE)
    if not bad.any():
        return
    i = int(np.flatnonzero(bad)[0])
    word, points = log.frame["layout"].iloc[i].strip(), task[int(layouts[i])].waypoints
    pose = f"({log.frame['x'].iloc[i].strip()}, {log.frame['y'].iloc[i].strip()})"
    trial = f"trial {log.trial.iloc[i]!r} of participant {log.participant.iloc[i]!r}"
    if new_trial[i]:
        start = f"({points[0][0]:g}, {points[0][1]:g})"
        problem = f"{trial} starts at {pose}, but layout {word} starts at {start}"
    else:
        path = ", ".join(f"({wx:g}, {wy:g})" for wx, wy in points)
        problem = (f"{pose} of {trial} is not on layout {word}'s path ({path}; within {SNAP_TOLERANCE:g} "
                   "units on each axis)")
    raise DataError(f"{log.row_name(i)}, column layout: {problem}; give each row the CIAA task's trial "
                    "index of the layout its trial ran on, or leave the layout column out")


def _trial_cells(log: _Log, lo: int, hi: int, rate_hz: float, all_waypoints: dict[int, np.ndarray],
                 start_modes: dict[int, int]) -> pd.DataFrame:
    """The cells of one trial, rows ``lo`` to ``hi`` (exclusive), read every ``1 / rate_hz`` s
    from its first row by zero-order hold."""
    time, participant, trial = log.time, log.participant, log.trial
    dt = 1.0 / rate_hz
    rel = time[lo:hi] - time[lo]
    reads = math.floor(rel[-1] / dt + TIME_SLACK) + 1
    if reads < 2:
        raise DataError(f"{log.path}, rows {lo + 2}-{hi + 1}: trial {trial.iloc[lo]!r} of participant "
                        f"{participant.iloc[lo]!r} lasts {rel[-1]:g} s, less than one {dt:g} s cell; "
                        "give each trial from its start to its end")
    grid = np.arange(reads) * dt
    held = lo + np.searchsorted(rel, grid + TIME_SLACK, side="right") - 1  # zero-order hold
    pose = np.column_stack([log.numbers[c][held] for c in ("x", "y", "theta")])
    rows = lo + np.flatnonzero(log.switch.to_numpy()[lo:hi])
    fired = np.ceil(rel[rows - lo] / dt - TIME_SLACK).astype(int)
    inside = fired < reads - 1
    cell_switch = np.zeros(reads - 1, dtype=bool)
    cell_switch[fired[inside]] = True
    known = False
    start_mode = -1
    at_waypoint = np.zeros(reads - 1, dtype=bool)
    if log.layout is not None:  # one known index per trial (_check_layouts)
        index = int(log.layout.iloc[lo])
        known = True
        start_mode = start_modes[index]
        at_waypoint = on_waypoints(pose[1:, :2], np.full(reads - 1, index), all_waypoints)
    # each switch comes from where the one before it went (the first: the layout's start mode)
    went_to = log.switch_to[rows]
    came_from = np.concatenate(([start_mode], went_to[:-1]))
    cell_from, cell_to = np.full(reads - 1, -1), np.full(reads - 1, -1)
    cell_from[fired[inside]] = came_from[inside]
    cell_to[fired[inside]] = went_to[inside]
    cells = pd.DataFrame({
        "participant": participant.iloc[lo], "trial": trial.iloc[lo], "kind": log.kinds[held[:-1]],
        "moving": pose_changes(pose[:-1], pose[1:]), "switch": cell_switch, "at_waypoint": at_waypoint,
        "waypoints_known": known, "switch_from": cell_from, "switch_to": cell_to})
    if log.person_turn is not None:  # a cell is in the turn of the row it holds, as a run folder's step
        cells["person_turn"] = log.person_turn[held[:-1]]
    return cells


def read_log_cells(path: str | Path, rate_hz: float = HABIT_RATE_HZ) -> pd.DataFrame:
    """The cells of a real log: a CSV of time-stamped labelled samples, resampled by zero-order hold.

    Columns: ``t`` (or ``time``, seconds), ``trial``, ``label`` (an interface label, a deadband,
    or a neutral one: empty, ``Zero Band``, ``input stopped``, ``None``), ``x``, ``y``, ``theta``
    (the robot's pose after the row), ``mode_switch`` (non-empty and not ``0``/``false``: a mode
    switch fired at this time; a mode word, ``x``/``y``/``theta``, says where it went, which undone
    switches need); optional ``participant`` (default, and where it is blank on every row: the
    file's name; a blank cell in a column filled elsewhere is refused), ``layout``
    (the CIAA task's trial index, whose waypoints mark the stops, the same on every row of a trial;
    without it stops at a waypoint are not measured) and ``turn`` (``human`` or ``autonomy``: whose
    turn the row is in, carried into the cells' ``person_turn`` as a run folder's; without it every
    cell is the person's). Each row holds the whole state from its time
    on, so an event-driven log (a row per change) and a sampled one read alike. A trial starts at
    its first row; its cells are read at ``t0, t0 + 0.1, ...`` up to its last row; a switch belongs
    to the first cell read at or after it.

    Raises
    ------
    DataError
        No time stamps or labels, an unknown label, a blank participant among named ones, a time
        that is not a number or goes back, a pose missing, a trial shorter than one cell, or one
        longer than :data:`MAX_TRIAL_S` or a log of more than :data:`MAX_LOG_CELLS` cells (checked
        before any cell is built), a turn other than ``human`` / ``autonomy``, a layout that is no
        trial index of the task or changes within a trial, a trial that does not start at its
        layout's start or a pose off its path: naming the file and the row.
    """
    path = Path(path)
    frame, time_column = _read_log_frame(path)
    log = _parse_log(path, frame, time_column)
    new_trial = _trial_starts(log)
    _check_log_size(log, new_trial, rate_hz)
    from nudgecli.sim.ciaa import packaged_task, task_layouts

    task = task_layouts(packaged_task())
    all_waypoints = {index: lay.waypoints for index, lay in task.items()}
    start_modes = {index: lay.start_mode for index, lay in task.items()}
    _check_layouts(log, new_trial, set(all_waypoints))
    _check_poses_on_layouts(log, new_trial, task)
    bounds = np.append(np.flatnonzero(new_trial), len(frame))
    pieces = [_trial_cells(log, lo, hi, rate_hz, all_waypoints, start_modes)
              for lo, hi in itertools.pairwise(bounds)]
    return pd.concat(pieces, ignore_index=True)
