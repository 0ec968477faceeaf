"""A batch of a researcher's own policy keeps its policy code, as a run folder does: an exact copy of
each module file the experiment imported from its folder, under the same relative path in the batch
folder, with its SHA-256 in ``batch.json`` (``policy_files``); a resume with a module that differs
from the recorded one is refused naming the file and touches nothing, and ``--force`` removes the
copies the replaced batch recorded (docs/batches.md). Also: the one reading of a batch's recorded
people entry (:func:`nudgecli.runs.batch_folder.recorded_people`)."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest
from cli_helpers import nudge, nudge_interrupted, one_error_line

from nudgecli.api.resuming import people_to_resume
from nudgecli.errors import ConfigError
from nudgecli.runs.batch_folder import BATCH_FOLDERS, BATCH_MANIFEST, recorded_people
from nudgecli.sim.policy_files import RUN_FOLDERS, loaded_policy_files

ROOT = Path(__file__).resolve().parents[1]

STUDY = """
[experiment]
name = "{name}"

[study]
participants = 2
conditions = ["control", "{policy}"]
goal_counts = [3]
corners = ["tr"]
start_modes = ["x"]
blocks_per_condition = 1
"""
POLICY = """
[policies.threshold]
factory = "{package}.threshold:ThresholdAssist"
params = {{ threshold = 0.6, weight = 0.5 }}
"""
BLENDING = """
[blending]
gate = "gap"
gap = 0.4
"""
SWEEP = """
experiment = "mine.toml"
plan = "mine-plan.toml"
replications = 1
seed = 3

[design]
method = "grid"

[parameters]
"policies.threshold.params.threshold" = { values = [0.5, 0.7] }
"""


# the shipped custom-policy plan, for the two conditions of these experiments
PLAN = (ROOT / "analysis" / "custom-policy.toml").read_text().replace(
    'name = "custom-policy"', 'name = "{name}"').replace(
    'conditions = ["disambiguation", "blending", "threshold"]', 'conditions = ["control", "{policy}"]')


def experiment_folder(root: Path, package: str = "policies") -> Path:
    """``root/mine.toml``, ``root/plain.toml`` (no policy of its own), their plans
    (``root/<name>-plan.toml``), ``root/sweep.toml`` (over mine's threshold) and the shipped
    threshold policy as ``root/<package>/``."""
    root.mkdir(parents=True)
    shutil.copytree(ROOT / "experiments" / "policies", root / package,
                    ignore=shutil.ignore_patterns("__pycache__"))
    mine = STUDY.format(name="mine", policy="threshold") + POLICY.format(package=package)
    (root / "mine.toml").write_text(mine)
    (root / "plain.toml").write_text(STUDY.format(name="plain", policy="blending") + BLENDING)
    (root / "sweep.toml").write_text(SWEEP)
    for name, policy in (("mine", "threshold"), ("plain", "blending")):
        (root / f"{name}-plan.toml").write_text(PLAN.format(name=name, policy=policy))
    return root / "mine.toml"


def command(kind: str, experiment: Path, out: Path, *flags: str) -> list[str | Path]:
    """``nudge KIND`` of ``experiment`` (the sweep file beside it for ``sweep``) into ``out``."""
    if kind == "sweep":
        return ["sweep", experiment.parent / "sweep.toml", "--out", out, *flags]
    counts = ["--participants", "2,3"] if kind == "power" else ["--participants", "2"]
    plan = experiment.with_name(f"{experiment.stem}-plan.toml")
    return [kind, experiment, "-R", "1", *counts, "--plan", plan, "--out", out, *flags]


def snapshot(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file() and "__pycache__" not in p.parts}


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture
def experiment(tmp_path: Path) -> Path:
    return experiment_folder(tmp_path / "exp")


@pytest.mark.parametrize("kind", ["replicate", "power", "sweep"])
def test_a_batch_keeps_exact_copies_of_its_policy_modules_with_their_sha256(
        experiment: Path, tmp_path: Path, kind: str) -> None:
    out = tmp_path / "batch"
    made = nudge(*command(kind, experiment, out))
    assert made.exit_code == 0, made.output
    source = experiment.parent / "policies"
    for name in ("__init__.py", "threshold.py"):
        assert (out / "policies" / name).read_bytes() == (source / name).read_bytes()
    manifest = json.loads((out / BATCH_MANIFEST).read_text())
    assert manifest["policy_files"] == {f"policies/{name}": sha256(source / name)
                                        for name in ("__init__.py", "threshold.py")}
    # the record is the manifest's own, not the batch's description: what a resume compares as
    # settings is as before, so a batch of an older nudge (no record) still resumes
    assert "policy_files" not in manifest["batch"]


def test_a_batch_without_policies_of_its_own_keeps_no_copies(experiment: Path, tmp_path: Path) -> None:
    out = tmp_path / "batch"
    made = nudge(*command("replicate", experiment.parent / "plain.toml", out))
    assert made.exit_code == 0, made.output
    assert not (out / "policies").exists()
    assert "policy_files" not in json.loads((out / BATCH_MANIFEST).read_text())


def test_a_resume_with_an_edited_module_is_refused_naming_it_and_leaves_the_batch(
        experiment: Path, tmp_path: Path) -> None:
    out = tmp_path / "batch"
    made = nudge(*command("replicate", experiment, out))
    assert made.exit_code == 0, made.output
    before = snapshot(out)
    original = experiment.parent / "policies" / "threshold.py"
    original.write_text(original.read_text() + "\n# tuned since\n")
    refused = nudge(*command("replicate", experiment, out, "--resume"))
    assert refused.exit_code == 1
    line = one_error_line(refused.stderr)
    assert str(original) in line and "mix two policies in one batch" in line
    assert str(out / "policies" / "threshold.py") in line
    assert snapshot(out) == before


def test_an_edited_copy_is_refused_with_advice_that_restores_it(experiment: Path, tmp_path: Path) -> None:
    out = tmp_path / "batch"
    assert nudge(*command("replicate", experiment, out)).exit_code == 0
    copy = out / "policies" / "threshold.py"
    kept = copy.read_bytes()
    copy.write_bytes(kept + b"# x\n")
    before = snapshot(out)
    # the command a Ctrl-C'd batch prints: the folder's own experiment, which imports the copy
    refused = nudge("replicate", out / "experiment.toml", "-R", "1", "--participants", "2", "--plan",
                    out / "plan.toml", "--out", out, "--resume")
    assert refused.exit_code == 1
    line = one_error_line(refused.stderr)
    assert str(copy) in line and "put the file back" not in line, line  # not: restore it from itself
    assert "delete it and resume with the command that started the batch" in line, line
    assert snapshot(out) == before
    copy.unlink()  # the advice works
    resumed = nudge(*command("replicate", experiment, out, "--resume"))
    assert resumed.exit_code == 0, resumed.output
    assert copy.read_bytes() == kept


def test_a_resume_with_the_same_modules_finishes_the_batch_with_the_same_tables(
        experiment: Path, tmp_path: Path) -> None:
    out = tmp_path / "batch"
    made = nudge(*command("replicate", experiment, out))
    assert made.exit_code == 0, made.output
    tables = {name: (out / name).read_bytes() for name in ("replications.csv", "summary.csv")}
    for part in (out / "analyses").glob("*.json"):
        part.unlink()  # the resume computes them again
    copy = out / "policies" / "threshold.py"
    copy.unlink()  # and puts back a copy that went missing
    resumed = nudge(*command("replicate", experiment, out, "--resume"))
    assert resumed.exit_code == 0, resumed.output
    assert {name: (out / name).read_bytes() for name in tables} == tables
    assert copy.read_bytes() == (experiment.parent / "policies" / "threshold.py").read_bytes()


def test_a_batch_of_an_older_nudge_without_a_record_resumes_and_records_its_copies(
        experiment: Path, tmp_path: Path) -> None:
    out = tmp_path / "batch"
    made = nudge(*command("replicate", experiment, out))
    assert made.exit_code == 0, made.output
    manifest = json.loads((out / BATCH_MANIFEST).read_text())
    recorded = manifest.pop("policy_files")
    (out / BATCH_MANIFEST).write_text(json.dumps(manifest))
    shutil.rmtree(out / "policies")
    resumed = nudge(*command("replicate", experiment, out, "--resume"))
    assert resumed.exit_code == 0, resumed.output
    assert json.loads((out / BATCH_MANIFEST).read_text())["policy_files"] == recorded
    assert (out / "policies" / "threshold.py").is_file()


def test_force_removes_the_replaced_batchs_policy_copies_and_keeps_other_files(
        experiment: Path, tmp_path: Path) -> None:
    out = tmp_path / "batch"
    made = nudge(*command("replicate", experiment, out))
    assert made.exit_code == 0, made.output
    (out / "policies" / "notes.txt").write_text("mine")
    replaced = nudge(*command("replicate", experiment.parent / "plain.toml", out, "--force"))
    assert replaced.exit_code == 0, replaced.output
    assert sorted(p.relative_to(out / "policies").as_posix() for p in (out / "policies").rglob("*")) \
        == ["notes.txt"]
    (out / "policies" / "notes.txt").unlink()
    again = nudge(*command("replicate", experiment, out, "--force"))
    assert again.exit_code == 0, again.output
    assert (out / "experiment.toml").is_file() and (out / "plan.toml").is_file()
    again = nudge(*command("replicate", experiment.parent / "plain.toml", out, "--force"))
    assert again.exit_code == 0, again.output
    assert not (out / "policies").exists()
    # the replaced batch's experiment and plan go too: the new batch keeps its own (importing nothing)
    kept = (out / "experiment.toml").read_text()
    assert 'name = "plain"' in kept and "ThresholdAssist" not in kept and (out / "plan.toml").is_file()


@pytest.mark.parametrize("package", ["tasks", "analyses"])
def test_a_policy_package_named_like_a_batch_folders_own_is_refused_before_the_folder_is_made(
        tmp_path: Path, package: str) -> None:
    experiment = experiment_folder(tmp_path / "exp", package=package)
    refused = nudge(*command("replicate", experiment, tmp_path / "batch"))
    assert refused.exit_code == 1
    line = one_error_line(refused.stderr)
    assert f"{package!r}" in line and "batch folder" in line
    assert not (tmp_path / "batch").exists()


def test_the_batch_folders_own_folders_are_reserved_beside_the_run_folders(tmp_path: Path) -> None:
    from nudgecli.config import load_experiment

    assert {"tasks", "analyses", "people", "figures"} <= BATCH_FOLDERS
    config = load_experiment(str(experiment_folder(tmp_path / "exp", package="tasks")))
    assert "tasks" not in RUN_FOLDERS
    assert set(loaded_policy_files(config)) == {"tasks/__init__.py", "tasks/threshold.py"}  # a run's
    with pytest.raises(ConfigError, match="batch folder's own tasks/"):
        loaded_policy_files(config, BATCH_FOLDERS, "batch")


# --- the recorded people entry: one reading for the resume hint and the resume check ----------

PEOPLE = {"file": "p.csv", "sha256": "ab" * 32}


@pytest.mark.parametrize(("text", "expected"), [
    (None, (False, None)),  # no batch.json
    ("{not json", (False, None)),
    ("[1, 2]", (False, None)),
    ('{"batch": 3}', (False, None)),
    ('{"batch": {"kind": "replicate"}}', (True, None)),  # a batch of the population's people
    (json.dumps({"batch": {"people": PEOPLE}, "people": "not this one"}), (True, PEOPLE)),
])
def test_recorded_people_reads_the_batch_descriptions_entry(tmp_path: Path, text: str | None,
                                                             expected: tuple[bool, object]) -> None:
    if text is not None:
        (tmp_path / BATCH_MANIFEST).write_text(text)
    assert recorded_people(tmp_path) == expected


def test_the_resume_hint_names_the_batchs_copy_of_its_people_file(tmp_path: Path) -> None:
    kept = {**PEOPLE, "sha256": hashlib.sha256(b"x").hexdigest()}  # the copy's bytes as kept
    (tmp_path / BATCH_MANIFEST).write_text(json.dumps({"batch": {"people": kept}}))
    assert people_to_resume(tmp_path, "typed.csv") == "typed.csv"  # no copy written yet
    (tmp_path / "people").mkdir()
    (tmp_path / "people" / "p.csv").write_text("x")
    assert people_to_resume(tmp_path, "typed.csv") == str(tmp_path / "people" / "p.csv")


# --- --force into a folder of the person's own files ------------------------------------------

def user_folder(tmp_path: Path, text: str) -> Path:
    """A folder that holds no run or batch, with the person's own ``policies/threshold.py``."""
    folder = tmp_path / "mine-folder"
    (folder / "policies").mkdir(parents=True)
    (folder / "policies" / "threshold.py").write_text(text)
    (folder / "notes.txt").write_text("my notes")
    return folder


def run_command(experiment: Path, out: Path, *flags: str) -> list[str | Path]:
    """``nudge simulate`` of ``experiment`` into ``out``."""
    return ["simulate", experiment, "--participants", "2", "--out", out, *flags]


@pytest.mark.parametrize("kind", ["replicate", "sweep", "simulate"])
def test_force_into_a_folder_with_a_users_file_at_a_copys_path_is_refused_and_touches_nothing(
        experiment: Path, tmp_path: Path, kind: str) -> None:
    folder = user_folder(tmp_path, "# my own threshold, not the experiment's\n")
    before = snapshot(folder)
    words = run_command(experiment, folder, "--force") if kind == "simulate" else \
        command(kind, experiment, folder, "--force")
    refused = nudge(*words)
    assert refused.exit_code == 1, refused.output
    line = one_error_line(refused.stderr)
    assert str(folder / "policies" / "threshold.py") in line and "never writes over it" in line
    assert "policies/threshold.py" in line and ("batch" in line) == (kind != "simulate")
    assert snapshot(folder) == before


def test_a_users_file_where_a_copys_folder_goes_is_refused(experiment: Path, tmp_path: Path) -> None:
    folder = tmp_path / "mine-folder"
    folder.mkdir()
    (folder / "policies").write_text("a file named policies")
    refused = nudge(*command("replicate", experiment, folder, "--force"))
    assert refused.exit_code == 1
    line = one_error_line(refused.stderr)  # before: "policies: File exists", from the copy's mkdir
    assert line.startswith(f"Error: {folder / 'policies'}: a file of your own")
    assert "never writes over it" in line
    assert snapshot(folder) == {"policies": b"a file named policies"}


@pytest.mark.parametrize("kind", ["replicate", "simulate"])
def test_force_into_a_folder_whose_file_holds_the_copys_bytes_runs_and_leaves_the_rest(
        experiment: Path, tmp_path: Path, kind: str) -> None:
    source = experiment.parent / "policies" / "threshold.py"
    folder = user_folder(tmp_path, source.read_text())
    words = run_command(experiment, folder, "--force") if kind == "simulate" else \
        command(kind, experiment, folder, "--force")
    made = nudge(*words)
    assert made.exit_code == 0, made.output
    assert (folder / "policies" / "threshold.py").read_bytes() == source.read_bytes()
    assert (folder / "notes.txt").read_text() == "my notes"


@pytest.mark.parametrize("kind", ["replicate", "simulate"])
def test_force_over_its_own_kind_replaces_an_edited_recorded_copy(
        experiment: Path, tmp_path: Path, kind: str) -> None:
    """A copy the folder's manifest records is the folder's own, not the person's: --force
    replaces it with the new experiment's module (the rule refuses only unrecorded files)."""
    out = tmp_path / "out"
    words = run_command(experiment, out) if kind == "simulate" else command(kind, experiment, out)
    assert nudge(*words).exit_code == 0
    copy = out / "policies" / "threshold.py"
    copy.write_text(copy.read_text() + "\n# edited in the folder\n")
    again = nudge(*words, "--force")
    assert again.exit_code == 0, again.output
    assert copy.read_bytes() == (experiment.parent / "policies" / "threshold.py").read_bytes()


# --- a batch resumes from its own folder ------------------------------------------------------

def interrupted_batch(kind: str, experiment: Path, monkeypatch: pytest.MonkeyPatch,
                      *flags: str) -> list[str]:
    """Run ``nudge KIND`` from the experiment's folder with paths as typed there (``mine.toml``,
    ``--out batch``), Ctrl-C'd after its first task; the words of the resume command it printed."""
    import shlex

    monkeypatch.chdir(experiment.parent)
    typed = command(kind, experiment, Path("batch"))
    words = [str(w).replace(str(experiment.parent) + "/", "") for w in typed]
    result = nudge_interrupted(monkeypatch, *words, *flags)
    assert result.exit_code == 130, result.output
    return shlex.split(result.output.split("resume with: ")[1].strip().splitlines()[0])


@pytest.mark.parametrize(("kind", "name"), [("replicate", "mine"), ("power", "mine"), ("replicate", "plain")])
def test_a_batchs_printed_resume_command_works_from_another_folder_with_the_experiment_gone(
        experiment: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, kind: str, name: str) -> None:
    # mine.toml has a policy of its own, plain.toml only built-in ones: both batches keep their inputs
    experiment = experiment.with_name(f"{name}.toml")
    whole = tmp_path / "whole"
    made = nudge(*command(kind, experiment, whole, "--set", "study.time_limit_s=40"))
    assert made.exit_code == 0, made.output
    words = interrupted_batch(kind, experiment, monkeypatch, "--set", "study.time_limit_s=40")
    batch = experiment.parent / "batch"
    assert words[:3] == ["nudge", kind, "batch/experiment.toml"]
    assert words[words.index("--plan") + 1] == "batch/plan.toml" and "--set" not in words
    moved = tmp_path / "moved"
    shutil.move(batch, moved / "batch")  # the batch as well: the command names it from its parent
    shutil.rmtree(experiment.parent)  # the experiment, its plan and its policies are gone
    monkeypatch.chdir(moved)  # another folder than the one the batch was started in
    resumed = nudge(*words[1:])
    assert resumed.exit_code == 0, resumed.output
    tables = sorted(p.name for p in whole.glob("*.csv"))
    assert tables and {name: (moved / "batch" / name).read_bytes() for name in tables} == \
        {name: (whole / name).read_bytes() for name in tables}
    manifest = json.loads((moved / "batch" / BATCH_MANIFEST).read_text())
    assert manifest["inputs"] == {name: sha256(moved / "batch" / name)
                                  for name in ("experiment.toml", "plan.toml")}


def test_a_resume_puts_back_a_lost_experiment_copy_and_leaves_one_there(
        experiment: Path, tmp_path: Path) -> None:
    out = tmp_path / "batch"
    assert nudge(*command("replicate", experiment, out)).exit_code == 0
    kept = (out / "experiment.toml").read_bytes()
    (out / "experiment.toml").unlink()
    (out / "plan.toml").write_text((out / "plan.toml").read_text() + "# a note of mine\n")
    noted = (out / "plan.toml").read_bytes()
    resumed = nudge(*command("replicate", experiment, out, "--resume"))
    assert resumed.exit_code == 0, resumed.output
    assert (out / "experiment.toml").read_bytes() == kept
    assert (out / "plan.toml").read_bytes() == noted  # a resume never writes over a file it may read


def test_force_into_a_folder_with_a_users_experiment_toml_is_refused_and_touches_nothing(
        experiment: Path, tmp_path: Path) -> None:
    folder = tmp_path / "mine-folder"
    folder.mkdir()
    (folder / "experiment.toml").write_text("# my own experiment\n")
    refused = nudge(*command("replicate", experiment, folder, "--force"))
    assert refused.exit_code == 1
    line = one_error_line(refused.stderr)
    assert line.startswith(f"Error: {folder / 'experiment.toml'}: a file of your own") and "input" in line
    assert snapshot(folder) == {"experiment.toml": b"# my own experiment\n"}
