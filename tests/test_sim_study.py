"""The study runner: design, determinism across executors, resume after SIGKILL, CLI errors."""

from __future__ import annotations

import gc
import os
import pickle
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from import_guard import run_refusing

from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.runs.study import run_study
from nudgecli.sim.study import (
    ParticipantResult,
    StudyPlan,
    build_layouts,
    fewer_collections,
    participant_schedule,
    simulate_participant,
    simulate_participant_columns,
)
from nudgecli.steplog import STEP_NUMERIC_DTYPES
from nudgecli.store import RunFolder


def read_tables(path: Path) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    run = RunFolder(path)
    return run.read_trials(), run.read_steps(), pd.read_parquet(path / "participants.parquet")


def assert_same_run(a: Path, b: Path) -> None:
    for left, right in zip(read_tables(a), read_tables(b), strict=True):
        pd.testing.assert_frame_equal(left, right, check_exact=True)
    layouts = [pd.read_parquet(p / "layouts.parquet") for p in (a, b)]
    pd.testing.assert_frame_equal(*layouts)


def test_design_has_the_papers_structure():
    config = load_experiment("paper")
    layouts = build_layouts(config, 2022)
    assert len(layouts) == 48
    assert [lay.condition for lay in layouts[:24]] == ["disambiguation"] * 24
    for lay in layouts:
        cells = lay.layout.goal_cells
        assert len(cells) == lay.n_goals
        d = ((cells[:, None, :] - cells[None, :, :]) ** 2).sum(-1) ** 0.5
        assert (d[~pd.DataFrame(d).eq(0).to_numpy()] > 1.0).all()  # goals more than one cell apart
    starts = set()
    for p in range(4):
        schedule = participant_schedule(config, 2022, p, layouts)
        assert len(schedule) == 48 and sorted(s.layout_index for s in schedule) == list(range(48))
        blocks = [schedule[k].condition for k in range(0, 48, 8)]
        # 6 blocks of 8, conditions alternating, the first condition balanced across participants
        assert all(len({s.condition for s in schedule[k:k + 8]}) == 1 for k in range(0, 48, 8))
        assert blocks in (["disambiguation", "control"] * 3, ["control", "disambiguation"] * 3)
        starts.add(blocks[0])
    assert starts == {"disambiguation", "control"}


@pytest.mark.usefixtures("restored_environ")  # the cluster sets its workers' settings in os.environ
def test_same_seed_same_tables_serial_processes_and_dask(tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    config = load_experiment("smoke")
    run_study(config, tmp_path / "serial", participants=3, workers=1)
    run_study(config, tmp_path / "two", participants=3, workers=2)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address="127.0.0.1:0") as cluster:  # ":0": every interface
        run_study(config, tmp_path / "dask", participants=3, scheduler=cluster.scheduler_address)
    assert_same_run(tmp_path / "serial", tmp_path / "two")
    assert_same_run(tmp_path / "serial", tmp_path / "dask")


def test_more_participants_than_the_pool_holds_ahead_give_the_serial_tables(tmp_path):
    from nudgecli.runs.study import PARTICIPANTS_AHEAD_PER_WORKER

    config = load_experiment("smoke")
    n = 2 * PARTICIPANTS_AHEAD_PER_WORKER + 3  # some participants are submitted as others finish
    run_study(config, tmp_path / "serial", participants=n, workers=1)
    run_study(config, tmp_path / "two", participants=n, workers=2)
    assert_same_run(tmp_path / "serial", tmp_path / "two")


def test_the_local_pool_holds_a_few_participants_ahead_not_all(monkeypatch):
    # every finished participant is held until the run has written it: the pool may hold a few
    # beyond the ones written, whatever the study's size
    import concurrent.futures

    import nudgecli.runs.study as study_module

    submitted: list[int] = []

    class InstantPool:  # runs a task when it is submitted
        def __init__(self, *args, **kwargs):
            pass

        def submit(self, fn, index):
            submitted.append(index)
            future = concurrent.futures.Future()
            future.set_result(index)
            return future

        def shutdown(self, wait=True, cancel_futures=False):
            pass

    monkeypatch.setattr(study_module, "ProcessPoolExecutor", InstantPool)
    workers, todo = 2, list(range(40))
    taken, most_held = [], 0
    for result in study_module._processes(None, todo, workers):
        taken.append(result)
        most_held = max(most_held, len(submitted) - len(taken) + 1)  # (the one just taken, unwritten)
    assert sorted(taken) == todo and sorted(submitted) == todo
    assert most_held <= study_module.PARTICIPANTS_AHEAD_PER_WORKER * workers + 1


def test_a_different_seed_gives_different_tables(tmp_path):
    config = load_experiment("smoke")
    a = run_study(config, tmp_path / "a", seed=1, participants=1)
    b = run_study(config, tmp_path / "b", seed=2, participants=1)
    assert not a.trials.equals(b.trials)


def test_tables_hold_no_wall_clock_values(tmp_path):
    config = load_experiment("smoke")
    run_study(config, tmp_path / "a", participants=1)
    time.sleep(1.1)
    run_study(config, tmp_path / "b", participants=1)
    assert_same_run(tmp_path / "a", tmp_path / "b")
    manifest = RunFolder(tmp_path / "a").read_manifest()
    assert manifest["status"] == "complete" and "wall_s" in manifest and manifest["completed"] == [0]


def test_resume_after_sigkill_equals_an_uninterrupted_run(tmp_path):
    killed = tmp_path / "killed"
    args = [sys.executable, "-m", "nudgecli.cli", "simulate", "smoke", "--participants", "10", "--out",
            str(killed)]
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    proc = subprocess.Popen(args, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not list((killed / "participants").glob("part-*.parquet")):
        time.sleep(0.005)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    done = RunFolder(killed).completed_participants()
    assert 1 <= len(done) < 10, "the run must be interrupted part-way for this test to mean anything"
    assert RunFolder(killed).read_manifest()["status"] == "running"
    result = CliRunner().invoke(main, ["simulate", "smoke", "--participants", "10", "--out", str(killed),
                                       "--resume"])
    assert result.exit_code == 0, result.output
    run_study(load_experiment("smoke"), tmp_path / "clean", participants=10)
    assert_same_run(killed, tmp_path / "clean")


def test_an_existing_run_is_refused_without_resume_or_force(tmp_path):
    runner = CliRunner()
    out = str(tmp_path / "r")
    assert runner.invoke(main, ["simulate", "smoke", "--participants", "1", "--out", out]).exit_code == 0
    again = runner.invoke(main, ["simulate", "smoke", "--participants", "1", "--out", out])
    assert again.exit_code == 1 and "already holds a run" in again.output
    other = runner.invoke(main, ["simulate", "smoke", "--participants", "1", "--seed", "9", "--out", out,
                                 "--resume"])
    assert other.exit_code == 1 and "different" in other.output
    forced = runner.invoke(main, ["simulate", "smoke", "--participants", "1", "--seed", "9", "--out", out,
                                  "--force"])
    assert forced.exit_code == 0, forced.output
    assert RunFolder(out).read_manifest()["seed"] == 9


BAD = [
    (["simulate", "nonexistent"], "neither an experiment preset nor a file"),
    (["simulate", "smoke", "--participants", "0"], "--participants must be at least 1"),
    (["simulate", "smoke", "--workers", "-1"], "--workers must be at least 1"),
    (["simulate", "smoke", "--set", "study.participnts=3"], "did you mean 'participants'"),
    (["simulate", "smoke", "--set", "study.participants=abc"], "study.participants: give a number, not text"),
    (["simulate", "smoke", "--set", "disambiguation.window=4"], "3 or 5"),
    (["simulate", "smoke", "--set", "assistance.rho3=2"], "must be at most 1.0"),
    (["simulate", "smoke", "--set", "nonsense"], "expected section.key=value"),
]


@pytest.mark.parametrize(("args", "message"), BAD)
def test_bad_experiments_fail_with_one_error_line(tmp_path, args, message):
    result = CliRunner().invoke(main, [*args, "--out", str(tmp_path / "never")])
    assert result.exit_code == 1, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error: ") and message in lines[0], lines
    assert "Traceback" not in result.output
    assert not (tmp_path / "never").exists()


@pytest.mark.parametrize(("text", "message"), [
    ("[study]\nparticipants = 2\nwindow = 3\n", "unknown key 'study.window'"),
    ("[study]\nparticipants = 'two'\n", "study.participants"),
    ("[disambiguation]\nestimator = 'guess'\n", "'exact' or 'monte_carlo'"),
    ("[study\n", "invalid TOML"),
])
def test_bad_experiment_files_name_the_file_and_field(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    result = CliRunner().invoke(main, ["simulate", str(path), "--out", str(tmp_path / "never")])
    assert result.exit_code == 1
    assert result.output.count("Error:") == 1 and str(path) in result.output and message in result.output


CALIBRATION = Path(__file__).resolve().parents[2] / "shared" / "data" / "calibration"


@pytest.mark.skipif(not CALIBRATION.is_dir(), reason="shared/data/calibration is not beside the repository")
def test_a_study_can_use_a_real_persons_physiology(tmp_path):
    from nudgecli.sim.participant_fitting import participant_from_log
    from nudgecli.sim.study import study_participant

    log = str(CALIBRATION / "andrewtest")
    config = load_experiment("smoke", [f"population.physiology_logs=['{log}']"])
    real = study_participant(config, 7, 0)
    expected = participant_from_log(log, index=0)
    np.testing.assert_array_equal(real.pressure_level, expected.pressure_level)
    np.testing.assert_array_equal(real.pressure_spread, expected.pressure_spread)
    drawn = study_participant(load_experiment("smoke"), 7, 0)
    assert real.epsilon == drawn.epsilon and real.operate_s == drawn.operate_s  # habits still drawn
    assert not np.array_equal(real.pressure_level, drawn.pressure_level)
    run = run_study(config, tmp_path / "real", participants=2)
    record = pd.read_parquet(tmp_path / "real" / "participants.parquet")
    assert record["seed_key"].iloc[0].startswith("log:") and len(run.trials) == 16


def test_a_missing_physiology_log_fails_before_the_run(tmp_path):
    result = CliRunner().invoke(main, ["simulate", "smoke", "--set", "population.physiology_logs=['nowhere']",
                                       "--out", str(tmp_path / "never")])
    assert result.exit_code == 1 and result.output.startswith(
        "Error: --set population.physiology_logs=['nowhere']: population.physiology_logs[0]")
    assert not (tmp_path / "never").exists()


def test_the_simulated_calibration_logs_refit_to_the_agents_tables(tmp_path):
    import json

    from nudgecli.model.interface import distortion_table_from_dict, mapping_table_from_dict

    run_study(load_experiment("smoke"), tmp_path / "run", participants=1)
    logs = tmp_path / "run" / "calibration" / "participant-0000"
    assert sorted(p.name for p in logs.iterdir()) == ["distortion_prompts.csv", "distortion_stream.csv",
                                                      "mapping_prompts.csv", "mapping_responses.csv"]
    result = CliRunner().invoke(main, ["fit", str(logs), "--out", str(tmp_path / "profile.json")])
    assert result.exit_code == 0, result.output
    profile = json.loads((tmp_path / "profile.json").read_text())
    record = pd.read_parquet(tmp_path / "run" / "participants.parquet").iloc[0]
    np.testing.assert_allclose(mapping_table_from_dict(profile["p_phi_given_a"]),
                               np.array(json.loads(record["agent_p_phi_given_a"])), rtol=0, atol=1e-12)
    np.testing.assert_allclose(distortion_table_from_dict(profile["p_phm_given_phi"]),
                               np.array(json.loads(record["agent_p_phm_given_phi"])), rtol=0, atol=1e-12)


def test_fewer_collections_raises_the_first_threshold_for_the_block_only() -> None:
    before = gc.get_threshold()
    try:
        gc.set_threshold(700, 10, 10)
        with pytest.raises(RuntimeError), fewer_collections(12_345):
            assert gc.get_threshold() == (12_345, 10, 10)
            raise RuntimeError("a trial failed")
        assert gc.get_threshold() == (700, 10, 10)  # restored, even after an error
        gc.set_threshold(50_000, 10, 10)
        with fewer_collections(12_345):
            assert gc.get_threshold() == (50_000, 10, 10)  # never lowered
    finally:
        gc.set_threshold(*before)


# A fresh Python in which pandas and pyarrow cannot be imported (as if not installed) imports a
# study's worker tasks and simulates one participant of the smoke preset as a worker does.
_WORKER_WITHOUT_PANDAS_OR_SCIPY = """
import os, pickle, sys

from nudgecli.runs import study_tasks
from nudgecli.config import load_experiment
from nudgecli.sim.study import StudyPlan, simulate_participant_columns

config = load_experiment("smoke")
plan = StudyPlan.build(config, config.experiment.seed)
columns = simulate_participant_columns(plan, 1)
study_tasks._init_worker(plan, os.getppid())  # a pool worker's start and task
in_pool = study_tasks._run_in_worker(1)
assert not {"pandas", "pyarrow", "scipy"} & set(sys.modules), "pandas, pyarrow or scipy was imported"
parent_side = [name for name in ("nudgecli.store", "nudgecli.locks", "nudgecli.run_folder_record",
                                 "nudgecli.parquet_reader", "nudgecli.runs.study") if name in sys.modules]
assert not parent_side, f"the run folder's modules were imported: {parent_side}"
with open(sys.argv[1], "wb") as handle:
    pickle.dump((columns, in_pool), handle)
"""


def test_a_study_worker_runs_without_pandas_or_scipy_and_its_columns_make_the_parents_tables(tmp_path):
    out = tmp_path / "columns.pickle"
    done = run_refusing(_WORKER_WITHOUT_PANDAS_OR_SCIPY, ("pandas", "pyarrow", "scipy"), str(out))
    assert done.returncode == 0, done.stderr
    with open(out, "rb") as handle:
        sent = pickle.load(handle)
    config = load_experiment("smoke")
    expected = simulate_participant(StudyPlan.build(config, config.experiment.seed), 1)
    for columns in sent:
        made = ParticipantResult.from_columns(columns)
        for name in ("trials", "steps", "record"):
            pd.testing.assert_frame_equal(getattr(made, name), getattr(expected, name), check_exact=True)
        assert made.participant == expected.participant == 1


_WORKER_BUILDS_NO_VALIDATOR = """
import os, pickle, sys

from pydantic import BaseModel

from nudgecli.runs import study_tasks

with open(sys.argv[1], "rb") as handle:
    plan = pickle.load(handle)
study_tasks._init_worker(plan, os.getppid())
study_tasks._run_in_worker(0)


def models(kind):
    for sub in kind.__subclasses__():
        yield sub
        yield from models(sub)


built = sorted(model.__name__ for model in models(BaseModel)
               if model.__module__.startswith("nudgecli") and model.__pydantic_complete__)
assert not built, f"the worker built the validators of {built}"
print("ok")
"""


@pytest.mark.parametrize("experiment", ["paper", "baselines"])
def test_a_study_worker_builds_no_config_validator(tmp_path, experiment):
    # the worker is sent its experiment pickled: it validates none, and takes the defaults of
    # absent sections from section_defaults (building a validator is most of a config's import)
    config = load_experiment(experiment)
    path = tmp_path / "plan.pickle"
    path.write_bytes(pickle.dumps(StudyPlan.build(config, config.experiment.seed)))
    done = run_refusing(_WORKER_BUILDS_NO_VALIDATOR, (), str(path))
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"


@pytest.mark.parametrize("experiment", ["smoke", "ciaa-teleop"])
def test_simulate_participant_is_the_frames_of_its_columns(experiment):
    config = load_experiment(experiment)
    plan = StudyPlan.build(config, config.experiment.seed)
    columns = simulate_participant_columns(plan, 0)
    result = simulate_participant(plan, 0)
    # the columns as a worker sends them: typed arrays for numbers, Python lists for the rest
    for name, values in columns.steps.items():
        if name in STEP_NUMERIC_DTYPES:
            assert isinstance(values, np.ndarray) and values.dtype == STEP_NUMERIC_DTYPES[name], name
        else:
            assert isinstance(values, list), name
    assert isinstance(columns.record, dict) and all(isinstance(row, dict) for row in columns.trials)
    # the frames, built here the plain way: pandas inferring every column from Python values
    plain_steps = pd.DataFrame({name: values.tolist() if isinstance(values, np.ndarray) else values
                                for name, values in columns.steps.items()})
    pd.testing.assert_frame_equal(result.steps, plain_steps, check_exact=True)
    pd.testing.assert_frame_equal(result.trials, pd.DataFrame(columns.trials), check_exact=True)
    pd.testing.assert_frame_equal(result.record, pd.DataFrame([columns.record]), check_exact=True)
    assert list(result.steps.columns) == list(columns.steps) and len(result.trials) == len(columns.trials) > 0
    assert result.participant == columns.participant == 0
    assert (result.calibration is None) == (columns.calibration is None)
