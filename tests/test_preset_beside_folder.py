"""A preset's name is the preset even where the working folder holds a folder of that name (a run
written with ``--out paper``); a folder named where a TOML file is expected is one Error line."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from nudgecli.cli import main


def test_a_preset_named_like_a_folder_beside_it_is_the_preset(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    result = runner.invoke(main, ["simulate", "smoke", "--participants", "2", "--out", "paper"])
    assert result.exit_code == 0, result.output
    # the default plan of this run is the preset paper; the folder paper is the run
    result = runner.invoke(main, ["analyze", "paper"])
    assert result.exit_code == 0, result.output
    result = runner.invoke(main, ["simulate", "paper", "--participants", "2", "--out", "other"])
    assert result.exit_code == 0, result.output


@pytest.mark.parametrize("command", [["simulate", "mine"], ["analyze", "table.csv", "--plan", "mine"]])
def test_a_folder_where_a_toml_file_is_expected_is_one_error_line(tmp_path: Path, monkeypatch,
                                                                  command: list[str]) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "mine").mkdir()
    (tmp_path / "table.csv").write_text("participant,condition,trial,success\n0,a,0,1\n0,b,1,0\n")
    result = CliRunner().invoke(main, command)
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    expected = "Error: mine: a folder, not a .toml file; give a preset name or a path to a .toml file"
    assert result.exit_code != 0 and errors == [expected], result.output
