"""A run folder restores and records itself faithfully: config.toml holds the seed the run used
(so simulating it again gives the same tables), a lost config.toml is restored from the experiment
the manifest names, and a lowered participant count in the manifest is named, not read silently."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import pandas as pd
import pytest
from cli_helpers import copy_run
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.config import experiment_from_toml, load_experiment
from nudgecli.runs.study import run_study
from nudgecli.store import RunFolder

PARTS = ("trials", "steps", "participants")


@pytest.fixture(scope="module")
def seeded_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished smoke run of 2 participants with a seed of its own (--seed 99; smoke's is 7)."""
    out = tmp_path_factory.mktemp("restore") / "run"
    result = CliRunner().invoke(main, ["simulate", "smoke", "--seed", "99", "--out", str(out)])
    assert result.exit_code == 0, result.output
    return out


def _trials(folder: Path) -> pd.DataFrame:
    return RunFolder(folder).read_trials()


def _drop_participant(run: Path, participant: int) -> None:
    """Participant ``participant``'s parts gone, as if the run was killed before them."""
    for kind in PARTS:
        (run / kind / f"part-{participant:04d}.parquet").unlink()
    manifest = json.loads((run / "manifest.json").read_text())
    kept = [index for index in manifest["completed"] if index != participant]
    manifest.update({"status": "interrupted", "completed": kept})
    manifest["checksums"].pop(str(participant))
    (run / "manifest.json").write_text(json.dumps(manifest))


def _run_printed(command: str) -> str:
    """Run a printed ``nudge ...`` command line; its stderr (it must succeed)."""
    words = shlex.split(command)
    assert words[0] == "nudge", command
    result = CliRunner().invoke(main, words[1:])
    assert result.exit_code == 0, result.output
    return result.stderr


# --- config.toml records the seed the run used -------------------------------------------------------

def test_config_toml_records_the_seed_given_and_simulating_it_gives_the_same_tables(tmp_path, seeded_run):
    recorded = experiment_from_toml((seeded_run / "config.toml").read_text(), "config.toml")
    assert recorded.experiment.seed == 99
    assert json.loads((seeded_run / "manifest.json").read_text())["seed"] == 99
    again = tmp_path / "again"
    result = CliRunner().invoke(main, ["simulate", str(seeded_run / "config.toml"), "--out", str(again)])
    assert result.exit_code == 0, result.output
    pd.testing.assert_frame_equal(_trials(again), _trials(seeded_run))
    # the seed given beats the experiment's, in the run and in its record alike
    api = tmp_path / "api"
    run_study(load_experiment("smoke", ("experiment.seed=9",)), api, seed=4, participants=1)
    assert experiment_from_toml((api / "config.toml").read_text(), "config.toml").experiment.seed == 4
    assert json.loads((api / "manifest.json").read_text())["config"]["experiment"]["seed"] == 4
    direct = tmp_path / "direct"
    run_study(load_experiment("smoke"), direct, seed=4, participants=1)
    pd.testing.assert_frame_equal(_trials(api), _trials(direct))


def test_a_run_made_before_config_toml_recorded_its_seed_resumes_as_printed(tmp_path, seeded_run):
    run = copy_run(seeded_run, tmp_path / "run")
    # as such a run was written: the experiment's own seed in config.toml and the manifest's experiment
    smoke_toml = load_experiment("smoke").to_toml()
    (run / "config.toml").write_text(smoke_toml)
    manifest = json.loads((run / "manifest.json").read_text())
    manifest["config"]["experiment"]["seed"] = 7
    (run / "manifest.json").write_text(json.dumps(manifest))
    _drop_participant(run, 1)
    command = RunFolder(run).resume_command()
    assert "--seed 99" in command and str(run / "config.toml") in command
    warning = _run_printed(command)
    assert "held the experiment's own seed (7), not the one the run used (99); rewritten with it" in warning
    pd.testing.assert_frame_equal(_trials(run), _trials(seeded_run))
    assert experiment_from_toml((run / "config.toml").read_text(), "config.toml").experiment.seed == 99


def test_a_resume_with_another_seed_is_still_refused(tmp_path, seeded_run):
    run = copy_run(seeded_run, tmp_path / "run")
    _drop_participant(run, 1)
    result = CliRunner().invoke(main, ["simulate", "smoke", "--seed", "98", "--participants", "2",
                                       "--out", str(run), "--resume"])
    assert result.exit_code == 1
    assert "seed: 99 in the manifest, 98 now" in result.output and "experiment.seed" not in result.output
