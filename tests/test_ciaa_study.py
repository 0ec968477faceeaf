"""`nudge simulate / analyze / plot ciaa-teleop`: the run folder, determinism, one-condition analysis."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.report.analysis import analyze
from nudgecli.report.metrics import trial_metrics
from nudgecli.run_folder_names import FIGURES_RECORD
from nudgecli.runs.study import run_study
from nudgecli.sim.ciaa import packaged_task, subject_schedule
from nudgecli.store import RunFolder

PARTICIPANTS = 3


def tables(path: Path) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    run = RunFolder(path)
    return run.read_trials(), run.read_steps(), pd.read_parquet(path / "participants.parquet")


@pytest.fixture(scope="module")
def ciaa_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("ciaa") / "run"
    result = CliRunner().invoke(main, ["simulate", "ciaa-teleop", "--participants", str(PARTICIPANTS),
                                       "--out", str(out)])
    assert result.exit_code == 0, result.output
    return out


def test_the_run_folder_holds_the_subjects_trials(ciaa_run):
    trials, steps, participants = tables(ciaa_run)
    assert len(participants) == PARTICIPANTS and set(trials["condition"]) == {"no_assistance"}
    for p in range(PARTICIPANTS):
        mine = trials[trials["participant"] == p].sort_values("trial")
        expected = [t.layout_index for t in subject_schedule(packaged_task(), p, ("no_assistance",))]
        assert mine["layout"].tolist() == expected
    assert {"duration_s", "success", "human_mode_switches"} <= set(trials.columns)
    assert (trials["duration_s"] <= 50.0).all() and (trials["autonomy_turns"] == 0).all()
    # every logged position lies on the trial's path (TASK.md section 4: "the robot always lies
    # exactly on the polyline"), the heading only changes at the turn waypoint
    layouts = RunFolder(ciaa_run).read_layouts().set_index("layout")
    merged = steps.merge(trials[["participant", "trial", "layout"]], on=["participant", "trial"])
    for (_, _), group in merged.groupby(["participant", "trial"]):
        row = layouts.loc[int(group["layout"].iloc[0])]
        points = np.asarray(row["waypoints"], dtype=float).reshape(-1, 2)
        xy = group[["x", "y"]].to_numpy()
        on_leg = np.zeros(len(xy), dtype=bool)
        for a, b in itertools.pairwise(points):
            lo, hi = np.minimum(a, b) - 1e-9, np.maximum(a, b) + 1e-9
            on_leg |= ((xy >= lo) & (xy <= hi)).all(axis=1)
        assert on_leg.all()
        turning = np.abs(np.diff(group["theta"].to_numpy())) > 0
        turn_xy = points[int(row["turn_waypoint"])]
        assert (np.abs(xy[1:][turning] - turn_xy) < 1e-9).all()
    assert set(steps["phi_m"]) <= {"", "Hard Puff", "Hard Sip", "Soft Puff", "Soft Sip",
                                   "Soft-Hard Puff Deadband", "Soft-Hard Sip Deadband"}
    assert steps["pressure"].abs().max() <= 1.0


def test_same_seed_same_tables_serial_and_two_workers(ciaa_run, tmp_path):
    config = load_experiment("ciaa-teleop")
    run_study(config, tmp_path / "two", participants=PARTICIPANTS, workers=2)
    for a, b in zip(tables(ciaa_run), tables(tmp_path / "two"), strict=True):
        pd.testing.assert_frame_equal(a, b)
    run_study(config, tmp_path / "other", participants=PARTICIPANTS, seed=1)
    assert not tables(ciaa_run)[0].equals(tables(tmp_path / "other")[0])


def test_analyze_describes_a_single_condition_without_tests(ciaa_run, tmp_path):
    result = CliRunner().invoke(main, ["analyze", str(ciaa_run), "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert "descriptive statistics only" in result.output
    stats = json.loads((tmp_path / "stats.json").read_text())
    assert stats["conditions"] == ["no_assistance"]
    names = [m["metric"] for m in stats["metrics"]]
    assert names == ["completion_time", "success", "mode_switches", "first_input_latency",
                     "active_input_fraction"]
    for entry in stats["metrics"]:
        assert entry["kruskal"]["p"] is None and entry["conover"] == [] and entry["ci"]["pairs"] == []
        assert "descriptive statistics only" in entry["participant_level"]["note"]
    metrics = pd.read_csv(tmp_path / "metrics.csv")
    trials = RunFolder(ciaa_run).read_trials()
    assert metrics["completion_time"].tolist() == trials["duration_s"].tolist()
    assert (metrics["mode_switches"] == trials["human_mode_switches"]).all()
    assert "no tests" in (tmp_path / "summary.md").read_text()


def test_a_single_condition_metrics_table_is_analysed_descriptively(tmp_path):
    table = pd.DataFrame({"participant": [1, 1, 2, 2], "condition": ["none"] * 4,
                          "completion_time": [20.0, 30.0, 25.0, 35.0]})
    table.to_csv(tmp_path / "real.csv", index=False)
    result = analyze(tmp_path / "real.csv", out=tmp_path / "out")
    (entry,) = result.stats["metrics"]
    assert entry["median"]["none"] == 27.5 and entry["n"]["none"] == 4  # median of 20, 25, 30, 35


def test_plot_draws_the_trajectory_along_the_path_and_the_measures(ciaa_run, tmp_path):
    analyze(ciaa_run, plan=None, out=None)
    result = CliRunner().invoke(main, ["plot", str(ciaa_run), "--formats", "png", "--out", str(tmp_path),
                                       "--trial", "1:3"])
    assert result.exit_code == 0, result.output
    assert {p.name for p in tmp_path.iterdir()} == {"trajectory.png", "measures.png", FIGURES_RECORD}
    result = CliRunner().invoke(main, ["plot", str(ciaa_run), "--out", str(tmp_path), "--trial", "1:12",
                                       "--force"])  # --out holds the first figures now
    assert result.exit_code == 1 and "no such trial" in result.stderr


def test_new_measures_on_a_hand_built_step_log():
    trials = pd.DataFrame({"participant": [0, 0], "condition": ["c", "c"], "block": [0, 0], "trial": [0, 1],
                           "true_goal": [0, 0], "success": [True, False], "duration_s": [0.5, 0.3],
                           "human_turns": [1, 1]})
    labels = ["", "Soft-Hard Sip Deadband", "", "Soft Sip", "Hard Puff", "", "", ""]
    steps = pd.DataFrame({"participant": 0, "trial": [0] * 5 + [1] * 3, "step": [0, 1, 2, 3, 4, 0, 1, 2],
                          "t": [0.0, 0.1, 0.2, 0.3, 0.4, 0.0, 0.1, 0.2], "turn": "human", "phi_m": labels,
                          "alpha": 0.0, "inferred_goal": -1, "event": ""})
    metrics = trial_metrics(trials, steps)
    # trial 0: the first command (not the deadband) at t = 0.3; 3 of 5 steps with input
    assert metrics["first_input_latency"].iloc[0] == pytest.approx(0.3)
    assert metrics["active_input_fraction"].iloc[0] == pytest.approx(0.6)
    # trial 1: no input at all
    assert np.isnan(metrics["first_input_latency"].iloc[1])
    assert metrics["active_input_fraction"].iloc[1] == 0.0
