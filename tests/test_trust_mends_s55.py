"""Nothing on a run's or a batch's disk is taken on trust where it decides the advice: a manifest
whose seed differs from its experiment's, a damaged config.toml, a batch.json whose plan was edited,
a sweep file's `set` of the wrong type, a kept input damaged since it was kept, and an edited kept
people file."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import pytest
from batch_helpers import REPLICATE, a_finished_replicate
from cli_helpers import copy_run, nudge, one_error_line
from run_builders import with_seeds


def _drop(run: Path, participant: int, kinds: tuple[str, ...] = ("trials", "steps")) -> None:
    for kind in kinds:
        (run / kind / f"part-{participant:04d}.parquet").unlink()


def _printed(command: str) -> list[str]:
    words = shlex.split(command)
    assert words[0] == "nudge", command
    return words[1:]


@pytest.fixture(scope="module")
def finished_replicate(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """:data:`REPLICATE` finished (do not modify: tests damage a copy)."""
    return a_finished_replicate(tmp_path_factory.mktemp("trust") / "B")


def _batch_resume(batch: Path) -> list[str]:
    """The command that resumes a copy of ``finished_replicate`` (as its messages print it)."""
    return [*REPLICATE[:1], str(batch / "experiment.toml"), *REPLICATE[2:], "--out", str(batch),
            "--plan", str(batch / "plan.toml"), "--resume"]


# --- a manifest's seed differing from its experiment's ----------------------------------------------

def test_a_manifest_whose_seed_was_edited_is_refused_not_resumed(tmp_path, analysed_smoke_run):
    run = with_seeds(copy_run(analysed_smoke_run, tmp_path / "run"), seed=4)  # its experiment records 5
    _drop(run, 1)
    analyzed = nudge("analyze", run)
    assert analyzed.exit_code == 1
    line = one_error_line(analyzed.output)
    assert "needs a resume" in line and "manifest.json records seed 4 but config.experiment.seed = 5" in line
    assert "put back the run's own manifest.json from a copy" in line and "seed back" not in line
    resumed = nudge("simulate", run / "config.toml", "--out", run, "--participants", "2", "--resume")
    assert resumed.exit_code == 1
    line = one_error_line(resumed.output)
    assert "cannot resume with seed 5" in line and "nothing was resumed" in line
    assert not (run / "trials" / "part-0001.parquet").exists()  # nothing of another seed simulated


def test_an_older_runs_seeds_read_and_its_printed_resume_restores_its_own_parts(tmp_path, analysed_smoke_run):
    # an older nudge's `--set experiment.seed=3 --seed 5`: 3 in its experiment, its parts made with 5
    run = with_seeds(copy_run(analysed_smoke_run, tmp_path / "run"), experiment_seed=3)
    analyzed = nudge("analyze", run, "--bootstrap", "100", "--out", tmp_path / "A")
    assert analyzed.exit_code == 0, analyzed.output  # intact and complete: vouched for by its SHA-256
    _drop(run, 1, ("trials",))
    line = one_error_line(nudge("analyze", run).output)
    assert "--seed 5)" in line and "older nudge with --set experiment.seed and --seed" in line
    command = line.split("`")[1]
    assert "--seed 5 " in command
    resumed = nudge(*_printed(command))
    assert resumed.exit_code == 0, resumed.output
    part = "trials/part-0001.parquet"
    assert (run / part).read_bytes() == (analysed_smoke_run / part).read_bytes()  # seed 5's, as before


# --- a damaged config.toml is not named in the advice ----------------------------------------------

def test_a_damaged_config_toml_is_not_the_experiment_advised(tmp_path, analysed_smoke_run):
    run = copy_run(analysed_smoke_run, tmp_path / "run")
    (run / "config.toml").write_text((analysed_smoke_run / "config.toml").read_text()[:300])  # cut off
    _drop(run, 1, ("trials",))
    analyzed = nudge("analyze", run)
    assert analyzed.exit_code == 1
    command = one_error_line(analyzed.output).split("`")[1]
    assert command.startswith("nudge simulate smoke --out") and "config.toml" not in command
    resumed = nudge(*_printed(command))  # it works: config.toml is written again from the manifest
    assert resumed.exit_code == 0, resumed.output
    assert (run / "config.toml").read_text() == (analysed_smoke_run / "config.toml").read_text()


# --- batch.json's plan edited --------------------------------------------------------------------

def test_a_batch_json_whose_plan_was_edited_is_named_not_resumed_in_a_loop(tmp_path, finished_replicate):
    batch = copy_run(finished_replicate, tmp_path / "B")
    record = json.loads((batch / "batch.json").read_text())
    record["batch"]["plan"]["stats"]["star_thresholds"] = [0.5, 0.1, 0.01]
    (batch / "batch.json").write_text(json.dumps(record))
    resumed = nudge(*_batch_resume(batch))
    assert resumed.exit_code == 1
    line = one_error_line(resumed.output)
    assert "batch.json: its plan differs from the plan whose SHA-256 it records" in line
    assert "batch.json was edited" in line and "--force" in line and "--resume" not in line


# --- a sweep file's `set` of another type -----------------------------------------------------------

@pytest.mark.parametrize(("written", "got"), [("set = 3", "(got 3)"),
                                              ('[set]\n"study.participants" = 2', "(got a table)")])
def test_a_sweep_files_set_of_another_type_is_one_error_line(tmp_path, written, got):
    from nudgecli.errors import ConfigError
    from nudgecli.runs.sweep import load_sweep

    sweep = tmp_path / "my.toml"
    sweep.write_text(f'experiment = "smoke"\n{written}\n[parameters]\n"blending.gain" = [0.5, 1.0]\n')
    with pytest.raises(ConfigError) as refused:
        load_sweep(str(sweep))
    assert str(refused.value) == (f'{sweep}: set: should be a list of --set values, e.g. set = '
                                  f'["study.participants=2"] {got}')


def test_a_list_fields_example_takes_its_default_factorys_list():
    from pydantic import BaseModel, Field

    from nudgecli.config_files import list_example

    class Listed(BaseModel):
        corners: list[str] = Field(default_factory=lambda: ["tr", "bl"])

    assert list_example(3, Listed.model_fields["corners"]) == '["tr", "bl"]'


# --- a damaged kept input is named as changed since kept, not by its parse or import error ---------

def test_a_cut_off_kept_experiment_is_named_as_changed_not_as_invalid_toml(tmp_path, finished_replicate):
    batch = copy_run(finished_replicate, tmp_path / "B")
    (batch / "experiment.toml").write_bytes((finished_replicate / "experiment.toml").read_bytes()[:200])
    resumed = nudge(*_batch_resume(batch))
    assert resumed.exit_code == 1
    line = one_error_line(resumed.output)
    assert "experiment.toml: changed since the batch wrote it" in line and "invalid TOML" not in line


def test_a_cut_off_kept_sweep_file_is_named_as_changed_not_as_invalid_toml(tmp_path):
    import hashlib

    from nudgecli.errors import ConfigError
    from nudgecli.runs.batch_trust import reading_as_folder
    from nudgecli.runs.sweep import load_sweep

    written = b'experiment = "smoke"\n[parameters]\n"disambiguation.window" = [3, 5]\n'
    (tmp_path / "batch.json").write_text(json.dumps(
        {"batch": {"kind": "sweep"}, "inputs": {"sweep.toml": hashlib.sha256(written).hexdigest()}}))
    (tmp_path / "sweep.toml").write_bytes(written[:30])  # cut off inside [parameters]
    with pytest.raises(ConfigError, match=r"sweep\.toml: changed since the batch wrote it"), \
            reading_as_folder(tmp_path):  # read by the folder's own command (its --out)
        load_sweep(str(tmp_path / "sweep.toml"))
    with pytest.raises(ConfigError, match=r"sweep\.toml: invalid TOML"):  # another folder's command
        load_sweep(str(tmp_path / "sweep.toml"))
    (tmp_path / "sweep.toml").write_bytes(written)
    assert load_sweep(str(tmp_path / "sweep.toml")).points  # the batch's own bytes read as before


def test_an_emptied_kept_policy_copy_is_named_as_changed_not_by_its_import(tmp_path):
    import hashlib
    import shutil

    experiments = Path(__file__).resolve().parents[1] / "experiments"
    run = tmp_path / "run"
    shutil.copytree(experiments / "policies", run / "policies", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(experiments / "custom-policy.toml", run / "config.toml")
    module = run / "policies" / "threshold.py"
    (run / "manifest.json").write_text(json.dumps({  # a run with a finished participant, its copy kept
        "policy_files": {"policies/threshold.py": hashlib.sha256(module.read_bytes()).hexdigest()},
        "checksums": {"0": {}}}))
    module.write_text("")
    resumed = nudge("simulate", run / "config.toml", "--out", run, "--participants", "2", "--resume")
    assert resumed.exit_code == 1
    line = one_error_line(resumed.output)
    assert "policies/threshold.py: changed since the run kept it" in line and "no attribute" not in line


# --- an edited kept people copy -------------------------------------------------------------------

def test_an_edited_people_copy_is_not_advised_and_its_resume_says_the_copy_changed(tmp_path, monkeypatch):
    from people_helpers import people_typed_here

    here = people_typed_here(tmp_path, monkeypatch, "ppl.csv")
    made = nudge("simulate", "smoke", "--participants", "2", "--people", "ppl.csv", "--out", "pr")
    assert made.exit_code == 0, made.output
    run = here / "pr"
    with (run / "people" / "ppl.csv").open("ab") as copy:
        copy.write(b"2,by hand,slow,2.0,\r\n")  # edited since the run kept it
    _drop(run, 1, ("trials",))
    analyzed = nudge("analyze", "pr")
    command = one_error_line(analyzed.output).split("`")[1]
    assert "--people ppl.csv " in command  # the file it was simulated with, not the edited copy
    refused = nudge("simulate", "smoke", "--out", "pr", "--seed", "7", "--participants", "2",
                    "--people", "pr/people/ppl.csv", "--resume")
    line = one_error_line(refused.output)
    assert "pr/people/ppl.csv: the copy pr keeps of its people file changed since it was kept" in line
    assert "--people ppl.csv (the resume puts the copy back)" in line
    resumed = nudge(*_printed(command))
    assert resumed.exit_code == 0, resumed.output
    assert (run / "people" / "ppl.csv").read_bytes() == (here / "ppl.csv").read_bytes()
