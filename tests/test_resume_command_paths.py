"""The resume command the toolkit prints works for a folder whose name starts with ``-``
(``--out=-dash``): such a path is written ``./-dash``, else the command would read it as options."""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest
from cli_helpers import nudge, nudge_interrupted

from nudgecli.store import resume_command


def test_a_folder_starting_with_a_dash_is_written_as_a_path() -> None:
    words = shlex.split(resume_command(["replicate", "-dash/experiment.toml", "--plan", "-dash/plan.toml"],
                                       "-dash", ["--people", "-dash/people/p.csv"]))
    assert words == ["nudge", "replicate", "./-dash/experiment.toml", "--plan", "./-dash/plan.toml", "--out",
                     "./-dash", "--people", "./-dash/people/p.csv", "--resume"]
    plain = shlex.split(resume_command(["simulate", "smoke"], "runs/x"))
    assert plain == ["nudge", "simulate", "smoke", "--out", "runs/x", "--resume"]


def test_the_printed_resume_command_of_a_dash_folder_works(tmp_path: Path,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    result = nudge_interrupted(monkeypatch, "replicate", "smoke", "-R", "2", "--participants", "2",
                               "--out=-dash")
    assert result.exit_code == 130, result.output
    words = shlex.split(result.output.split("resume with: ")[1].strip().splitlines()[0])
    resumed = nudge(*words[1:])
    assert resumed.exit_code == 0, resumed.output
