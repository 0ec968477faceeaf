"""A folder of ``nudge study`` sessions (a real person's) is never replaced or taken over by a
simulation, and its "no trials yet" message continues the session, not a simulation."""

from __future__ import annotations

import hashlib
import json
import shlex
from pathlib import Path

import pytest

pytest.importorskip("aiohttp", reason="the live server needs aiohttp: pip install '.[study]'")

from cli_helpers import one_error_line
from click.testing import CliRunner
from live_helpers import DEFAULT_TABLES, TWO_TRIALS, play_session

from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.errors import RunFolderError
from nudgecli.live.app import build_session
from nudgecli.runs.study import run_study

OVERRIDES = TWO_TRIALS + DEFAULT_TABLES


def _started_session(out: Path, seed: int | None = None) -> None:
    """A session of P01 opened and stopped before its first trial (Ctrl-C at the start)."""
    session = build_session("paper", "P01", out, seed=seed, overrides=OVERRIDES)
    session.folder.release()


def _fingerprint(folder: Path) -> dict[str, str]:
    """Every file under ``folder`` (relative name -> SHA-256 of its bytes)."""
    return {str(path.relative_to(folder)): hashlib.sha256(path.read_bytes()).hexdigest()
            for path in sorted(folder.rglob("*")) if path.is_file()}


@pytest.mark.parametrize("options", [[], ["--force"], ["--resume"], ["--resume", "--force"]])
@pytest.mark.parametrize("command", ["simulate", "run"])
def test_simulate_and_run_refuse_a_folder_of_live_sessions_and_leave_it_as_it_was(tmp_path, command, options):
    out = tmp_path / "live"
    _started_session(out)
    before = _fingerprint(out)
    result = CliRunner().invoke(main, [command, "smoke", "--out", str(out), *options])
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    assert "holds live sessions of a person" in line and "simulate into another --out" in line, line
    assert _fingerprint(out) == before


def test_the_api_refuses_a_folder_of_live_sessions(tmp_path):
    out = tmp_path / "live"
    _started_session(out)
    with pytest.raises(RunFolderError, match="holds live sessions of a person"):
        run_study(load_experiment("smoke"), out, force=True)
    assert (out / "manifest.json").is_file() and (out / "config.toml").is_file()


def test_no_trials_yet_of_a_live_folder_names_the_study_command_that_continues_the_session(tmp_path):
    out = tmp_path / "live"
    _started_session(out, seed=5)  # a seed of its own: the command must carry it
    result = CliRunner().invoke(main, ["analyze", str(out)])
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    assert "nudge simulate" not in line, line
    command = line.split("`")[1]
    words = shlex.split(command)
    assert words[:2] == ["nudge", "study"] and words[-1] == "--resume", command
    assert words[words.index("--participant") + 1] == "P01" and words[words.index("--out") + 1] == str(out)
    assert words[words.index("--seed") + 1] == "5"
    # the command is the one that continues P01's session: the folder takes it (its --set values are
    # in the experiment it names, the folder's own config.toml)
    session = build_session(words[2], "P01", out, seed=int(words[words.index("--seed") + 1]), resume=True)
    session.folder.release()
    assert session.entry["participant_id"] == "P01"


def test_an_incomplete_live_folder_names_the_part_to_restore_from_a_backup(tmp_path):
    out = tmp_path / "live"
    for participant, stop in (("P01", None), ("P02", 1)):  # P01 finished, P02 under way after one trial
        session = build_session("paper", participant, out, seed=5, overrides=OVERRIDES)
        play_session(session, lambda s, n=stop: n is not None and len(s.entry["completed_trials"]) >= n)
        session.folder.release()
    manifest = json.loads((out / "manifest.json").read_text())
    index = next(key for key, entry in manifest["live"].items() if entry["participant_id"] == "P01")
    (out / "steps" / f"part-{int(index):04d}.parquet").unlink()
    result = CliRunner().invoke(main, ["analyze", str(out)])
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    # a session's --resume does not write a finished participant's part again: only a backup brings it back
    assert f"participant {index}: steps/part-{int(index):04d}.parquet (missing); restore " \
           f"steps/part-{int(index):04d}.parquet from a backup" in line, line
    assert "`" not in line, line
