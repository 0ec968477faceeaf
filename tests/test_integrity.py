"""Nothing silently wrong: resume refuses a changed experiment, analyze reads exactly the
manifest's parts and verifies their SHA-256, compare refuses duplicated trials, a sweep is
reproducible file for file, replication seeds and the bootstrap interval's level are pinned, and
a bad plan or input is one ``Error:`` line before anything is written (issue 21)."""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_helpers import copy_run, one_error_line
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.errors import RunFolderError
from nudgecli.report.analysis import analyze
from nudgecli.runs.study import run_study
from nudgecli.store import RunFolder

ROOT = Path(__file__).resolve().parents[1]


def invoke(args: list[str]):
    return CliRunner().invoke(main, args)


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished smoke run of 2 participants (copied by the tests that damage it)."""
    out = tmp_path_factory.mktemp("integrity") / "run"
    run_study(load_experiment("smoke"), out, participants=2)
    return out


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
    assert f"{config} was edited after the run started: put back the manifest's values" in line
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
    import nudgecli.run_folder_state as record  # where the resume compares the versions

    monkeypatch.setattr(record, "__version__", "99.0")
    with pytest.raises(RunFolderError, match=r"nudgecli version: .* in the manifest, 99.0 now"):
        run_study(load_experiment("smoke"), run, participants=2, resume=True)


def test_resume_with_the_same_settings_finishes_the_run(tmp_path, smoke_run):
    run = partial_run(tmp_path, smoke_run)
    done = run_study(load_experiment("smoke"), run, participants=2, resume=True)
    assert done.computed == [1]
    pd.testing.assert_frame_equal(RunFolder(run).read_trials(), RunFolder(smoke_run).read_trials())


def test_resume_counts_no_stray_part_as_a_completed_participant(tmp_path, smoke_run):
    # a part of participant 7 copied into a run of 2: resume neither lists it nor reports it done
    run = partial_run(tmp_path, smoke_run)
    for kind in ("trials", "steps", "participants"):
        shutil.copy(run / kind / "part-0000.parquet", run / kind / "part-0007.parquet")
    reported = []
    done = run_study(load_experiment("smoke"), run, participants=2, resume=True,
                     progress=lambda finished, total: reported.append((finished, total)))
    assert done.computed == [1]
    assert json.loads((run / "manifest.json").read_text())["completed"] == [0, 1]
    trials_per = len(RunFolder(smoke_run).read_trials()) // 2
    assert reported == [(trials_per, 2 * trials_per), (2 * trials_per, 2 * trials_per)]


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


def test_a_run_read_a_participant_at_a_time_parses_its_manifest_once_while_unchanged(tmp_path, smoke_run):
    from nudgecli.run_folder_record import RunRecord
    from nudgecli.store import write_json_atomic

    run = copy_run(smoke_run, tmp_path / "run")
    folder = RunFolder(run)
    parsed, checked = [], []
    read_manifest, recorded_checksums = RunRecord.read_manifest, RunRecord.recorded_checksums
    folder.read_manifest = lambda: parsed.append(1) or read_manifest(folder)  # type: ignore[method-assign]
    folder.recorded_checksums = lambda m: checked.append(1) or recorded_checksums(folder, m)  # type: ignore[method-assign]
    first = [folder.read_table("steps", participants=[p]) for p in (0, 1, 0)]
    assert len(parsed) == 1 and len(checked) == 1
    # a manifest written again (atomically: another file) is read again, and its new record holds
    manifest = json.loads((run / "manifest.json").read_text())
    manifest["checksums"]["1"]["steps"] = "0" * 64
    write_json_atomic(run / "manifest.json", manifest)
    pd.testing.assert_frame_equal(folder.read_table("steps", participants=[0]), first[0])
    assert len(parsed) == 2
    with pytest.raises(RunFolderError, match=r"steps/part-0001\.parquet changed since it was written"):
        folder.read_table("steps", participants=[1])
    # a reader that changes a manifest gets its own copy each time
    assert folder.read_manifest() is not folder.read_manifest()


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
        assert "1 duplicate trial row(s)" in line and f"rows {expected_row}" in line, line
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
    # the first in a process of its own: pytest records warnings, so only a real stderr shows them
    child = subprocess.run([sys.executable, "-m", "nudgecli.cli", "sweep", str(sweep_file), "--out",
                            str(tmp_path / "a")], capture_output=True, text=True, cwd=ROOT,
                           env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=300)
    assert child.returncode == 0, child.stderr
    assert "warn" not in child.stderr.lower(), child.stderr
    result = CliRunner().invoke(main, ["sweep", str(sweep_file), "--out", str(tmp_path / "b")])
    assert result.exit_code == 0, result.output
    outputs = [tmp_path / "a", tmp_path / "b"]
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


def test_the_docs_sweep_file_example_loads(tmp_path):
    from nudgecli.runs.sweep import load_sweep

    readme = (ROOT / "docs" / "batches.md").read_text()
    start = readme.index("A sweep file:")
    block = readme[readme.index("```toml\n", start) + len("```toml\n"):]
    block = block[:block.index("```")]
    sweep_file = tmp_path / "sweep.toml"
    sweep_file.write_text(block)
    loaded = load_sweep(str(sweep_file))
    assert loaded.spec.design.method == "sobol" and len(loaded.points) > 0


# --- 7: replication seeds ----------------------------------------------------------------------------

def _independent_replication_seed(master: int, replication: int) -> int:
    """Replication r's seed derived by hand: SeedSequence(master, spawn_key=(sha256("replication")'s
    first 4 bytes little-endian, r)), its first 64-bit word, the top 63 bits."""
    word = int.from_bytes(hashlib.sha256(b"replication").digest()[:4], "little")
    state = np.random.SeedSequence(entropy=master, spawn_key=(word, replication)).generate_state(
        1, dtype=np.uint64)
    return int(state[0]) >> 1


def test_replication_seeds_are_pinned():
    from nudgecli.runs.batch import replication_seed

    # known values: changing how replication r's seed is derived changes every batch's results
    assert [replication_seed(0, r) for r in range(3)] == [
        5680765575968178681, 9047310466983199066, 7246022461404314051]
    assert [replication_seed(2022, r) for r in (0, 1, 19)] == [
        2939163322461918595, 267096466384655483, 8362738465882206593]
    for master, replication in ((0, 0), (11, 3), (2022, 19), (2**40, 7)):
        assert replication_seed(master, replication) == _independent_replication_seed(master, replication)


def test_a_batch_runs_replication_r_with_its_pinned_seed(tmp_path):
    from nudgecli.runs.batch_kinds import replicate

    result = replicate("smoke", 2, tmp_path / "batch", seed=5, participants=2)
    seeds = sorted(set(result.rows[["replication", "seed"]].itertuples(index=False, name=None)))
    assert seeds == [(0, _independent_replication_seed(5, 0)), (1, _independent_replication_seed(5, 1))]


# --- 8: the bootstrap interval's level -------------------------------------------------------------

def test_the_bootstrap_interval_is_the_levels_percentiles_of_brute_force_resamples():
    from nudgecli.report.cluster_bootstrap import bootstrap_median_differences

    rng = np.random.default_rng(3)
    rows = [{"participant": p, "condition": c, "value": float(rng.integers(0, 20))}
            for p in range(6) for c in ("a", "b") for _ in range(int(rng.integers(1, 4)))]
    data = pd.DataFrame(rows)
    resamples, level, seed = 300, 0.8, 12
    result = bootstrap_median_differences(data, "value", ["a", "b"], resamples=resamples, level=level,
                                          seed=seed).iloc[0]
    # by hand: the documented draws, every resample's trials replicated, np.median, percentiles
    codes, _ = pd.factorize(data["participant"])
    draws = np.random.default_rng(seed).integers(0, 6, size=(resamples, 6))
    differences = []
    for drawn in draws:
        picked = pd.concat([data[codes == p] for p in drawn])
        differences.append(np.median(picked.loc[picked["condition"] == "a", "value"])
                           - np.median(picked.loc[picked["condition"] == "b", "value"]))
    low, high = np.quantile(differences, [0.1, 0.9])
    assert (result["low"], result["high"]) == (low, high)
    assert result["valid_resamples"] == resamples


@pytest.mark.parametrize("level", [0.5, 0.9])
def test_the_bootstrap_interval_covers_a_known_median_difference_at_its_level(level):
    from nudgecli.report.cluster_bootstrap import bootstrap_median_differences

    datasets, participants, shift = 300, 30, 1.0
    covered = 0
    for k in range(datasets):
        rng = np.random.default_rng([7, k])
        data = pd.DataFrame({
            "participant": np.r_[np.arange(participants), np.arange(participants)],
            "condition": ["a"] * participants + ["b"] * participants,
            # normal a and b: the population medians differ by `shift`
            "value": np.r_[rng.normal(shift, 1.0, participants), rng.normal(0.0, 1.0, participants)],
        })
        interval = bootstrap_median_differences(data, "value", ["a", "b"], resamples=400, level=level,
                                                seed=k).iloc[0]
        covered += interval["low"] <= shift <= interval["high"]
    # binomial standard error at 300 datasets: 0.029 at level 0.5, 0.017 at 0.9; 3.5 of them allowed
    tolerance = 3.5 * np.sqrt(level * (1 - level) / datasets)
    assert abs(covered / datasets - level) < tolerance


# --- 23: smaller faults, each one Error: line (or handled) --------------------------------------------

@pytest.mark.parametrize("pid", ['"abc"', "null", "[1]", "1.5e400"])
def test_a_lock_file_with_a_non_numeric_pid_is_taken_over(tmp_path, smoke_run, pid):
    import socket

    run = copy_run(smoke_run, tmp_path / "run")
    (run / ".nudge.lock").write_text(f'{{"pid": {pid}, "host": "{socket.gethostname()}", '
                                     '"command": "nudge simulate smoke"}\n')
    result = invoke(["analyze", str(run)])
    assert result.exit_code == 0, result.output
    assert "taking over the stale lock" in result.stderr and "Traceback" not in result.output
    assert not (run / ".nudge.lock").exists()


@pytest.mark.parametrize("content", ["[1, 2]", '{"conditions": ["a"]}', '"text"', '{"metrics": 3}'])
def test_a_batch_analysis_of_the_wrong_shape_is_recomputed_on_resume(tmp_path, content):
    from nudgecli.runs.batch_kinds import replicate

    first = replicate("smoke", 1, tmp_path / "a", seed=3, participants=2)
    (analysis,) = sorted((tmp_path / "a" / "analyses").glob("*.json"))
    good = analysis.read_text()
    analysis.write_text(content)
    again = replicate("smoke", 1, tmp_path / "a", seed=3, participants=2, resume=True)
    assert again.run.computed == 1  # the analysis, not the participants
    assert analysis.read_text() == good
    pd.testing.assert_frame_equal(again.rows, first.rows)


def test_a_truncated_batch_task_part_is_recomputed_on_resume(tmp_path):
    from nudgecli.runs.batch_kinds import replicate

    first = replicate("smoke", 1, tmp_path / "a", seed=3, participants=2)
    part = sorted((tmp_path / "a" / "tasks").glob("*/part-0001.parquet"))[0]
    good = part.read_bytes()
    part.write_bytes(good[: len(good) // 2])  # a footer that does not parse
    again = replicate("smoke", 1, tmp_path / "a", seed=3, participants=2, resume=True)
    assert again.run.computed == 1  # the participant (its analysis is on disk and readable)
    assert part.read_bytes() == good
    pd.testing.assert_frame_equal(again.rows, first.rows)


@pytest.mark.parametrize("value", ["inf", "-inf", "nan"])
def test_validate_refuses_a_non_finite_belief_concentration(value):
    result = invoke(["validate", "--simulations", "2", "--max-goals", "4", "--mc-queries", "0",
                     "--belief-concentration", value])
    assert result.exit_code == 1
    assert "--belief-concentration" in one_error_line(result.output)


def test_a_non_numeric_cell_is_named_by_its_value_and_row(tmp_path):
    table = tmp_path / "study.csv"
    lines = ["participant,condition,completion_time"] + \
        [f"{p},{c},{10 + p}.5" for p in range(4) for c in ("disambiguation", "control")]
    assert lines[6] == "2,control,12.5"
    lines[6] = "2,control,12x5"  # line 7 of the file
    table.write_text("\n".join(lines) + "\n")
    line = one_error_line(invoke(["analyze", str(table)]).output)
    assert "'12x5'" in line and "row 7" in line and "completion_time" in line


def test_a_table_with_two_columns_of_one_name_is_refused(tmp_path):
    table = tmp_path / "study.csv"
    lines = ["participant,condition,completion_time,completion_time"] + \
        [f"{p},{c},{10 + p},{20 + p}" for p in range(4) for c in ("disambiguation", "control")]
    table.write_text("\n".join(lines) + "\n")
    for args in (["analyze", str(table)], ["compare", str(table), str(table)]):
        line = one_error_line(invoke(args).output)
        assert "'completion_time'" in line and "columns 3 and 4" in line
    assert not (tmp_path / "study-analysis").exists()


@pytest.mark.parametrize("damage", [[1, 2], {"zero": {}}, {"0": {"trials": 5}}, {"0": {"layouts": "ab"}}])
def test_a_damaged_checksums_entry_is_one_error_line(tmp_path, smoke_run, damage):
    run = copy_run(smoke_run, tmp_path / "run")
    manifest = json.loads((run / "manifest.json").read_text())
    manifest["checksums"] = damage
    (run / "manifest.json").write_text(json.dumps(manifest))
    assert "'checksums' is damaged" in one_error_line(invoke(["analyze", str(run)]).output)


def test_changed_parts_compares_only_the_parts_on_disk(tmp_path):
    from nudgecli.run_folder_record import RunRecord

    (tmp_path / "trials").mkdir()
    (tmp_path / "trials" / "part-0000.parquet").write_bytes(b"written")
    recorded = {"checksums": {"0": {"trials": hashlib.sha256(b"other").hexdigest(),
                                    "steps": hashlib.sha256(b"gone").hexdigest()},
                              "1": {"trials": hashlib.sha256(b"never written").hexdigest()}}}
    # participant 0's steps part and participant 1's trials part are missing: that is for
    # missing_parts to name, not a change
    assert RunRecord(tmp_path).changed_parts(recorded) == {0: ["trials/part-0000.parquet"]}


@pytest.mark.parametrize(("value", "count"), [(1, 1), (2, 2)])
def test_a_whole_participant_count_is_read_as_it_is(tmp_path, value, count):
    from nudgecli.run_folder_record import RunRecord

    record = RunRecord(tmp_path)
    assert record.participant_count({"participants": value}) == count
    assert record.manifest_participants({"participants": value}) == list(range(count))


@pytest.mark.parametrize(("manifest", "shown"), [({"participants": 0}, "0"), ({"participants": -1}, "-1"),
                                                 ({"participants": 2.0}, "2.0"), ({}, "(missing)")])
def test_a_participant_count_below_one_or_missing_is_refused(tmp_path, manifest, shown):
    # a run simulates one participant at least (run_study refuses fewer): 0 is a damaged manifest
    from nudgecli.run_folder_record import RunRecord

    with pytest.raises(RunFolderError, match=re.escape(f"participants = {shown} is not a whole number")):
        RunRecord(tmp_path).participant_count(manifest)


def test_a_manifest_with_no_participants_is_one_error_line_not_an_empty_run(tmp_path, smoke_run):
    run = copy_run(smoke_run, tmp_path / "run")
    manifest = json.loads((run / "manifest.json").read_text())
    manifest["participants"] = 0
    (run / "manifest.json").write_text(json.dumps(manifest))
    for command in (["analyze", str(run)], ["simulate", "smoke", "--out", str(run), "--resume"]):
        line = one_error_line(invoke(command).output)
        assert "participants = 0 is not a whole number" in line and "manifest.json" in line, command


def test_a_live_study_folder_is_noted_unverified_only_where_it_records_no_sha256(tmp_path):
    from nudgecli.run_folder_record import RunRecord

    record = RunRecord(tmp_path)
    # a `nudge study` folder records its parts' SHA-256 as a simulated run does: nothing to tell its
    # reader once finished, and while under way only how far it got; one of an older nudge, which
    # recorded none, is read unverified (said once)
    entries = {"0": {"status": "complete", "completed_trials": [0]}, "1": {"status": "complete"}}
    sums = {"0": dict.fromkeys(("trials", "steps", "participants"), "0" * 64),
            "1": {"participants": "0" * 64}}
    finished = {"executor": "live", "status": "complete", "live": entries}
    assert record.integrity_notes({**finished, "checksums": sums}) == []
    older = record.integrity_notes(finished)
    assert len(older) == 1 and "no SHA-256 of the parts of 2 participant(s)" in older[0], older
    under_way = record.integrity_notes({"executor": "live", "live": {"0": {}, "1": {}}})
    assert len(under_way) == 1 and "still under way" in under_way[0] and "SHA-256" not in under_way[0]
    notes = record.integrity_notes({"executor": "serial", "participants": 2})
    assert len(notes) == 1 and "no SHA-256 of the parts of 2 participant(s)" in notes[0]


def test_a_participant_is_completed_only_with_all_three_parts_readable(tmp_path):
    from nudgecli.run_folder_record import RunRecord

    for kind in ("trials", "steps", "participants"):
        (tmp_path / kind).mkdir()
        pd.DataFrame({"x": [1]}).to_parquet(tmp_path / kind / "part-0000.parquet")
    pd.DataFrame({"x": [1]}).to_parquet(tmp_path / "trials" / "part-0001.parquet")  # killed after trials
    for kind in ("trials", "steps"):
        pd.DataFrame({"x": [1]}).to_parquet(tmp_path / kind / "part-0002.parquet")
    (tmp_path / "participants" / "part-0002.parquet").write_bytes(b"PAR1 truncated")
    assert RunRecord(tmp_path).completed_participants() == [0]
    assert RunRecord(tmp_path).has_completed_participant()


def test_whether_a_participant_completed_reads_footers_only_until_the_first(tmp_path, monkeypatch):
    from nudgecli import run_folder_record
    from nudgecli.run_folder_record import RunRecord

    kinds = ("trials", "steps", "participants")
    for kind in kinds:
        (tmp_path / kind).mkdir()
        for index in range(4):
            pd.DataFrame({"x": [1]}).to_parquet(tmp_path / kind / f"part-{index:04d}.parquet")
    for index in (0, 1):  # the first two have a broken part each; the third is complete
        (tmp_path / kinds[index + 1] / f"part-{index:04d}.parquet").write_bytes(b"PAR1 truncated")
    (tmp_path / "steps" / "part-0003.parquet").unlink()  # never a candidate
    read = []
    real = run_folder_record.readable_parquet
    monkeypatch.setattr(run_folder_record, "readable_parquet",
                        lambda part: read.append(part.name) or real(part))
    record = RunRecord(tmp_path)
    assert record.has_completed_participant()
    assert read == ["part-0000.parquet"] * 2 + ["part-0001.parquet"] * 3 + ["part-0002.parquet"] * 3
    assert record.completed_participants() == [2]
    (tmp_path / "trials" / "part-0002.parquet").write_bytes(b"PAR1 truncated")
    assert not record.has_completed_participant() and record.completed_participants() == []


def test_resume_differences_name_the_participant_count_once(tmp_path):
    from nudgecli import __version__
    from nudgecli.run_folder_record import RunRecord

    config = load_experiment("smoke")
    recorded = {"seed": 1, "participants": 2, "versions": {"nudgecli": __version__},
                "config": config.model_dump(mode="json")}
    record = RunRecord(tmp_path)
    # the experiment is the same, only the count differs: one line for it
    assert record.resume_differences(recorded, config, 1, 3) == ["participants: 2 in the manifest, 3 now"]
    # the count differs inside the experiment too: its study.participants line says it, once
    grown = config.model_copy(update={"study": config.study.model_copy(update={"participants": 3})})
    recorded["config"]["study"]["participants"] = 2
    differences = record.resume_differences(recorded, grown, 1, 3)
    assert differences == ["study.participants: 2 in the manifest, 3 now"]


@pytest.mark.parametrize(("strays", "tail"), [(6, ""), (7, " and 1 more")])
def test_a_stray_note_names_six_parts_then_counts_the_rest(tmp_path, strays, tail):
    from nudgecli.run_folder_record import RunRecord

    (tmp_path / "trials").mkdir()
    for index in range(1, strays + 1):
        (tmp_path / "trials" / f"part-{index:04d}.parquet").write_bytes(b"")
    manifest = {"participants": 1, "checksums": {"0": {}}}
    notes = RunRecord(tmp_path).integrity_notes(manifest)
    shown = ", ".join(f"trials/part-{index:04d}.parquet" for index in range(1, 7))
    assert notes == [f"{tmp_path}: left out {strays} part(s) not in the manifest: {shown}{tail}; they do "
                     "not belong to this run (remove them)"]


def test_resume_with_a_plan_records_it_and_without_one_keeps_the_recorded(tmp_path, smoke_run):
    run = partial_run(tmp_path, smoke_run)
    assert json.loads((run / "manifest.json").read_text())["plan"] == "paper"
    run_study(load_experiment("smoke"), run, participants=2, resume=True, plan="study-code")
    assert json.loads((run / "manifest.json").read_text())["plan"] == "study-code"
    run_study(load_experiment("smoke"), run, participants=2, resume=True)
    assert json.loads((run / "manifest.json").read_text())["plan"] == "study-code"
