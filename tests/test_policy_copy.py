"""A run of a researcher's own policy keeps its policy code: an exact copy of each module file the
experiment imported from its folder, under the same relative path in the run folder, with its
SHA-256 in the manifest; the resume command a damaged run prints (``nudge simulate R/config.toml
... --resume``) imports those copies and works from any folder, and a resume with a module that
differs from the recorded one is refused naming the file (docs/policies.md, docs/run-folders.md)."""

from __future__ import annotations

import hashlib
import json
import py_compile
import shlex
import shutil
from pathlib import Path

import pandas as pd
import pytest
from cli_helpers import nudge, one_error_line
from policy_helpers import policy_experiment

from nudgecli.errors import DataError
from nudgecli.sim.policy_files import check_same_policy_files, policy_record

ROOT = Path(__file__).resolve().parents[1]

def experiment_folder(root: Path, package: str = "policies") -> Path:
    """``root/mine.toml`` and the shipped threshold policy as ``root/<package>/``."""
    root.mkdir(parents=True)
    shutil.copytree(ROOT / "experiments" / "policies", root / package,
                    ignore=shutil.ignore_patterns("__pycache__"))
    return policy_experiment(root, {"threshold": f"{package}.threshold:ThresholdAssist"},
                             params={"threshold": "{ threshold = 0.6, weight = 0.5 }"}, participants=2)


def snapshot(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file() and "__pycache__" not in p.parts}


@pytest.fixture
def simulated(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A run ``tmp_path/here/run`` of ``tmp_path/exp/mine.toml``, typed in ``tmp_path/here``."""
    experiment = experiment_folder(tmp_path / "exp")
    (tmp_path / "here").mkdir()
    monkeypatch.chdir(tmp_path / "here")
    made = nudge("simulate", experiment, "--out", "run")
    assert made.exit_code == 0, made.output
    return tmp_path / "here" / "run"


def test_a_run_keeps_exact_copies_of_its_policy_modules_with_their_sha256(
        simulated: Path, tmp_path: Path) -> None:
    source = tmp_path / "exp" / "policies"
    for name in ("__init__.py", "threshold.py"):
        assert (simulated / "policies" / name).read_bytes() == (source / name).read_bytes()
    recorded = json.loads((simulated / "manifest.json").read_text())["policy_files"]
    assert recorded == {f"policies/{name}": hashlib.sha256((source / name).read_bytes()).hexdigest()
                        for name in ("__init__.py", "threshold.py")}


def test_the_printed_resume_command_imports_the_copies_and_works_from_another_folder(
        simulated: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    whole = pd.read_parquet(simulated / "trials")
    (simulated / "trials" / "part-0001.parquet").unlink()
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)  # neither the experiment's folder nor the run's parent
    refused = nudge("analyze", "../here/run")
    words = shlex.split(one_error_line(refused.stderr).split("`")[1])
    assert words[:3] == ["nudge", "simulate", str(Path("../here/run") / "config.toml")]
    resumed = nudge(*words[1:])
    assert resumed.exit_code == 0, resumed.output
    pd.testing.assert_frame_equal(pd.read_parquet(simulated / "trials"), whole)


def test_a_resume_with_an_edited_module_is_refused_naming_it_and_leaves_the_run(
        simulated: Path, tmp_path: Path) -> None:
    (simulated / "trials" / "part-0001.parquet").unlink()
    before = snapshot(simulated)
    original = tmp_path / "exp" / "policies" / "threshold.py"
    original.write_text(original.read_text() + "\n# tuned since\n")
    refused = nudge("simulate", tmp_path / "exp" / "mine.toml", "--out", simulated, "--resume")
    assert refused.exit_code == 1
    line = one_error_line(refused.stderr)
    assert str(original) in line and "mix two policies" in line
    assert snapshot(simulated) == before
    # the copy itself, edited, is refused as well when the run's own config.toml resumes it
    copy = simulated / "policies" / "threshold.py"
    copy.write_text(original.read_text())
    refused = nudge("simulate", simulated / "config.toml", "--out", simulated, "--resume")
    assert refused.exit_code == 1
    assert str(copy) in one_error_line(refused.stderr)


def test_a_policy_package_named_like_a_run_folder_part_is_refused_before_the_folder_is_made(
        tmp_path: Path) -> None:
    experiment = experiment_folder(tmp_path / "exp", package="trials")
    refused = nudge("simulate", experiment, "--out", tmp_path / "run")
    assert refused.exit_code == 1
    assert "'trials'" in one_error_line(refused.stderr)
    assert not (tmp_path / "run").exists()


def test_the_check_compares_every_recorded_and_loaded_file() -> None:
    files = {"policies/a.py": b"x = 1\n", "policies/b.py": b"y = 2\n"}
    recorded = {name: hashlib.sha256(data).hexdigest() for name, data in files.items()}
    assert policy_record(files) == recorded
    check_same_policy_files(recorded, files, "/exp", "run")  # the same: no error
    check_same_policy_files(None, files, "/exp", "run")  # an older run records none: nothing to compare
    for changed in ({**files, "policies/b.py": b"y = 3\n"}, {"policies/a.py": files["policies/a.py"]},
                    {**files, "policies/c.py": b""}):
        with pytest.raises(DataError):
            check_same_policy_files(recorded, changed, "/exp", "run")



def test_force_removes_the_replaced_runs_policy_copies(simulated: Path, tmp_path: Path) -> None:
    # the copies are the replaced run's inputs: left behind, they would look like the new run's
    (simulated / "policies" / "notes.txt").write_text("mine")
    # the bytecode a resume from the run's config.toml caches for a copy goes with it
    py_compile.compile(str(simulated / "policies" / "threshold.py"), doraise=True)
    replaced = nudge("simulate", "smoke", "--participants", "1", "--out", simulated, "--force")
    assert replaced.exit_code == 0, replaced.output
    copies = simulated / "policies"
    assert sorted(p.relative_to(copies).as_posix() for p in copies.rglob("*")) == ["notes.txt"]
    (simulated / "policies" / "notes.txt").unlink()
    experiment = tmp_path / "exp" / "mine.toml"
    again = nudge("simulate", experiment, "--out", simulated, "--force")
    assert again.exit_code == 0, again.output
    again = nudge("simulate", "smoke", "--participants", "1", "--out", simulated, "--force")
    assert again.exit_code == 0, again.output
    assert not (simulated / "policies").exists()
