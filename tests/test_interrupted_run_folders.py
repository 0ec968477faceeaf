"""A run folder and its figures after a command was killed or failed half-way: a ``--force`` killed
before its new manifest is resumed, temporaries a killed writer left are removed, a failed plot
changes no figure, and an interrupted run's refusal names the command that finishes it."""

from __future__ import annotations

import fcntl
import json
import shutil
import socket
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

from nudgecli.config import load_experiment
from nudgecli.errors import RunFolderError
from nudgecli.report.analysis import analyze
from nudgecli.run_folder_names import FIGURES_RECORD, LOCK, MANIFEST
from nudgecli.runs.study import run_study
from nudgecli.store import RunFolder

SIMULATE = ("simulate", "smoke", "--participants", "2", "--seed", "6")


@pytest.fixture(scope="module")
def analysed_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The smoke study, analysed and plotted (png, pdf). Do not modify: copy it."""
    run = run_study(load_experiment("smoke"), tmp_path_factory.mktemp("smoke") / "run", seed=6,
                    participants=2).path
    analyze(run, plan="paper")
    assert nudge("plot", run, "--formats", "png,pdf").exit_code == 0
    return run


@pytest.fixture()
def run(analysed_run: Path, tmp_path: Path) -> Path:
    return Path(shutil.copytree(analysed_run, tmp_path / "run"))


def _killed_force(folder: Path) -> None:
    """What ``simulate --force`` killed as it wrote its layouts leaves: the new config.toml (the
    same experiment), a layouts temporary and the old run's emptied part and calibration folders."""
    for entry in folder.iterdir():
        if entry.is_dir():
            shutil.rmtree(entry)
            if entry.name in ("trials", "steps", "participants", "calibration"):
                entry.mkdir()
        elif entry.name != "config.toml":
            entry.unlink()
    (folder / ".layouts.parquet.a1b2c3d4.tmp").write_bytes(b"half")


def test_a_force_killed_before_its_manifest_is_resumed_and_analyze_says_how(run: Path) -> None:
    _killed_force(run)
    advice = one_error_line(nudge("analyze", run).output)
    assert "--resume" in advice and "killed before it wrote its manifest" in advice, advice
    result = nudge(*SIMULATE, "--out", run, "--resume")
    assert result.exit_code == 0, result.output
    assert json.loads((run / MANIFEST).read_text())["status"] == "complete"
    assert not list(run.glob(".*.tmp"))


def test_a_folder_with_a_file_of_the_persons_own_in_a_part_folder_is_no_start(run: Path) -> None:
    _killed_force(run)
    (run / "trials" / "notes.txt").write_text("mine")
    result = nudge(*SIMULATE, "--out", run, "--resume")
    assert "exists and is not empty" in one_error_line(result.output)
    assert (run / "trials" / "notes.txt").read_text() == "mine"


@pytest.mark.parametrize("command", [(*SIMULATE, "--resume"), (*SIMULATE, "--force"), ("plot",)])
def test_figure_temporaries_of_a_killed_plot_are_removed(run: Path, command: tuple[str, ...]) -> None:
    left = run / "figures" / ".fig3.png.x7y8z9w0.tmp"
    left.write_bytes(b"half a figure")
    args = [*command, run] if command == ("plot",) else [*command, "--out", run]
    result = nudge(*args)
    assert result.exit_code == 0, result.output
    assert not left.exists()


def test_a_failed_plot_changes_no_figure_and_leaves_no_temporary(run: Path) -> None:
    folder = run / "figures"
    (folder / "trajectory.pdf").unlink()
    (folder / "trajectory.pdf").mkdir()
    before = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    result = nudge("plot", run, "--formats", "pdf,svg", "--trial", "1:2")
    line = one_error_line(result.output)
    assert result.exit_code == 1 and line.startswith("Error: cannot write ") and "Is a directory" in line
    assert {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()} == before  # the record too
    assert FIGURES_RECORD in before and not list(folder.glob(".*.tmp"))


def test_plot_of_an_incomplete_run_names_the_command_that_restores_it(run: Path) -> None:
    (run / "steps" / "part-0001.parquet").unlink()
    (run / "metrics.csv").unlink()
    line = one_error_line(nudge("plot", run).output)
    assert "is incomplete" in line and "--resume" in line, line


def test_a_run_killed_after_its_last_part_is_said_interrupted(run: Path) -> None:
    manifest = json.loads((run / MANIFEST).read_text())
    (run / MANIFEST).write_text(json.dumps({**manifest, "status": "running"}))
    killed = {"pid": 2**22 + 12345, "host": socket.gethostname(), "command": "nudge simulate"}
    (run / LOCK).write_text(json.dumps(killed))  # its lock file, of a process that is no more
    line = nudge("analyze", run).output.strip().splitlines()[-1]
    assert "interrupted" in line and "is running" not in line and "--resume" in line, line


def test_a_run_whose_lock_a_live_process_holds_is_said_running(run: Path) -> None:
    manifest = json.loads((run / MANIFEST).read_text())
    (run / MANIFEST).write_text(json.dumps({**manifest, "status": "running"}))
    with open(run / LOCK, "w") as handle:
        fcntl.flock(handle.fileno(), fcntl.LOCK_EX)  # as the writing command holds it
        # its --resume would be refused ("in use by"): the reader is told to wait
        with pytest.raises(RunFolderError, match=r"the run is running, in use by .*; wait for it to finish$"):
            RunFolder(run).check_complete()
