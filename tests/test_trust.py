"""Nothing taken on trust (issue 38): an output never replaces a record or an input, a resume keeps
only the parts its manifest vouches for, a run that lost its manifest is not read as complete, a
folder holding another run is written only with --force, a batch's parts and a run's layouts are
verified, and an exit of 0 means the whole document reached stdout (strict JSON: null, never NaN).

Each test was seen failing with its fix removed (the commands of the commit before it)."""

from __future__ import annotations

import hashlib
import json
import math
import os
import resource
import shutil
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_helpers import copy_run, files_of, one_error_line
from click.testing import CliRunner
from hypothesis import given
from hypothesis import strategies as st

from nudgecli.cli import main
from nudgecli.commands import stdout as checked
from nudgecli.commands.common import strict_json_value
from nudgecli.config import load_experiment
from nudgecli.runs.study import run_study

DATA = Path(__file__).parent / "data"
TABLE = DATA / "metrics_two_conditions.csv"
PARTS = ("trials", "steps", "participants")


def invoke(args: list[str]):
    return CliRunner().invoke(main, args)


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished smoke run of 2 participants (seed 7), copied by the tests that change it."""
    out = tmp_path_factory.mktemp("trust") / "run"
    run_study(load_experiment("smoke"), out, participants=2)
    return out


@pytest.fixture(scope="module")
def other_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Another finished smoke run of 2 participants, of another seed: its parts differ."""
    out = tmp_path_factory.mktemp("trust") / "other"
    run_study(load_experiment("smoke"), out, participants=2, seed=8)
    return out


@pytest.fixture(scope="module")
def analysed_run(smoke_run: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    run = copy_run(smoke_run, tmp_path_factory.mktemp("trust") / "analysed")
    assert invoke(["analyze", str(run)]).exit_code == 0
    return run


def _partial(run: Path) -> dict:
    """``run`` as if killed after participant 0: participant 1 neither done nor recorded."""
    manifest = json.loads((run / "manifest.json").read_text())
    manifest.update({"status": "running", "completed": [0]})
    manifest["checksums"].pop("1")
    (run / "manifest.json").write_text(json.dumps(manifest))
    return manifest


# --- 1. outputs never replace records or inputs ----------------------------------------------------

def test_analyze_with_the_study_questionnaires_keeps_the_participants_answers(tmp_path, smoke_run):
    # the command docs/live-study.md gives: the answers sit in the run folder, the analysis writes there
    run = copy_run(smoke_run, tmp_path / "run")
    answers = run / "questionnaires.csv"
    shutil.copy(DATA / "questionnaires_smoke_run.csv", answers)
    recorded = answers.read_bytes()
    result = invoke(["analyze", str(run), "--questionnaires", str(answers)])
    assert result.exit_code == 0, result.output
    assert answers.read_bytes() == recorded  # the six NASA-TLX ratings are still there
    scores = pd.read_csv(run / "questionnaire_scores.csv")
    raw = pd.read_csv(answers)
    subscales = [f"tlx_{name}" for name in ("mental", "physical", "temporal", "performance", "effort",
                                            "frustration")]
    assert np.allclose(scores["tlx_raw"], raw[subscales].mean(axis=1))
    plotted = invoke(["plot", str(run), "--formats", "png"])  # the figures read the scores back
    assert plotted.exit_code == 0, plotted.output
    assert any("questionnaire" in Path(line).name for line in plotted.stdout.splitlines())


def _collisions(tmp_path: Path, smoke_run: Path) -> dict[str, tuple[list[str], Path]]:
    """For each command, arguments under which one of its outputs is a file it reads (``--force``
    given, so that the folder rule lets it write there), and that file."""
    folder = tmp_path / "folder"
    folder.mkdir()
    table = pd.read_csv(TABLE)
    pd.concat([table, table.iloc[:1]]).to_csv(folder / "metrics.csv", index=False)  # a repeated row
    shutil.copy(TABLE, folder / "compare.csv")
    shutil.copy(DATA / "questionnaires_two_conditions.csv", folder / "questionnaire_scores.csv")
    calibration = copy_run(smoke_run / "calibration" / "participant-0000", tmp_path / "calibration")
    log = sorted(p for p in calibration.rglob("*.csv"))[0]
    return {
        # dropping the repeated row changes the table, so the analysis writes metrics.csv
        "analyze": (["analyze", str(folder / "metrics.csv"), "--out", str(folder), "--drop-duplicates",
                     "--force", "--bootstrap", "100"], folder / "metrics.csv"),
        # answers in a file named like the scores: the last output, refused before the first is written
        "analyze-scores": (["analyze", str(TABLE), "--questionnaires",
                            str(folder / "questionnaire_scores.csv"), "--out", str(folder), "--force",
                            "--bootstrap", "100"], folder / "questionnaire_scores.csv"),
        "compare": (["compare", str(folder / "compare.csv"), str(TABLE), "--resamples", "0", "--formats",
                     "png", "--out", str(folder), "--force"], folder / "compare.csv"),
        "fit": (["fit", str(calibration), "--out", str(log)], log),
    }


@pytest.mark.parametrize("command", ["analyze", "analyze-scores", "compare", "fit"])
def test_no_command_writes_an_output_onto_a_file_it_read(tmp_path, smoke_run, command):
    args, read = _collisions(tmp_path, smoke_run)[command]
    before = files_of(tmp_path)
    result = invoke(args)
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    assert str(read) in line and "this command's input" in line
    assert files_of(tmp_path) == before  # nothing replaced, nothing half-written


# --- 2. resume keeps only what the manifest vouches for --------------------------------------------

def test_resume_simulates_again_a_part_copied_in_from_another_run(tmp_path, smoke_run, other_run):
    run = copy_run(smoke_run, tmp_path / "run")
    _partial(run)
    for kind in PARTS:  # another run's participant 1, readable, copied into the interrupted run
        shutil.copy(other_run / kind / "part-0001.parquet", run / kind / "part-0001.parquet")
    result = invoke(["simulate", "smoke", "--participants", "2", "--out", str(run), "--resume"])
    assert result.exit_code == 0, result.output
    assert "trials/part-0001.parquet (no SHA-256 recorded)" in result.stderr
    assert "simulating participant(s) 1 again" in result.stderr
    for kind in PARTS:
        assert (run / kind / "part-0001.parquet").read_bytes() == \
            (smoke_run / kind / "part-0001.parquet").read_bytes()
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["status"] == "complete"
    assert manifest["checksums"]["1"]["steps"] == \
        hashlib.sha256((run / "steps" / "part-0001.parquet").read_bytes()).hexdigest()


def test_resume_keeps_the_parts_the_manifest_vouches_for(tmp_path, smoke_run):
    # the other side: participant 0's recorded parts are not simulated again
    run = copy_run(smoke_run, tmp_path / "run")
    _partial(run)
    for kind in PARTS:
        (run / kind / "part-0001.parquet").unlink()
    done = run_study(load_experiment("smoke"), run, participants=2, resume=True)
    assert done.computed == [1]


def test_analyze_refuses_parts_the_manifest_records_no_checksum_of(tmp_path, smoke_run):
    run = copy_run(smoke_run, tmp_path / "run")
    manifest = json.loads((run / "manifest.json").read_text())
    manifest["checksums"].pop("1")  # e.g. copied in, then the manifest marked complete by hand
    (run / "manifest.json").write_text(json.dumps(manifest))
    result = invoke(["analyze", str(run)])
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    assert "records no SHA-256 of trials/part-0001.parquet" in line and line.endswith("--resume`")
    assert not (run / "stats.json").exists()


# --- 3. a run that lost its manifest --------------------------------------------------------------

def test_analyze_refuses_a_run_whose_manifest_is_gone(tmp_path, smoke_run):
    run = copy_run(smoke_run, tmp_path / "run")
    for kind in PARTS:  # interrupted after participant 0 ...
        (run / kind / "part-0001.parquet").unlink()
    (run / "manifest.json").unlink()  # ... and its manifest deleted
    result = invoke(["analyze", str(run)])
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    assert "no manifest.json" in line and "parts of 1 found" in line and "--force" in line
    assert not (run / "stats.json").exists()


def test_a_folder_of_parts_alone_is_analysed_with_a_note(tmp_path, smoke_run):
    folder = tmp_path / "parts"
    folder.mkdir()
    for kind in ("trials", "steps"):  # parts assembled by hand: no other trace of a nudge run
        shutil.copytree(smoke_run / kind, folder / kind)
    result = invoke(["analyze", str(folder)])
    assert result.exit_code == 0, result.output
    assert f"Note: {folder} has no manifest.json" in result.stderr and "unverified" in result.stderr


# --- 4. a folder of another run, or not empty, needs --force ---------------------------------------

def _out_args(command: str, source: Path, out: Path) -> list[str]:
    return {"analyze": ["analyze", str(source), "--bootstrap", "100"],
            "compare": ["compare", str(source), str(TABLE), "--resamples", "0", "--formats", "png"],
            "validate": ["validate", "--simulations", "1", "--mc-queries", "0"],
            "plot": ["plot", str(source), "--formats", "png"]}[command] + ["--out", str(out)]


@pytest.mark.parametrize("held", ["another run", "other files"])
@pytest.mark.parametrize("command", ["analyze", "compare", "validate", "plot"])
def test_an_out_folder_holding_another_run_or_files_needs_force(tmp_path, analysed_run, other_run, command,
                                                                 held):
    if held == "another run":
        out = copy_run(other_run, tmp_path / "b")
        assert invoke(["analyze", str(out)]).exit_code == 0  # B has an analysis of its own
    else:
        out = tmp_path / "b"
        out.mkdir()
        (out / "notes.txt").write_text("mine")
    before = files_of(out)
    args = _out_args(command, analysed_run, out)
    result = invoke(args)
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    assert ("holds another run" if held == "another run" else "is not empty") in line and "--force" in line
    assert files_of(out) == before  # B's own analysis is intact: `nudge plot B` still draws B
    forced = invoke([*args, "--force"])
    assert forced.exit_code == 0, forced.output
    assert all(files_of(out)[name] == data for name, data in before.items()
               if name in ("notes.txt", "manifest.json"))  # --force replaces outputs, nothing else


def test_a_commands_own_folders_need_no_force(tmp_path, analysed_run):
    run = copy_run(analysed_run, tmp_path / "run")
    table = tmp_path / "study.csv"
    shutil.copy(TABLE, table)
    for args in (["analyze", str(run), "--out", str(run)],  # the run folder is the run's own
                 ["analyze", str(table), "--bootstrap", "100"],  # study-analysis/, made ...
                 ["analyze", str(table), "--bootstrap", "100", "--out", str(tmp_path / "study-analysis")],
                 ["plot", str(run), "--formats", "png", "--out", str(run / "figures")]):
        result = invoke(args)
        assert result.exit_code == 0, (args, result.output)


# --- 5. an exit of 0 means the whole document was written ------------------------------------------

HABITS_LOG = "t,trial,label,x,y,theta,mode_switch\n" + "".join(
    f"{i / 10:.1f},0,{'Soft Puff' if 10 <= i < 15 else 'Zero Band'},{min(max(i - 10, 0), 5)},0,0,0\n"
    for i in range(30))


def _nudge(args: list[str], **options) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "nudgecli.cli", *args], stderr=subprocess.PIPE, text=True,
                          timeout=120, **options)


def _small_disk() -> None:
    """In the child: files end at 1,024 bytes, as a disk that fills up (a write is cut short, then
    fails), and SIGXFSZ is ignored so that the write fails instead of killing the process."""
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (1024, 1024))


@pytest.mark.parametrize("unbuffered", [True, False], ids=["unbuffered", "buffered"])
def test_a_document_cut_short_by_a_full_disk_is_an_error(tmp_path, unbuffered):
    log = tmp_path / "log.csv"
    log.write_text(HABITS_LOG)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    # the child's file size limit would also cut the bytecode it caches of a changed module at
    # 1,024 bytes (the cache's raw write takes the short count), breaking every later import of it
    env["PYTHONDONTWRITEBYTECODE"] = "1"
    if unbuffered:
        env["PYTHONUNBUFFERED"] = "1"  # a short write was then dropped silently: exit 0
    with open(tmp_path / "out.json", "w") as stdout:
        done = _nudge(["habits", str(log), "--format", "json"], stdout=stdout, env=env,
                      preexec_fn=_small_disk)
    assert done.returncode == 1, done.stderr
    assert one_error_line(done.stderr) == \
        "Error: cannot write to stdout: File too large; the output is incomplete"
    assert (tmp_path / "out.json").stat().st_size == 1024  # what was written is a prefix, and said to be one


def test_a_closed_stdout_is_an_error_not_a_silent_success(tmp_path):
    done = _nudge(["presets"], preexec_fn=lambda: os.close(1))
    assert done.returncode == 1
    assert one_error_line(done.stderr).startswith(
        "Error: stdout is closed, so the output could not be printed")


def test_a_reader_that_went_away_ends_the_command_quietly():
    read_end, write_end = os.pipe()
    os.close(read_end)  # `nudge presets | head -1`, head already gone
    try:
        done = _nudge(["presets"], stdout=write_end)
    finally:
        os.close(write_end)
    assert (done.returncode, done.stderr) == (checked.EXIT_BROKEN_PIPE, "")


def test_format_json_prints_null_never_nan(tmp_path):
    log = tmp_path / "log.csv"
    log.write_text(HABITS_LOG)
    reference = json.loads(invoke(["habits", str(log), "--format", "json"]).stdout)
    reference["habits"]["soft_blow"]["pooled"]["median"] = math.nan  # e.g. an older nudge's document
    (tmp_path / "reference.json").write_text(json.dumps(reference))
    result = invoke(["habits", str(log), "--format", "json", "--compare", str(tmp_path / "reference.json")])
    assert result.exit_code == 0, result.output

    def refuse(constant: str) -> None:
        raise AssertionError(f"stdout is not strict JSON: it holds {constant}")

    document = json.loads(result.stdout, parse_constant=refuse)
    row = next(r for r in document["compare"]["habits"] if r["habit"] == "soft_blow")
    assert row["reference_median"] is None


_LEAVES = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**6, 10**6),
                    st.text(max_size=4), st.none(), st.booleans(),
                    st.floats(allow_nan=True, allow_infinity=True).map(np.float64),
                    st.integers(-1000, 1000).map(np.int64))
_DOCUMENTS = st.recursive(_LEAVES, lambda inner: st.lists(inner, max_size=4)
                          | st.dictionaries(st.text(max_size=3), inner, max_size=4), max_leaves=20)


def _expected(value):
    """The strict JSON of ``value``, computed by its own walk: non-finite floats as None."""
    if isinstance(value, dict):
        return {k: _expected(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_expected(v) for v in value]
    if isinstance(value, float | np.floating):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


@given(_DOCUMENTS)
def test_strict_json_value_is_strict_json_with_null_for_every_non_finite_number(document):
    text = json.dumps(strict_json_value(document), allow_nan=False)  # raises on a NaN left over
    assert json.loads(text) == _expected(document)


def test_strict_json_value_makes_arrays_plain():
    assert strict_json_value({"a": np.array([1.0, np.nan, np.inf]), 2: (np.int32(3), np.bool_(True))}) == \
        {"a": [1.0, None, None], "2": [3, True]}


def test_checked_stdout_writes_every_byte_of_short_writes(monkeypatch):
    read_end, write_end = os.pipe()
    taken: list[int] = []
    write = os.write

    def three_at_most(fd: int, data) -> int:  # a descriptor that takes a few bytes at a time
        taken.append(len(data))
        return write(fd, bytes(data[:3]))

    monkeypatch.setattr(checked.os, "write", three_at_most)
    with open(write_end, "w", closefd=False) as stream:
        out = checked.CheckedStdout(stream)
        out.write("héllo, wörld\n")
    os.close(write_end)
    with open(read_end, "rb") as pipe:
        assert pipe.read() == "héllo, wörld\n".encode()
    assert len(taken) == 5  # 15 bytes, 3 at a time


def test_checked_stdout_waits_for_a_full_non_blocking_descriptor():
    read_end, write_end = os.pipe()
    os.set_blocking(write_end, False)  # a pipe's 64 KiB fill up long before the text is written
    text = "0123456789abcdef" * 65536
    received = bytearray()
    reader = threading.Thread(target=lambda: received.extend(_read_all(read_end)), daemon=True)
    reader.start()
    try:
        with open(write_end, "w", closefd=False) as stream:
            checked.CheckedStdout(stream).write(text)
    finally:
        os.close(write_end)
    reader.join(timeout=60)
    assert bytes(received) == text.encode()


def _read_all(fd: int) -> bytes:
    with open(fd, "rb") as pipe:
        return pipe.read()


def test_a_closed_stdout_is_not_taken_by_a_file_the_command_opens(tmp_path):
    # else the first file opened would get descriptor 1, and whatever writes to "stdout" would write into it
    code = "\n".join(["import os, sys", "from nudgecli.commands.stdout import checked_stdout",
                      "os.close(1)", "sys.stdout = None", "with checked_stdout():",
                      "    handle = open(sys.argv[1], 'w')", "    print(handle.fileno(), file=sys.stderr)"])
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "file")], stderr=subprocess.PIPE,
                          text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert int(done.stderr) != 1


# --- 6. a batch's parts and a run's layouts are verified --------------------------------------------

@pytest.fixture(scope="module")
def batch(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("trust") / "batch"
    result = invoke(["replicate", "smoke", "-R", "2", "--participants", "2", "--out", str(out)])
    assert result.exit_code == 0, result.output
    return out


def test_the_batch_record_holds_the_sha256_of_every_part(batch):
    lines = (batch / "checksums.sha256").read_text().splitlines()
    recorded = dict(reversed(line.split("  ", 1)) for line in lines)
    parts = sorted(p.relative_to(batch).as_posix() for folder in ("tasks", "analyses")
                   for p in (batch / folder).rglob("*") if p.is_file())
    assert sorted(recorded) == parts and len(parts) == 2 * 2 + 2
    for name, digest in recorded.items():
        assert hashlib.sha256((batch / name).read_bytes()).hexdigest() == digest


def test_a_batch_started_again_starts_a_new_record(tmp_path, batch):
    folder = copy_run(batch, tmp_path / "batch")
    result = invoke(["replicate", "smoke", "-R", "2", "--participants", "2", "--out", str(folder), "--force"])
    assert result.exit_code == 0, result.output
    assert (folder / "checksums.sha256").read_text() == (batch / "checksums.sha256").read_text()


def _edit_an_analysis(folder: Path) -> str:
    """Change every median of an analysis, keeping its shape (a readable, edited document)."""
    part = sorted((folder / "analyses").glob("*.json"))[0]
    document = json.loads(part.read_text())
    for entry in document["metrics"]:
        entry["median"] = {condition: 999.0 for condition in entry["median"]}
    part.write_text(json.dumps(document, indent=2))
    return f"analyses/{part.name}"


def _swap_a_task_part(folder: Path) -> str:
    """Participant 1's task part replaced by participant 0's (readable, not what was computed), its
    study's analysis gone, so that the analysis is made again from the parts kept."""
    study = sorted((folder / "tasks").iterdir())[0]
    shutil.copy(study / "part-0000.parquet", study / "part-0001.parquet")
    for analysis in (folder / "analyses").glob(f"{study.name}-*.json"):
        analysis.unlink()
    return f"tasks/{study.name}/part-0001.parquet"


@pytest.mark.parametrize("damage", [_edit_an_analysis, _swap_a_task_part], ids=["analysis", "task"])
def test_a_batch_resume_computes_again_what_its_record_does_not_vouch_for(tmp_path, batch, damage):
    folder = copy_run(batch, tmp_path / "batch")
    part = damage(folder)
    result = invoke(["replicate", "smoke", "-R", "2", "--participants", "2", "--out", str(folder),
                     "--resume"])
    assert result.exit_code == 0, result.output
    assert f"{part}: not vouched for by checksums.sha256" in result.stderr
    for table in ("replications.csv", "summary.csv", "conditions.csv"):
        assert (folder / table).read_bytes() == (batch / table).read_bytes(), table


def _reversed_layouts(run: Path) -> None:
    frame = pd.read_parquet(run / "layouts.parquet")
    frame.iloc[::-1].reset_index(drop=True).to_parquet(run / "layouts.parquet", index=False)


def _truncated_layouts(run: Path) -> None:
    data = (run / "layouts.parquet").read_bytes()
    (run / "layouts.parquet").write_bytes(data[: len(data) // 2])


def _truncated_unrecorded_layouts(run: Path) -> None:
    _truncated_layouts(run)
    manifest = json.loads((run / "manifest.json").read_text())
    del manifest["files"]  # as an older nudge's manifest: nothing to verify against
    (run / "manifest.json").write_text(json.dumps(manifest))


@pytest.mark.parametrize("damage, said", [(_reversed_layouts, "changed since it was written"),
                                          (_truncated_layouts, "changed since it was written"),
                                          (_truncated_unrecorded_layouts, "not a readable Parquet file")],
                         ids=["changed", "truncated", "truncated-unrecorded"])
def test_plot_refuses_layouts_not_as_written_and_resume_writes_them_again(tmp_path, analysed_run, damage,
                                                                          said):
    run = copy_run(analysed_run, tmp_path / "run")
    damage(run)
    args = ["plot", str(run), "--trial", "0:0", "--formats", "png", "--out", str(tmp_path / "figures")]
    result = invoke(args)
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    assert "layouts.parquet" in line and said in line and line.endswith("--resume`")
    resumed = invoke(["simulate", "smoke", "--participants", "2", "--out", str(run), "--resume"])
    assert resumed.exit_code == 0, resumed.output
    assert (run / "layouts.parquet").read_bytes() == (analysed_run / "layouts.parquet").read_bytes()
    assert invoke(args).exit_code == 0


def test_the_manifest_records_the_sha256_of_the_layouts_and_the_participants_table(smoke_run):
    files = json.loads((smoke_run / "manifest.json").read_text())["files"]
    for name in ("layouts.parquet", "participants.parquet"):
        assert files[name] == hashlib.sha256((smoke_run / name).read_bytes()).hexdigest()


def test_a_resumed_runs_part_changed_since_written_is_simulated_again_and_said(
        tmp_path: Path, capfd: pytest.CaptureFixture[str]) -> None:
    import nudgecli

    out = tmp_path / "run"
    nudgecli.simulate("smoke", out=out)
    part = out / "trials" / "part-0000.parquet"
    original = part.read_bytes()
    edited = pd.read_parquet(part)
    edited.loc[0, "duration_s"] = 1.25  # a hand edit: the manifest's SHA-256 no longer vouches for it
    edited.to_parquet(part, index=False)
    capfd.readouterr()
    said: list[str] = []
    nudgecli.simulate("smoke", out=out, resume=True, log=said.append)
    assert [line for line in said if "not vouched for" in line] == [
        f"Warning: {out}: trials/part-0000.parquet (changed since written): not vouched for by the manifest "
        "(not as this run wrote them); simulating participant(s) 0 again"]
    assert part.read_bytes() == original  # simulated again: the part the seed gives
    edited.to_parquet(part, index=False)
    nudgecli.simulate("smoke", out=out, resume=True)  # without log=: the API prints nothing
    assert capfd.readouterr().err == "" and part.read_bytes() == original
    # the command says it on stderr
    edited.to_parquet(part, index=False)
    result = CliRunner().invoke(main, ["simulate", "smoke", "--out", str(out), "--resume"])
    assert result.exit_code == 0 and "not vouched for by the manifest" in result.stderr


def test_a_batch_resumed_through_the_api_tells_log_what_it_computes_again(
        tmp_path: Path, batch: Path, capfd: pytest.CaptureFixture[str]) -> None:
    import nudgecli

    folder = copy_run(batch, tmp_path / "batch")
    part = _edit_an_analysis(folder)
    capfd.readouterr()
    said: list[str] = []
    nudgecli.replicate("smoke", replications=2, participants=2, out=folder, resume=True, log=said.append)
    assert any(line.startswith("Warning: ") and f"{part}: not vouched for by checksums.sha256" in line
               for line in said), said
    assert "not vouched for" not in capfd.readouterr().err  # the API prints nothing of its own
    assert (folder / "summary.csv").read_bytes() == (batch / "summary.csv").read_bytes()
