"""Guards of the command line (issue 21, items 9-14): machine output alone on stdout, batch
folders locked, a foreign service refused as a scheduler, size checked before any work, no
stderr, Ctrl-C of a batch, locks only on what is written, temporary names that fit.

Real processes where the fault is a process's (a concurrent batch, SIGINT, a closed stderr), a
tiny socket server in a thread for the scheduler, injected OSErrors where this machine (root)
cannot make a folder read-only."""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import shlex
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import click
import numpy as np
import pytest
from cli_helpers import one_error_line, wait_for
from click.testing import CliRunner

from nudgecli import store
from nudgecli.cli import main
from nudgecli.errors import ConfigError
from nudgecli.report.plans import MAX_RESAMPLES, check_resamples
from nudgecli.run_folder_names import LOCK
from nudgecli.runs import batch as batch_module
from nudgecli.runs import study as study_module
from nudgecli.runs.batch import Batch, Point, build_graph, estimate, estimate_batch, single_point
from nudgecli.runs.size import MAX_TRIALS_WITHOUT_YES, check_size, trials_per_participant
from nudgecli.store import write_text_atomic

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}
NUDGE = [sys.executable, "-m", "nudgecli.cli"]
TABLE = ROOT / "tests" / "data" / "metrics_two_conditions.csv"
SHIPPED_TIMEOUT_S = study_module.SCHEDULER_TIMEOUT_S
GRID = """
experiment = "smoke"
replications = 1
seed = 3

[design]
method = "grid"

[parameters]
"study.participants" = [2]
"""


def invoke(args: list[str]):
    return CliRunner().invoke(main, args)


@contextlib.contextmanager
def held_elsewhere(folder: Path) -> Iterator[subprocess.Popen]:
    """Another process holds ``folder``'s lock (as a running ``analyze`` or batch does)."""
    code = ("import sys, time\nfrom nudgecli.locks import run_lock\n"
            "with run_lock(sys.argv[1], command='nudge analyze (elsewhere)'):\n"
            "    print('held', flush=True)\n    time.sleep(120)\n")
    proc = subprocess.Popen([sys.executable, "-c", code, str(folder)], env=ENV, stdout=subprocess.PIPE,
                            text=True)
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == "held"
        yield proc
    finally:
        proc.kill()
        proc.wait()


# --- 9: under --format json|csv, stdout is the document alone ----------------------------------


def format_args(tmp_path: Path) -> dict[str, list[str]]:
    """Small but real arguments of every command that has --format."""
    sweep = tmp_path / "grid.toml"
    sweep.write_text(GRID)
    log = tmp_path / "log.csv"  # a real log: a 0.5 s soft blow that moves the robot, then a pause
    log.write_text("t,trial,label,x,y,theta,mode_switch\n" + "".join(
        f"{i / 10:.1f},0,{'Soft Puff' if 10 <= i < 15 else 'Zero Band'},{min(max(i - 10, 0), 5)},0,0,0\n"
        for i in range(30)))
    return {
        "analyze": ["analyze", str(TABLE), "--out", str(tmp_path / "analysis"), "--bootstrap", "100"],
        "bench": ["bench", "--only", "model", "--repeats", "1", "--baseline-repeats", "1"],
        "compare": ["compare", str(TABLE), str(TABLE), "--resamples", "0", "--out", str(tmp_path / "compare"),
                    "--formats", "png"],
        "habits": ["habits", str(log)],
        "plot-population": ["plot-population", "smoke", "--participants", "1", "--formats", "png", "--out",
                            str(tmp_path / "population")],
        "power": ["power", "smoke", "--participants", "2,3", "-R", "1", "--out", str(tmp_path / "power")],
        "replicate": ["replicate", "smoke", "-R", "1", "--participants", "2", "--out",
                      str(tmp_path / "replicate")],
        "sweep": ["sweep", str(sweep), "--out", str(tmp_path / "sweep")],
        "validate": ["validate", "--simulations", "2", "--mc-queries", "0", "--out",
                     str(tmp_path / "validate")],
    }


def commands_with_format() -> dict[str, list[str]]:
    """Every command of the group with a --format option, and its machine formats (not "table")."""
    found = {}
    for name, command in main.commands.items():
        for param in command.params:
            if param.name == "output_format" and isinstance(param.type, click.Choice):
                found[name] = [str(c) for c in param.type.choices if c != "table"]
    return found


@pytest.mark.parametrize("name", sorted(commands_with_format()))
def test_machine_formats_put_the_document_alone_on_stdout(tmp_path, name):
    args = format_args(tmp_path).get(name)
    assert args is not None, f"`nudge {name}` has --format: give it arguments in format_args"
    batch = name in ("replicate", "power", "sweep")
    for position, output_format in enumerate(commands_with_format()[name]):
        again = ["--resume"] if batch and position > 0 else []  # the batch's tasks are done: fast
        if name in ("analyze", "compare") and position > 0:
            again = ["--force"]  # --out holds the first format's files now
        result = invoke([*args, *again, "--format", output_format])
        assert result.exit_code == 0, result.output
        if output_format == "json":
            json.loads(result.stdout)  # the whole of stdout is one JSON document
        else:
            rows = list(csv.reader(io.StringIO(result.stdout)))
            assert len(rows) >= 2 and all(len(row) == len(rows[0]) for row in rows), result.stdout
        if batch:
            assert "Batch folder: " in result.stderr  # the folder is said on stderr instead
    assert set(commands_with_format()) >= {"replicate", "power", "sweep", "analyze"}


def test_the_table_format_still_ends_with_the_batch_folder(tmp_path):
    out = tmp_path / "r"
    result = invoke(["replicate", "smoke", "-R", "1", "--participants", "2", "--out", str(out)])
    assert result.exit_code == 0 and result.stdout.splitlines()[-1] == str(out)


# --- 10 and 13a: batch folders are locked; Ctrl-C of a batch says the command that resumes it ---


def test_a_running_batch_is_locked_and_ctrl_c_prints_the_command_that_resumes_it(tmp_path):
    out = tmp_path / "batch"
    # 20 studies: long enough that the batch cannot finish between its first part and the test's
    # SIGSTOP on a loaded machine (6 could, once its analyses stopped importing scipy.stats)
    args = ["replicate", "smoke", "-R", "20", "--participants", "2", "--seed", "4", "--workers", "2",
            "--format", "csv"]
    # a new session: Ctrl-C in a terminal reaches the whole process group, workers included
    first = subprocess.Popen([*NUDGE, *args, "--out", str(out)], env=ENV, stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        wait_for(lambda: any((out / "tasks").glob("*/part-*.parquet")) or first.poll() is not None)
        if first.poll() is not None:
            pytest.skip("the first batch finished before its first part was seen (a very fast machine)")
        # held where it is (workers too), so that neither the second writer nor Ctrl-C can come
        # after the batch's end, however long the second writer takes on a loaded machine
        os.killpg(first.pid, signal.SIGSTOP)
        second = invoke(["replicate", "smoke", "-R", "1", "--out", str(out), "--force"])
        line = one_error_line(second.output)
        assert second.exit_code == 1 and "in use by" in line and f"pid {first.pid}" in line
        assert json.loads((out / "batch.json").read_text())["batch"]["replications"] == 20  # untouched
        assert any((out / "tasks").glob("*/part-*.parquet"))
        os.killpg(first.pid, signal.SIGINT)  # pending until it runs again: Ctrl-C as it resumes
        os.killpg(first.pid, signal.SIGCONT)
        interrupted = time.monotonic()
        stderr = first.communicate(timeout=60)[1]
        assert time.monotonic() - interrupted < 10, "the batch must exit promptly after Ctrl-C"
    finally:
        if first.poll() is None:
            first.kill()
            first.wait()
    assert first.returncode == 130, (first.returncode, stderr)
    assert "Traceback" not in stderr
    manifest = json.loads((out / "batch.json").read_text())
    assert manifest["status"] == "interrupted"  # not left "running"
    command = stderr.split("resume with: ")[1].strip().splitlines()[0]
    # the batch's own experiment and plan (every replicate and power batch keeps them), so the
    # command works from any folder
    assert command == (f"nudge replicate {out}/experiment.toml --plan {out}/plan.toml --replications 20 "
                       f"--seed 4 --participants 2 --workers 2 --format csv --out {out} --resume")
    resumed = invoke(shlex.split(command)[1:])
    assert resumed.exit_code == 0, resumed.output
    assert json.loads((out / "batch.json").read_text())["status"] == "complete"
    assert not (out / LOCK).exists()


def test_ctrl_c_before_a_batch_starts_says_to_run_it_again(tmp_path, monkeypatch):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(batch_module, "prepare_folder", interrupted)
    result = invoke(["replicate", "smoke", "-R", "1", "--out", str(tmp_path / "b")])
    assert result.exit_code == 130 and "nothing was computed yet; run the command again" in result.output


def test_ctrl_c_of_simulate_with_workers_exits_promptly(tmp_path):
    out = tmp_path / "run"
    proc = subprocess.Popen([*NUDGE, "simulate", "smoke", "--participants", "60", "--workers", "2", "--out",
                             str(out)], env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        wait_for(lambda: (out / "participants" / "part-0000.parquet").exists() or proc.poll() is not None)
        os.killpg(proc.pid, signal.SIGINT)
        interrupted = time.monotonic()
        stderr = proc.communicate(timeout=60)[1]
        waited = time.monotonic() - interrupted
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130, stderr
    assert waited < 5, f"exited {waited:.1f} s after Ctrl-C: the pool ran its queued participants first"
    assert "--resume" in stderr
    assert json.loads((out / "manifest.json").read_text())["status"] == "interrupted"



class _ExitCalledError(Exception):
    """What the test's stand-in for ``os._exit`` raises instead of ending pytest."""


@pytest.mark.parametrize("code", [130, 1, 0])
def test_entry_point_leaves_at_once_only_after_ctrl_c(monkeypatch, code):
    # After Ctrl-C the interpreter's shutdown can wait for ever on a stopped pool worker's queue
    # (CPython 3.11), so the program must leave with os._exit, its streams flushed first; any
    # other exit goes through the normal shutdown.
    from nudgecli import cli

    events: list[str] = []

    def fake_main() -> None:
        print("written before the exit", end="")
        raise SystemExit(code)

    class Stream(io.StringIO):
        def flush(self) -> None:
            events.append("flush")
            super().flush()

    def fake_exit(status: int) -> None:
        events.append(f"exit {status}")
        raise _ExitCalledError

    monkeypatch.setattr(cli, "main", fake_main)
    monkeypatch.setattr(os, "_exit", fake_exit)
    monkeypatch.setattr(sys, "stdout", Stream())
    monkeypatch.setattr(sys, "stderr", Stream())
    if code == 130:
        with pytest.raises(_ExitCalledError):
            cli.entry_point()
        assert events == ["flush", "flush", "exit 130"]
    else:
        with pytest.raises(SystemExit) as raised:
            cli.entry_point()
        assert raised.value.code == code and events == []


def test_the_program_freezes_the_collector_after_every_other_exit_handler() -> None:
    # The interpreter's final collections over the heap a command built took 0.1-0.2 s of a
    # short command; frozen, they skip it. Frozen last: exit handlers that free things
    # (a pool's, a temporary folder's) run first, with the collector still working.
    program = (
        "import atexit, gc, sys\n"
        "from nudgecli import cli\n"
        "gc.freeze = lambda: print('frozen', flush=True)\n"
        "def command():\n"
        "    atexit.register(print, 'a handler the command registered')\n"
        "    raise SystemExit(3)\n"
        "cli.main = command\n"
        "cli.entry_point()\n"
    )
    done = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, timeout=60,
                          env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])})
    assert done.returncode == 3, done.stderr
    assert done.stdout.splitlines() == ["a handler the command registered", "frozen"]


# --- 11: a service that is not a dask scheduler ------------------------------------------------


@contextlib.contextmanager
def foreign_service(greeting: bytes | None) -> Iterator[int]:
    """A local TCP service that greets first (``greeting``, as SSH does) or never says anything
    (an HTTP server waits for a request); yields its port."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    clients: list[socket.socket] = []

    def serve() -> None:
        with contextlib.suppress(OSError):
            while True:
                client, _ = server.accept()
                clients.append(client)
                if greeting is not None:
                    client.sendall(greeting)

    threading.Thread(target=serve, daemon=True).start()
    try:
        yield server.getsockname()[1]
    finally:
        server.close()
        for client in clients:
            client.close()


@pytest.mark.parametrize("greeting", [b"SSH-2.0-OpenSSH_9.6\r\n", None], ids=["speaks-first", "silent"])
def test_a_scheduler_address_of_another_service_is_refused_in_one_line(tmp_path, monkeypatch, greeting):
    monkeypatch.setattr(study_module, "SCHEDULER_TIMEOUT_S", 1.5)  # the shipped 7 s, shortened for the test
    out = tmp_path / "batch"
    results = []
    with foreign_service(greeting) as port:
        address = f"tcp://127.0.0.1:{port}"
        call = threading.Thread(target=lambda: results.append(CliRunner().invoke(
            main, ["replicate", "smoke", "-R", "1", "--participants", "2", "--scheduler", address, "--out",
                   str(out)])), daemon=True)
        started = time.monotonic()
        call.start()
        call.join(timeout=20)
        assert not call.is_alive(), "connecting to a foreign service must not hang"
    assert time.monotonic() - started < 10
    said = "\n".join(line for line in results[0].output.splitlines() if not line.startswith("batch: "))
    line = one_error_line(said)
    assert results[0].exit_code == 1 and address in line and "dask scheduler" in line
    assert not out.exists()
    assert 0 < SHIPPED_TIMEOUT_S <= 8  # the refusal, with Python's start, comes within 10 s


# --- 12: size first, in constant memory --------------------------------------------------------


def _never(*args, **kwargs):
    raise AssertionError("work started before the size check")


def test_the_size_limits_allow_the_limit_itself_and_refuse_one_more() -> None:
    check_resamples(MAX_RESAMPLES, "--bootstrap")
    check_resamples(None, "--bootstrap")
    with pytest.raises(ConfigError, match="--bootstrap 1,000,001: at most 1,000,000"):
        check_resamples(MAX_RESAMPLES + 1, "--bootstrap")
    check_size(MAX_TRIALS_WITHOUT_YES, False)
    check_size(MAX_TRIALS_WITHOUT_YES + 1, True)  # --yes
    with pytest.raises(ConfigError, match=f"simulate {MAX_TRIALS_WITHOUT_YES + 1:,} trials"):
        check_size(MAX_TRIALS_WITHOUT_YES + 1, False)
    check_size(5, False, limit=5)
    with pytest.raises(ConfigError, match=r"calibrate 6 people \(more than 5; 1 s\)"):
        check_size(6, False, limit=5, work="calibrate {} people", details="1 s")


@pytest.mark.parametrize(("args", "limit"), [
    (["replicate", "smoke", "-R", "1000000000000"], f"more than {MAX_TRIALS_WITHOUT_YES:,}"),
    # (counts within the participant bound, 10,000: above it the bound refuses them first)
    (["power", "smoke", "--participants", "2,10000", "-R", "30"], f"more than {MAX_TRIALS_WITHOUT_YES:,}"),
    (["simulate", "paper", "--participants", "10000"], f"more than {MAX_TRIALS_WITHOUT_YES:,}"),
    (["run", "paper", "--participants", "10000"], f"more than {MAX_TRIALS_WITHOUT_YES:,}"),
    (["plot-population", "smoke", "--participants", "100000000"], "calibrate 100,000,000 simulated"),
    (["validate", "--simulations", "100000000"], "run 20,000,000,000 queries"),
    (["analyze", str(TABLE), "--bootstrap", "1000000000"], "at most 1,000,000 bootstrap resamples"),
    (["compare", str(TABLE), str(TABLE), "--resamples", "1000000000"], "at most 1,000,000 bootstrap"),
], ids=["replicate", "power", "simulate", "run", "plot-population", "validate", "analyze", "compare"])
def test_a_huge_command_is_refused_before_any_work(tmp_path, monkeypatch, args, limit):
    import nudgecli.report.analysis as analysis
    import nudgecli.report.compare as compare
    import nudgecli.sim.real_population as real_population
    import nudgecli.sim.validation as validation

    for module, name in ((batch_module, "build_graph"), (batch_module, "check_physiology_logs"),
                         (study_module.StudyPlan, "build"), (study_module, "check_physiology_logs"),
                         (study_module, "build_plan_on"),
                         (real_population, "simulated_diagonals"), (validation, "run_validation"),
                         (analysis, "analyze"), (compare, "compare_sources")):
        monkeypatch.setattr(module, name, _never)
    out = tmp_path / "out"
    started = time.monotonic()
    result = invoke([*args, "--out", str(out)])
    assert time.monotonic() - started < 5
    line = one_error_line(result.output)
    assert result.exit_code == 1 and limit in line
    assert "--yes" in line or "resamples" in line
    assert not out.exists()


def test_a_huge_sweep_is_refused_before_any_work(tmp_path, monkeypatch):
    monkeypatch.setattr(batch_module, "build_graph", _never)
    path = tmp_path / "big.toml"
    path.write_text(GRID)
    result = invoke(["sweep", str(path), "-R", "1000000000000", "--out", str(tmp_path / "out")])
    assert result.exit_code == 1 and "--yes" in one_error_line(result.output)


def test_simulate_above_the_limit_runs_with_yes(tmp_path, monkeypatch):
    monkeypatch.setattr("nudgecli.runs.size.MAX_TRIALS_WITHOUT_YES", 10)
    out = tmp_path / "run"
    refused = invoke(["simulate", "smoke", "--participants", "2", "--out", str(out)])
    assert refused.exit_code == 1 and "16 trials" in refused.output and not out.exists()
    accepted = invoke(["simulate", "smoke", "--participants", "2", "--out", str(out), "--yes"])
    assert accepted.exit_code == 0, accepted.output


def test_the_closed_form_size_is_the_graphs(tmp_path):
    from nudgecli.config import load_experiment
    from nudgecli.report.plans import AnalysisPlan

    smoke = load_experiment("smoke")
    other = load_experiment("smoke", ["inference.kappa=0.7"])
    power = Batch("power", single_point(smoke, (2, 3, 5)), 4, 1, AnalysisPlan())
    # a sweep with a repeated experiment (one study) and another with a different count per point
    sweep = Batch("sweep", (Point(0, {"k": 1}, smoke, (3,)), Point(1, {"k": 2}, other, (2,)),
                            Point(2, {"k": 1}, smoke, (4,))), 3, 7, AnalysisPlan())
    for batch in (power, sweep):
        assert estimate_batch(batch, workers=2) == estimate(build_graph(batch), workers=2,
                                                            power=batch.kind == "power")
    assert estimate_batch(sweep, 1).trials == 3 * (4 + 2) * trials_per_participant(smoke)


# --- 13: no stderr at all ----------------------------------------------------------------------


def without_stderr(command_line: str) -> subprocess.CompletedProcess:
    """Run a shell command line with stderr closed, as ``2>&-`` does."""
    return subprocess.run(["bash", "-c", f"{command_line} 2>&-"], env=ENV, capture_output=True, text=True,
                          timeout=120)


@pytest.mark.parametrize("command", ["simulate", "analyze", "replicate"])
def test_commands_work_with_stderr_closed(tmp_path, command):
    out = tmp_path / "out"
    args = {"simulate": ["simulate", "smoke", "--participants", "2"],
            "analyze": ["analyze", str(TABLE), "--bootstrap", "100"],
            "replicate": ["replicate", "smoke", "-R", "1", "--participants", "2"]}[command]
    line = " ".join(shlex.quote(a) for a in [*NUDGE, *args, "--out", str(out)])
    done = without_stderr(line)
    assert done.returncode == 0, done.stdout
    assert done.stdout.strip().splitlines()[-1] == str(out) or command == "analyze"
    if command == "replicate":
        assert json.loads((out / "batch.json").read_text())["status"] == "complete"
    assert not (out / LOCK).exists()


def test_a_refusal_with_stderr_closed_is_clean(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    line = " ".join(shlex.quote(a) for a in [*NUDGE, "replicate", "smoke", "-R", "1", "--out", str(out)])
    done = without_stderr(line)
    assert done.returncode == 1 and done.stdout == ""  # the error had nowhere to go, and nothing else
    assert sorted(p.name for p in out.iterdir()) == ["keep.txt"]


# --- 14: lock what is written, check writability first -----------------------------------------


@pytest.fixture(scope="module")
def analysed_table(tmp_path_factory: pytest.TempPathFactory) -> Path:
    table = tmp_path_factory.mktemp("table") / "study.csv"
    table.write_text(TABLE.read_text())
    assert invoke(["analyze", str(table), "--bootstrap", "100"]).exit_code == 0
    return table


@pytest.fixture(scope="module")
def analysed_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    run = tmp_path_factory.mktemp("run") / "run"
    assert invoke(["simulate", "smoke", "--participants", "2", "--out", str(run)]).exit_code == 0
    assert invoke(["analyze", str(run), "--bootstrap", "100"]).exit_code == 0
    return run


def test_plot_of_a_table_waits_for_the_analysis_that_holds_its_folder(analysed_table):
    folder = analysed_table.with_name("study-analysis")
    with held_elsewhere(folder) as holder:
        result = invoke(["plot", str(analysed_table), "--formats", "png"])
    line = one_error_line(result.output)
    assert result.exit_code == 1 and "in use by" in line and f"pid {holder.pid}" in line
    assert not (folder / "figures").exists()
    assert invoke(["plot", str(analysed_table), "--formats", "png"]).exit_code == 0


def test_plot_elsewhere_locks_only_elsewhere(tmp_path, analysed_run):
    elsewhere = tmp_path / "figures"
    with held_elsewhere(analysed_run):  # e.g. an analysis of RUN: plotting elsewhere only reads it
        result = invoke(["plot", str(analysed_run), "--formats", "png", "--out", str(elsewhere)])
    assert result.exit_code == 0, result.output
    assert any(elsewhere.glob("*.png")) and not (elsewhere / LOCK).exists()
    with held_elsewhere(elsewhere) as holder:
        refused = invoke(["plot", str(analysed_run), "--formats", "png", "--out",
                                            str(elsewhere)])
    assert refused.exit_code == 1 and f"pid {holder.pid}" in one_error_line(refused.output)


def test_plot_of_a_read_only_run_elsewhere_works(tmp_path, analysed_run, monkeypatch):
    # root ignores a folder's permissions: make every file creation inside RUN fail as read-only
    import builtins
    import tempfile

    real_open, real_mkstemp = builtins.open, tempfile.mkstemp

    def inside_run(path) -> bool:
        return str(path).startswith(str(analysed_run))

    def read_only_open(file, mode="r", *args, **kwargs):
        if any(c in mode for c in "wax+") and inside_run(file):
            raise PermissionError(13, "Permission denied", str(file))
        return real_open(file, mode, *args, **kwargs)

    def read_only_mkstemp(*args, dir=None, **kwargs):
        if inside_run(dir):
            raise PermissionError(13, "Permission denied", str(dir))
        return real_mkstemp(*args, dir=dir, **kwargs)

    monkeypatch.setattr(builtins, "open", read_only_open)
    monkeypatch.setattr(tempfile, "mkstemp", read_only_mkstemp)
    result = invoke(["plot", str(analysed_run), "--formats", "png", "--out",
                                       str(tmp_path / "elsewhere")])
    assert result.exit_code == 0, result.output
    refused = invoke(["plot", str(analysed_run), "--formats", "png"])  # into RUN itself
    assert refused.exit_code == 1 and "Permission denied" in one_error_line(refused.output)


@pytest.mark.parametrize("command", ["compare", "plot-population"])
def test_an_unwritable_out_is_refused_before_computing(tmp_path, monkeypatch, command):
    import nudgecli.report.compare as compare
    import nudgecli.sim.real_population as real_population

    monkeypatch.setattr(compare, "compare_sources", _never)
    monkeypatch.setattr(real_population, "simulated_diagonals", _never)
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    out = str(blocker / "out")  # cannot be made, even by root
    args = {"compare": ["compare", str(TABLE), str(TABLE), "--out", out],
            "plot-population": ["plot-population", "smoke", "--participants", "1", "--out", out]}[command]
    result = invoke(args)
    assert result.exit_code == 1 and out in one_error_line(result.output)
    assert result.stdout == ""  # nothing computed, nothing printed


# --- temporary names that fit ------------------------------------------------------------------


@pytest.mark.parametrize("name", ["a" * 255, "é" * 127 + "a", "p" * 250 + ".json", "x.json"],
                         ids=["ascii-255", "utf8-255", "json-255", "short"])
def test_a_legal_long_file_name_is_written(tmp_path, name):
    target = tmp_path / name
    assert len(name.encode()) <= 255
    write_text_atomic(target, "content")
    assert target.read_text() == "content" and sorted(p.name for p in tmp_path.iterdir()) == [name]
    prefix = store.temporary_prefix(target)
    assert prefix.startswith(".") and len(prefix.encode()) + 8 + len(".tmp") <= 255
    assert name.startswith(prefix[1:-1])  # still tells which file it belongs to


def test_fit_writes_a_profile_named_with_255_bytes(tmp_path, analysed_run):
    out = tmp_path / ("profile-" + "q" * 242 + ".json")
    assert len(out.name.encode()) == 255
    result = invoke(["fit", str(analysed_run / "calibration" / "participant-0000"), "--out",
                                       str(out)])
    assert result.exit_code == 0, result.output
    assert json.loads(out.read_text()) and sorted(p.name for p in tmp_path.iterdir()) == [out.name]


def test_aborting_the_process_pool_does_not_wait_for_a_running_task():
    from nudgecli.runs.executors import Job, ProcessExecutor

    executor = ProcessExecutor(1)
    executor.submit(Job("slow", time.sleep, (30,), affinity="a"))
    executor._fill()  # the job is now in the worker
    time.sleep(0.2)
    started = time.monotonic()
    executor.abort()
    assert time.monotonic() - started < 3  # close() would wait for its farewell, then terminate
    assert all(not slot.process.is_alive() for slot in executor._slots)


def test_ctrl_c_of_a_large_simulation_resumes_with_yes(tmp_path, monkeypatch):
    monkeypatch.setattr("nudgecli.runs.size.MAX_TRIALS_WITHOUT_YES", 10)
    out = tmp_path / "run"
    original = store.RunFolder.write_participant_parts
    calls = []

    def interrupted_after_one(self, *args, **kwargs):
        if calls:
            raise KeyboardInterrupt
        calls.append(1)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(store.RunFolder, "write_participant_parts", interrupted_after_one)
    result = invoke(["simulate", "smoke", "--participants", "3", "--yes", "--out", str(out)])
    assert result.exit_code == 130
    command = result.output.split("resume with: ")[1].strip().splitlines()[0]
    assert "--yes" in shlex.split(command)
    monkeypatch.setattr(store.RunFolder, "write_participant_parts", original)
    resumed = invoke(shlex.split(command)[1:])
    assert resumed.exit_code == 0, resumed.output


# --- values as the user wrote them ---------------------------------------------------------------


@pytest.mark.parametrize(("override", "said"), [
    ("population.rest_s=abc",
     "population.rest_s: should be a list, e.g. --set 'population.rest_s=[0.3, 1.5]' (got \"abc\")"),
    ("population.rest_s=[1]", "population.rest_s: too few values (got [1])"),
    ("study.participants=eight", '(got "eight")'),
    ("study.conditions=[true]", "(got true)"),
])
def test_config_errors_show_values_as_written_without_pydantic_words(override, said):
    result = invoke(["simulate", "smoke", "--set", override, "--out", "never-made"])
    line = one_error_line(result.output)
    assert result.exit_code == 1 and said in line
    for internal in ("tuple", "Field required", "np.", "True"):
        assert internal not in line
    assert not Path("never-made").exists()


def test_a_numpy_value_is_shown_plainly():
    from pydantic import ValidationError

    from nudgecli.config import ExperimentConfig
    from nudgecli.config_files import format_validation_error

    with pytest.raises(ValidationError) as caught:
        ExperimentConfig.model_validate({"population": {"rest_s": (np.float64(0.0), np.float64(150.0))}})
    message = format_validation_error(caught.value, "x.toml", ExperimentConfig)
    assert "got [0.0, 150.0]" in message and "np." not in message
