"""The resume command a Ctrl-C'd run of a researcher's own policy prints is the one docs/policies.md
documents, ``nudge simulate R/config.toml --out R ... --resume``: the run's resolved experiment
(its ``--set`` values in it) importing the run's own policy copies, so it works from any folder
(was: the experiment file as typed, a relative path that failed from another folder)."""

from __future__ import annotations

import shlex
import shutil
from pathlib import Path

import pandas as pd
import pytest
from cli_helpers import nudge
from policy_helpers import policy_experiment

from nudgecli import store

ROOT = Path(__file__).resolve().parents[1]
OPTIONS = ("--participants", "3", "--set", "policies.threshold.params.weight=0.4")


def _experiment(root: Path) -> Path:
    root.mkdir(parents=True)
    shutil.copytree(ROOT / "experiments" / "policies", root / "policies",
                    ignore=shutil.ignore_patterns("__pycache__"))
    return policy_experiment(root, {"threshold": "policies.threshold:ThresholdAssist"},
                             params={"threshold": "{ threshold = 0.6, weight = 0.5 }"}, participants=3)


def test_the_printed_resume_command_of_a_policy_run_works_from_another_folder(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    experiment = _experiment(tmp_path / "here" / "exp")
    monkeypatch.chdir(tmp_path / "here")
    whole = nudge("simulate", experiment.relative_to(tmp_path / "here"), *OPTIONS, "--out", "whole")
    assert whole.exit_code == 0, whole.output
    original, calls = store.RunFolder.write_participant_parts, []

    def interrupted_after_one(self: store.RunFolder, *args: object, **kwargs: object) -> object:
        if calls:
            raise KeyboardInterrupt
        calls.append(1)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(store.RunFolder, "write_participant_parts", interrupted_after_one)
    stopped = nudge("simulate", experiment.relative_to(tmp_path / "here"), *OPTIONS, "--out", "run")
    assert stopped.exit_code == 130, stopped.output
    monkeypatch.setattr(store.RunFolder, "write_participant_parts", original)
    words = shlex.split(stopped.output.split("resume with: ")[1].strip().splitlines()[0])
    assert words[:3] == ["nudge", "simulate", "run/config.toml"] and "--set" not in words, words
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")  # neither the experiment's folder nor the run's parent
    words = [str(tmp_path / "here" / w) if w.startswith("run") else w for w in words]  # the folder from here
    resumed = nudge(*words[1:])
    assert resumed.exit_code == 0, resumed.output
    for table in ("trials", "steps", "participants.parquet"):
        pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "here" / "run" / table),
                                      pd.read_parquet(tmp_path / "here" / "whole" / table))
