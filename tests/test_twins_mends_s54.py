"""Mends of the twins' sources and fit: a real log's ``turn`` column, the reaction spread of one
cell, and the advice of the people-file and compare refusals; each on a small synthetic input."""

from __future__ import annotations

import csv
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from cli_helpers import write_csv_rows

from nudgecli.errors import DataError
from nudgecli.report.habit_cells import _trial_cells
from nudgecli.report.habit_logs import read_log_cells
from nudgecli.report.habits import measure_habits
from nudgecli.report.twin_sources import twins_of_sources
from nudgecli.sim.twin_fit import STOP_PARAMETERS

PILOT = Path(__file__).resolve().parents[1] / "experiments" / "pilots" / "pilot-1.csv"

# --- a real log's turn column --------------------------------------------------------------------

#: One grid-world trial at 10 Hz, a step per row: (turn, label, moves, switch). The person blows a
#: soft puff (moving), pauses 0.5 s, blows again, switches mode with a hard sip, waits; the autonomy
#: moves the robot for 1 s; the person, back, waits 0.3 s and blows once more.
_TRIAL = ([("human", "", False, False)] * 5 + [("human", "Soft Puff", True, False)] * 3
          + [("human", "", False, False)] * 5 + [("human", "Soft Puff", True, False)] * 2
          + [("human", "Hard Sip", False, False), ("human", "Hard Sip", False, True)]
          + [("human", "", False, False)] * 3 + [("autonomy", "", True, False)] * 10
          + [("human", "", False, False)] * 3 + [("human", "Soft Puff", True, False)] * 3)


def _poses() -> np.ndarray:
    """``(N + 1,)`` the robot's x before each step and after the last (x grows by 1 per moving step)."""
    return np.concatenate(([0.0], np.cumsum([1.0 if moves else 0.0 for _, _, moves, _ in _TRIAL])))


def _log_of_trial(tmp_path: Path, turns: list[str] | None = None) -> Path:
    """The trial as a real log: a row per step at its time, holding the pose from then on, and a last
    row at the trial's end; a ``turn`` column of ``turns`` (the steps' own when None)."""
    x = _poses()
    turns = turns if turns is not None else [turn for turn, _, _, _ in _TRIAL] + ["human"]
    labels = [label for _, label, _, _ in _TRIAL] + [""]
    switches = ["y" if switch else "0" for _, _, _, switch in _TRIAL] + ["0"]
    rows = [f"{i / 10:.1f},1,{labels[i]},{x[i]:g},0,0,{switches[i]},{turns[i]}\n" for i in range(len(x))]
    path = tmp_path / "assisted.csv"
    path.write_text("t,trial,label,x,y,theta,mode_switch,turn\n" + "".join(rows))
    return path


def _run_folder_cells() -> pd.DataFrame:
    """The trial's cells as a run folder's steps give them."""
    x = _poses()
    switched = next(i for i, (_, _, _, switch) in enumerate(_TRIAL) if switch) + 1
    steps = pd.DataFrame({"participant": 0, "trial": 0, "turn": [t for t, _, _, _ in _TRIAL], "x": x[:-1],
                          "y": 0.0, "theta": 0.0, "mode": ["x"] * switched + ["y"] * (len(_TRIAL) - switched),
                          "phi_m": [label for _, label, _, _ in _TRIAL],
                          "event": ["mode_switch_human" if s else "" for _, _, _, s in _TRIAL]})
    trials = pd.DataFrame({"participant": [0], "trial": [0], "layout": [0], "final_x": [x[-1]],
                           "final_y": [0.0], "final_theta": [0.0]})
    return _trial_cells(SimpleNamespace(path=Path("run")), steps, trials, None)  # type: ignore[arg-type]


def _habit_values(events: pd.DataFrame) -> dict[str, list[float]]:
    return {str(habit): sorted(group["value"].tolist()) for habit, group in events.groupby("habit")}


def test_a_logs_autonomy_turn_is_cut_out_as_a_run_folders_is(tmp_path: Path) -> None:
    cells = read_log_cells(_log_of_trial(tmp_path))
    assert cells["person_turn"].tolist() == [turn == "human" for turn, _, _, _ in _TRIAL]
    from_log = _habit_values(measure_habits(cells))
    assert from_log == _habit_values(measure_habits(_run_folder_cells()))
    # the 1.6 s across the autonomy's turn is no pause of the person's (it was counted)
    assert from_log["pause_between_blows"] == [0.5]
    assert from_log.get("reaction_switch_to_motion", []) == []


def test_a_log_without_the_turn_column_is_every_cell_the_persons(tmp_path: Path) -> None:
    path = _log_of_trial(tmp_path)
    frame = pd.read_csv(path, dtype=str, keep_default_na=False).drop(columns="turn")
    frame.to_csv(path, index=False)
    cells = read_log_cells(path)
    assert "person_turn" not in cells.columns
    assert _habit_values(measure_habits(cells))["pause_between_blows"] == [0.5, 1.6]


def test_an_unknown_turn_is_refused_naming_the_file_row_and_values(tmp_path: Path) -> None:
    turns = ["human"] * (len(_TRIAL) + 1)
    turns[3] = "robot"
    path = _log_of_trial(tmp_path, turns)
    with pytest.raises(DataError) as caught:
        read_log_cells(path)
    message = str(caught.value)
    assert "\n" not in message
    assert f"{path}, row 5" in message and "'robot'" in message and "human or autonomy" in message


def test_a_log_of_an_assisted_study_leaves_the_stop_parameters_to_the_population(tmp_path: Path) -> None:
    assisted = twins_of_sources([_log_of_trial(tmp_path)])[0]
    for name in STOP_PARAMETERS:
        assert name not in assisted.parameters
        assert assisted.notes[name].startswith("a log of an assisted study without its layout")
    (tmp_path / "human").mkdir()
    unassisted = twins_of_sources([_log_of_trial(tmp_path / "human", ["human"] * (len(_TRIAL) + 1))])[0]
    assert not any("without its layout" in note for note in unassisted.notes.values())


def test_a_log_of_an_assisted_study_with_its_layout_keeps_the_stop_parameters(tmp_path: Path) -> None:
    # a pilot log (its layout column puts it on the CIAA task) with one autonomy turn: before, any
    # autonomy turn made it a grid-world log, its stop parameters left to the population
    with PILOT.open(newline="") as file:
        rows = [{**row, "turn": "human"} for row in csv.DictReader(file) if int(row["trial"]) < 4]
    rows[5]["turn"] = "autonomy"  # a neutral row of the first trial
    twin = twins_of_sources([write_csv_rows(tmp_path / "assisted.csv", rows)])[0]
    for name in STOP_PARAMETERS:
        assert name in twin.parameters, twin.notes.get(name)


# --- a Parquet file given as a people file ---------------------------------------------------------


@pytest.mark.parametrize("in_run", [True, False])
def test_a_parquet_people_file_names_fit_people_of_its_run(tmp_path: Path, in_run: bool) -> None:
    from nudgecli.run_folder_names import MANIFEST
    from nudgecli.sim.people_file import read_people

    run = tmp_path / "run"
    (run / "participants").mkdir(parents=True)
    if in_run:
        (run / MANIFEST).write_text("{}")
    path = run / "participants" / "part-0000.parquet"
    path.write_bytes(b"PAR1\x15\x04\xe4PAR1")
    with pytest.raises(DataError) as caught:
        read_people(path)
    message = str(caught.value)
    # before: "...; give the CSV file", but a people file is never Parquet and the run has no CSV of it
    assert "give the CSV file" not in message and "not a people file" in message
    source = str(run) if in_run else "SOURCE..."
    assert f"`nudge fit-people {source} --out people.csv`" in message


# --- compare given a run folder as REAL ----------------------------------------------------------


def test_compare_of_a_run_folder_as_real_names_its_metrics_table(analysed_smoke_run: Path,
                                                                  tmp_path: Path) -> None:
    from nudgecli.report.compare import compare_sources
    from nudgecli.run_folder_names import MANIFEST

    with pytest.raises(DataError) as caught:
        compare_sources(analysed_smoke_run, analysed_smoke_run)
    # before: only "REAL must be a metrics table"; `nudge analyze RUN` (no --out) writes RUN/metrics.csv
    assert str(caught.value).endswith(f"(give {analysed_smoke_run / 'metrics.csv'})")
    unanalysed = tmp_path / "twins"
    unanalysed.mkdir()
    (unanalysed / MANIFEST).write_text("{}")
    with pytest.raises(DataError) as caught:
        compare_sources(analysed_smoke_run, unanalysed)
    assert str(caught.value).endswith(f"(`nudge analyze {unanalysed}` writes it, then give "
                                      f"{unanalysed / 'metrics.csv'})")
    with pytest.raises(DataError, match="one row per trial"):
        compare_sources(analysed_smoke_run, tmp_path)  # a folder of no run: a table is what it needs


# --- a reaction spread within one cell -----------------------------------------------------------


def test_switch_to_motion_quartiles_in_one_cell_leave_the_spread_to_the_population() -> None:
    from nudgecli.sim.twin_fit import HabitFigures, fit_twin_with_notes

    habits = {"reaction_stop_to_switch": HabitFigures(40, 1.2, 0.9, 1.5),
              "reaction_switch_to_motion": HabitFigures(40, 1.2, 1.2, 1.2)}
    parameters, notes = fit_twin_with_notes(habits)
    # before: ln(q75 / q25) = 0, a twin whose every reaction is its median, and no note
    assert "event_reaction_log_sd" not in parameters
    assert "not measurable" in notes["event_reaction_log_sd"]
    spread = {**habits, "reaction_switch_to_motion": HabitFigures(40, 1.2, 1.1, 1.3)}
    assert "event_reaction_log_sd" in fit_twin_with_notes(spread)[0]
