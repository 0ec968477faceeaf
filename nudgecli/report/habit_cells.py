"""HABITS.md's cell table (``nudge habits``): the 10 Hz cells operating habits are measured on,
their kinds and columns, the helpers that derive them, and the reader of a run folder's steps.
A real log's cells are read by :mod:`nudgecli.report.habit_logs`."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from nudgecli.config import ExperimentConfig
from nudgecli.errors import DataError, RunFolderError, shell_words
from nudgecli.model.interface import HARD_PUFF, HARD_SIP, PUFF_DEADBAND, SIP_DEADBAND, SOFT_PUFF, SOFT_SIP
from nudgecli.model.world import MODE_NAMES, angle_difference
from nudgecli.run_folder_config import run_experiment
from nudgecli.run_folder_names import BATCH_MANIFEST
from nudgecli.sim.calibration_io import STREAM_CODES
from nudgecli.sim.calibration_readers import holds_calibration_session
from nudgecli.steplog import AUTONOMY_TURN, HUMAN_TURN, MODE_SWITCH_HUMAN, has_event
from nudgecli.store import RunFolder, is_run_folder

#: The rate of HABITS.md's cells (a real log is resampled to it).
HABIT_RATE_HZ = 10.0
#: Float slack of time comparisons (cell edges are multiples of 0.1 s in binary floating point).
TIME_SLACK = 1e-9
#: A pose closer than this to a waypoint (units) stands on it: the worlds snap onto waypoints
#: exactly, so this only absorbs the rounding of a written log.
WAYPOINT_TOLERANCE = 1e-3
#: Pose changes below this (units, rad) are no motion: float noise of a written log.
POSE_TOLERANCE = 1e-9

#: The values of a real log's optional ``turn`` column, the person's first: a run folder's step turns.
LOG_TURNS = (HUMAN_TURN, AUTONOMY_TURN)

#: Cell kinds.
NEUTRAL, DEADBAND, SOFT, HARD = 0, 1, 2, 3
_KIND_OF_CODE = {HARD_PUFF: HARD, HARD_SIP: HARD, SOFT_PUFF: SOFT, SOFT_SIP: SOFT, PUFF_DEADBAND: DEADBAND,
                 SIP_DEADBAND: DEADBAND}
#: Label name -> cell kind: the interface labels, deadbands, and every neutral spelling (the
#: toolkit's empty label, the pilots' ``None``, the sibling study's ``Zero Band`` and ``input stopped``).
LABEL_KINDS = {"": NEUTRAL, **{name: _KIND_OF_CODE.get(code, NEUTRAL) for name, code in STREAM_CODES.items()}}

#: The columns of the cell table :func:`nudgecli.report.habits.measure_habits` reads (one row
#: per cell, trials contiguous and in time order): ``kind`` (:data:`NEUTRAL` ...), ``moving``,
#: ``switch`` (a mode switch fired in the cell), ``at_waypoint`` (after this cell the robot stands
#: at a waypoint; read at the last cell of a motion run) and ``waypoints_known`` (False where a real
#: log names no layout, and in the grid world, which has none); optional ``switch_from`` /
#: ``switch_to``: a switch cell's mode before and after (0 x, 1 y, 2 theta; -1 unknown), and
#: optional ``person_turn``: the cell is in the person's turn (False in an autonomy turn of an
#: assisted run, whose input and motion are not the person's; absent: every cell is the person's,
#: as in a real log without a ``turn`` column and an unassisted run).
CELL_COLUMNS = ("participant", "trial", "kind", "moving", "switch", "at_waypoint", "waypoints_known")


# --- runs of cells -----------------------------------------------------------------------------


def cell_runs(mask: np.ndarray, new_trial: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and end (exclusive) indices of the runs of True in ``mask`` that do not cross a trial.

    ``new_trial[i]`` is True where cell ``i`` is its trial's first.
    """
    mask = np.asarray(mask, dtype=bool)
    before = np.concatenate(([False], mask[:-1])) & ~new_trial
    after = np.concatenate((mask[1:], [False])) & ~np.concatenate((new_trial[1:], [True]))
    return np.flatnonzero(mask & ~before), np.flatnonzero(mask & ~after) + 1


# --- sources: a run folder ---------------------------------------------------------------------

_HABIT_STEP_COLUMNS = ["participant", "trial", "turn", "x", "y", "theta", "mode", "phi_m", "event"]
_TRIAL_COLUMNS = ["participant", "trial", "layout", "final_x", "final_y", "final_theta"]
#: Participants whose step parts a run's cells are made from at once (about 13 MB of steps each
#: for the paper's 48 trials): few enough to bound memory, enough that each read's cost is shared.
_PARTICIPANTS_AT_ONCE = 16


def label_kinds(labels: pd.Series, where: str | Callable[[int], str]) -> np.ndarray:
    """``(N,)`` cell kinds of label names; an unknown name is a :class:`DataError` naming its row
    (``where``: the file, or the name of a row by its index)."""
    # each distinct label read once (a run's 3.6 M labels one by one took a second): a missing one
    # is "" (no input), the others stripped of white space
    codes, distinct = pd.factorize(labels)
    text = pd.Series(distinct, dtype=labels.dtype).fillna("").astype(str).str.strip()
    kinds = np.append(text.map(LABEL_KINDS).to_numpy(dtype=float), LABEL_KINDS[""])[codes]
    unknown = np.isnan(kinds)
    if unknown.any():
        row = int(np.flatnonzero(unknown)[0])
        known = ", ".join(repr(k) for k in LABEL_KINDS)
        label = text.iloc[codes[row]]
        raise DataError(f"{where(row) if callable(where) else where}: unknown label {label!r}; "
                        f"labels are {known}")
    return kinds.astype(np.int8)


def pose_changes(pose: np.ndarray, after: np.ndarray) -> np.ndarray:
    """``(N,)`` whether the pose changed across each cell (``pose``, ``after``: ``(N, 3)``)."""
    shift = np.abs(after[:, :2] - pose[:, :2]).max(axis=1)
    turn = np.abs(angle_difference(after[:, 2], pose[:, 2]))
    return (shift > POSE_TOLERANCE) | (turn > POSE_TOLERANCE)


def on_waypoints(position: np.ndarray, layouts: np.ndarray,
                  waypoints: Mapping[int, np.ndarray]) -> np.ndarray:
    """``(N,)`` whether each position ``(N, 2)`` lies on a waypoint of its layout ``(N,)``."""
    at = np.zeros(len(position), dtype=bool)
    for layout in np.unique(layouts):
        rows = layouts == layout
        points = waypoints[int(layout)]
        gap = np.abs(position[rows, None, :] - points[None, :, :]).max(axis=2)
        at[rows] = (gap <= WAYPOINT_TOLERANCE).any(axis=1)
    return at


def stops_at_waypoints(experiment: ExperimentConfig | None) -> bool:
    """Whether the robot of a habits source stops at the CIAA task's waypoints: a CIAA run's
    ``experiment``, or a real log or habits table (``None``: no experiment recorded); not a
    grid-world run's (``paper``, ``smoke``, a ``nudge study`` session), whose robot stops in any cell."""
    return experiment is None or experiment.world.kind == "ciaa"


def run_folder_cells(folder: str | Path) -> tuple[pd.DataFrame, float]:
    """:func:`run_folder_cells_with_experiment` without the experiment."""
    cells, rate, _ = run_folder_cells_with_experiment(folder)
    return cells, rate


def run_folder_cells_with_experiment(folder: str | Path) -> tuple[pd.DataFrame, float, ExperimentConfig]:
    """The cells of a run folder (``nudge simulate`` / ``run`` / ``study``): its steps.

    The pose after a step is the next step's, or the trial's final pose; a switch is the person's
    (``mode_switch_human``); a motion run ends at a waypoint when its last pose is one of the
    CIAA layout's waypoints; the grid world has none (``waypoints_known`` False, as a real log
    without its layout: no stop -> switch is measured).

    Returns
    -------
    tuple
        The cell table (:data:`CELL_COLUMNS`) in HABITS.md's 10 Hz cells (a run at another rate
        read in them, :func:`habit_rate_cells`), their rate, and the experiment the run was made
        with (:func:`run_experiment`, read once: a caller of the cells needs no second read).
    """
    run = RunFolder(folder)
    if not is_run_folder(folder):
        raise RunFolderError(_not_a_run_message(Path(folder)))
    run.check_complete()
    config = run_experiment(run)
    trials = run.read_table("trials", columns=_TRIAL_COLUMNS)
    waypoints = None
    if config.world.kind == "ciaa":
        waypoints = {int(row.layout): np.asarray(row.waypoints, dtype=float).reshape(-1, 2)
                     for row in run.read_layouts().itertuples()}
    parts: Iterator[tuple[pd.DataFrame, pd.DataFrame]]
    if run.is_run():  # a few participants at a time: a cell is its own trial's (1.4 GB for 300 at once)
        participants = sorted(set(trials["participant"].astype(int)))
        at_once = _PARTICIPANTS_AT_ONCE
        groups = [participants[i:i + at_once] for i in range(0, len(participants), at_once)]
        parts = ((run.read_table("steps", _HABIT_STEP_COLUMNS, participants=group),
                  trials[trials["participant"].isin(group)]) for group in groups)
    else:  # parts put together by hand: any part may hold any participant's steps
        parts = iter([(run.read_table("steps", columns=_HABIT_STEP_COLUMNS), trials)])
    cells = pd.concat([_trial_cells(run, steps, part_trials, waypoints) for steps, part_trials in parts],
                      ignore_index=True)
    return habit_rate_cells(cells, float(config.study.rate_hz)), HABIT_RATE_HZ, config


def _not_a_run_message(folder: Path) -> str:
    """The line for a folder given as a habits source that is no run folder: a batch folder (which
    keeps no step logs) and a calibration session (physiology) are named, with what reads them."""
    reads = "operating habits are measured on a run folder or a real log (CSV)"
    if (folder / BATCH_MANIFEST).is_file():  # its tasks/ hold each study's per-trial metrics only
        simulate = shell_words(_simulate_batch_study(folder))
        return (f"{folder}: a batch folder (nudge replicate, power or sweep), whose tasks/ keep each study's "
                f"per-trial metrics and no step logs; {reads}: simulate one study of its experiment "
                f"(`{simulate}`) and give RUN")
    if holds_calibration_session(folder):  # the quotes as docs/people.md writes the setting
        simulate = f"nudge simulate paper --set \"population.physiology_logs=['{folder}']\""
        return (f"{folder}: a calibration session (prompted blows: a person's physiology, not the habits "
                f"of operating the robot); {reads}; a simulation takes a p(phi_m | phi_i) session's "
                f"physiology as population.physiology_logs (`{simulate}`), and "
                f"`{shell_words(['nudge', 'fit', str(folder)])}` fits its interface model")
    return (f"{folder}: not a run folder (no manifest.json, steps/ or trials/); give a folder written by "
            "`nudge simulate`, `nudge run` or `nudge study`, or a CSV log")


def _simulate_batch_study(folder: Path) -> list[str]:
    """The words of ``nudge simulate`` for one study of the batch in ``folder``, from the inputs it
    keeps (:func:`~nudgecli.runs.batch_folder.kept_inputs`): its experiment copy, its first
    participant count and its people file's copy (``--people``: the batch's people, not the
    population's), as the batch's resume command names them."""
    from nudgecli.runs.batch_folder import EXPERIMENT_COPY, kept_inputs, read_manifest, recorded_people
    from nudgecli.sim.people_file import resume_people

    manifest, _ = read_manifest(folder / BATCH_MANIFEST)
    kept = kept_inputs(folder, manifest) if manifest is not None else {}
    # a batch of an older nudge records no inputs: its experiment copy, where there, is still its own
    experiment = kept.get("experiment") or (folder / EXPERIMENT_COPY if (folder / EXPERIMENT_COPY).is_file()
                                            else "EXPERIMENT")
    words = ["nudge", "simulate", str(experiment), "--out", "RUN"]
    points = manifest["batch"].get("points") if manifest is not None else None
    first = points[0] if isinstance(points, list) and points and isinstance(points[0], Mapping) else {}
    counts = first.get("participants")
    if isinstance(counts, list) and counts:
        words += ["--participants", str(counts[0])]
    described, people = recorded_people(folder)
    if described and isinstance(people, dict):
        named = resume_people(folder, people, str(people.get("file")))
        words += ["--people", named] if named else []
    return words


def habit_rate_cells(cells: pd.DataFrame, rate_hz: float) -> pd.DataFrame:
    """A cell table at ``rate_hz`` read in HABITS.md's 10 Hz cells, as a real log is: each trial
    read at ``0, 0.1, ...`` s by zero-order hold up to its end. A 10 Hz cell has the kind (and
    the turn) of the cell it starts in, moves when any cell within it of that turn moved (the
    autonomy's motion is never the person's cell's), ends at a waypoint when its last cell does,
    and holds a switch that fired at or after its start and before the next (a cell at
    :data:`HABIT_RATE_HZ` is returned as it is)."""
    if abs(rate_hz - HABIT_RATE_HZ) <= TIME_SLACK or cells.empty:
        return cells
    new_trial = np.ones(len(cells), dtype=bool)
    new_trial[1:] = (cells["participant"].to_numpy()[1:] != cells["participant"].to_numpy()[:-1]) | \
        (cells["trial"].to_numpy()[1:] != cells["trial"].to_numpy()[:-1])
    firsts = np.flatnonzero(new_trial)
    sizes = np.diff(np.append(firsts, len(cells)))
    counts = np.floor(sizes / rate_hz * HABIT_RATE_HZ + TIME_SLACK).astype(int)  # reads - 1
    trial_of = np.repeat(np.arange(len(firsts)), counts)
    j = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)  # each cell's index
    scale = rate_hz / HABIT_RATE_HZ
    lo = firsts[trial_of] + np.floor(j * scale + TIME_SLACK).astype(int)
    hi = firsts[trial_of] + np.minimum(np.floor((j + 1) * scale + TIME_SLACK).astype(int), sizes[trial_of])
    # a cell's motion is counted from the small cells of its own turn only: the person's last cell
    # before an autonomy turn would otherwise take the autonomy's first step of motion as theirs
    moving = cells["moving"].to_numpy(dtype=bool)
    turn = cells["person_turn"].to_numpy(dtype=bool) if "person_turn" in cells.columns else \
        np.ones(len(cells), dtype=bool)
    person = np.concatenate(([0], np.cumsum(moving & turn)))
    autonomy = np.concatenate(([0], np.cumsum(moving & ~turn)))
    moved = np.where(turn[lo], person[hi] > person[lo], autonomy[hi] > autonomy[lo])
    started = hi > firsts[trial_of]  # a cell of the trial has ended by the 10 Hz cell's end
    ended = np.where(started, hi - 1, lo)  # the last one that has (at 20 Hz, the second within)
    out = pd.DataFrame({
        "participant": cells["participant"].to_numpy()[lo], "trial": cells["trial"].to_numpy()[lo],
        "kind": cells["kind"].to_numpy()[lo], "moving": moved,
        "switch": False, "at_waypoint": cells["at_waypoint"].to_numpy()[ended] & started,
        "waypoints_known": cells["waypoints_known"].to_numpy()[lo]})
    switches = np.flatnonzero(cells["switch"].to_numpy(dtype=bool))
    trial = np.searchsorted(firsts, switches, side="right") - 1
    fired = np.ceil((switches - firsts[trial]) / scale - TIME_SLACK).astype(int)
    inside = fired < counts[trial]
    at = (np.cumsum(counts) - counts)[trial[inside]] + fired[inside]
    out.loc[at, "switch"] = True
    # the mode at the cell's start and after its end, a switch cell's those of its switch
    for column, held in (("switch_from", lo), ("switch_to", np.where(hi > lo, hi - 1, lo))):
        if column in cells.columns:
            values = cells[column].to_numpy()[held]
            values[at] = cells[column].to_numpy()[switches[inside]]
            out[column] = values
    if "person_turn" in cells.columns:
        out["person_turn"] = cells["person_turn"].to_numpy(dtype=bool)[lo]
    return out


def _trial_cells(run: RunFolder, steps: pd.DataFrame, trials: pd.DataFrame,
                 waypoints: Mapping[int, np.ndarray] | None) -> pd.DataFrame:
    """The cells of ``steps`` (of the ``trials``: every one of them has steps), the CIAA
    ``waypoints`` by layout (``None``: the grid world)."""
    steps = steps.sort_values(["participant", "trial"], kind="stable").reset_index(drop=True)
    key = ["participant", "trial"]
    sizes = steps.groupby(key, sort=False).size()
    empty = trials.set_index(key).index.difference(sizes.index)
    if len(empty):
        participant, trial = empty[0]
        raise DataError(f"{run.path / 'steps'}: trial {trial} of participant {participant} has no steps; "
                        f"re-simulate the run (`{run.resume_command()}` after removing its parts)")
    final = steps[key].merge(trials, on=key, how="left")
    n = len(steps)
    last = np.ones(n, dtype=bool)
    last[:-1] = (steps["participant"].to_numpy()[1:] != steps["participant"].to_numpy()[:-1]) | \
        (steps["trial"].to_numpy()[1:] != steps["trial"].to_numpy()[:-1])
    pose = steps[["x", "y", "theta"]].to_numpy(dtype=float)
    after = np.roll(pose, -1, axis=0)
    after[last] = final.loc[last, ["final_x", "final_y", "final_theta"]].to_numpy(dtype=float)
    moving = pose_changes(pose, after)
    # the grid world has no waypoints: its motion runs end in any cell (a hard blow's soft onset,
    # the autonomy's motion), none a stop where the plan changes, so stop -> switch is not measured
    at_waypoint = np.zeros(n, dtype=bool) if waypoints is None else \
        on_waypoints(after[:, :2], final["layout"].to_numpy(dtype=int), waypoints)
    # each distinct mode name looked up once (-1: missing or unknown)
    codes, names = pd.factorize(steps["mode"])
    mode = np.array([*(MODE_NAMES.index(name) if name in MODE_NAMES else -1 for name in names), -1])[codes]
    mode_after = np.roll(mode, -1)
    mode_after[last] = -1  # a switch in a trial's last step: where it went is not logged
    return pd.DataFrame({
        "participant": steps["participant"], "trial": steps["trial"],
        "kind": label_kinds(steps["phi_m"], str(run.path / "steps")),
        "moving": moving, "switch": has_event(steps["event"], MODE_SWITCH_HUMAN),
        "at_waypoint": at_waypoint, "waypoints_known": waypoints is not None, "switch_from": mode,
        "switch_to": mode_after, "person_turn": (steps["turn"] == HUMAN_TURN).to_numpy(dtype=bool),
    })
