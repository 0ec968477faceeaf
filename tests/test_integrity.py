"""Nothing silently wrong: resume refuses a changed experiment, analyze reads exactly the
manifest's parts and verifies their SHA-256, compare refuses duplicated trials, a sweep is
reproducible file for file, replication seeds and the bootstrap interval's level are pinned, and
a bad plan or input is one ``Error:`` line before anything is written (issue 21)."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.errors import DataError, RunFolderError
from nudgecli.report.analysis import analyze
from nudgecli.sim.study import run_study
from nudgecli.store import RunFolder

ROOT = Path(__file__).resolve().parents[1]


def one_error_line(output: str) -> str:
    lines = [line for line in output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error: "), output
    assert "Traceback" not in output
    return lines[0]


def invoke(args: list[str]):
    return CliRunner().invoke(main, args)


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished smoke run of 2 participants (copied by the tests that damage it)."""
    out = tmp_path_factory.mktemp("integrity") / "run"
    run_study(load_experiment("smoke"), out, participants=2)
    return out


def copy_run(source: Path, target: Path) -> Path:
    shutil.copytree(source, target)
    return target


def partial_run(tmp_path: Path, smoke_run: Path) -> Path:
    """A copy of the smoke run as if killed after participant 0: participant 1's parts gone."""
    run = copy_run(smoke_run, tmp_path / "run")
    for kind in ("trials", "steps", "participants"):
        (run / kind / "part-0001.parquet").unlink()
    manifest = json.loads((run / "manifest.json").read_text())
    manifest.update({"status": "running", "completed": [0]})
    manifest.get("checksums", {}).pop("1", None)
    (run / "manifest.json").write_text(json.dumps(manifest))
    return run


# --- 1, 2: resume compares the resolved experiment, seed, participants, version ----------------

def test_resume_with_an_edited_config_toml_is_refused_naming_the_key(tmp_path, smoke_run):
    run = partial_run(tmp_path, smoke_run)
    config = run / "config.toml"
    text = config.read_text()
    assert "kappa = 0.65" in text
    config.write_text(text.replace("kappa = 0.65", "kappa = 0.95"))
    before = {p: p.read_bytes() for p in run.rglob("*") if p.is_file()}
    result = invoke(["simulate", str(config), "--out", str(run), "--participants", "2", "--seed",
                     str(json.loads((run / "manifest.json").read_text())["seed"]), "--resume"])
    assert result.exit_code == 1
    line = one_error_line(result.output)
    assert "inference.kappa: 0.65 in the manifest, 0.95 now" in line
    after = {p: p.read_bytes() for p in run.rglob("*") if p.is_file() and p.name != ".nudge.lock"}
    assert after == {p: b for p, b in before.items() if p.name != ".nudge.lock"}


def test_resume_with_another_participant_count_is_refused(tmp_path, smoke_run):
    run = partial_run(tmp_path, smoke_run)
    with pytest.raises(RunFolderError, match=r"participants: 2 in the manifest, 3 now"):
        run_study(load_experiment("smoke"), run, participants=3, resume=True)
    assert not (run / "trials" / "part-0002.parquet").exists()


def test_resume_with_another_seed_or_version_is_refused(tmp_path, smoke_run, monkeypatch):
    run = partial_run(tmp_path, smoke_run)
    seed = json.loads((run / "manifest.json").read_text())["seed"]
    with pytest.raises(RunFolderError, match=rf"seed: {seed} in the manifest, {seed + 1} now"):
        run_study(load_experiment("smoke"), run, participants=2, seed=seed + 1, resume=True)
    import nudgecli.store as store

    monkeypatch.setattr(store, "__version__", "99.0")
    with pytest.raises(RunFolderError, match=r"nudgecli version: .* in the manifest, 99.0 now"):
        run_study(load_experiment("smoke"), run, participants=2, resume=True)


def test_resume_with_the_same_settings_finishes_the_run(tmp_path, smoke_run):
    run = partial_run(tmp_path, smoke_run)
    done = run_study(load_experiment("smoke"), run, participants=2, resume=True)
    assert done.computed == [1]
    pd.testing.assert_frame_equal(RunFolder(run).read_trials(), RunFolder(smoke_run).read_trials())


# --- 3: exactly the manifest's parts ------------------------------------------------------------

def test_analyze_reads_only_the_manifests_participants_and_names_a_stray(tmp_path, smoke_run):
    run = copy_run(smoke_run, tmp_path / "run")
    reference = analyze(copy_run(smoke_run, tmp_path / "reference"))
    for kind in ("trials", "steps", "participants"):
        shutil.copy(run / kind / "part-0001.parquet", run / kind / "part-0007.parquet")
    result = analyze(run)
    assert sorted(result.metrics["participant"].unique()) == [0, 1]
    pd.testing.assert_frame_equal(result.metrics, reference.metrics)
    assert any("part-0007.parquet" in note and "not in the manifest" in note for note in result.notes)


# --- 4: SHA-256 of every part ---------------------------------------------------------------------

def test_the_manifest_records_the_sha256_of_every_part(smoke_run):
    manifest = json.loads((smoke_run / "manifest.json").read_text())
    for participant in ("0", "1"):
        for kind in ("trials", "steps", "participants"):
            part = smoke_run / kind / f"part-000{participant}.parquet"
            assert manifest["checksums"][participant][kind] == hashlib.sha256(part.read_bytes()).hexdigest()


def _flip_a_byte(part: Path) -> None:
    """Change one byte of the Parquet data, keeping the footer readable."""
    data = bytearray(part.read_bytes())
    data[len(data) // 3] ^= 0x01
    part.write_bytes(bytes(data))


def test_analyze_plot_and_resume_name_a_changed_part(tmp_path, smoke_run):
    run = copy_run(smoke_run, tmp_path / "run")
    invoke(["analyze", str(run)])
    _flip_a_byte(run / "steps" / "part-0001.parquet")
    for args in (["analyze", str(run)], ["plot", str(run), "--out", str(tmp_path / "figures")]):
        result = invoke(args)
        assert result.exit_code == 1, result.output
        line = one_error_line(result.output)
        assert "steps/part-0001.parquet" in line and "SHA-256" in line and "--resume" in line
    # resume recomputes the changed part (a participant is a pure function of the seed)
    done = run_study(load_experiment("smoke"), run, participants=2, resume=True)
    assert done.computed == [1]
    assert (run / "steps" / "part-0001.parquet").read_bytes() == \
        (smoke_run / "steps" / "part-0001.parquet").read_bytes()
    analyze(run)


def test_a_manifest_without_checksums_is_analysed_with_a_note(tmp_path, smoke_run):
    run = copy_run(smoke_run, tmp_path / "run")
    manifest = json.loads((run / "manifest.json").read_text())
    del manifest["checksums"]
    (run / "manifest.json").write_text(json.dumps(manifest))
    result = analyze(run)
    assert any("no SHA-256" in note for note in result.notes)


def test_a_manifest_with_a_non_numeric_participant_count_is_one_error_line(tmp_path, smoke_run):
    run = copy_run(smoke_run, tmp_path / "run")
    manifest = json.loads((run / "manifest.json").read_text())
    manifest["participants"] = "eight"
    (run / "manifest.json").write_text(json.dumps(manifest))
    line = one_error_line(invoke(["analyze", str(run)]).output)
    assert 'participants = "eight"' in line and "manifest.json" in line


# --- 8c: the plan is checked before anything runs ------------------------------------------------

def test_run_with_an_unknown_plan_writes_nothing(tmp_path):
    out = tmp_path / "run"
    result = invoke(["run", "smoke", "--participants", "2", "--out", str(out), "--plan", "bogus"])
    assert result.exit_code == 1
    assert "bogus" in one_error_line(result.output)
    assert not out.exists() or not any(out.iterdir())


# --- 5: compare refuses duplicated trial rows as analyze does ------------------------------------

def test_compare_refuses_duplicated_trial_rows_like_analyze(tmp_path, smoke_run):
    metrics = analyze(copy_run(smoke_run, tmp_path / "run")).metrics
    real = tmp_path / "real.csv"
    doubled = pd.concat([metrics, metrics.iloc[[3]]], ignore_index=True)
    doubled.to_csv(real, index=False)
    expected_row = len(metrics) + 2  # the CSV's line of the repeat (line 1 is the header)
    for args in (["compare", str(tmp_path / "run"), str(real)], ["analyze", str(real)]):
        line = one_error_line(invoke(args).output)
        assert f"1 duplicate trial row(s)" in line and f"rows {expected_row}" in line, line
    # the same table as the simulated side
    line = one_error_line(invoke(["compare", str(real), str(real)]).output)
    assert "duplicate trial row" in line
    kept = invoke(["compare", str(tmp_path / "run"), str(real), "--drop-duplicates", "--resamples", "0",
                   "--format", "json"])
    assert kept.exit_code == 0, kept.output
    assert "Note: " in kept.output and "dropped 1 duplicate" in kept.output


# --- 6: a sweep is reproducible file for file; SALib says nothing on stderr ----------------------

SMALL_SWEEP = """\
experiment = "smoke"
replications = 1
seed = 0
plan = "paper"
set = ["study.participants=2"]

[design]
method = "sobol"
samples = 2
seed = 0

[parameters]
"disambiguation.window" = { values = [3, 5] }
"inference.kappa" = { values = [0.6, 0.75] }
"""

#: batch.json's fields that record when and how fast, not what
_TIMING_FIELDS = ("created", "finished", "wall_s", "worker_peak_rss_mb")


def test_a_sweep_run_twice_gives_the_same_files_and_salib_warns_nothing(tmp_path):
    sweep_file = tmp_path / "sweep.toml"
    sweep_file.write_text(SMALL_SWEEP)
    runner = CliRunner()
    outputs = []
    for name in ("a", "b"):
        result = runner.invoke(main, ["sweep", str(sweep_file), "--out", str(tmp_path / name)])
        assert result.exit_code == 0, result.output
        assert "Warning" not in result.stderr and "warn" not in result.stderr.lower(), result.stderr
        outputs.append(tmp_path / name)
    first, second = outputs
    files = sorted(p.relative_to(first) for p in first.rglob("*") if p.is_file())
    assert Path("sensitivity.csv") in files and Path("figures/sensitivity.png") in files
    assert files == sorted(p.relative_to(second) for p in second.rglob("*") if p.is_file())
    for name in files:
        if name == Path("batch.json"):
            left, right = (json.loads((folder / name).read_text()) for folder in outputs)
            for document in (left, right):
                for key in _TIMING_FIELDS:
                    document.pop(key)
            assert left == right
        else:
            assert (first / name).read_bytes() == (second / name).read_bytes(), name


def test_the_readme_sweep_file_example_loads(tmp_path):
    from nudgecli.sim.sweep import load_sweep

    readme = (ROOT / "README.md").read_text()
    start = readme.index("A sweep file:")
    block = readme[readme.index("```toml\n", start) + len("```toml\n"):]
    block = block[:block.index("```")]
    sweep_file = tmp_path / "sweep.toml"
    sweep_file.write_text(block)
    loaded = load_sweep(str(sweep_file))
    assert loaded.spec.design.method == "sobol" and len(loaded.points) > 0
