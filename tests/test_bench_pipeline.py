"""``nudge bench --only pipeline``: the rows' arithmetic on injected timings, and the wiring of one
tiny real batch (no timing assertions)."""

from __future__ import annotations

import tempfile
from pathlib import Path

import pytest
from click.testing import CliRunner

from nudgecli import bench
from nudgecli.bench import common, pipeline
from nudgecli.cli import main


def _measurement() -> pipeline.PipelineMeasurement:
    # 1,728 trials at 4 ms on 2 workers is 3.456 s of ideal wall time; in 4 s: 86.4 %
    return pipeline.PipelineMeasurement(
        "paper", 2, 0.004,
        {4: pipeline.BatchTiming(4, 1728, 4.0, 8.64, 150.0),
         20: pipeline.BatchTiming(20, 8640, 20.0, 40.0, None)},
        pipeline.BatchTiming(50, 57_600, 150.0, 290.0, 120.0))


def test_the_efficiency_row_is_trials_times_the_loop_over_workers_times_wall() -> None:
    measured = _measurement()
    row = pipeline.pipeline_row(measured, 4)
    assert list(row) == list(common.COLUMNS)
    assert row["what"] == "pipeline: replicate paper -R 4, 2 workers"
    assert row["time_s"] == 4.0 and row["baseline_s"] == pytest.approx(1728 * 0.004 / 2)
    assert row["ratio"] == pytest.approx(0.864)  # the ratio column is the efficiency
    assert row["ok"] and row["peak_mb"] == 150.0 and row["target"] == "efficiency >= 80%"
    assert row["note"].startswith("pipeline efficiency 86% (1,728 trials x 4.00 ms")
    assert "1,555,200 trials per hour" in row["note"]  # 1728 / 4 s x 3600
    assert "5.00 ms a trial end to end, 80% of it the loop" in row["note"]  # 8.64 CPU s / 1728; 4 / 5
    # -R 20: 8640 x 4 ms / (2 x 20 s) = 86.4 %, under its 90 % target
    twenty = pipeline.pipeline_row(measured, 20)
    assert twenty["ratio"] == pytest.approx(0.864) and not twenty["ok"]
    assert twenty["target"] == "efficiency >= 90%"


def test_the_throughput_row_counts_the_larger_batch() -> None:
    row = pipeline.throughput_row(_measurement())
    assert row["what"] == "pipeline: trials an hour, replicate paper -R 20, 2 workers"
    assert row["baseline_s"] == pytest.approx(8640 / 10_000_000 * 3600)
    assert row["note"].startswith("1,555,200 trials per hour end to end")  # 8640 / 20 s x 3600
    assert "the loop alone on 2 workers: 1,800,000" in row["note"]  # 2 x 3600 / 4 ms
    assert not row["ok"]


def test_the_power_row_holds_the_wall_time_to_two_minutes() -> None:
    measured = _measurement()
    row = pipeline.power_row(measured)
    assert row["what"] == "pipeline: power paper --participants 6,9,12,18,24 -R 50, 2 workers"
    assert row["time_s"] == 150.0 and row["baseline_s"] == 120.0 and row["ratio"] == pytest.approx(0.8)
    assert not row["ok"] and row["target"] == "<= 120 s" and row["peak_mb"] == 120.0
    # 57,600 / 150 s x 3600; 57,600 x 4 ms / (2 x 150 s) = 76.8 %
    assert row["note"].startswith("57,600 trials simulated (each replication's largest study, once), "
                                  "1,382,400 trials per hour; pipeline efficiency 77%")
    quick = pipeline.PipelineMeasurement("paper", 2, 0.004, measured.batches,
                                         pipeline.BatchTiming(50, 57_600, 119.5, 230.0, None))
    assert pipeline.power_row(quick)["ok"]


def test_the_loop_counts_each_participants_better_run(monkeypatch: pytest.MonkeyPatch) -> None:
    runs = iter([[(1.0, 10), (3.0, 30)], [(2.0, 10), (2.5, 30)]])  # before and after the batches
    monkeypatch.setattr(pipeline, "loop_seconds_per_trial", lambda experiment, repeats: next(runs))
    monkeypatch.setattr(pipeline, "time_replicate",
                        lambda experiment, r, workers: pipeline.BatchTiming(r, 40 * r, float(r), 1.0, None))
    asked = []
    monkeypatch.setattr(pipeline, "time_power", lambda *args: asked.append(args) or pipeline.BatchTiming(
        50, 1, 1.0, 1.0, None))
    measured = pipeline.measure_pipeline(common.BenchOptions())
    assert measured.loop_s_per_trial == pytest.approx((1.0 + 2.5) / 40)
    assert sorted(measured.batches) == [4, 20] and measured.workers == 2
    assert asked == [("paper", (6, 9, 12, 18, 24), 50, 2)] and measured.power.replications == 50


def test_one_tiny_batch_end_to_end(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    timing = pipeline.time_replicate("smoke", 1, 1)  # 2 participants x 2 conditions x 4 trials
    assert timing.trials == 16 and timing.wall_s > 0 and timing.cpu_s > 0
    assert list(tmp_path.iterdir()) == []
    # the largest study only (3 participants x 2 conditions x 4 trials): the smaller is its first 2
    power = pipeline.time_power("smoke", (2, 3), 1, 1)
    assert power.trials == 24 and power.replications == 1 and power.wall_s > 0 and power.cpu_s > 0
    assert list(tmp_path.iterdir()) == []


def test_the_pipeline_group_is_asked_for_by_name(monkeypatch: pytest.MonkeyPatch) -> None:
    names = [f.__name__ for f in bench.select_figures("pipeline")]
    assert names == ["figure_pipeline_4", "figure_pipeline_20", "figure_pipeline_throughput",
                     "figure_pipeline_power"]
    assert not set(bench.select_figures("pipeline")) & set(bench.select_figures("all"))
    monkeypatch.setattr(pipeline, "measure_pipeline", lambda options: _measurement())
    result = CliRunner().invoke(main, ["bench", "--only", "pipeline", "--format", "json"])
    assert result.exit_code == 0, result.output
    assert '"pipeline: replicate paper -R 4, 2 workers"' in result.stdout


def test_the_loop_is_timed_as_a_participant_task_runs_it(monkeypatch: pytest.MonkeyPatch) -> None:
    # not simulate_participant, whose frames (about a sixth of a paper trial) no batch worker builds:
    # timing them would flatter every efficiency
    from nudgecli.runs import batch_tasks
    from nudgecli.sim import study

    asked = []
    real = batch_tasks.simulate_task_participant
    monkeypatch.setattr(batch_tasks, "simulate_task_participant",
                        lambda plan, index: asked.append(index) or real(plan, index))
    monkeypatch.setattr(study, "simulate_participant", lambda *args, **kwargs: pytest.fail("frames timed"))
    measured = pipeline.loop_seconds_per_trial("smoke", 2)
    assert asked == [0, 0, 1, 1] and [trials for _, trials in measured] == [8, 8]
    assert all(seconds > 0 for seconds, _ in measured)
