"""Ctrl-C of ``nudge simulate`` after its folder's start is written but before any participant:
the advice printed is a command that continues the run (a plain rerun is refused: the folder is
not empty), and it gives the tables of an uninterrupted run."""

from __future__ import annotations

import shlex
from pathlib import Path

import pandas as pd
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.store import RunFolder

ARGS = ["simulate", "smoke", "--participants", "2", "--seed", "3"]


def test_the_advice_after_an_interrupted_start_continues_the_run(tmp_path: Path, monkeypatch) -> None:
    out = tmp_path / "run"

    def interrupted(self: RunFolder, layouts: pd.DataFrame) -> str:
        raise KeyboardInterrupt  # Ctrl-C after config.toml, before the layouts and the manifest

    with monkeypatch.context() as patch:
        patch.setattr(RunFolder, "write_layouts", interrupted)
        result = CliRunner().invoke(main, [*ARGS, "--out", str(out)])
    assert result.exit_code == 130, result.output
    (line,) = [x for x in result.output.splitlines() if x.startswith("Interrupted")]
    assert "holds the run's start: continue with: " in line, line
    command = shlex.split(line.split("continue with: ", 1)[1])
    assert command[0] == "nudge" and "--resume" in command
    assert CliRunner().invoke(main, [*ARGS, "--out", str(out)]).exit_code == 1  # a plain rerun: refused
    result = CliRunner().invoke(main, command[1:])
    assert result.exit_code == 0, result.output
    whole = tmp_path / "whole"
    assert CliRunner().invoke(main, [*ARGS, "--out", str(whole)]).exit_code == 0
    for name in ("trials", "steps"):
        pd.testing.assert_frame_equal(RunFolder(out).read_table(name), RunFolder(whole).read_table(name))


def test_an_interrupt_before_the_folder_is_made_says_run_it_again(tmp_path: Path, monkeypatch) -> None:
    out = tmp_path / "run"

    def interrupted(*args: object, **kwargs: object) -> str:
        raise KeyboardInterrupt

    with monkeypatch.context() as patch:
        patch.setattr(RunFolder, "prepare", interrupted)
        result = CliRunner().invoke(main, [*ARGS, "--out", str(out)])
    assert result.exit_code == 130, result.output
    assert "nothing was simulated yet; run the command again" in result.output
