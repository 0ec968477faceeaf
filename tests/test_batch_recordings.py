"""A batch records a digest of the files of each ``population.physiology_logs`` recording in its
description: a resume that would take another recording (a relative path read from another folder)
is refused naming it, and the resume command a Ctrl-C'd batch prints says where to run it from
(docs/batches.md)."""

from __future__ import annotations

import shlex
import shutil
from pathlib import Path

import pytest
from cli_helpers import files_of, nudge, nudge_interrupted, one_error_line

from nudgecli.runs.batch_folder import BATCH_MANIFEST

RECORDING = "population.physiology_logs=['pilot/calibration/participant-0000']"
BATCH = ("replicate", "smoke", "-R", "2", "--participants", "2", "--set", RECORDING)


@pytest.fixture(scope="module")
def started(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``a/``: a pilot run ``a/pilot`` and another, ``a/b/pilot`` (another seed), and a finished batch
    ``a/B`` that took ``pilot/calibration/participant-0000`` typed in ``a``."""
    root = tmp_path_factory.mktemp("recordings") / "a"
    for out, seed in ((root / "pilot", "7"), (root / "b" / "pilot", "123")):
        made = nudge("simulate", "smoke", "--participants", "1", "--seed", seed, "--out", str(out))
        assert made.exit_code == 0, made.output
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(root)
        done = nudge(*BATCH, "--out", "B")
    assert done.exit_code == 0, done.output
    return root


@pytest.fixture()
def root(started: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    copy = Path(shutil.copytree(started, tmp_path / "a"))
    monkeypatch.chdir(copy)
    return copy


def test_the_batch_records_each_recordings_digest(root: Path) -> None:
    import json

    point = json.loads((root / "B" / BATCH_MANIFEST).read_text())["batch"]["points"][0]
    assert len(point["physiology_logs"]) == 1


def test_a_resume_from_another_folder_that_would_take_another_recording_is_refused(
        root: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(root / "b")
    before = files_of(root / "B")
    refused = nudge("replicate", "../B/experiment.toml", "--plan", "../B/plan.toml", "-R", "2",
                    "--participants", "2", "--out", "../B", "--resume")
    assert refused.exit_code == 1, refused.output
    line = one_error_line(refused.output)
    assert "physiology_logs" in line and "resume from the folder the batch was started in" in line, line
    assert files_of(root / "B") == before
    monkeypatch.chdir(root)  # from where it was started, the same command resumes it
    resumed = nudge("replicate", "B/experiment.toml", "--plan", "B/plan.toml", "-R", "2",
                    "--participants", "2", "--out", "B", "--resume")
    assert resumed.exit_code == 0, resumed.output


def test_the_printed_resume_command_says_where_to_run_it(root: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    result = nudge_interrupted(monkeypatch, *BATCH, "--out", "C")
    assert result.exit_code == 130, result.output
    lines = result.output.split("resume with: ")[1].strip().splitlines()
    assert f"run it from {root}" in lines[1], lines
    monkeypatch.chdir(root)
    resumed = nudge(*shlex.split(lines[0])[1:])
    assert resumed.exit_code == 0, resumed.output


def test_a_run_records_its_recordings_and_a_resume_that_would_read_another_is_refused(
        root: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import json

    made = nudge("simulate", "smoke", "--participants", "2", "--set", RECORDING, "--out", "R")
    assert made.exit_code == 0, made.output
    manifest = json.loads((root / "R" / "manifest.json").read_text())
    assert len(manifest["physiology_logs"]) == 1
    (root / "R" / "trials" / "part-0001.parquet").unlink()  # a participant left to simulate
    monkeypatch.chdir(root / "b")  # where pilot/ is another recording
    before = files_of(root / "R")
    refused = nudge("simulate", "../R/config.toml", "--out", "../R", "--resume")
    assert refused.exit_code == 1, refused.output
    line = one_error_line(refused.output)
    assert "physiology_logs" in line and "resume from the folder the run was started in" in line, line
    assert files_of(root / "R") == before
    monkeypatch.chdir(root)
    resumed = nudge("simulate", "R/config.toml", "--out", "R", "--resume")
    assert resumed.exit_code == 0, resumed.output


def _resume_b(*extra: str) -> object:
    return nudge("replicate", "B/experiment.toml", "--plan", "B/plan.toml", "-R", "2", "--participants", "2",
                 "--out", "B", "--resume", *extra)


def test_a_batch_without_the_record_resumes_as_a_run_without_it(root: Path) -> None:
    """A batch made before the digests were recorded (its description has no ``physiology_logs``:
    ``batch.json`` holds no checksum of the description, so removing it is what an older nudge
    wrote) is not compared, as a run's manifest without it; it resumes."""
    import json

    manifest = root / "B" / BATCH_MANIFEST
    document = json.loads(manifest.read_text())
    del document["batch"]["points"][0]["physiology_logs"]
    manifest.write_text(json.dumps(document, indent=2))
    resumed = _resume_b()
    assert resumed.exit_code == 0, resumed.output
    made = nudge("simulate", "smoke", "--participants", "2", "--set", RECORDING, "--out", "R")
    assert made.exit_code == 0, made.output
    run_manifest = root / "R" / "manifest.json"
    document = json.loads(run_manifest.read_text())
    del document["physiology_logs"]
    run_manifest.write_text(json.dumps(document, indent=2))
    (root / "R" / "trials" / "part-0001.parquet").unlink()
    resumed = nudge("simulate", "R/config.toml", "--out", "R", "--resume")
    assert resumed.exit_code == 0, resumed.output


def test_a_file_the_reader_does_not_read_leaves_the_recording_as_it_was(root: Path) -> None:
    """Notes, a Finder's .DS_Store or the mapping session beside the recording change nothing the
    simulation reads: the batch resumes; another recording's distortion session is refused."""
    recording = root / "pilot" / "calibration" / "participant-0000"
    (recording / "notes.txt").write_text("participant was tired\n")
    (recording / ".DS_Store").write_bytes(b"\0\1\2")
    with (recording / "mapping_prompts.csv").open("a") as handle:
        handle.write("\n")
    resumed = _resume_b()
    assert resumed.exit_code == 0, resumed.output
    other = root / "b" / "pilot" / "calibration" / "participant-0000"
    for name in ("distortion_prompts.csv", "distortion_stream.csv"):
        shutil.copy(other / name, recording / name)
    # the pilot run's manifest vouches for its logs, so it refuses the swap first (as damage);
    # as an older nudge's run, which records none, the batch's digest of the recording refuses it
    pilot = root / "pilot" / "manifest.json"
    pilot.write_text(pilot.read_text().replace('"calibration_checksums"', '"calibration_checksums_of_old"'))
    before = files_of(root / "B")
    refused = _resume_b()
    assert refused.exit_code == 1, refused.output
    assert "physiology_logs" in one_error_line(refused.output)
    assert files_of(root / "B") == before


@pytest.mark.parametrize("layout", ["study", "tidy"])
def test_the_digest_covers_exactly_the_files_the_reader_reads(tmp_path: Path, layout: str) -> None:
    from nudgecli.recording_digests import recording_digest
    from nudgecli.sim.calibration_io import STUDY_FILES, TIDY_FILES

    folder = tmp_path / "participant"
    names, where = (STUDY_FILES, folder / "p_phm_given_phi") if layout == "study" else (TIDY_FILES, folder)
    mapping = folder / "p_phi_given_a" if layout == "study" else folder
    for base, keys in ((where, ("distortion_prompts", "distortion_stream")),
                       (mapping, ("mapping_prompts", "mapping_responses"))):
        base.mkdir(parents=True, exist_ok=True)
        for key in keys:
            (base / names[key]).write_text(f"{key}\n")
    first = recording_digest(folder)
    (folder / "notes.txt").write_text("tired\n")
    (where / ".DS_Store").write_bytes(b"\0")
    (mapping / names["mapping_responses"]).write_text("edited\n")
    assert recording_digest(folder) == first
    for key in ("distortion_prompts", "distortion_stream"):
        read = where / names[key]
        read.write_text(read.read_text() + "1\n")
        assert recording_digest(folder) != first, key
        first = recording_digest(folder)
