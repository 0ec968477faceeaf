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
from nudgecli.run_folder_record import RunRecord
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


# --- a lowered participant count ----------------------------------------------------------------------

def test_a_lowered_participant_count_names_the_checksummed_participants_left_out(tmp_path, seeded_run):
    run = copy_run(seeded_run, tmp_path / "run")
    manifest = json.loads((run / "manifest.json").read_text())
    manifest["participants"] = 1
    (run / "manifest.json").write_text(json.dumps(manifest))
    result = CliRunner().invoke(main, ["analyze", str(run), "--out", str(tmp_path / "analysis")])
    assert result.exit_code == 0, result.output
    notes = [line for line in result.output.splitlines() if line.startswith("Note:")]
    expected = (f"Note: {run}: the manifest records the SHA-256 of the parts of participant(s) 1, beyond its "
                "1 participant(s): this run wrote them, but they were left out (was 'participants' in "
                "manifest.json lowered?); set it back to 2 to read them")
    assert expected in notes, notes
    # its parts are this run's: not called strays that "do not belong to this run"
    assert not any("do not belong" in note for note in notes), notes


def test_the_beyond_count_note_names_each_checksummed_participant_and_strays_apart(tmp_path):
    (tmp_path / "trials").mkdir()
    for index in (1, 3, 4):
        (tmp_path / "trials" / f"part-{index:04d}.parquet").write_bytes(b"")
    manifest = {"participants": 1, "checksums": {"0": {}, "2": {}, "3": {}}}
    notes = RunRecord(tmp_path).integrity_notes(manifest)
    assert notes == [
        f"{tmp_path}: left out 2 part(s) not in the manifest: trials/part-0001.parquet, "
        "trials/part-0004.parquet; they do not belong to this run (remove them)",
        f"{tmp_path}: the manifest records the SHA-256 of the parts of participant(s) 2, 3, beyond its "
        "1 participant(s): this run wrote them, but they were left out (was 'participants' in "
        "manifest.json lowered?); set it back to 4 to read them",
    ]
    # within the count, nothing is beyond it (participant 1's parts are unverified, another note)
    sums = {"0": {}, "2": {}, "3": {}}
    within = RunRecord(tmp_path).integrity_notes({"participants": 4, "checksums": sums})
    assert within[0] == (f"{tmp_path}: left out 1 part(s) not in the manifest: trials/part-0004.parquet; "
                         "they do not belong to this run (remove them)")
    assert len(within) == 2 and "no SHA-256 of the parts of 1 participant(s)" in within[1]
# --- a lost config.toml -------------------------------------------------------------------------------

def test_a_lost_config_toml_is_restored_with_the_experiment_the_manifest_names(tmp_path, seeded_run):
    run = copy_run(seeded_run, tmp_path / "run")
    (run / "config.toml").unlink()
    _drop_participant(run, 1)
    result = CliRunner().invoke(main, ["analyze", str(run)])
    assert result.exit_code == 1
    command = result.output.split("`")[1]
    assert shlex.split(command)[:3] == ["nudge", "simulate", "smoke"], command
    warning = _run_printed(command)
    assert f"Warning: {run / 'config.toml'} was missing; written again from the experiment in the manifest" \
        in warning and "differed" not in warning
    assert (run / "config.toml").read_text() == (seeded_run / "config.toml").read_text()
    pd.testing.assert_frame_equal(_trials(run), _trials(seeded_run))


def test_an_edited_config_toml_still_says_it_differed(tmp_path, seeded_run):
    run = copy_run(seeded_run, tmp_path / "run")
    (run / "config.toml").write_text((run / "config.toml").read_text() + "\n# edited\n")
    _drop_participant(run, 1)
    warning = _run_printed(RunFolder(run).resume_command())
    assert "differed from the experiment in the manifest; rewritten from it" in warning
