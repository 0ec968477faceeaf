"""Nothing taken on trust, in the configuration (issue 38): a rate or time limit that cannot be
simulated, a file that is not UTF-8, a ``--set`` value of the wrong type or holding two
assignments, an experiment name that is a path and an out-of-range ``--belief-concentration`` are
each refused with one ``Error:`` line, before anything is cleared or written.

Each command-line test was seen failing with its fix removed (a traceback, or exit 0)."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import copy_run, one_error_line
from click.testing import CliRunner
from hypothesis import given
from hypothesis import strategies as st

import nudgecli.runs.study as study_module
from nudgecli.cli import main
from nudgecli.config import MAX_RATE_HZ, MAX_TIME_LIMIT_S, load_experiment
from nudgecli.config_files import parse_override
from nudgecli.errors import ConfigError
from nudgecli.runs import size
from nudgecli.runs.study import run_study
from nudgecli.sim.validation.settings import (
    MAX_BELIEF_CONCENTRATION,
    MIN_BELIEF_CONCENTRATION,
    ValidationSettings,
)


def invoke(args: list[str]):
    return CliRunner().invoke(main, args)


def files_of(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and p.name != ".nudge.lock"}


def _never(*args, **kwargs):
    raise AssertionError("work started before the check")


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished smoke run of 1 participant, copied by the tests that point --force at it."""
    out = tmp_path_factory.mktemp("config-trust") / "run"
    run_study(load_experiment("smoke"), out, participants=1)
    return out


# --- 1. rate_hz and the steps it makes --------------------------------------------------------------

@pytest.mark.parametrize("value", ["inf", "-inf", "nan", "0", "1e6", "0.5", f"{MAX_RATE_HZ * 1.001}"])
def test_a_rate_that_cannot_be_simulated_is_refused_before_force_clears_a_run(tmp_path, smoke_run, value):
    run = copy_run(smoke_run, tmp_path / "run")
    before = files_of(run)
    result = invoke(["simulate", "smoke", "--set", f"study.rate_hz={value}", "--out", str(run), "--force"])
    line = one_error_line(result.output)
    assert result.exit_code == 1 and "study.rate_hz" in line
    assert files_of(run) == before  # the complete run --force would have replaced is untouched


@pytest.mark.parametrize("value", ["inf", "nan", f"{MAX_TIME_LIMIT_S * 1.001}"])
def test_a_time_limit_that_cannot_be_simulated_is_refused(tmp_path, value):
    result = invoke(["simulate", "smoke", "--set", f"study.time_limit_s={value}",
                     "--out", str(tmp_path / "r")])
    assert result.exit_code == 1 and "study.time_limit_s" in one_error_line(result.output)
    assert not (tmp_path / "r").exists()


def test_a_trial_shorter_than_one_step_is_refused():
    with pytest.raises(ConfigError, match=r"study.time_limit_s \* study.rate_hz.*no step"):
        load_experiment("smoke", ["study.rate_hz=1", "study.time_limit_s=0.5"])
    # a trial runs the whole steps within its limit: 0.99 s at 1 Hz is none (it ran 1 s, past the limit)
    with pytest.raises(ConfigError, match=r"study.time_limit_s \* study.rate_hz.*no step"):
        load_experiment("smoke", ["study.rate_hz=1", "study.time_limit_s=0.99"])
    assert load_experiment("smoke", ["study.rate_hz=1", "study.time_limit_s=1.0"]).study.time_limit_s == 1.0


def test_the_rate_range_holds_its_bounds():
    assert load_experiment("smoke", [f"study.rate_hz={MAX_RATE_HZ}"]).study.rate_hz == MAX_RATE_HZ
    assert load_experiment("smoke", ["study.rate_hz=1"]).study.rate_hz == 1.0


@pytest.mark.parametrize("command", [["simulate"], ["run"], ["replicate", "-R", "1"]])
def test_the_size_guard_counts_steps_before_anything_is_cleared(tmp_path, smoke_run, monkeypatch, command):
    # 8 trials of 3,600,000 steps each (an hour at 1 kHz): within the trial limit, not the steps'
    for module, name in ((study_module, "build_plan_on"), (study_module.RunFolder, "prepare")):
        monkeypatch.setattr(module, name, _never)
    run = copy_run(smoke_run, tmp_path / "run")
    before = files_of(run)
    result = invoke([*command, "smoke", "--participants", "2",  # replicate needs 2 (steps: per participant)
                     "--set", f"study.time_limit_s={MAX_TIME_LIMIT_S}",
                     "--set", f"study.rate_hz={MAX_RATE_HZ}", "--out", str(run), "--force"])
    line = one_error_line(result.output)
    assert result.exit_code == 1 and "28,800,000" in line and "steps" in line and "--yes" in line
    assert files_of(run) == before


def test_the_step_limits_allow_the_limit_itself_and_refuse_one_more(monkeypatch):
    config = load_experiment("smoke")  # 8 trials a participant, 60 s at 10 Hz: 600 steps a trial
    assert size.steps_per_trial(config) == 600
    monkeypatch.setattr(size, "MAX_TRIALS_WITHOUT_YES", 10**9)
    monkeypatch.setattr(size, "MAX_STEPS_PER_PARTICIPANT_WITHOUT_YES", 8 * 600)
    monkeypatch.setattr(size, "MAX_STEPS_WITHOUT_YES", 3 * 8 * 600)
    size.check_study_size(config, 3, confirm=False)
    with pytest.raises(ConfigError, match=r"simulate up to 19,200 steps"):
        size.check_study_size(config, 4, confirm=False)
    size.check_study_size(config, 4, confirm=True)
    longer = load_experiment("smoke", ["study.time_limit_s=60.1"])  # 601 steps a trial
    with pytest.raises(ConfigError, match=r"up to 4,808 steps for one participant"):
        size.check_study_size(longer, 1, confirm=False)
    size.check_study_size(longer, 1, confirm=True)


def test_a_batch_counts_the_steps_of_its_studies_as_its_graph_does(monkeypatch):
    from nudgecli.report.plans import AnalysisPlan
    from nudgecli.runs.batch import Batch, Point, build_graph, estimate_batch

    smoke = load_experiment("smoke")
    longer = load_experiment("smoke", ["study.time_limit_s=90"])
    # points 0 and 2 share one study (4 people), point 1 is its own: 3 replications
    batch = Batch("sweep", (Point(0, {"k": 1}, smoke, (3,)), Point(1, {"k": 2}, longer, (2,)),
                            Point(2, {"k": 1}, smoke, (4,))), 3, 7, AnalysisPlan())
    graph = build_graph(batch)  # the studies the batch would run, counted one by one
    steps = sum(study.participants * size.trials_per_participant(study.config)
                * round(study.config.study.time_limit_s * study.config.study.rate_hz)
                for study in graph.studies.values())
    assert steps == 3 * (4 * 8 * 600 + 2 * 8 * 900)
    estimate = estimate_batch(batch, workers=1)
    monkeypatch.setattr(size, "MAX_STEPS_WITHOUT_YES", steps)
    size.check_batch_size(batch, estimate, confirm=False)
    monkeypatch.setattr(size, "MAX_STEPS_WITHOUT_YES", steps - 1)
    with pytest.raises(ConfigError, match=rf"simulate up to {steps:,} steps .*study.time_limit_s = 90 s"):
        size.check_batch_size(batch, estimate, confirm=False)
    size.check_batch_size(batch, estimate, confirm=True)


@given(st.floats(0.1, MAX_TIME_LIMIT_S), st.floats(1.0, MAX_RATE_HZ))
def test_steps_per_trial_is_the_protocols_count(time_limit_s, rate_hz):
    from nudgecli.sim.protocol import ProtocolSettings

    config = load_experiment("smoke")
    study = config.study.model_construct(**{**config.study.__dict__, "time_limit_s": time_limit_s,
                                            "rate_hz": rate_hz})
    config = config.model_construct(**{**config.__dict__, "study": study})
    assert size.steps_per_trial(config) == ProtocolSettings.from_config(config).time_limit_steps


# --- 2. a TOML file that is not UTF-8 --------------------------------------------------------------

def test_a_toml_file_that_is_not_utf8_is_refused_by_name(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes('[experiment]\nname = "café"\n'.encode("latin-1"))
    result = invoke(["simulate", str(path), "--out", str(tmp_path / "r")])
    line = one_error_line(result.output)
    assert result.exit_code == 1 and str(path) in line and "UTF-8" in line and "line 2" in line
    assert not (tmp_path / "r").exists()


# --- 3. --set values taken as written --------------------------------------------------------------

@pytest.mark.parametrize(("value", "words"), [
    ('study.participants="10"', "text"), ("study.participants=2.0", "whole number"),
    ("study.participants=2.5", "whole number"), ('study.rate_hz="10"', "text"),
    ("study.participants=2\nexperiment.seed=3", "one assignment"),
    ("study.participants=2\r\nexperiment.seed=3", "one assignment"),
    ("experiment.name=pilot\rexperiment.seed=3", "one assignment"),  # TOML's bare CR: read as text
])
def test_a_set_value_is_taken_as_written_or_refused(tmp_path, value, words):
    result = invoke(["simulate", "smoke", "--set", value, "--out", str(tmp_path / "r")])
    line = one_error_line(result.output)
    assert result.exit_code == 1 and words in line and "--set" in line
    assert not (tmp_path / "r").exists()


def test_a_file_holding_a_float_for_a_whole_number_is_refused(tmp_path):
    path = tmp_path / "e.toml"
    path.write_text("[study]\nparticipants = 4.0\n")
    with pytest.raises(ConfigError, match=r"e.toml: study.participants: give a whole number.*\(got 4.0\)"):
        load_experiment(str(path))


def test_a_whole_number_for_a_decimal_and_an_unquoted_word_still_pass():
    config = load_experiment("smoke", ["study.rate_hz=5", "experiment.name=my-study_2",
                                       "study.participants=3"])
    assert (config.study.rate_hz, config.experiment.name, config.study.participants) == (5.0, "my-study_2", 3)
    assert isinstance(config.study.rate_hz, float) and isinstance(config.study.participants, int)
    assert parse_override("study.conditions=['a', 'b'] ") == (["study", "conditions"], ["a", "b"])


# --- 4. the experiment's name is a plain name ------------------------------------------------------

@pytest.mark.parametrize("name", ["../../x", "a/b", "a\\b", "..", ".", "", "x\x00y", "..hidden/../x"])
def test_an_experiment_name_that_is_a_path_is_refused(tmp_path, name):
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        result = invoke(["simulate", "smoke", "--set", f"experiment.name={name!r}".replace("'", '"')])
    finally:
        os.chdir(cwd)
    line = one_error_line(result.output)
    assert result.exit_code == 1 and "experiment.name" in line and "plain name" in line
    assert list(tmp_path.iterdir()) == [] and not (tmp_path.parent / "x").exists()


def test_a_plain_name_with_dots_inside_passes():
    assert load_experiment("smoke", ['experiment.name="pilot.v2"']).experiment.name == "pilot.v2"


# --- 5. validate --belief-concentration ------------------------------------------------------------

@pytest.mark.parametrize("value", ["1e308", "1e-300", "inf", "nan", "0", "-1",
                                   f"{MAX_BELIEF_CONCENTRATION * 1.01}",
                                   f"{MIN_BELIEF_CONCENTRATION * 0.99}"])
def test_validate_refuses_a_concentration_out_of_range(tmp_path, value):
    result = invoke(["validate", "--simulations", "2", f"--belief-concentration={value}",
                     "--out", str(tmp_path / "v")])
    line = one_error_line(result.output)
    assert result.exit_code == 1 and "--belief-concentration" in line
    assert f"{MIN_BELIEF_CONCENTRATION:g}" in line and f"{MAX_BELIEF_CONCENTRATION:g}" in line
    assert not (tmp_path / "v").exists()


@pytest.mark.parametrize("concentration", [MIN_BELIEF_CONCENTRATION, MAX_BELIEF_CONCENTRATION])
def test_the_concentration_bounds_give_proper_beliefs(concentration):
    settings = ValidationSettings(belief_concentration=concentration)
    settings.check()
    # the bounds draw proper beliefs (finite, summing to one) for the most goals validate allows
    goals = settings.n_cells // 2
    beliefs = np.random.default_rng(0).dirichlet(np.full(goals, concentration), size=2000)
    assert np.isfinite(beliefs).all() and np.allclose(beliefs.sum(axis=1), 1.0)
    assert math.isfinite(concentration)
