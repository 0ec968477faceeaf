"""A replicate or power batch keeps its experiment and plan (``experiment.toml``, ``plan.toml``, their
SHA-256 in ``batch.json``'s ``inputs``): ``--force`` with one of them as the command's input is
refused before anything is touched (replacing the batch removes them), and a resume whose kept
input changed since the batch wrote it is refused naming the file (docs/batches.md)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from batch_helpers import REPLICATE, a_finished_replicate
from cli_helpers import files_of, nudge, one_error_line


@pytest.fixture(scope="module")
def finished(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished replicate batch of the smoke experiment (2 studies of 2 participants)."""
    return a_finished_replicate(tmp_path_factory.mktemp("kept") / "B")


@pytest.fixture()
def batch(finished: Path, tmp_path: Path) -> Path:
    """A copy of :func:`finished` of this test's own."""
    return Path(shutil.copytree(finished, tmp_path / "B"))


def refused_untouched(args: tuple[str, ...], folder: Path, expected: str) -> str:
    before = files_of(folder)
    refused = nudge(*args)
    assert refused.exit_code == 1, refused.output
    line = one_error_line(refused.output)
    assert expected in line, line
    assert files_of(folder) == before
    return line


# --- --force with a kept input -------------------------------------------------------------------


@pytest.mark.parametrize("given", ["plan", "experiment"])
def test_force_refuses_a_kept_input_before_removing_anything(batch: Path, given: str) -> None:
    experiment = str(batch / "experiment.toml") if given == "experiment" else "smoke"
    plan = ["--plan", str(batch / "plan.toml")] if given == "plan" else []
    label = "--plan" if given == "plan" else "EXPERIMENT"
    refused_untouched(("replicate", experiment, *plan, "-R", "2", "--participants", "2", "--out", str(batch),
                       "--force"), batch, f"{batch / f'{given}.toml'} is this command's input ({label}")


def test_force_of_a_sweep_refuses_the_kept_inputs_it_names(batch: Path, tmp_path: Path) -> None:
    sweep = tmp_path / "sweep.toml"
    sweep.write_text('experiment = "B/experiment.toml"\nplan = "B/plan.toml"\nreplications = 1\nseed = 1\n'
                     '[design]\nmethod = "grid"\n[parameters]\n"inference.kappa" = [0.5, 0.6]\n')
    refused_untouched(("sweep", str(sweep), "--out", str(batch), "--force"), batch,
                      "experiment.toml is this command's input (the sweep file's experiment")


def test_a_resume_of_the_kept_inputs_still_works(batch: Path) -> None:
    resumed = nudge("replicate", str(batch / "experiment.toml"), "--plan", str(batch / "plan.toml"),
                    "-R", "2", "--participants", "2", "--out", str(batch), "--resume")
    assert resumed.exit_code == 0, resumed.output


# --- a resume checks the kept inputs against batch.json --------------------------------------------


def edited_plan(batch: Path) -> Path:
    plan = batch / "plan.toml"
    plan.write_text(plan.read_text(encoding="utf-8").replace("kruskal_alpha = 0.05", "kruskal_alpha = 0.1"))
    return plan


@pytest.mark.parametrize("how", ["typed", "kept"])
def test_a_resume_refuses_an_edited_kept_input(batch: Path, how: str) -> None:
    plan = edited_plan(batch)
    given = ("smoke",) if how == "typed" else (str(batch / "experiment.toml"), "--plan", str(plan))
    line = refused_untouched(("replicate", *given, "-R", "2", "--participants", "2", "--out", str(batch),
                              "--resume"), batch, f"{plan}: changed since the batch wrote it")
    assert "delete it and resume with the command that started the batch" in line


def test_a_deleted_kept_input_is_written_again_by_the_starting_command(batch: Path) -> None:
    original = (batch / "plan.toml").read_bytes()
    edited_plan(batch).unlink()
    resumed = nudge(*REPLICATE, "--out", str(batch), "--resume")
    assert resumed.exit_code == 0, resumed.output
    assert (batch / "plan.toml").read_bytes() == original


def test_a_resume_refuses_an_experiment_file_not_the_batchs_own(batch: Path) -> None:
    # a batch of an older nudge recorded no inputs: an experiment.toml there is the person's
    manifest = json.loads((batch / "batch.json").read_text(encoding="utf-8"))
    del manifest["inputs"]
    (batch / "batch.json").write_text(json.dumps(manifest))
    (batch / "experiment.toml").write_text("# mine\n")
    refused_untouched((*REPLICATE, "--out", str(batch), "--resume"), batch,
                      f"{batch / 'experiment.toml'}: a file of your own where the batch keeps its copy")
