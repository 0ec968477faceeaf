"""What a resume keeps: ``--resume`` with ``--force`` is refused by every command that takes both
(the one keeps the folder's finished work, the other deletes it: neither may win quietly); a power
batch records its ``--target`` and refuses a resume with another; a batch's refusal names
``batch.json`` (it has no manifest.json), and a sweep's names the command that resumes it from the
sweep file its folder keeps."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import pytest
from batch_helpers import REPLICATE
from cli_helpers import copy_run, files_of, nudge, nudge_interrupted, one_error_line

import nudgecli
from nudgecli.errors import RunFolderError
from nudgecli.runs.batch_folder import BATCH_MANIFEST, batch_differences, prepare_folder

#: The words of the refusal of the pair.
CONTRADICT = "--resume and --force contradict each other"
#: A small power batch (the smoke experiment, one replication of 2 and 3 participants).
POWER = ("power", "smoke", "--participants", "2,3", "-R", "1", "--seed", "4")
#: A sweep of one point (the smoke experiment, 2 participants), its file's replications 2.
SWEEP = ('experiment = "smoke"\nreplications = 2\nseed = 3\nset = ["study.participants=2"]\n'
         '[parameters]\n"disambiguation.window" = [3]\n')


@pytest.fixture(scope="module")
def power_batch(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A :data:`POWER` batch of ``--target 0.2``, Ctrl-C'd after its first part (its tables, a power
    batch's slowest work, not written). Do not modify: tests work on a copy."""
    folder = tmp_path_factory.mktemp("leftovers") / "P"
    with pytest.MonkeyPatch.context() as monkeypatch:
        started = nudge_interrupted(monkeypatch, *POWER, "--target", "0.2", "--out", folder)
    assert started.exit_code == 130, started.output
    return folder


# --- 1. --resume --force --------------------------------------------------------------------------


def test_resume_with_force_is_refused_and_a_batchs_work_is_left_as_it_was(tmp_path, power_batch):
    folder = copy_run(power_batch, tmp_path / "P")
    before = files_of(folder)
    for replications in ("1", "2"):  # the same settings, and others: neither replaces the batch
        result = nudge(*POWER[:5], replications, *POWER[6:], "--target", "0.2", "--out", folder, "--resume",
                       "--force")
        assert result.exit_code == 1, result.output
        line = one_error_line(result.output)
        assert line == (f"Error: {folder}: {CONTRADICT} (--resume keeps the batch's finished work, --force "
                        "deletes it); use --resume alone to finish the batch, or --force alone to start it "
                        "afresh"), line
    assert files_of(folder) == before


def test_resume_with_force_is_refused_and_a_finished_run_is_left_as_it_was(tmp_path, analysed_smoke_run):
    folder = copy_run(analysed_smoke_run, tmp_path / "run")
    before = files_of(folder)
    for command in ("simulate", "run"):
        result = nudge(command, "smoke", "--participants", "2", "--seed", "5", "--out", folder, "--resume",
                       "--force")
        assert result.exit_code == 1, result.output
        assert f"{CONTRADICT} (--resume keeps the run's finished work" in one_error_line(result.output)
    assert files_of(folder) == before


@pytest.mark.parametrize("words", [("simulate", "smoke"), ("run", "smoke"), REPLICATE, POWER, ("sweep",)])
def test_every_command_that_takes_both_refuses_them_and_makes_no_folder(tmp_path, words):
    if words == ("sweep",):
        (tmp_path / "s.toml").write_text(SWEEP)
        words = ("sweep", str(tmp_path / "s.toml"))
    result = nudge(*words, "--out", tmp_path / "new", "--resume", "--force")
    assert result.exit_code == 1, result.output
    assert CONTRADICT in one_error_line(result.output)
    assert not (tmp_path / "new").exists()


def test_the_python_api_refuses_resume_with_force(tmp_path, power_batch):
    folder = copy_run(power_batch, tmp_path / "P")
    before = files_of(folder)
    with pytest.raises(RunFolderError, match=CONTRADICT):
        nudgecli.power("smoke", [2, 3], 1, seed=4, target=0.2, out=folder, resume=True, force=True)
    with pytest.raises(RunFolderError, match=CONTRADICT):
        nudgecli.simulate("smoke", participants=1, out=tmp_path / "run", resume=True, force=True)
    assert files_of(folder) == before and not (tmp_path / "run").exists()


def test_a_batch_killed_before_its_manifest_is_not_started_afresh_by_the_pair(tmp_path):
    folder = tmp_path / "B"
    folder.mkdir()  # only a start (a writer's temporary): --resume or the same command starts it afresh
    (folder / ".batch.json.abcd1234.tmp").write_text("")
    with pytest.raises(RunFolderError, match=CONTRADICT):
        prepare_folder(folder, {"kind": "replicate"}, resume=True, force=True)
    assert prepare_folder(folder, {"kind": "replicate"}, resume=True, force=False) == "new"


def test_the_resume_command_printed_after_ctrl_c_of_a_forced_batch_drops_force(tmp_path, monkeypatch,
                                                                                power_batch):
    folder = copy_run(power_batch, tmp_path / "P")
    result = nudge_interrupted(monkeypatch, *POWER, "--out", folder, "--force")
    assert result.exit_code == 130, result.output
    command = shlex.split(result.output.split("resume with: ")[1].splitlines()[0])
    assert command[-1] == "--resume" and "--force" not in command, command


# --- 2. power's --target --------------------------------------------------------------------------


def test_a_power_batch_records_its_target_and_refuses_a_resume_with_another(tmp_path, power_batch):
    folder = copy_run(power_batch, tmp_path / "P")
    assert json.loads((folder / BATCH_MANIFEST).read_text())["batch"]["target"] == 0.2
    before = files_of(folder)
    for other in ((), ("--target", "0.5")):  # the default (0.8), and another
        result = nudge(*POWER, *other, "--out", folder, "--resume")
        assert result.exit_code == 1, result.output
        shown = "0.5" if other else "0.8"
        assert f"(target: 0.2 in batch.json, {shown} now)" in one_error_line(result.output)
    assert files_of(folder) == before


def test_a_target_is_compared_only_where_batch_json_records_one(tmp_path):
    recorded = {"kind": "power", "replications": 1, "seed": 4}
    assert batch_differences(recorded, {**recorded, "target": 0.8}) == []
    assert batch_differences({**recorded, "target": 0.2}, {**recorded, "target": 0.8}) == [
        "target: 0.2 in batch.json, 0.8 now"]
    # a batch of an older nudge recorded none: it resumes with the target given (and records it)
    (tmp_path / BATCH_MANIFEST).write_text(json.dumps({"batch": recorded, "status": "interrupted"}))
    assert prepare_folder(tmp_path, {**recorded, "target": 0.5}, resume=True, force=False) == "resume"


# --- 3. the refusal's words -----------------------------------------------------------------------


def test_a_sweeps_refusal_names_batch_json_and_the_command_that_resumes_it(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("s.toml").write_text(SWEEP)
    assert nudge_interrupted(monkeypatch, "sweep", "s.toml", "-R", "1", "--out", "S").exit_code == 130
    before = files_of(Path("S"))
    result = nudge("sweep", "s.toml", "--out", "S", "--resume")  # the file's 2 replications, not 1
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    assert "(replications: 1 in batch.json, 2 now)" in line and "manifest" not in line, line
    command = line.split("`")[1]
    assert command == "nudge sweep S/sweep.toml --out S --replications 1 --resume", line
    assert files_of(Path("S")) == before
    resumed = nudge_interrupted(monkeypatch, *shlex.split(command)[1:])  # accepted: it computes a part
    assert resumed.exit_code == 130, resumed.output
    assert len(files_of(Path("S"))) > len(before)
