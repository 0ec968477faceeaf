"""A wrong kind of value in an experiment file, a plan or ``--set`` gets the house's one line with
its fix: the closest choice (case-insensitively), quotes for text, a number for a TOML date, one
table for a list of them, at most as many values as the key takes, a finite plan [filters] maximum."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest
from cli_helpers import one_error_line
from pydantic import ValidationError

from nudgecli.config import ExperimentConfig, load_experiment
from nudgecli.config_files import format_validation_error, list_presets
from nudgecli.errors import ConfigError
from nudgecli.report.plans import AnalysisPlan, load_plan

SMOKE = list_presets("experiments")["smoke"]


def _error(*overrides: str, path: str | Path = "smoke") -> str:
    with pytest.raises(ConfigError) as caught:
        load_experiment(str(path), list(overrides))
    return one_error_line(f"Error: {caught.value}")


def _smoke_copy(path: Path, old: str, new: str) -> Path:
    text = SMOKE.read_text(encoding="utf-8")
    assert old in text
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    return path


@pytest.mark.parametrize(("override", "suggestion"), [
    ("study.counterbalancing=willams", "'williams'"),
    ("disambiguation.estimator=exakt", "'exact'"),
    ("model.tables=Fitted", "'fitted'"),  # the right choice but for case
])
def test_a_choice_that_is_none_of_its_values_names_them_and_the_closest(override: str,
                                                                         suggestion: str) -> None:
    line = _error(override)
    assert f"(did you mean {suggestion}?)" in line and "should be '" in line, line
    assert "Input should be" not in line


def test_a_plan_choice_names_the_plan_file_and_the_closest_choice(tmp_path: Path) -> None:
    plan = tmp_path / "p2.toml"
    plan.write_text('[stats]\np_adjust = "holms"\n', encoding="utf-8")
    with pytest.raises(ConfigError) as caught:
        load_plan(plan)
    assert str(caught.value).startswith(f"{plan}: stats.p_adjust: should be 'none', 'bonferroni', ")
    assert "(did you mean 'holm'?)" in str(caught.value) and '(got "holms")' in str(caught.value)


def test_text_given_as_a_number_is_told_to_quote_it() -> None:
    line = _error("experiment.name=2024")
    assert "experiment.name: should be text, in quotes" in line and "'experiment.name=\"2024\"'" in line, line


def test_a_list_item_given_as_a_boolean_gets_an_example_of_the_list_as_written() -> None:
    # before: e.g. --set 'study.conditions.0="True"' (no such --set key, and Python's spelling)
    with pytest.raises(ConfigError) as raised:
        load_experiment("smoke", ["study.conditions=[true]"])
    assert str(raised.value).endswith(
        """should be text, in quotes: e.g. --set 'study.conditions=["true"]' (got true)""")


@pytest.mark.parametrize("source", ["--set", "file"])
def test_an_infinite_list_item_gets_an_example_of_the_whole_list(tmp_path: Path, source: str) -> None:
    # before: e.g. --set population.rest_s.1=10 (no such key), and "1 = 10" in a file
    if source == "--set":
        with pytest.raises(ConfigError) as raised:
            load_experiment("smoke", ["population.rest_s=[1,inf]"])
        example = "e.g. --set 'population.rest_s=[0.3, 1.5]' (got Infinity)"
    else:
        path = tmp_path / "exp.toml"
        path.write_text("[population]\nrest_s = [1, nan]\n", encoding="utf-8")
        with pytest.raises(ConfigError) as raised:
            load_experiment(str(path))
        example = "e.g. rest_s = [0.3, 1.5] (got NaN)"
    said = f"population.rest_s.1: should be a finite number (not inf or nan), {example}"
    assert str(raised.value).endswith(said)


def test_a_toml_date_where_a_number_goes_is_named_as_a_date_with_a_number_to_write(tmp_path: Path) -> None:
    path = _smoke_copy(tmp_path / "e.toml", "seed = 7", "seed = 1979-05-27")
    line = _error(path=path)
    assert line.startswith(f"Error: {path}: experiment.seed: should be a whole number, not a TOML date"), line
    assert "e.g. seed = " in line and "(got 1979-05-27)" in line and "datetime" not in line


def test_a_list_where_a_table_goes_is_told_to_write_one_table(tmp_path: Path) -> None:
    path = _smoke_copy(tmp_path / "e.toml", "[study]", "[[study]]")
    line = _error(path=path)
    assert f"{path}: study: should be a table of keys (not a list, nor [[study]])" in line, line
    assert "write [study] once" in line and "instance of StudySection" not in line
    data = tomllib.loads(SMOKE.read_text(encoding="utf-8")) | {"study": [1, 2]}
    with pytest.raises(ValidationError) as caught:
        ExperimentConfig.model_validate(data)
    assert "e.toml: study: should be a table of keys" in format_validation_error(caught.value, "e.toml",
                                                                                   ExperimentConfig, data)


def test_too_many_values_say_how_many_the_key_takes_with_an_example() -> None:
    line = _error("population.handover_idle_s=[1,2,3]")
    assert "population.handover_idle_s: too many values: give at most 2, e.g. --set" in line, line
    assert "after validation" not in line


@pytest.mark.parametrize("maximum", ["nan", "inf", "-inf"])
def test_a_plan_filter_maximum_must_be_finite(tmp_path: Path, maximum: str) -> None:
    # a comparison with nan is false for every value: a nan maximum filtered nothing, unsaid
    plan = tmp_path / "p6.toml"
    plan.write_text(f"[filters]\nmode_switches = {maximum}\n", encoding="utf-8")
    with pytest.raises(ConfigError) as caught:
        load_plan(plan)
    assert f"{plan}: filters.mode_switches: should be a finite number (not inf or nan), e.g. " \
           "mode_switches = 10" in str(caught.value)
    with pytest.raises(ValueError):
        AnalysisPlan(filters={"mode_switches": float(maximum)})
