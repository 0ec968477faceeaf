"""A resume under another plan removes the run's analysis before it records that plan (a kill then
leaves no analysis, never the old one under the new plan's name), and a folder holding only the start
of a run is advised honestly: a start records no plan, and it may be a ``--force`` cut short."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

from nudgecli.config import load_experiment
from nudgecli.run_folder_names import CONFIG, LOCK, MANIFEST, STATS_JSON
from nudgecli.runs.study import run_study


@pytest.fixture()
def run(analysed_smoke_run: Path, tmp_path: Path) -> Path:
    return Path(shutil.copytree(analysed_smoke_run, tmp_path / "run"))


def test_a_resume_under_another_plan_killed_before_its_analysis_leaves_none(run: Path) -> None:
    recorded = json.loads((run / MANIFEST).read_text())["plan"]
    other = "paper" if recorded != "paper" else "study-code"
    # `nudge run --resume --plan OTHER` killed after simulating, before analyze_and_plot
    run_study(load_experiment("smoke"), run, participants=2, seed=5, resume=True, plan=other)
    assert json.loads((run / MANIFEST).read_text())["plan"] == other
    assert not (run / STATS_JSON).exists()  # was: the old plan's stats.json under the new plan's name
    assert nudge("plot", run).exit_code == 1  # was: exit 0, drawn with the new plan's star rule


def test_a_resume_under_the_recorded_plan_keeps_the_analysis(run: Path) -> None:
    recorded = json.loads((run / MANIFEST).read_text())["plan"]
    run_study(load_experiment("smoke"), run, participants=2, seed=5, resume=True, plan=recorded)
    assert (run / STATS_JSON).is_file()


def _only_a_start(folder: Path, seed: int) -> None:
    """What a run (or a --force replacing the run there) killed before its manifest leaves."""
    folder.mkdir()
    (folder / CONFIG).write_text(load_experiment("smoke", [f"experiment.seed={seed}"]).to_toml())
    (folder / LOCK).write_text("")
    for kind in ("trials", "steps"):
        (folder / kind).mkdir()


def test_the_advice_for_a_start_names_run_with_its_plan_and_a_force_cut_short(tmp_path: Path) -> None:
    folder = tmp_path / "P3"
    _only_a_start(folder, 5)
    line = one_error_line(nudge("analyze", folder).output)
    assert "records no analysis plan" in line, line  # was: only `nudge simulate ... --resume` (plan paper)
    assert f"nudge run {folder / CONFIG} --out {folder} --plan PLAN --resume" in line, line
    assert "--force" in line and "replac" in line, line  # was: silent on a --force cut short


def test_a_force_cut_short_with_the_old_config_is_refused_as_another_runs_start(tmp_path: Path) -> None:
    folder = tmp_path / "K38"
    _only_a_start(folder, 3)  # the replaced run's config.toml (seed 3), its manifest already removed
    args = ("run", "smoke", "--participants", "1", "--seed", "4", "--plan", "study-code", "--out", folder)
    line = one_error_line(nudge(*args, "--resume").output)
    assert "start of another run" in line and "experiment.seed: 3" in line, line  # was: "not empty"
    assert "--force (without --resume)" in line and "cut short" in line, line
    assert (folder / CONFIG).read_text() == load_experiment("smoke", ["experiment.seed=3"]).to_toml()
