"""Mends of analysis plans: a metric listed twice, the plan summary.md names, a table's metrics
under a plan's include, the CI level as given, and completion times under the study's success proxy."""

from __future__ import annotations

import shutil
from pathlib import Path

from cli_helpers import nudge, one_error_line

from nudgecli.config_files import list_presets

TWO_CONDITIONS = Path(__file__).with_name("data") / "metrics_two_conditions.csv"
PAPER = list_presets("analysis")["paper"]


def _paper_copy(path: Path, old: str = "", new: str = "") -> Path:
    """The paper preset, edited."""
    text = PAPER.read_text(encoding="utf-8")
    assert old in text
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    return path


def _table(tmp_path: Path) -> Path:
    return Path(shutil.copy(TWO_CONDITIONS, tmp_path / "pp.csv"))


# --- a metric listed twice -----------------------------------------------------------------------


def test_a_metric_listed_twice_in_include_is_refused_naming_the_file_and_the_metric(tmp_path):
    """It was tested twice: stats.json held it twice, replicate and power counted it twice."""
    plan = _paper_copy(tmp_path / "twice.toml", "include = [", 'include = ["completion_time", ')
    line = one_error_line(nudge("analyze", _table(tmp_path), "--plan", plan).output)
    assert line.startswith(f"Error: {plan}: metrics.include: 'completion_time' listed more than once; "
                           "list each metric once"), line
    assert not (tmp_path / "pp-analysis").exists()


# --- summary.md names a plan file by its file, and lists its definitions -------------------------


def _summary_head(folder: Path) -> list[str]:
    return [line for line in (folder / "summary.md").read_text(encoding="utf-8").splitlines()
            if line.startswith("- plan:") or line.startswith("- definitions:")]


def test_summary_names_a_plan_file_by_its_file_not_its_name_key(tmp_path, analysed_smoke_run):
    """An edited copy of the paper plan was reported as "paper"; ``name = ""`` read "- plan: ;"."""
    study_code = list_presets("analysis")["study-code"].read_text(encoding="utf-8")
    plan = tmp_path / "plans" / "mine.toml"
    plan.parent.mkdir()
    plan.write_text(study_code.replace('name = "study-code"', 'name = ""'), encoding="utf-8")
    out = tmp_path / "a"
    result = nudge("analyze", analysed_smoke_run, "--plan", plan, "--out", out, "--bootstrap", "100")
    assert result.exit_code == 0, result.output
    plan_line, definitions = _summary_head(out)
    assert plan_line.startswith("- plan: ../plans/mine.toml; conditions:"), plan_line
    assert definitions == ("- definitions: computed from the run's trials and steps under the plan's "
                           "assistance_engagement = 'per_turn', assistance_strength = 'per_turn', "
                           "mode_switches = 'human_turn', success = 'last_inferred_goal', "
                           "completion_time = 'all_trials'")
    table = _table(tmp_path)
    copy = _paper_copy(tmp_path / "paper-copy.toml", "star_comparison = \"<\"", "star_comparison = \"<=\"")
    assert nudge("analyze", table, "--plan", copy).exit_code == 0
    assert _summary_head(tmp_path / "pp-analysis")[0].startswith("- plan: ../paper-copy.toml; "), \
        _summary_head(tmp_path / "pp-analysis")


def test_summary_names_a_preset_by_its_name_without_definitions(tmp_path, analysed_smoke_run):
    out = tmp_path / "a"
    assert nudge("analyze", analysed_smoke_run, "--plan", "study-code", "--out", out,
                 "--bootstrap", "100").exit_code == 0
    (plan_line,) = _summary_head(out)
    assert plan_line.startswith("- plan: study-code; conditions:"), plan_line


# --- the interval's level as the plan gives it -----------------------------------------------------


def test_the_interval_level_is_printed_as_given_not_rounded_to_whole_percent(tmp_path):
    """[bootstrap] level = 0.975 printed "98% CI", 0.999 "100% CI"."""
    plan = _paper_copy(tmp_path / "level.toml", "level = 0.95", "level = 0.975")
    result = nudge("analyze", _table(tmp_path), "--plan", plan, "--bootstrap", "100")
    assert result.exit_code == 0, result.output
    assert "a-b [97.5% CI]" in result.output
    summary = (tmp_path / "pp-analysis" / "summary.md").read_text(encoding="utf-8")
    assert "- interval: 97.5% cluster bootstrap" in summary and "| 97.5% CI |" in summary
    assert "98%" not in summary


def test_a_comparison_prints_its_level_as_given(tmp_path):
    import numpy as np
    import pandas as pd

    from nudgecli.report.compare import CompareOptions, compare_sources
    from nudgecli.report.compare_text import format_comparison
    from nudgecli.report.summary import format_level

    assert [format_level(v) for v in (0.95, 0.975, 0.999, 0.9)] == ["95%", "97.5%", "99.9%", "90%"]
    rng = np.random.default_rng(0)
    for name, conditions, shift in (("sim", ("disambiguation", "control"), 20), ("real", ("control",), 21)):
        rows = [{"participant": f"{name}{p}", "condition": c, "trial": t,
                 "completion_time": shift + rng.normal()}
                for p in range(3) for c in conditions for t in range(3)]
        pd.DataFrame(rows).to_csv(tmp_path / f"{name}.csv", index=False)
    result = compare_sources(tmp_path / "sim.csv", tmp_path / "real.csv",
                             options=CompareOptions(resamples=0, level=0.999))
    assert "KS [99.9%]" in format_comparison(result)


# --- completion time of successful trials under the study's success proxy ------------------------


def test_a_trial_timed_out_is_no_completion_under_the_success_proxy():
    """success = "last_inferred_goal" with completion_time = "successful_trials" kept the time of a
    trial timed out (reached_goal -1, its time the limit) whose last inferred goal was the true one."""
    import pandas as pd

    from nudgecli.report.metrics import trial_metrics

    trials = pd.DataFrame({
        "participant": [0, 0], "condition": ["a", "a"], "block": [0, 0], "trial": [0, 1],
        "true_goal": [0, 0], "reached_goal": [0, -1], "success": [True, False], "duration_s": [12.5, 22.0],
        "human_turns": [2, 3]})
    steps = pd.DataFrame({"participant": [0, 0], "trial": [0, 1], "step": [0, 0], "turn": ["human"] * 2,
                          "alpha": [0.0, 0.0], "inferred_goal": [0, 0], "event": ["", ""]})
    metrics = trial_metrics(trials, steps, success="last_inferred_goal", completion_time="successful_trials")
    assert metrics["success"].tolist() == [True, True]  # the proxy, as the plan reports success
    assert metrics["completion_time"].iloc[0] == 12.5 and pd.isna(metrics["completion_time"].iloc[1])


# --- plot of a run analysed in its own folder under another plan -----------------------------------


def test_plot_labels_a_copied_run_analysed_under_study_code_per_study_code(tmp_path, analysed_smoke_run):
    """cp -r RUN RUN2; analyze RUN2 --plan study-code; plot RUN2: the success axis is study-code's."""
    from nudgecli.api.figures import plot

    copy = Path(shutil.copytree(analysed_smoke_run, tmp_path / "copy"))
    assert nudge("analyze", copy, "--plan", "study-code", "--bootstrap", "100").exit_code == 0
    labels = [" ".join(axes.get_ylabel().split()) for axes in plot(copy, "success").axes]
    assert labels == ["Success (1 = last inferred goal is the true goal)"], labels


# --- a table under a plan whose include leaves out some of its metrics -----------------------------


def test_a_table_analysed_under_a_plan_leaving_out_its_metrics_says_they_are_taken(tmp_path):
    """A plan's include was ignored for a table unsaid: its numeric columns are all its metrics (the
    paper plan, a table's default, leaves out metrics the baselines' tables hold), so a Note says so
    where a plan is given, and --metric chooses."""
    import re

    text = re.sub(r"include = \[[^\]]*\]", 'include = ["completion_time", "success"]',
                  PAPER.read_text(encoding="utf-8"))
    plan = tmp_path / "two.toml"
    plan.write_text(text, encoding="utf-8")
    table = _table(tmp_path)
    given = nudge("analyze", table, "--plan", plan, "--bootstrap", "100")
    assert given.exit_code == 0, given.output
    notes = [line for line in given.output.splitlines() if "include leaves out" in line]
    assert len(notes) == 1, given.output
    assert notes[0] == (f"Note: {table}: plan {plan.resolve()}'s [metrics] include leaves out mode_switches, "
                        "which this table's analysis takes as they are (every numeric column of a table is a "
                        "metric); choose a table's metrics with --metric NAME")
    for args in (["--plan", plan, "--metric", "completion_time"], []):  # chosen, or no plan given: no note
        result = nudge("analyze", table, *args, "--bootstrap", "100", "--force")
        assert result.exit_code == 0 and "include leaves out" not in result.output, result.output
