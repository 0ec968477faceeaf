"""A live (``nudge study``) folder holds a person's trials, which no command can make again: its
damaged files are named with advice that keeps them, and nothing simulates over them."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

pytest.importorskip("aiohttp", reason="the live server needs aiohttp: pip install '.[study]'")

from click.testing import CliRunner
from live_helpers import DEFAULT_TABLES, TWO_TRIALS, play_session

from nudgecli.cli import main
from nudgecli.live.app import build_session

OVERRIDES = TWO_TRIALS + DEFAULT_TABLES


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    """A live folder: P01 finished (two trials, their questionnaires)."""
    out = tmp_path_factory.mktemp("live") / "study"
    session = build_session("paper", "P01", out, overrides=OVERRIDES)
    play_session(session, lambda s: False)
    session.folder.release()
    return out


@pytest.fixture()
def live(recorded, tmp_path) -> Path:
    copy = tmp_path / "study"
    shutil.copytree(recorded, copy)
    return copy


def _nudge(*args: str):
    return CliRunner().invoke(main, list(args))


def _one_error(result) -> str:
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert result.exit_code == 1 and len(errors) == 1, result.output
    return errors[0]


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("damage", ["unreadable", "deleted", "deleted, no questionnaires"])
def test_a_live_folder_without_its_manifest_is_never_advised_or_allowed_a_simulation(live, damage):
    manifest = live / "manifest.json"
    if damage == "unreadable":
        manifest.write_text('{"broken\n', encoding="utf-8")
    else:
        manifest.unlink()
    if "questionnaires" in damage:
        (live / "questionnaires.csv").unlink()
    before = _files(live)
    line = _one_error(_nudge("analyze", str(live)))
    assert "put manifest.json back from a copy" in line and "simulate again" not in line, line
    assert "--force" not in line and "nudge simulate" not in line, line
    for command in ("simulate", "run"):
        for flag in ("--force", "--resume"):
            line = _one_error(_nudge(command, str(live / "config.toml"), "--out", str(live), flag))
            assert "live study" in line, line
            assert _files(live) == before, (command, flag)
