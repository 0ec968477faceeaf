"""Nothing taken on trust (issue 38), the misleading messages: ``compare``'s conditions, a plan's
conditions, SIGTERM and a lost dask worker, each through the command line where a user meets it."""

from __future__ import annotations

import json
import os
import shlex
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from cli_helpers import one_error_line, wait_for
from click.testing import CliRunner
from dask_helpers import local_cluster

from nudgecli.cli import main

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}
NUDGE = [sys.executable, "-m", "nudgecli.cli"]


def invoke(args: list[str]):
    return CliRunner().invoke(main, args)


# --- SIGTERM -------------------------------------------------------------------------------------


@pytest.mark.parametrize("workers", ["1", "2"])
def test_sigterm_marks_the_run_interrupted_releases_the_lock_and_exits_143(tmp_path, workers):
    """200 participants take far longer than the wait for the manifest: the signal lands mid-run,
    with two workers often while a worker is being forked (a handler's exception lost there)."""
    out = tmp_path / "run"
    proc = subprocess.Popen([*NUDGE, "simulate", "smoke", "--participants", "200", "--workers", workers,
                             "--out", str(out)], env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)
    try:
        wait_for(lambda: (out / "manifest.json").exists() or proc.poll() is not None)
        proc.send_signal(signal.SIGTERM)
        stderr = proc.communicate(timeout=60)[1]
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
    assert proc.returncode == 143, stderr
    assert "Traceback" not in stderr
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["status"] == "interrupted"
    assert not (out / ".nudge.lock").exists()
    command = stderr.split("resume with: ")[1].strip().splitlines()[0]
    assert command.startswith("nudge simulate smoke --out ") and command.endswith("--resume")
    assert shlex.split(command)[4] == str(out)


@pytest.mark.parametrize("workers", [1, 2])
def test_an_interrupt_before_the_first_participant_marks_the_run_interrupted(tmp_path, workers):
    """The signal in the test above can land in the instant after the manifest reads "running" and
    before the first participant (here: in the progress bar's first call); CI once saw that
    leave the manifest "running"."""
    from nudgecli.config import load_experiment
    from nudgecli.runs.study import run_study

    def interrupted_progress(done: int, total: int) -> None:
        raise KeyboardInterrupt

    out = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        run_study(load_experiment("smoke"), out, participants=3, workers=workers,
                  progress=interrupted_progress)
    assert json.loads((out / "manifest.json").read_text())["status"] == "interrupted"
    assert not (out / ".nudge.lock").exists()


# --- a lost dask worker --------------------------------------------------------------------------


@pytest.fixture()
def cluster():
    """An in-process dask cluster on TCP (its tasks see this test's monkeypatching)."""
    with local_cluster(1) as local:
        yield local


def _cancel_own_task(*args):
    """A task that cancels itself, as the scheduler cancels the tasks of a worker it lost."""
    from distributed import Future, get_client, get_worker

    key = get_worker().get_current_task()
    client = get_client()
    client.cancel([Future(key, client=client)], reason="worker-lost")
    import time

    time.sleep(1)


def test_a_cancelled_dask_task_is_one_error_line_naming_the_loss_and_the_resume_command(tmp_path, cluster,
                                                                                       monkeypatch):
    monkeypatch.setattr("nudgecli.runs.study.simulate_on_worker", _cancel_own_task)
    out = tmp_path / "run"
    result = invoke(["simulate", "smoke", "--participants", "2", "--out", str(out),
                     "--scheduler", cluster.scheduler_address])
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output.replace(f"Run folder: {out}", ""))
    assert "lost" in line and "dask" in line
    # the resume command Ctrl-C prints, on the scheduler typed (a resume without it ran locally)
    assert line.endswith(f"resume with: nudge simulate smoke --out {out} --participants 2 "
                         f"--scheduler {cluster.scheduler_address} --resume"), line
    assert json.loads((out / "manifest.json").read_text())["status"] == "interrupted"


def test_a_watched_result_turns_a_cancelled_future_into_a_worker_lost_error(cluster):
    from distributed import Client

    from nudgecli.errors import WorkerLostError
    from nudgecli.runs.dask_results import watched_result

    with Client(cluster) as client:
        assert watched_result(client.submit(sum, [1, 2]), "a sum") == 3
        future = client.submit(__import__("time").sleep, 2, pure=False)
        client.cancel([future], reason="worker-lost")
        with pytest.raises(WorkerLostError, match=r"^the dask cluster lost task 7 \(worker-lost: "):
            watched_result(future, "task 7")
        failing = client.submit(int, "x")  # a task's own error is not a lost worker
        with pytest.raises(ValueError):
            watched_result(failing, "task 8")


# --- compare's conditions ------------------------------------------------------------------------


def _metrics_table(path: Path, conditions: list[str], seed: int = 0) -> Path:
    """A small metrics table: 3 participants x 4 trials of each condition."""
    import numpy as np
    import pandas as pd

    rng = np.random.default_rng(seed)
    rows = [{"participant": f"p{p}", "condition": condition, "trial": t,
             "completion_time": float(20 + rng.normal()), "mode_switches": int(rng.integers(3, 9))}
            for condition in conditions for p in range(3) for t in range(4)]
    pd.DataFrame(rows).to_csv(path, index=False)
    return path


def test_compare_refuses_near_identical_condition_labels_with_a_did_you_mean(tmp_path):
    simulated = _metrics_table(tmp_path / "sim.csv", ["disambiguation", "control"])
    for label in ("Control ", "CONTROL", " control"):
        real = _metrics_table(tmp_path / "real.csv", ["disambiguation", label], seed=1)
        result = invoke(["compare", str(simulated), str(real), "--resamples", "0"])
        assert result.exit_code == 1, result.output
        line = one_error_line(result.output)
        assert f"{real}: condition {label!r}" in line and "(did you mean 'control'?)" in line, line
        assert f"--match {shlex.quote('control=' + label)}" in line, line
        # the fix the line gives works
        fixed = invoke(["compare", str(simulated), str(real), "--resamples", "0", "--format", "json",
                        "--match", f"control={label}"])
        assert fixed.exit_code == 0, fixed.output
        assert json.loads(fixed.stdout)["conditions"] == ["disambiguation", label]


def test_compare_says_which_conditions_one_table_holds_alone(tmp_path):
    simulated = _metrics_table(tmp_path / "sim.csv", ["disambiguation", "control", "teleoperation"])
    real = _metrics_table(tmp_path / "real.csv", ["disambiguation", "control", "blending"], seed=1)
    result = CliRunner().invoke(main, ["compare", str(simulated), str(real), "--resamples", "0",
                                       "--format", "json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["conditions"] == ["disambiguation", "control"]
    notes = [line for line in result.stderr.splitlines() if line.startswith("Note: condition ")]
    assert notes == [
        f"Note: condition 'blending' is only in the real table ({real}): not compared; pair it with "
        "--match SIMULATED=blending",
        f"Note: condition 'teleoperation' is only in the simulated source ({simulated}): not compared; "
        "pair it with --match teleoperation=REAL",
    ], result.stderr


# --- a plan's conditions -------------------------------------------------------------------------

TWO_CONDITIONS = Path(__file__).with_name("data") / "metrics_two_conditions.csv"


def _plan(path: Path, conditions: list[str]) -> Path:
    path.write_text(f"conditions = {json.dumps(conditions)}\n")
    return path


@pytest.mark.parametrize(("listed", "named", "suggested"), [
    (["Disambiguation", "control"], "Disambiguation", "disambiguation"),  # differently cased
    (["disambiguation", "control "], "control ", "control"),               # a space too many
    (["disambiguation", "baseline"], "baseline", None),                    # missing, control unnamed
    (["disambig", "ctrl"], "disambig", "disambiguation"),                  # neither spelled as the data
])
def test_a_plan_naming_a_condition_the_data_lacks_is_refused(tmp_path, listed, named, suggested):
    plan = _plan(tmp_path / "mine.toml", listed)
    out = tmp_path / "analysis"
    result = invoke(["analyze", str(TWO_CONDITIONS), "--plan", str(plan), "--out", str(out)])
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    assert line.startswith(f"Error: {plan}: conditions names {named!r}, which {TWO_CONDITIONS} does not hold")
    assert "its conditions: control, disambiguation" in line, line
    if suggested is not None:
        assert f"(did you mean {suggested!r}?)" in line, line
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.parametrize("listed", [
    ["disambiguation", "control", "blending"],  # a plan over more conditions than this study's
    ["teleoperation", "hindsight"],             # another study's plan: its order applies to nothing here
])
def test_a_plan_whose_conditions_cover_the_data_or_name_none_of_it_is_used(tmp_path, listed):
    plan = _plan(tmp_path / "wider.toml", listed)
    result = invoke(["analyze", str(TWO_CONDITIONS), "--plan", str(plan), "--out", str(tmp_path / "a"),
                     "--bootstrap", "100", "--format", "json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["conditions"] == ["disambiguation", "control"]


def test_run_refuses_a_plan_misnaming_the_experiments_conditions_before_simulating(tmp_path):
    """The run will hold the experiment's conditions: a plan misnaming them was refused only by the
    analysis, after the whole study had been simulated."""
    plan = _plan(tmp_path / "mine.toml", ["Disambiguation", "control"])
    out = tmp_path / "run"
    result = invoke(["run", "smoke", "--plan", str(plan), "--out", str(out)])
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    assert line.startswith(f"Error: {plan}: conditions names 'Disambiguation', which experiment smoke does "
                           "not hold (did you mean 'disambiguation'?)"), line
    assert not out.exists()


@pytest.mark.parametrize("command", [["replicate", "smoke", "-R", "2"],
                                     ["power", "smoke", "--participants", "2,3", "-R", "2"]])
def test_a_batch_refuses_a_plan_misnaming_the_experiments_conditions_before_simulating(tmp_path, command):
    plan = _plan(tmp_path / "mine.toml", ["disambiguation", "Control"])
    out = tmp_path / "batch"
    result = invoke([*command, "--plan", str(plan), "--out", str(out)])
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    assert line.startswith(f"Error: {plan}: conditions names 'Control', which experiment smoke does not hold "
                           "(did you mean 'control'?)"), line
    assert not out.exists()


def test_a_sweep_refuses_a_plan_misnaming_its_experiments_conditions_before_simulating(tmp_path):
    plan = _plan(tmp_path / "mine.toml", ["Disambiguation", "control"])
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(f'experiment = "smoke"\nreplications = 1\nplan = {json.dumps(str(plan))}\n'
                     '[design]\nmethod = "grid"\n[parameters]\n"inference.kappa" = { values = [0.5, 0.6] }\n')
    out = tmp_path / "batch"
    result = invoke(["sweep", str(sweep), "--out", str(out)])
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    assert line.startswith(f"Error: {plan}: conditions names 'Disambiguation', which experiment smoke does "
                           "not hold"), line
    assert not out.exists()


def test_a_plan_spelling_short_labels_in_another_case_is_refused(tmp_path):
    # difflib sees nothing alike in 'A' and 'a': the labels are compared with case folded
    table = _metrics_table(tmp_path / "ab.csv", ["a", "b"])
    plan = _plan(tmp_path / "ab.toml", ["B", "A"])
    result = invoke(["analyze", str(table), "--plan", str(plan), "--out", str(tmp_path / "out")])
    assert result.exit_code == 1, result.output
    assert "conditions names 'B', which" in one_error_line(result.output)
    assert "(did you mean 'b'?)" in result.output
