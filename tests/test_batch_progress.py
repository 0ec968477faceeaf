"""The batch commands' progress line (tasks, rate, ETA on stderr): for a person reading the table,
not where a script reads json or csv from stdout (there only on a terminal)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from nudgecli.cli import main

COMMANDS = {
    "power": ["power", "smoke", "--participants", "2,3", "-R", "1"],
    "sweep": ["sweep", "sweep.toml"],
}
#: Two points of the smoke study, one replication each.
SWEEP = 'experiment = "smoke"\nreplications = 1\nseed = 3\n[design]\nmethod = "grid"\n[parameters]\n' \
        '"inference.kappa" = [0.6, 0.7]\n'


@pytest.mark.parametrize("command", ["power", "sweep"])
def test_the_progress_line_with_its_eta_is_on_stderr_beside_the_table(
        command: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sweep.toml").write_text(SWEEP)
    result = CliRunner().invoke(main, [*COMMANDS[command], "--workers", "2", "--out", str(tmp_path / "t")])
    assert result.exit_code == 0, result.output
    lines = [line for line in result.stderr.splitlines() if line.startswith(f"{command}: ")]
    # at 100% the ETA is the tables and figures still to come (it read "ETA 0 s" for 1-3 s more)
    assert lines and "ETA" in lines[0] and "(100%)" in lines[-1] and not lines[-1].endswith("ETA 0 s")
    assert "ETA" not in result.stdout


def test_no_progress_line_where_a_script_reads_json(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # (click's isolated_filesystem is deprecated, gone in Click 9)
    result = CliRunner().invoke(main, [*COMMANDS["power"], "--out", "batch", "--format", "json"])
    assert result.exit_code == 0, result.output
    assert "ETA" not in result.stderr and "tasks (" not in result.stderr
    assert json.loads(result.stdout)  # stdout is the document alone
    assert "batch: " in result.stderr  # the size estimate and the folder are still said
