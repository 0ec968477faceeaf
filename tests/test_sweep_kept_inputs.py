"""A sweep keeps its inputs as a replicate or power batch does (docs/batches.md): its sweep file as
``sweep.toml``, naming the experiment file it names (kept as ``experiment.toml``, byte for byte) and
its analysis plan (``plan.toml``), their SHA-256 in ``batch.json``'s ``inputs``. The resume command
a Ctrl-C'd sweep prints names the kept sweep file, so it works from any folder, the sweep file typed
relative to another, moved or edited since; an edited kept input is refused, and so is ``--force``
with one of them as its input."""

from __future__ import annotations

import json
import shlex
import shutil
from pathlib import Path

import pytest
from batch_helpers import a_sweep_study
from cli_helpers import files_of, nudge, nudge_interrupted, one_error_line

from nudgecli.runs.batch_folder import BATCH_MANIFEST

#: A table before a list: the kept copy keeps the design's order of its parameters (Sobol's dimensions).
SWEEP = ('experiment = "exp.toml"\nreplications = 2\nseed = 3\nset = ["study.participants=2"]\n'
         '[design]\nmethod = "sobol"\nsamples = 2\n[parameters]\n'
         '"inference.kappa" = { low = 0.6, high = 0.7 }\n"disambiguation.window" = [3, 5]\n')


@pytest.fixture()
def study(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """``study/``: a sweep file ``my.toml`` naming the experiment file beside it (the smoke
    preset's copy), the current folder."""
    folder = a_sweep_study(tmp_path / "study", SWEEP)
    monkeypatch.chdir(folder)
    return folder


def interrupted(monkeypatch: pytest.MonkeyPatch, out: Path) -> list[str]:
    """``nudge sweep my.toml --out OUT``, Ctrl-C'd after its first part: the resume command it prints."""
    result = nudge_interrupted(monkeypatch, "sweep", "my.toml", "--out", str(out))
    assert result.exit_code == 130, result.output
    return shlex.split(result.output.split("resume with: ")[1].strip().splitlines()[0])


def test_the_printed_resume_command_works_from_another_folder_the_sweep_file_moved_and_edited(
        study: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "S"
    command = interrupted(monkeypatch, out)
    assert command[:3] == ["nudge", "sweep", str(out / "sweep.toml")], command
    kept = json.loads((out / BATCH_MANIFEST).read_text())["inputs"]
    assert sorted(kept) == ["experiment.toml", "plan.toml", "sweep.toml"]
    assert (out / "experiment.toml").read_bytes() == (study / "exp.toml").read_bytes()
    (study / "my.toml").write_text(SWEEP.replace("0.7", "0.8"))  # edited, then moved away
    shutil.move(study, tmp_path / "elsewhere")
    elsewhere = tmp_path / "other"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    resumed = nudge(*command[1:])
    assert resumed.exit_code == 0, resumed.output
    manifest = json.loads((out / BATCH_MANIFEST).read_text())
    assert manifest["status"] == "complete" and manifest["batch"]["experiment"] == "exp.toml"


def test_a_resume_with_the_sweep_file_that_started_it_still_works(
        study: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "S"
    interrupted(monkeypatch, out)
    resumed = nudge("sweep", "my.toml", "--out", str(out), "--resume")
    assert resumed.exit_code == 0, resumed.output


def test_an_edited_kept_sweep_file_is_refused_and_force_refuses_it_as_its_input(
        study: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "S"
    command = interrupted(monkeypatch, out)
    kept = out / "sweep.toml"
    kept.write_text(kept.read_text().replace("0.7", "0.75"))
    before = files_of(out)
    named = f"{out / 'experiment.toml'} is this command's input (the sweep file's experiment"  # the first
    for args, expected in ((command[1:], f"{kept}: changed since the batch wrote it"),
                           (["sweep", str(kept), "--out", str(out), "--force"], named)):
        refused = nudge(*args)
        assert refused.exit_code == 1, refused.output
        assert expected in one_error_line(refused.output)
        assert files_of(out) == before
