"""experiments/pilot_logs.py: pilot logs of a simulated CIAA run, and the run folders it refuses (a
missing folder, a grid-world run whose layout indices are not the CIAA task's trials) with one
`Error:` line, exit 1 and nothing written."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import pandas as pd
import pytest

from nudgecli.config import load_experiment
from nudgecli.report.habit_logs import read_log_cells
from nudgecli.runs.study import run_study

SCRIPT = Path(__file__).resolve().parents[1] / "experiments" / "pilot_logs.py"


def pilot_logs_module() -> ModuleType:
    spec = importlib.util.spec_from_file_location("pilot_logs", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def pilot_logs_main(argv: list[str]) -> int:
    return int(pilot_logs_module().main(argv))


def refused(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    assert pilot_logs_main(argv) == 1
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert captured.out == "" and len(lines) == 1 and lines[0].startswith("Error: "), captured.err
    return lines[0]


def test_a_missing_run_folder_is_one_error_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    line = refused(capsys, [str(tmp_path / "nothere"), "--out", str(tmp_path / "pilots")])
    assert "nothere" in line and "not a run folder" in line
    assert not (tmp_path / "pilots").exists()


def test_a_grid_world_run_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = run_study(load_experiment("smoke"), tmp_path / "smoke", seed=11, participants=1).path
    line = refused(capsys, [str(run), "--out", str(tmp_path / "pilots")])
    assert str(run) in line and "grid" in line and "ciaa-teleop" in line
    assert not (tmp_path / "pilots").exists()


def test_a_ciaa_run_gives_one_log_a_participant(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = run_study(load_experiment("ciaa-teleop"), tmp_path / "ciaa", seed=3, participants=1).path
    assert pilot_logs_main([str(run), "--out", str(tmp_path / "pilots")]) == 0
    log = pd.read_csv(tmp_path / "pilots" / "pilot-1.csv")
    trials = pd.read_parquet(Path(run) / "trials")
    assert set(log["layout"]) == set(trials["layout"]) and set(log["participant"]) == {"pilot-1"}


def test_a_switch_in_a_trials_last_step_is_written(tmp_path: Path) -> None:
    """A switch in a trial's last step is a row of the log, of unknown direction (``1``), which the
    log's reader counts as the run folder's cells do: every switch of the steps is a switch cell."""
    steps = pd.DataFrame({
        "trial": [0, 0, 0, 1, 1, 1], "step": [0, 1, 2, 0, 1, 2], "t": [0.0, 0.1, 0.2] * 2,
        "phi_m": ["", "Hard Puff", "Hard Sip", "", "", "Hard Sip"],
        "x": [0.0] * 6, "y": [0.0] * 6, "theta": [0.0] * 6, "mode": ["x", "x", "y", "y", "y", "y"],
        "event": ["trial_start", "mode_switch_human", "mode_switch_human", "trial_start", "",
                  "mode_switch_human"]})
    trials = pd.DataFrame({"trial": [0, 1], "final_x": [0.0, 0.0], "final_y": [0.0, 0.0],
                           "final_theta": [0.0, 0.0], "layout": [3, 4]})
    log = pilot_logs_module().participant_log(steps, trials, "pilot-1", 0.1)
    switches = log[log["mode_switch"] != "0"]
    assert switches[["trial", "t", "mode_switch"]].values.tolist() == [[0, 0.1, "y"], [0, 0.2, "1"],
                                                                        [1, 0.2, "1"]]
    path = tmp_path / "pilot-1.csv"
    log.drop(columns="layout").to_csv(path, index=False)
    cells = read_log_cells(path)
    assert cells["switch"].tolist() == [False, True, True, False, False, True]
    assert cells["switch_to"].tolist() == [-1, 1, -1, -1, -1, -1]
