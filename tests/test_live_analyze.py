"""`nudge analyze` of a live folder whose study is still under way says how far it got."""

from __future__ import annotations

import pytest

pytest.importorskip("aiohttp", reason="the live server needs aiohttp: pip install '.[study]'")

from click.testing import CliRunner
from live_helpers import DEFAULT_TABLES, TWO_TRIALS, play_session

from nudgecli.cli import main
from nudgecli.live.app import build_session
from nudgecli.live.session import LiveSession
from nudgecli.store import RunFolder

OVERRIDES = TWO_TRIALS + DEFAULT_TABLES


def _play(session: LiveSession, trials: int | None) -> None:
    """Skip the practice, then run ``trials`` evaluation trials without input (all: ``None``),
    answering each questionnaire."""
    play_session(session, lambda s: trials is not None and len(s.entry["completed_trials"]) >= trials)


def test_analyze_of_an_unfinished_live_study_notes_how_far_it_got(tmp_path):
    out = tmp_path / "run"
    first = build_session("paper", "P01", out, overrides=OVERRIDES)
    _play(first, None)
    first.folder.release()
    second = build_session("paper", "P02", out, overrides=OVERRIDES)
    _play(second, 1)
    second.folder.release()
    assert first.phase == "done" and second.phase != "done"
    result = CliRunner().invoke(main, ["analyze", str(out)])
    assert result.exit_code == 0, result.output
    notes = [line for line in result.output.splitlines() if line.startswith("Note:")]
    assert any(
        "a live study still under way: 1 of 2 participant(s) finished, 3 trial(s) recorded "
        "(unfinished: P02 with 1 trial(s)); the statistics are of the trials recorded so far" in note
        for note in notes
    ), result.output
    # once the second participant finishes, the note goes
    resumed = build_session("paper", "P02", out, overrides=OVERRIDES, resume=True)
    _play(resumed, None)
    resumed.folder.release()
    run = RunFolder(out)
    assert run.read_manifest()["status"] == "complete"
    assert not any("under way" in note for note in run.integrity_notes(run.read_manifest()))
