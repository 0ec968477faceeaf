"""What ``nudge fit-people`` reads: each participant's habit figures from a source.

A source is one of
- a real log in ``nudge habits``' CSV format (:mod:`nudgecli.report.habit_logs`), or a run folder:
  measured here with ``nudge habits``' own functions (:mod:`nudgecli.report.habits`);
- the per-participant table of ``nudge habits --by participant --format csv`` (its
  ``participant`` rows; the ``pooled`` rows are ignored, a row of another scope or a participant
  row with no label refused): read as it is.

Either way the result is, per participant in the source's order, habit -> its
:class:`~nudgecli.sim.twins.HabitFigures`. Bad input is one :class:`~nudgecli.errors.DataError`
naming the file, the participant and the field.
"""

from __future__ import annotations

import csv
import dataclasses
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from nudgecli.config import BehaviourSection, ExperimentConfig, InterfaceSection, PopulationSection
from nudgecli.csv_rows import read_csv_whole_rows
from nudgecli.csv_text import not_utf8_message, starts_as_json, starts_as_toml, toml_source_message
from nudgecli.errors import DataError, did_you_mean
from nudgecli.report.habit_cells import NEUTRAL, run_folder_cells_with_experiment, stops_at_waypoints
from nudgecli.report.habit_figures import check_unit, checked_figure, figure
from nudgecli.report.habits import (
    HABIT_KEYS,
    HABITS,
    cell_arrays,
    measure_cell_habits,
    reaction_events,
    source_cells,
    summarise_habits,
)
from nudgecli.report.tables import check_unique_columns
from nudgecli.run_folder_config import run_experiment
from nudgecli.sim.twin_fit import (
    PARAMETER_HABITS,
    STOP_PARAMETERS,
    HabitFigures,
    Mechanics,
    fit_twin_with_notes,
)
from nudgecli.sim.twins import Twin
from nudgecli.store import RunFolder, is_run_folder

if TYPE_CHECKING:
    from nudgecli.report.habits import _CellArrays  # what cell_arrays builds

#: Participant label -> habit -> figures, participants in the source's order.
SourceHabits = dict[str, dict[str, HabitFigures]]
#: Columns a habits table must have.
TABLE_COLUMNS = ("participant", "habit", "median")
#: The scopes of a habits table's rows, as ``nudge habits --by participant --format csv`` writes
#: them: one participant's figures (read), or all of them pooled (left out).
TABLE_SCOPES = ("participant", "pooled")
#: The unit each habit is given in (``nudge habits --format json``'s ``unit``).
HABIT_UNITS = {h.key: "share" if h.share else "s" for h in HABITS}


#: The columns of ``nudge habits --by participant --format csv`` that tell a habits table from a log.
TABLE_MARKS = ("scope", "habit", "n", "median", "q25", "q75", "people_min", "people_max")


def _is_habits_table(path: Path) -> bool:
    """Whether a CSV file's header is a habits table's, not a log's: ``habit`` and ``median``
    columns, or (one of them misspelt, which the table's reader then names) three of
    :data:`TABLE_MARKS` and no ``label``, which every log holds."""
    try:
        header = pd.read_csv(path, nrows=0, sep=None, engine="python").columns
    except (ValueError, pd.errors.ParserError, UnicodeDecodeError, csv.Error):  # csv.Error: no delimiter
        return False
    names = {str(c).strip().lower() for c in header}
    return {"habit", "median"} <= names or (len(names & set(TABLE_MARKS)) >= 3 and "label" not in names)


def _figures_of(people: pd.DataFrame) -> SourceHabits:
    """Per participant (in order of appearance), habit -> figures, of a per-participant summary."""
    found: SourceHabits = {}
    for row in people.itertuples(index=False):
        found.setdefault(str(row.participant), {})[str(row.habit)] = HabitFigures(
            n=int(row.n), median=float(row.median), q25=figure(row.q25), q75=figure(row.q75))
    return found


#: ``(participant, reaction habit)`` -> each event's ``(value, blow_after, release)``, s.
Releases = dict[tuple[str, str], list[tuple[float, float, float]]]


def reaction_releases(cells: pd.DataFrame, rate_hz: float) -> Releases:
    """``(participant, reaction habit)`` -> each event in ``nudge habits``' order, ``(value,
    blow_after, release)``, s: the event as it measures it; from the event's start (the stop; the
    step after the switch, when it is seen) to the first non-neutral cell after the first neutral
    one (the next blow, after the hold-on or the pulse); and that release (its neutral cells).
    ``(value, value, 0)`` where no release comes before the event ends (the twin fit's reactions:
    :func:`~nudgecli.sim.twin_fit.reaction_observations`)."""
    return _releases_of(cell_arrays(cells, rate_hz))


def _releases_of(c: _CellArrays) -> Releases:
    """:func:`reaction_releases` of the cells' arrays (:func:`~nudgecli.report.habits.cell_arrays`)."""
    neutral = c.kind == NEUTRAL
    index = np.arange(c.n)

    def next_at_or_after(mask: np.ndarray) -> np.ndarray:
        return np.minimum.accumulate(np.where(mask, index, c.n)[::-1])[::-1]

    next_neutral, next_input = next_at_or_after(neutral), next_at_or_after(~neutral)
    found: Releases = {}
    for habit, where, values in reaction_events(c):
        if habit not in PARAMETER_HABITS["event_reaction_s"]:
            continue
        ends = where + np.round(np.asarray(values, float) / c.dt).astype(int)  # the switch; the motion
        starts = where if habit == "reaction_stop_to_switch" else where + 1
        for cell, start, end, value in zip(where.tolist(), starts.tolist(), ends.tolist(), values.tolist(),
                                           strict=True):
            released = int(next_neutral[start])  # (start < end <= the cell count: a later cell ends it)
            event = (value, value, 0.0)
            if released < end:  # the next blow is at or before the event's end, in its trial
                blow = int(next_input[released])
                event = (value, round((blow - start) * c.dt, 6), round((blow - released) * c.dt, 6))
            found.setdefault((str(c.participant[cell]), habit), []).append(event)
    return found


def measured_source(path: Path) -> SourceHabits:
    """A run folder's or a real log's participants' habits, measured as ``nudge habits`` does.

    Raises
    ------
    DataError
        No participants, or a participant with no trial to measure (no input at all).
    """
    return _measured(path)[0]


def _measured(path: Path) -> tuple[SourceHabits, ExperimentConfig | None, bool]:
    """:func:`measured_source`, the experiment of a run folder (``None``: a real log), read once with
    its cells, and whether its robot stops at the CIAA task's waypoints
    (:func:`~nudgecli.report.habit_cells.stops_at_waypoints` of the experiment; a real log's unless
    it is :func:`_assisted_without_layout`)."""
    experiment = None
    if path.is_dir():  # a run folder (source_cells'): its experiment comes with its cells
        cells, rate, experiment = run_folder_cells_with_experiment(path)
        waypoints = stops_at_waypoints(experiment)
    else:
        cells, rate, _ = source_cells(path)
        waypoints = not _assisted_without_layout(cells)
    if cells.empty:
        raise DataError(f"{path}: no participants (no trial to measure)")
    arrays = cell_arrays(cells, rate)  # once: the habits are measured and the releases read from them
    events = measure_cell_habits(arrays, rate)
    found = _figures_of(summarise_habits(events, str(path)).people) if not events.empty else {}
    participants = [str(p) for p in pd.unique(cells["participant"])]
    for participant in participants:
        if participant not in found:
            raise DataError(f"{path}: participant {participant!r}: no trial with input to measure (every "
                            "cell neutral); a twin needs their habits")
    for (participant, habit), events in _releases_of(arrays).items():
        values, blow_after, releases = zip(*events, strict=True)
        found[participant][habit] = dataclasses.replace(found[participant][habit], values=values,
                                                        blow_after=blow_after, releases=releases)
    return {participant: found[participant] for participant in participants}, experiment, waypoints


def _assisted_without_layout(cells: pd.DataFrame) -> bool:
    """Whether a real log's ``cells`` are of an assisted study without its layout, whose stops are
    not known to be the CIAA task's: its ``turn`` column marks autonomy turns and no ``layout``
    column places it on the task (``waypoints_known`` False throughout). With its layout, a log of
    an assisted study is of the CIAA task, its stops at the layout's waypoints."""
    has_autonomy_turns = "person_turn" in cells and not bool(cells["person_turn"].all())
    return has_autonomy_turns and not bool(cells["waypoints_known"].any())


#: The note on each of :data:`~nudgecli.sim.twin_fit.STOP_PARAMETERS` of a log of an assisted
#: study without its layout (the fit's own says "a grid-world run", which a log may not be).
LOG_WITHOUT_LAYOUT_NOTE = ("a log of an assisted study without its layout: its robot's stops are not known "
                           "to be at the CIAA task's waypoints (give the log's layout column to fit it)")


def _events_of(where: str, habit: str, row: pd.Series) -> int | None:
    """A habits table row's ``n`` (None: no ``n`` column); a :class:`DataError` for one that is no
    count of events (negative, fractional, not a number, empty)."""
    if "n" not in row.index:
        return None
    n = figure(row["n"])
    if not (math.isfinite(n) and n >= 0 and n == int(n)):
        given = str(row["n"]).strip() or "empty"
        raise DataError(f"{where}: {habit}: n {given!r} is not a number of events; give the whole number "
                        "(0 or more) `nudge habits --by participant --format csv` writes")
    return int(n)


def _check_row(path: Path, participant: str, habit: str, row: pd.Series) -> HabitFigures | None:
    """One row of a habits table as figures (None: a habit with no event), or a DataError."""
    where = f"{path}: participant {participant!r}"
    if habit not in HABIT_UNITS:
        raise DataError(f"{where}: habit {habit!r} is not one nudge measures"
                        f"{did_you_mean(habit, HABIT_KEYS)}; the habits are {', '.join(HABIT_KEYS)}")
    if "unit" in row.index:
        check_unit(where, habit, row["unit"], HABIT_UNITS[habit])
    n = _events_of(where, habit, row)
    if n == 0:
        return None
    median = checked_figure(where, habit, "median", row["median"], HABIT_UNITS[habit])
    q25, q75 = (checked_figure(where, habit, column, row[column], HABIT_UNITS[habit])
                if column in row.index else math.nan
                for column in ("q25", "q75"))
    if q25 > q75:  # (False where either is NaN)
        raise DataError(f"{where}: {habit}: q25 {q25:g} is above q75 {q75:g}; give the lower quartile in q25 "
                        "and the upper in q75")
    return HabitFigures(n=0 if n is None else n, median=median, q25=q25, q75=q75)


def _participant_rows(path: Path, table: pd.DataFrame) -> pd.DataFrame:
    """A habits table's participant rows (its ``pooled`` rows left out; every row, without a
    ``scope`` column), or a :class:`DataError` naming the line of the first row whose scope is none
    of :data:`TABLE_SCOPES` (``Participant`` would drop a person's rows unsaid) or whose participant
    label is empty (a pooled row of a table without its scope column would make a person '')."""
    scoped = "scope" in table.columns
    scopes = table["scope"].str.strip() if scoped else pd.Series("participant", index=table.index)
    unknown = scopes[~scopes.isin(TABLE_SCOPES)]
    if not unknown.empty:  # the header is line 1
        scope, line = str(unknown.iloc[0]), unknown.index[0] + 2
        raise DataError(f"{path}: line {line}: scope {scope!r} is neither 'participant' nor 'pooled'"
                        f"{did_you_mean(scope, TABLE_SCOPES)}; write 'participant' for a participant's row "
                        "or 'pooled' for a row of them all (left out), as `nudge habits --by participant "
                        "--format csv` does")
    rows = table[scopes == "participant"]
    unnamed = rows.index[rows["participant"].str.strip() == ""]
    if len(unnamed) and scoped:
        raise DataError(f"{path}: line {unnamed[0] + 2}: a participant row with no participant label; "
                        "give the participant's label")
    if len(unnamed):
        raise DataError(f"{path}: line {unnamed[0] + 2}: no participant label, and no scope column to say "
                        "the row is a pooled one; give the participant's label, or the scope column `nudge "
                        "habits --by participant --format csv` writes ('pooled' rows are left out)")
    return rows


def _header_names(path: Path) -> list[str]:
    """A habits table's column names as its header line writes them (repeats kept), in the
    delimiter pandas finds for the whole table."""
    header = pd.read_csv(path, dtype=str, keep_default_na=False, sep=None, engine="python", header=None,
                         nrows=1, encoding="utf-8-sig")
    return [str(name) for name in header.iloc[0]] if len(header) else []


def table_source(path: Path) -> SourceHabits:
    """The participants' habits of a ``nudge habits --by participant --format csv`` table.

    Raises
    ------
    DataError
        A row with fewer or more fields than the header (a table cut off), a trial table, a
        scope that is neither ``participant`` nor ``pooled``, a participant row with no label, no
        participant rows, an unknown habit or unit, an ``n`` that is no whole number of events, a
        median or quartile that is no finite non-negative number (a share's above 1: a percent?),
        quartiles the wrong way round, a habit
        listed twice for one participant, or a participant with no trials (``n``
        0 for every habit).
    """
    try:
        table = read_csv_whole_rows(path, dtype=str, keep_default_na=False, sep=None, engine="python")
    except UnicodeDecodeError:
        raise DataError(not_utf8_message(path, reads_run_folders=True)) from None
    except (ValueError, pd.errors.ParserError, csv.Error) as exc:
        raise DataError(f"{path}: not a habits table ({str(exc).strip()})") from None
    # pandas renames a repeated name (median.1) and keeps a differently cased one (Median): either
    # would leave a column read unsaid, or make a row's median two values
    check_unique_columns([str(c).strip().lower() for c in _header_names(path)], path)
    table.columns = [str(c).strip().lower() for c in table.columns]
    missing = [c for c in TABLE_COLUMNS if c not in table.columns]
    if missing:
        others = [c for c in table.columns if c not in (*TABLE_COLUMNS, *TABLE_MARKS)]
        close = next((f" (is {c!r} it, misspelt? rename it {missing[0]!r})" for c in others
                      if did_you_mean(c, [missing[0]])), "")
        raise DataError(f"{path}: no column {missing[0]!r}{close}; give `nudge habits --by participant "
                        "--format csv`")
    if "trial" in table.columns:
        raise DataError(f"{path}: a table per trial; fit-people reads one per participant "
                        "(`nudge habits --by participant --format csv`)")
    table = _participant_rows(path, table)
    if table.empty:
        raise DataError(f"{path}: no participants (no 'participant' rows); give `nudge habits --by "
                        "participant --format csv`")
    found: SourceHabits = {}
    for _, row in table.iterrows():
        participant, habit = str(row["participant"]).strip(), str(row["habit"]).strip()
        habits = found.setdefault(participant, {})
        if habit in habits:
            raise DataError(f"{path}: participant {participant!r}: habit {habit!r} is listed twice")
        figures = _check_row(path, participant, habit, row)
        if figures is not None:
            habits[habit] = figures
    for participant, habits in found.items():
        if not habits:
            raise DataError(f"{path}: participant {participant!r}: no trials (n is 0 for every habit)")
    return found


def _habits_and_experiment(source: str | Path) -> tuple[SourceHabits, ExperimentConfig | None, bool]:
    """Each participant's habits of ``source`` (a run folder, a real log, or a habits table), the
    experiment of a run folder (``None``: a log or a table), read once, and whether the source's
    robot stops at the CIAA task's waypoints (:func:`_measured`)."""
    path = Path(source)
    if path.is_file() and starts_as_toml(path):
        raise DataError(toml_source_message(path, "fit-people reads a run folder, a real log's CSV or the "
                                            "table `nudge habits --by participant --format csv` writes",
                                            ["fit-people", "SOURCE", "--out", "people.csv"]))
    if path.is_file() and starts_as_json(path):
        raise DataError(f"{path}: a JSON file; fit-people reads the CSV table that `nudge habits --by "
                        "participant --format csv` writes (or a real log's CSV, or a run folder)")
    if path.is_file() and _is_habits_table(path):
        return table_source(path), None, stops_at_waypoints(None)
    return _measured(path)


def source_interface(source: str | Path) -> tuple[InterfaceSection, BehaviourSection]:
    """The ``[interface]`` (its thresholds) and ``[behaviour]`` (its pauses) the source's people
    acted under, which the fit's offsets are taken with (:class:`~nudgecli.sim.twin_fit.Mechanics`):
    a run folder's own, as its manifest records them; the defaults for a real log or a habits
    table, which hold none (a log's labels are the interface's own, thresholds unsaid)."""
    path = Path(source)
    return _interface_of(run_experiment(RunFolder(path)) if path.is_dir() and is_run_folder(path) else None)


def _interface_of(experiment: ExperimentConfig | None) -> tuple[InterfaceSection, BehaviourSection]:
    """:func:`source_interface` of a source's experiment (``None``: a log or a table: the defaults)."""
    if experiment is None:
        return InterfaceSection(), BehaviourSection()
    return experiment.interface, experiment.behaviour


def twins_of_sources(sources: list[str | Path], population: PopulationSection | None = None) -> list[Twin]:
    """One twin per participant of each source, in order (:func:`~nudgecli.sim.twins.fit_twin`).

    ``population``: the ``[population]`` a twin's physiology is drawn from, which the fit's offsets
    are taken over (:class:`~nudgecli.sim.twin_fit.Mechanics`; the defaults when None), with the
    thresholds and pauses of each source's own interface (:func:`source_interface`).

    Raises
    ------
    DataError
        No source, or a bad source (:func:`_habits_and_experiment`).
    """
    if not sources:
        raise DataError("fit-people: give one or more sources (a real log, a run folder or a habits table)")
    seen: dict[Path, str | Path] = {}
    for source in sources:  # the same people twice would count twice in every study of the file
        where = Path(source).resolve()
        if where in seen:
            raise DataError(f"fit-people: {source} is given twice (as {seen[where]} too): its people would "
                            "be in the people file twice; give each source once")
        seen[where] = source
    population = population or PopulationSection()
    mechanics: dict[tuple[float, ...], Mechanics] = {}  # per source's interface: a few hundred draws each
    twins = []
    for source in sources:
        name = Path(source).name
        # a run's experiment read once, with its cells; a grid-world source's stops are not the fit's
        found, experiment, waypoints = _habits_and_experiment(source)
        interface, behaviour = _interface_of(experiment)
        thresholds = (interface.zero_threshold, interface.soft_threshold, interface.hard_threshold)
        key = (*thresholds, behaviour.pause_jitter)
        if key not in mechanics:
            mechanics[key] = Mechanics(population, behaviour, thresholds=thresholds)
        for participant, habits in found.items():
            parameters, notes = fit_twin_with_notes(habits, mechanics=mechanics[key], waypoints=waypoints)
            if experiment is None and not waypoints:  # a log, not a grid-world run folder
                notes = {name: LOG_WITHOUT_LAYOUT_NOTE if name in STOP_PARAMETERS else note
                         for name, note in notes.items()}
            twins.append(Twin(participant=participant, source=name, parameters=parameters, notes=notes))
    return twins
