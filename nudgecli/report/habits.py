"""Operating habits (``nudge habits``): how people operate the interface, as HABITS.md defines them.

The definitions are those of ``shared/data/ciaa-task/HABITS.md`` (the sibling study's ten real
sip-and-puff users), in the toolkit's 10 Hz view:

- every trial is a sequence of cells of ``1 / rate`` seconds; a simulated or live run's steps are
  its cells, a real log's label and pose are held between its rows (zero-order hold) and read at
  ``t = 0, 0.1, 0.2 ...`` s from the trial's first row;
- a **neutral** cell has no input (Zero Band, input stopped, the toolkit's empty label), a
  **command** cell a Soft or Hard Puff or Sip; deadband cells are neither;
- a **blow** is a run of non-neutral cells, merged across neutral gaps of at most
  :data:`MERGE_GAP_S` (one or two cells at 10 Hz); a **hard blow** holds at least one Hard cell;
- a **moving** cell is one across which the robot's pose changed;
- a motion run **ends at a waypoint** when its last pose is one of the world's waypoints (the CIAA
  world's path, or a real log's layout); the paper's grid world has none, so a grid-world run, like
  a log without its layout, has no stop -> switch reaction.

The habits (:data:`HABITS`) are measured per event and summarised per participant (or trial) and
pooled; ``people`` is the range of the participants' own medians, as HABITS.md gives it.

The cells are defined, and read from a run folder, in :mod:`nudgecli.report.habit_cells`; a real
log is read in :mod:`nudgecli.report.habit_logs`.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from nudgecli.csv_text import starts_as_json, starts_as_toml, toml_source_message
from nudgecli.errors import DataError, did_you_mean, shell_words
from nudgecli.reference import PACKAGED_REFERENCES, packaged_reference
from nudgecli.report.habit_cells import (
    HABIT_RATE_HZ,
    HARD,
    NEUTRAL,
    SOFT,
    TIME_SLACK,
    cell_runs,
    run_folder_cells,
)
from nudgecli.report.habit_deadband import deadband_events
from nudgecli.report.habit_figures import check_reference_habit
from nudgecli.report.habit_logs import read_log_cells
from nudgecli.report.habits_digits import compared_digits, fmt
from nudgecli.run_folder_names import MANIFEST

#: Blows are merged across neutral gaps of at most this long (HABITS.md).
MERGE_GAP_S = 0.25

@dataclass(frozen=True)
class Habit:
    """One habit: its key, its words, and whether it summarises as a median or a share."""

    key: str
    label: str
    short: str
    share: bool = False


#: The habits measured, in HABITS.md's order (keys as in the packaged reference ``ciaa-people``).
HABITS = (
    Habit("first_command_latency", "first-command latency (s)", "first_cmd"),
    Habit("pause_between_blows", "pause between blows (s)", "pause"),
    Habit("share_pauses_over_1s", "share of pauses > 1 s", "pause>1s", share=True),
    Habit("share_pauses_over_2s", "share of pauses > 2 s", "pause>2s", share=True),
    Habit("hard_blow_whole", "hard blow, whole (s)", "hard_blow"),
    Habit("hard_band_per_excursion", "time in the hard band per excursion (s)", "hard_band"),
    Habit("soft_blow", "soft blow (s)", "soft_blow"),
    Habit("reaction_stop_to_switch", "robot stops at a waypoint -> next switch (s)", "stop>switch"),
    Habit("reaction_switch_to_motion", "mode switch -> robot moves again (s)", "switch>move"),
    Habit("hold_on_per_trial", "holding on after the robot stopped (s per trial)", "hold_on"),
    # not in HABITS.md: the same holds one by one (a soft blow that moved the robot and went on
    # after it stopped), which shows a person's hold-on per stop where the per-trial sum mixes it
    # with the number of stops (what a twin's hold_on_s is fitted from)
    Habit("hold_on_per_stop", "holding on after the robot stopped (s per stop)", "hold_stop"),
    Habit("soft_blow_never_moving", "a soft blow that never moves the robot (s)", "soft_still"),
    Habit("undone_switch", "an undone switch: switch -> the switch back (s)", "undone"),
    # inside a soft blow (HABITS.md's second table, :mod:`nudgecli.report.habit_deadband`)
    Habit("deadband_share_soft_blows", "share of soft-blow time in the deadband", "db_share", share=True),
    Habit("deadband_run_in_soft_blow", "a deadband run inside a soft blow (s)", "db_run"),
    Habit("deadband_then_soft", "deadband run -> soft again", "db>soft", share=True),
    Habit("deadband_then_blow_ends", "deadband run -> the blow ends", "db>end", share=True),
    Habit("deadband_then_gap_soft", "deadband run -> neutral gap, soft again", "db>gap", share=True),
)
HABIT_KEYS = tuple(h.key for h in HABITS)
_BY_KEY = {h.key: h for h in HABITS}

#: Columns of the event table: one row per measured event.
EVENT_COLUMNS = ("participant", "trial", "habit", "value")
#: Columns of :meth:`HabitsResult.comparison`: one row per habit both the source and the reference have.
COMPARISON_COLUMNS = ("habit", "median", "people_min", "people_max", "reference_median", "reference_min",
                      "reference_max", "inside", "people_inside")


# --- runs of cells -----------------------------------------------------------------------------


def _any_in(mask: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Per run ``[start, end)``: whether ``mask`` holds a True in it."""
    total = np.concatenate(([0], np.cumsum(mask, dtype=np.int64)))
    return (total[ends] - total[starts]) > 0


def _merged_blows(kind: np.ndarray, new_trial: np.ndarray, gap_cells: int) -> tuple[np.ndarray, np.ndarray]:
    """Blows: runs of non-neutral cells after filling neutral gaps of at most ``gap_cells`` cells that
    lie between two non-neutral cells of the same trial (``new_trial``: or of one person's turn)."""
    active = kind != NEUTRAL
    gap_starts, gap_ends = cell_runs(~active, new_trial)
    # a gap is inside a trial's input when a non-neutral cell of the same trial precedes and follows it
    inside = ~new_trial[gap_starts] & (gap_ends < len(kind))
    inside[inside] &= ~new_trial[gap_ends[inside]]
    fill = inside & (gap_ends - gap_starts <= gap_cells)
    filled = active.copy()
    cover = np.zeros(len(kind) + 1, dtype=np.int64)
    np.add.at(cover, gap_starts[fill], 1)
    np.add.at(cover, gap_ends[fill], -1)
    filled |= np.cumsum(cover[:-1]) > 0
    return cell_runs(filled, new_trial)


def _next_at_or_after(sorted_index: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """Per position, the first entry of ``sorted_index`` at or after it (``-1`` where none)."""
    if len(sorted_index) == 0:
        return np.full(len(positions), -1)
    at = np.searchsorted(sorted_index, positions, side="left")
    found = at < len(sorted_index)
    return np.where(found, sorted_index[np.minimum(at, len(sorted_index) - 1)], -1)


# --- measuring ---------------------------------------------------------------------------------


def gap_cells_of(rate_hz: float, merge_gap_s: float = MERGE_GAP_S) -> int:
    """How many neutral cells a merged gap may hold: ``n / rate <= merge_gap_s`` (2 at 10 Hz)."""
    return math.floor(merge_gap_s * rate_hz + TIME_SLACK)


#: One measuring step's events: (habit key, the cell each event is filed at, its values).
_Events = list[tuple[str, np.ndarray, np.ndarray]]


@dataclass(frozen=True)
class _CellArrays:
    """The cell table's columns as arrays, with each cell's trial bookkeeping."""

    participant: np.ndarray
    trial: np.ndarray
    kind: np.ndarray
    moving: np.ndarray
    switch: np.ndarray
    at_waypoint: np.ndarray
    known: np.ndarray
    came_from: np.ndarray
    went_to: np.ndarray
    new_trial: np.ndarray  # True at a trial's first cell
    trial_id: np.ndarray  # 0, 1, ... per trial, in table order
    trial_first: np.ndarray  # each trial's first cell
    cell_index: np.ndarray  # the cell's index within its trial (its time from the trial's start)
    new_turn: np.ndarray  # True at a person's turn's first cell (a trial's first, or after an autonomy turn)
    turn_id: np.ndarray  # 0, 1, ... per person's turn, in table order
    dt: float

    @property
    def n(self) -> int:
        return len(self.kind)


def cell_arrays(cells: pd.DataFrame, rate_hz: float) -> _CellArrays:
    """The arrays the measuring steps read, from a cell table
    (:data:`~nudgecli.report.habit_cells.CELL_COLUMNS`): the person's cells (``person_turn``), cut at
    each autonomy turn (a pause across it, or the autonomy's motion, is none of theirs); the
    first-command latency stays timed from the trial's start, as HABITS.md defines it."""
    n = len(cells)
    participant = cells["participant"].to_numpy()
    trial = cells["trial"].to_numpy()
    starts_trial = np.ones(n, dtype=bool)
    if n:
        starts_trial[1:] = (participant[1:] != participant[:-1]) | (trial[1:] != trial[:-1])
    trial_of = np.cumsum(starts_trial) - 1
    cell_index = np.arange(n) - np.flatnonzero(starts_trial)[trial_of]
    person = cells["person_turn"].to_numpy(dtype=bool) if "person_turn" in cells else np.ones(n, dtype=bool)
    # a person's turn starts a trial or follows an autonomy cell of the same trial
    after_autonomy = np.concatenate(([False], ~person[:-1])) & ~starts_trial if n else starts_trial
    keep = np.flatnonzero(person)
    # a trial starts at its person's first cell (where the autonomy's came first too)
    new_trial = np.diff(trial_of[keep], prepend=-1) != 0
    new_turn = new_trial | after_autonomy[keep]
    trial_id = np.cumsum(new_trial) - 1
    unknown = np.full(n, -1)
    return _CellArrays(
        participant=participant[keep], trial=trial[keep], kind=cells["kind"].to_numpy(dtype=np.int8)[keep],
        moving=cells["moving"].to_numpy(dtype=bool)[keep], switch=cells["switch"].to_numpy(dtype=bool)[keep],
        at_waypoint=cells["at_waypoint"].to_numpy(dtype=bool)[keep],
        known=cells["waypoints_known"].to_numpy(dtype=bool)[keep],
        came_from=(cells["switch_from"].to_numpy(dtype=int) if "switch_from" in cells else unknown)[keep],
        went_to=(cells["switch_to"].to_numpy(dtype=int) if "switch_to" in cells else unknown)[keep],
        new_trial=new_trial, trial_id=trial_id, trial_first=np.flatnonzero(new_trial),
        cell_index=cell_index[keep], new_turn=new_turn, turn_id=np.cumsum(new_turn) - 1, dt=1.0 / rate_hz)


def _blow_events(c: _CellArrays, gap_cells: int) -> _Events:
    """The first command, the blows and the pauses between them, hard-band excursions, and what
    soft blows did to the robot."""
    dt, n, kind, moving, trial_id = c.dt, c.n, c.kind, c.moving, c.trial_id
    events: _Events = []
    # first command: the trial's first Soft or Hard cell
    command = np.flatnonzero(kind >= SOFT)
    first = command[np.unique(trial_id[command], return_index=True)[1]]
    events.append(("first_command_latency", first, c.cell_index[first] * dt))

    # blows, and the pauses between consecutive blows of one person's turn (an autonomy turn cuts them)
    starts, ends = _merged_blows(kind, c.new_turn, gap_cells)
    same = c.turn_id[starts[1:]] == c.turn_id[starts[:-1]]
    pause = (starts[1:] - ends[:-1])[same] * dt
    events.append(("pause_between_blows", starts[1:][same], pause))
    events.append(("share_pauses_over_1s", starts[1:][same], np.round(pause, 6) > 1.0))
    events.append(("share_pauses_over_2s", starts[1:][same], np.round(pause, 6) > 2.0))
    hard_blow = _any_in(kind == HARD, starts, ends)
    duration = (ends - starts) * dt
    events.append(("hard_blow_whole", starts[hard_blow], duration[hard_blow]))
    events.append(("soft_blow", starts[~hard_blow], duration[~hard_blow]))

    hard_starts, hard_ends = cell_runs(kind == HARD, c.new_turn)
    events.append(("hard_band_per_excursion", hard_starts, (hard_ends - hard_starts) * dt))

    # soft blows and motion: the robot's last moving cell inside the blow
    moved = _any_in(moving, starts, ends)
    last_moving = np.maximum.accumulate(np.where(moving, np.arange(n), -1)) if n else np.zeros(0, int)
    soft_moved = ~hard_blow & moved
    hold = (ends[soft_moved] - 1 - last_moving[ends[soft_moved] - 1]) * dt
    per_trial = pd.Series(hold).groupby(trial_id[starts[soft_moved]]).sum()
    events.append(("hold_on_per_trial", c.trial_first[per_trial.index.to_numpy(dtype=int)],
                   per_trial.to_numpy()))
    held = hold > 0
    events.append(("hold_on_per_stop", starts[soft_moved][held], hold[held]))
    still = ~hard_blow & ~moved
    events.append(("soft_blow_never_moving", starts[still], duration[still]))
    return events + deadband_events(kind, c.new_turn, starts[~hard_blow], ends[~hard_blow], dt)


def reaction_events(c: _CellArrays) -> _Events:
    """Reactions: a stop at a waypoint -> the next switch, and a switch -> the robot moving again."""
    dt, n, turn_id = c.dt, c.n, c.turn_id  # a reaction within one person's turn
    # reactions: motion runs, switches
    run_starts, run_ends = cell_runs(c.moving, c.new_turn)
    switches = np.flatnonzero(c.switch)
    # the next motion run of the same turn (n: none)
    next_run = np.full(len(run_starts), n)
    same_turn = turn_id[run_starts[1:]] == turn_id[run_starts[:-1]]
    next_run[:-1][same_turn] = run_starts[1:][same_turn]
    stop_switch = _next_at_or_after(switches, run_ends)
    stop_ok = (c.at_waypoint[run_ends - 1] & c.known[run_ends - 1] & (stop_switch >= 0))
    stop_ok[stop_ok] &= (turn_id[stop_switch[stop_ok]] == turn_id[run_starts[stop_ok]]) & \
        (stop_switch[stop_ok] < next_run[stop_ok])
    events: _Events = [("reaction_stop_to_switch", run_ends[stop_ok],
                        (stop_switch[stop_ok] - run_ends[stop_ok]) * dt)]

    motion_after = _next_at_or_after(run_starts, switches + 1)
    switch_after = _next_at_or_after(switches, switches + 1)
    ok = motion_after >= 0
    ok[ok] &= turn_id[motion_after[ok]] == turn_id[switches[ok]]
    ok &= (switch_after < 0) | (switch_after >= motion_after)  # no switch strictly between
    events.append(("reaction_switch_to_motion", switches[ok], (motion_after[ok] - switches[ok]) * dt))
    return events


def _undone_switch_events(c: _CellArrays) -> _Events:
    """Undone switches: a -> b, then straight back b -> a with no motion between."""
    switches = np.flatnonzero(c.switch)
    came_from, went_to, turn_id = c.came_from, c.went_to, c.turn_id
    first_switch, second_switch = switches[:-1], switches[1:]
    undone = (turn_id[first_switch] == turn_id[second_switch]) & (came_from[first_switch] >= 0) & \
        (went_to[second_switch] == came_from[first_switch]) & \
        ~_any_in(c.moving, first_switch + 1, second_switch)
    return [("undone_switch", first_switch[undone], (second_switch[undone] - first_switch[undone]) * c.dt)]


def measure_habits(cells: pd.DataFrame, rate_hz: float = HABIT_RATE_HZ,
                   merge_gap_s: float = MERGE_GAP_S) -> pd.DataFrame:
    """Every habit event of every trial.

    Parameters
    ----------
    cells
        ``(N,)`` cells with :data:`~nudgecli.report.habit_cells.CELL_COLUMNS`, each trial's cells
        contiguous and in time order.
    rate_hz
        Cells per second.
    merge_gap_s
        Blows are merged across neutral gaps of at most this long.

    Returns
    -------
    pd.DataFrame
        :data:`EVENT_COLUMNS`: one row per event, values in seconds (a share habit: 1.0 or 0.0 per
        pause), rounded to the microsecond.
    """
    return measure_cell_habits(cell_arrays(cells, rate_hz), rate_hz, merge_gap_s)


def measure_cell_habits(c: _CellArrays, rate_hz: float, merge_gap_s: float = MERGE_GAP_S) -> pd.DataFrame:
    """:func:`measure_habits` of the cells' arrays (:func:`cell_arrays` of them at ``rate_hz``), for a
    caller that reads the arrays too (built once)."""
    events = _blow_events(c, gap_cells_of(rate_hz, merge_gap_s)) + reaction_events(c) + \
        _undone_switch_events(c)
    frames = [pd.DataFrame({"participant": c.participant[where], "trial": c.trial[where], "habit": habit,
                            "value": np.round(np.asarray(values, float), 6)})
              for habit, where, values in events]
    if not frames:
        return pd.DataFrame(columns=list(EVENT_COLUMNS))
    return pd.concat(frames, ignore_index=True)


def source_cells(source: str | Path) -> tuple[pd.DataFrame, float, str]:
    """The cells of ``source`` (a run folder, or a real log's CSV), its rate and its kind
    (``run`` or ``log``)."""
    path = Path(source)
    if path.is_dir():
        cells, rate = run_folder_cells(path)
        return cells, rate, "run"
    if not path.exists():
        raise DataError(f"{path}: no such file or folder; give a run folder or a real log (CSV)")
    if path.is_file() and starts_as_toml(path):
        raise DataError(toml_source_message(path, "habits reads a run folder or a real log's CSV (t, trial, "
                                                  "label, x, y, theta, mode_switch)", ["habits", "SOURCE"]))
    if path.is_file() and starts_as_json(path):
        raise DataError(_json_source_message(path))
    return read_log_cells(path), HABIT_RATE_HZ, "log"


def _json_source_message(path: Path) -> str:
    """What habits says of a JSON file given as its source: what it reads, and the likely intent (a
    run folder's own JSON: the folder; else a ``--format json`` output: ``--compare``)."""
    reads = (f"{path}: a JSON file; habits reads a run folder or a real log's CSV (t, trial, label, x, y, "
             "theta, mode_switch)")
    if (path.parent / MANIFEST).is_file():
        return f"{reads}; for the run this file belongs to, give the run folder itself: " \
               f"{shell_words(['nudge', 'habits', str(path.parent)])}"
    try:  # --compare is advised only for a file it reads
        load_reference(str(path))
    except DataError as exc:  # a `nudge fit` profile: p(phi_m | phi_i) and no habits
        what = "a `nudge fit` profile" if "p_phm_given_phi" in path.read_text("utf-8", "replace") else "it"
        return f"{reads}; {what} is no reference for --compare either: {str(exc).removeprefix(f'{path}: ')}"
    return (f"{reads}; a JSON that `nudge habits --format json` wrote is read as a reference printed beside "
            f"a source: {shell_words(['nudge', 'habits', 'SOURCE', '--compare', str(path)])}")


# --- summaries ---------------------------------------------------------------------------------


def _summarise(events: pd.DataFrame, keys: list[str]) -> pd.DataFrame:
    """Per group of ``keys`` and habit: ``n``, ``median`` (a share habit: the share), ``q25``, ``q75``."""
    grouped = events.groupby([*keys, "habit"], sort=False)["value"]
    table = grouped.agg(n="size", median="median").reset_index()
    table["q25"] = grouped.quantile(0.25).to_numpy()
    table["q75"] = grouped.quantile(0.75).to_numpy()
    share = table["habit"].map(lambda h: _BY_KEY[h].share).to_numpy(dtype=bool)
    if share.any():
        means = grouped.mean().to_numpy()
        table.loc[share, "median"] = means[share]
        table.loc[share, ["q25", "q75"]] = np.nan
    # interpolated quartiles of 0.1 s cells: round away the binary float noise (0.8500000000000001)
    table[["median", "q25", "q75"]] = table[["median", "q25", "q75"]].round(6)
    order = {key: i for i, key in enumerate(HABIT_KEYS)}
    table["_order"] = table["habit"].map(order)
    return table.sort_values([*keys, "_order"], kind="stable").drop(columns="_order").reset_index(drop=True)


@dataclass
class HabitsResult:
    """The habits of one source.

    Attributes
    ----------
    source
        What was measured (path).
    kind
        ``run`` or ``log``.
    by
        ``participant`` or ``trial``: the units of :attr:`units`.
    events
        :data:`EVENT_COLUMNS`, one row per event.
    pooled
        Per habit: ``habit``, ``n``, ``median``, ``q25``, ``q75`` over all events, ``people_min`` /
        ``people_max`` (the range of the participants' medians) and ``participants`` (how many have one).
    units
        Per participant (and trial) and habit: ``n``, ``median``, ``q25``, ``q75``.
    people
        Per participant and habit: ``n``, ``median``, ``q25``, ``q75`` (whatever ``by``).
    reference
        The ``--compare`` reference's name and habits (``None`` without one).
    """

    source: str
    kind: str
    by: str
    events: pd.DataFrame
    pooled: pd.DataFrame
    units: pd.DataFrame
    people: pd.DataFrame
    reference: dict[str, Any] | None = None

    def comparison(self) -> pd.DataFrame:
        """Per habit both have: the measured pooled median and people's range beside the reference's,
        whether the pooled median lies inside the reference's people range (``inside``) and the share
        of participants whose own median does (``people_inside``)."""
        if self.reference is None:
            return pd.DataFrame()
        rows = []
        for habit in HABITS:
            entry = self.reference["habits"].get(habit.key)
            measured = self.pooled[self.pooled["habit"] == habit.key]
            if entry is None or measured.empty:
                continue
            median = float(measured["median"].iloc[0])
            own = self.people.loc[self.people["habit"] == habit.key, "median"].to_numpy(dtype=float)
            row = {"habit": habit.key, "median": median, "people_min": float(measured["people_min"].iloc[0]),
                   "people_max": float(measured["people_max"].iloc[0]),
                   "reference_median": float(entry["pooled"]["median"]), "reference_min": math.nan,
                   "reference_max": math.nan, "inside": None, "people_inside": math.nan}
            if entry.get("people") is not None:  # HABITS.md gives some shares pooled only
                lo, hi = (float(v) for v in entry["people"])
                row.update(reference_min=lo, reference_max=hi,
                           inside=bool(lo - TIME_SLACK <= median <= hi + TIME_SLACK),
                           people_inside=float(np.mean((own >= lo - TIME_SLACK) & (own <= hi + TIME_SLACK))))
            rows.append(row)
        # its columns even with no habit in common (one the source has no event of)
        return pd.DataFrame(rows, columns=list(COMPARISON_COLUMNS))

    def to_json(self) -> dict[str, Any]:
        """The JSON of ``--format json`` (the shape ``--compare FILE`` reads back)."""
        habits: dict[str, Any] = {}
        for row in self.pooled.itertuples():
            habit = _BY_KEY[str(row.habit)]
            pooled = {"median": _num(row.median), "q25": _num(row.q25), "q75": _num(row.q75),
                      "n": int(row.n)}
            habits[habit.key] = {"label": habit.label, "unit": "share" if habit.share else "s",
                                 "pooled": pooled,
                                 "people": [_num(row.people_min), _num(row.people_max)],
                                 "participants": int(row.participants)}
        data: dict[str, Any] = {"source": self.source, "kind": self.kind, "by": self.by, "habits": habits,
                                "units": [{k: _num(v) for k, v in record.items()}
                                          for record in self.units.to_dict(orient="records")]}
        if self.reference is not None:
            data["compare"] = {"reference": self.reference.get("name", ""),
                               "habits": self.comparison().to_dict(orient="records")}
        return data


def _num(value: Any) -> Any:
    """A JSON-ready scalar (NaN -> None, numpy -> Python)."""
    if isinstance(value, (float, np.floating)):
        return None if math.isnan(value) else float(value)
    if isinstance(value, np.integer):
        return int(value)
    return value


def load_reference(name_or_path: str) -> dict[str, Any]:
    """A ``--compare`` reference: a packaged name (``ciaa-people``) or a JSON file of the same shape
    (e.g. another source's ``nudge habits --format json``)."""
    if name_or_path in PACKAGED_REFERENCES:
        return packaged_reference(name_or_path)
    path = Path(name_or_path)
    if not path.is_file():
        raise DataError(f"--compare {name_or_path}: neither a packaged reference "
                        f"({', '.join(PACKAGED_REFERENCES)}) nor a JSON file")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: not a JSON reference ({exc})") from None
    habits = data.get("habits") if isinstance(data, dict) else None
    if not isinstance(habits, dict):
        raise DataError(f"{path}: no 'habits' object; a reference has the shape of "
                        "`nudge habits --format json`")
    if not habits:
        raise DataError(f"{path}: holds no habit to compare with; a reference has the shape of "
                        "`nudge habits --format json`, its habits one or more of " + ", ".join(HABIT_KEYS))
    # a habit nudge does not measure would be left out of the comparison unsaid (a misspelt key)
    unknown = [key for key in habits if key not in _BY_KEY]
    if unknown:
        suggestion = did_you_mean(unknown[0], HABIT_KEYS)
        raise DataError(f"{path}: habit {unknown[0]!r} is not one nudge measures{suggestion}; the habits are "
                        + ", ".join(HABIT_KEYS))
    for key, entry in habits.items():  # a range reversed, in ms or a percent would compare wrongly unsaid
        check_reference_habit(str(path), key, entry, "share" if _BY_KEY[key].share else "s")
    return {"name": str(data.get("name", path.name)), **data}


def habits_of(source: str | Path, by: str = "participant", compare: str | None = None) -> HabitsResult:
    """Measure the operating habits of ``source`` (a run folder or a real log's CSV).

    Parameters
    ----------
    source
        A run folder, or a CSV log (:func:`~nudgecli.report.habit_logs.read_log_cells`).
    by
        ``participant`` or ``trial``: the units listed beside the pooled figures.
    compare
        A reference to print beside them (:func:`load_reference`), or ``None``.
    """
    reference = load_reference(compare) if compare is not None else None
    cells, rate, kind = source_cells(source)
    events = measure_habits(cells, rate)
    if events.empty:
        raise DataError(_nothing_to_measure(str(source), cells, rate))
    return summarise_habits(events, str(source), kind, by, reference)


def _nothing_to_measure(source: str, cells: pd.DataFrame, rate_hz: float) -> str:
    """Why a source with no habit event has none, in the words of its cells.

    Every non-neutral cell is in a blow, and a blow is an event, so no event means no input at all:
    what is left to say is whether it switched modes or moved."""
    trials = len(cells.drop_duplicates(["participant", "trial"]))
    switches, moving = int(cells["switch"].sum()), int(cells["moving"].sum())
    found = f"its {switches} mode switch(es) and {moving} moving cell(s) make no reaction or undone switch" \
        if switches or moving else "no mode switch or motion"
    of_trials = f"{trials} trial" + ("" if trials == 1 else "s")
    return (f"{source}: nothing to measure: its {len(cells)} cells of {of_trials} at {rate_hz:g} Hz hold "
            f"no input (every label neutral: empty, Zero Band, input stopped or None) and {found}; "
            "habits are measured on a person operating the interface")


def summarise_habits(events: pd.DataFrame, source: str, kind: str = "run", by: str = "participant",
                     reference: dict[str, Any] | None = None) -> HabitsResult:
    """The :class:`HabitsResult` of measured events (:func:`measure_habits`, at least one: a source
    with none is refused by :func:`habits_of`), e.g. of several runs' cells measured together."""
    people = _summarise(events, ["participant"])
    units = people if by == "participant" else _summarise(events, ["participant", "trial"])
    pooled = _summarise(events, [])
    spread = people.groupby("habit")["median"].agg(people_min="min", people_max="max", participants="size")
    pooled = pooled.join(spread, on="habit")
    return HabitsResult(source, kind, by, events, pooled, units, people, reference)


def format_habits(result: HabitsResult) -> str:
    """The table of ``--format table``: pooled habits (with the reference beside them), then the units'
    medians, one row per participant (or trial)."""
    comparison = result.comparison().set_index("habit") if result.reference is not None else None
    count = result.people["participant"].nunique()
    people = f"{count} participant{'' if count == 1 else 's'}"
    lines = [f"Operating habits of {result.source} (HABITS.md definitions, {people})", ""]
    header = f"{'habit':<50} {'n':>6} {'median [q25, q75]':>20} {'people':>14}"
    if comparison is not None and result.reference is not None:
        name = str(result.reference.get("name", "reference")) + " median"
        header += f"   {name:>22} {'people':>14} inside people_inside"
    lines.append(header)
    for row in result.pooled.itertuples():
        habit = _BY_KEY[str(row.habit)]
        digits, compared = 2, ""  # a row's measured values get enough digits to read as compared
        if comparison is not None and habit.key in comparison.index:
            ref = comparison.loc[habit.key]
            own, digits = compared_digits(float(row.median), ref)
            low, high = fmt(ref["reference_min"], own), fmt(ref["reference_max"], own)
            inside = "-" if ref["inside"] is None else "yes" if ref["inside"] else "no"
            people_in = "-" if math.isnan(ref["people_inside"]) else f"{ref['people_inside']:.0%}"
            people_range = "-" if math.isnan(ref["reference_min"]) else f"{low}-{high}"
            compared = (f"   {fmt(ref['reference_median'], own):>22} {people_range:>14} {inside:>6} "
                        f"{people_in:>13}")
        quartiles = "" if habit.share else f" [{fmt(row.q25, digits)}, {fmt(row.q75, digits)}]"
        lines.append(f"{habit.label:<50} {int(row.n):>6} {fmt(row.median, digits) + quartiles:>20} "
                     f"{fmt(row.people_min, digits) + '-' + fmt(row.people_max, digits):>14}" + compared)
    keys = ["participant"] if result.by == "participant" else ["participant", "trial"]
    wide = result.units.pivot_table(index=keys, columns="habit", values="median", sort=False)
    wide = wide[[h.key for h in HABITS if h.key in wide.columns]]
    wide.columns = [_BY_KEY[c].short for c in wide.columns]
    shares = ", ".join(h.short for h in HABITS if h.share)
    lines += ["", f"Medians per {result.by} (shares for {shares}):",
              wide.to_string(float_format=lambda v: f"{v:.2f}", na_rep="-")]
    return "\n".join(lines)


def habits_csv(result: HabitsResult) -> str:
    """The CSV of ``--format csv``: pooled rows (scope ``pooled``) then the units' rows."""
    pooled = result.pooled.assign(scope="pooled")
    units = result.units.assign(scope=result.by)
    # a run's labels are integers: the pooled rows' empty cells would make them floats ("0.0") in
    # a numpy column, not in a nullable one; a real log's text labels stay as written
    units = units.astype({key: "Int64" for key in ("participant", "trial")
                          if key in units.columns and pd.api.types.is_integer_dtype(units[key])})
    table = pd.concat([pooled, units], ignore_index=True)
    columns = ["scope", "participant", *(["trial"] if result.by == "trial" else []), "habit", "n", "median",
               "q25", "q75", "people_min", "people_max"]
    if result.reference is not None:
        ref = result.comparison()[["habit", "reference_median", "reference_min", "reference_max", "inside",
                                   "people_inside"]]
        table = table.merge(ref.assign(scope="pooled"), on=["scope", "habit"], how="left")
        columns += list(ref.columns[1:])
    return table.reindex(columns=columns).to_csv(index=False)
