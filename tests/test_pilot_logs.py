"""experiments/pilot_logs.py: pilot logs of a simulated CIAA run, and the run folders it refuses (a
missing folder, a grid-world run whose layout indices are not the CIAA task's trials) with one
`Error:` line, exit 1 and nothing written."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pandas as pd
import pytest

from nudgecli.config import load_experiment
from nudgecli.runs.study import run_study

SCRIPT = Path(__file__).resolve().parents[1] / "experiments" / "pilot_logs.py"


def pilot_logs_main(argv: list[str]) -> int:
    spec = importlib.util.spec_from_file_location("pilot_logs", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return int(module.main(argv))


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
