"""Ctrl-C of a run or batch made with ``--people`` prints a resume command that names the copy of
the people file the folder keeps (``people/<name>``, by the folder's path as given), not the file
as typed: run from another directory it resumes, and the tables equal an uninterrupted run's byte
for byte. Interrupted before the copy was written, the hint names the file as typed, as before."""

from __future__ import annotations

import json
import shlex
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from people_helpers import people_typed_here

from nudgecli import store
from nudgecli.cli import main
from nudgecli.runs import batch_folder
from nudgecli.runs import study as study_module

NAME = "twins.csv"
SIMULATE = ("simulate", "smoke", "--participants", "2", "--seed", "4", "--people", NAME)
REPLICATE = ("replicate", "smoke", "-R", "2", "--participants", "2", "--seed", "5", "--people", NAME)
BATCH_TABLES = ("replications.csv", "conditions.csv", "summary.csv")


def nudge(*args: str) -> Any:
    return CliRunner().invoke(main, [*args])


@pytest.fixture
def typed_here(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    return people_typed_here(tmp_path, monkeypatch, NAME)


def interrupt_after_first(monkeypatch: pytest.MonkeyPatch, owner: type, method: str) -> Callable[[], None]:
    """Make ``owner.method`` raise ``KeyboardInterrupt`` (Ctrl-C) on its second call; returns what
    puts it back."""
    original = getattr(owner, method)
    calls: list[int] = []

    def interrupted(self: Any, *args: Any, **kwargs: Any) -> Any:
        if calls:
            raise KeyboardInterrupt
        calls.append(1)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(owner, method, interrupted)
    return lambda: monkeypatch.setattr(owner, method, original)


def hinted(result: Any) -> list[str]:
    """The words of the resume command a Ctrl-C'd command printed."""
    assert result.exit_code == 130, result.output
    return shlex.split(result.output.split("resume with: ")[1].strip().splitlines()[0])


def people_named(words: list[str]) -> str:
    return words[words.index("--people") + 1]


def run_tables(run: Path) -> dict[str, bytes]:
    """The run's tables (every Parquet file: parts, participants, layouts) by relative path."""
    return {p.relative_to(run).as_posix(): p.read_bytes() for p in sorted(run.rglob("*.parquet"))}


def resume_from_elsewhere(command: tuple[str, ...], out: Path, owner: type, method: str, elsewhere: Path,
                          monkeypatch: pytest.MonkeyPatch) -> None:
    """Run ``command`` into ``out``, Ctrl-C'd at ``owner.method``'s second call; its hint must name the
    folder's copy, and the hinted command must finish the work from ``elsewhere`` (where NAME is
    not: only the copy's path can work)."""
    restore = interrupt_after_first(monkeypatch, owner, method)
    words = hinted(nudge(*command, "--out", str(out)))
    assert people_named(words) == str(out / "people" / NAME)
    restore()
    monkeypatch.chdir(elsewhere)
    resumed = nudge(*words[1:])
    assert resumed.exit_code == 0, resumed.output


def test_ctrl_c_of_a_run_names_the_copy_and_resumes_from_another_folder(
        typed_here: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    whole, run = tmp_path / "whole", tmp_path / "run"
    assert nudge(*SIMULATE, "--out", str(whole)).exit_code == 0
    elsewhere = tmp_path / "b"
    elsewhere.mkdir()
    resume_from_elsewhere(SIMULATE, run, store.RunFolder, "write_participant_parts", elsewhere, monkeypatch)
    assert json.loads((run / "manifest.json").read_text())["status"] == "complete"
    tables = run_tables(run)
    # per participant its trials, steps and participant parts; the participants and layouts tables
    assert len(tables) == 8 and tables == run_tables(whole)


def test_ctrl_c_of_a_batch_names_the_copy_and_resumes_from_another_folder(
        typed_here: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    whole, batch = tmp_path / "whole", tmp_path / "batch"
    assert nudge(*REPLICATE, "--out", str(whole)).exit_code == 0
    resume_from_elsewhere(REPLICATE, batch, batch_folder.PartRecord, "write", tmp_path, monkeypatch)
    for table in BATCH_TABLES:
        assert (batch / table).read_bytes() == (whole / table).read_bytes(), table


def test_interrupted_before_the_copy_is_written_the_hint_names_the_file_as_typed(
        typed_here: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # a run whose copy is gone (made before folders kept one), resumed and interrupted as the copy
    # is about to be written: the folder holds a run but no copy, so the typed path is named
    restore = interrupt_after_first(monkeypatch, store.RunFolder, "write_participant_parts")
    hinted(nudge(*SIMULATE, "--out", "run"))
    restore()
    (typed_here / "run" / "people" / NAME).unlink()

    def not_yet(*args: Any, **kwargs: Any) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(study_module, "keep_copy", not_yet)
    words = hinted(nudge(*SIMULATE, "--out", "run", "--resume"))
    assert people_named(words) == NAME
    monkeypatch.setattr(batch_folder, "keep_copy", not_yet)  # a new batch: nothing computed yet
    refused = nudge(*REPLICATE, "--out", "batch")
    assert refused.exit_code == 130 and "nothing was computed yet; run the command again" in refused.output


def test_ctrl_c_of_nudge_run_names_the_copy_in_both_commands_it_offers(
        typed_here: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    interrupt_after_first(monkeypatch, store.RunFolder, "write_participant_parts")
    result = nudge("run", *SIMULATE[1:], "--out", "run")
    assert result.exit_code == 130, result.output
    simulate, also = result.output.split("resume with: ")[1].strip().splitlines()[0].split(
        " (or, to analyse and plot too: ")
    words = [shlex.split(simulate), shlex.split(also.removesuffix(")"))]
    assert [w[1] for w in words] == ["simulate", "run"]
    assert [people_named(w) for w in words] == [str(Path("run") / "people" / NAME)] * 2
