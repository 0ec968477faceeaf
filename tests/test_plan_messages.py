"""An analysis plan's errors: a plan read from a file is named by its file in every message (its
``name`` may be a copied preset's), ``analyze --bootstrap`` has the plan's lower bound, and a
plan's numbers must be numbers."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

from nudgecli.config_files import list_presets
from nudgecli.errors import ConfigError
from nudgecli.report.plans import MIN_RESAMPLES, load_plan

TWO_CONDITIONS = Path(__file__).with_name("data") / "metrics_two_conditions.csv"
PAPER = list_presets("analysis")["paper"]


def _table(tmp_path: Path) -> Path:
    return Path(shutil.copy(TWO_CONDITIONS, tmp_path / "pp.csv"))


def _paper_copy(path: Path, old: str = "", new: str = "") -> Path:
    """The paper preset, edited (``name = "paper"`` kept, as a user's copy keeps it)."""
    text = PAPER.read_text(encoding="utf-8")
    assert old in text
    path.write_text(text.replace(old, new), encoding="utf-8")
    return path


# --- a plan file is named by its file ------------------------------------------------------------


def test_a_plan_file_is_labelled_by_its_path_and_a_preset_by_its_name(tmp_path, monkeypatch):
    copy = _paper_copy(tmp_path / "mine.toml")
    assert load_plan(copy).label == str(copy.resolve())
    monkeypatch.chdir(tmp_path)
    assert load_plan("mine.toml").label == str(copy.resolve())  # relative: still the one file
    assert load_plan("paper").label == "paper"
    # where it was read from is not part of the plan: the copy is the same plan as the preset
    assert load_plan(copy) == load_plan("paper")
    assert load_plan(copy).name == "paper"


@pytest.mark.parametrize("command", ["analyze", "plot"])
def test_a_plan_file_misnaming_a_condition_is_named_by_its_file(tmp_path, command):
    """plot --plan hands analyze the loaded plan: its error named the plan's ``name`` ('paper')."""
    plan = _paper_copy(tmp_path / "p_cond.toml", '"control"]', '"controll"]')
    table = _table(tmp_path)
    line = one_error_line(nudge(command, table, "--plan", plan).output)
    assert line.startswith(f"Error: {plan.resolve()}: conditions names 'controll', which {table} does not "
                           "hold (did you mean 'control'?)"), line
    assert not (tmp_path / "pp-analysis").exists()


@pytest.mark.parametrize("command", ["analyze", "plot"])
def test_a_plan_file_filtering_an_unknown_metric_is_named_by_its_file(tmp_path, command):
    plan = _paper_copy(tmp_path / "p_filt.toml", "[filters]", "[filters]\nmode_switches_max = 10")
    line = one_error_line(nudge(command, _table(tmp_path), "--plan", plan).output)
    assert line == (f"Error: {plan.resolve()}: [filters] names unknown metric 'mode_switches_max' "
                    "(did you mean 'mode_switches'?)"), line


# --- analyze --bootstrap has a plan's lower bound ---------------------------------------------------


@pytest.mark.parametrize("resamples", [-1, 0, 1, MIN_RESAMPLES - 1])
def test_analyze_refuses_fewer_resamples_than_a_plan_allows(tmp_path, resamples):
    """``--bootstrap 1`` printed an 'interval' of one resample's value, off the median it surrounds."""
    table = _table(tmp_path)
    result = nudge("analyze", table, "--bootstrap", resamples)
    assert one_error_line(result.output) == (
        f"Error: --bootstrap {resamples}: at least {MIN_RESAMPLES} bootstrap resamples (an interval of fewer "
        "is a few resamples' values), as in a plan's [bootstrap] resamples; 2000 is the usual number")
    assert not (tmp_path / "pp-analysis").exists()
    # the plan file's bound is the same number
    plan = _paper_copy(tmp_path / "few.toml", "resamples = 2000", f"resamples = {resamples}")
    assert "resamples" in one_error_line(nudge("analyze", table, "--plan", plan).output)


def test_analyze_takes_as_few_resamples_as_a_plan_allows(tmp_path):
    plan = _paper_copy(tmp_path / "fewest.toml", "resamples = 2000", f"resamples = {MIN_RESAMPLES}")
    table = _table(tmp_path)
    by_plan = nudge("analyze", table, "--plan", plan, "--format", "json", "--out", tmp_path / "plan")
    by_flag = nudge("analyze", table, "--bootstrap", MIN_RESAMPLES, "--format", "json",
                    "--out", tmp_path / "flag")
    assert by_plan.exit_code == 0 and by_flag.exit_code == 0, (by_plan.output, by_flag.output)
    assert json.loads(by_flag.stdout)["metrics"][0]["ci"]["resamples"] == MIN_RESAMPLES
    assert json.loads(by_plan.stdout)["metrics"] == json.loads(by_flag.stdout)["metrics"]


def test_the_help_of_bootstrap_states_the_bound():
    assert f"at least {MIN_RESAMPLES}" in " ".join(nudge("analyze", "--help").output.split())


def test_the_help_of_bootstrap_states_no_other_bound():
    """The help showed click's ``[x>=1]`` beside the text's 100: one bound, the plan's, its check
    the Error line above (0 was a usage error, 50 that line)."""
    help_text = " ".join(nudge("analyze", "--help").output.split())
    option = help_text[help_text.index("--bootstrap"):help_text.index("--drop-duplicates")]
    assert "x>=" not in option, option


# --- a plan's numbers are numbers ------------------------------------------------------------------


@pytest.mark.parametrize(("old", "new", "message"), [
    ("kruskal_alpha = 0.05", 'kruskal_alpha = "0.05"',
     'stats.kruskal_alpha: give a number, not text: no quotes (got "0.05")'),
    ("level = 0.95", "level = true", "bootstrap: level = true: give a number, not true/false"),
    ("seed = 0", 'seed = "0"', 'bootstrap.seed: give a number, not text: no quotes (got "0")'),
    ("resamples = 2000", "resamples = 2000.0", "bootstrap.resamples: give a whole number, no decimal point "
                                               "(got 2000.0)"),
    ("star_thresholds = [0.05, 0.01, 0.001]", 'star_thresholds = [0.05, "0.01", 0.001]',
     'stats.star_thresholds: give a number, not text: no quotes (got [0.05, "0.01", 0.001])'),
    ("[filters]", '[filters]\nmode_switches = "10"',
     'filters.mode_switches: give a number, not text: no quotes (got "10")'),
    ("[filters]", "[filters]\nmode_switches = true",
     "filters.mode_switches = true: give a number, not true/false"),
])
def test_a_plan_number_written_as_text_or_true_is_refused(tmp_path, old, new, message):
    """pydantic's lax reading took ``kruskal_alpha = "0.05"`` for 0.05: a quoted value was used."""
    plan = _paper_copy(tmp_path / "typed.toml", old, new)
    line = one_error_line(nudge("analyze", _table(tmp_path), "--plan", plan).output)
    assert line == f"Error: {plan}: {message}", line
    assert not (tmp_path / "pp-analysis").exists()


def test_a_plan_takes_a_whole_number_where_a_decimal_is_asked(tmp_path):
    plan = _paper_copy(tmp_path / "whole.toml", "[filters]", "[filters]\nmode_switches = 10")
    assert load_plan(plan).filters == {"mode_switches": 10.0}
    assert load_plan(_paper_copy(tmp_path / "w.toml", "level = 0.95", "level = 0.9")).bootstrap.level == 0.9


# --- a plan handed over loaded is named by its file too --------------------------------------------


def test_a_loaded_plan_file_misnaming_the_experiments_conditions_is_named_by_its_file(tmp_path):
    """The batches hand checked_plan the plan as given; a loaded one was named by its name field."""
    from nudgecli.config import load_experiment
    from nudgecli.runs.study import checked_plan

    plan = _paper_copy(tmp_path / "p_cond.toml", '"control"]', '"controll"]')
    with pytest.raises(ConfigError, match=rf"^{re.escape(str(plan.resolve()))}: conditions names 'controll', "
                                          "which experiment smoke does not hold"):
        checked_plan(load_plan(plan), [load_experiment("smoke")])


def test_save_figures_with_a_loaded_plan_file_suggests_that_file(tmp_path):
    """plot --plan refuses an analysis with questionnaire scores and names the analyze command to
    run: with a loaded plan it named the plan's name field ('paper'), another plan than the file."""
    from nudgecli.api.figures import save_figures

    table = _table(tmp_path)
    assert nudge("analyze", table, "--bootstrap", MIN_RESAMPLES).exit_code == 0
    (tmp_path / "pp-analysis" / "questionnaire_scores.csv").write_text("participant,condition\n")
    plan = _paper_copy(tmp_path / "mine.toml")
    with pytest.raises(ConfigError, match=rf"--plan {re.escape(str(plan.resolve()))} --questionnaires"):
        save_figures(table, plan=load_plan(plan))
