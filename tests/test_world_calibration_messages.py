"""Experiment values of ``[world]``, ``[calibration]`` and ``population.physiology_logs`` that once
failed late or named nothing are one ``Error:`` line at load naming where they were written and the
key: a list or a table as a CIAA condition (a ``TypeError`` traceback), a calibration prompt or blank
shorter than one sample of its stream (a fit that failed with advice about real logs' clocks), an
empty ``physiology_logs`` entry (the working directory read as a recording, refused naming no
folder) and a folder without a recording (named without the key)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from cli_helpers import nudge, one_error_line

from nudgecli.config import CalibrationSection, InterfaceSection, PopulationSection, load_experiment
from nudgecli.errors import ConfigError
from nudgecli.sim.calibration_io import distortion_windows
from nudgecli.sim.calibration_sessions import simulate_distortion_session
from nudgecli.sim.participants import draw_participant


def _refused(preset: str, *sets: str) -> str:
    with pytest.raises(ConfigError) as caught:
        load_experiment(preset, list(sets))
    assert "\n" not in str(caught.value), caught.value
    return str(caught.value)


@pytest.mark.parametrize("value", ["[[1]]", "[{a=1}]", '[["no_assistance"]]'])
def test_a_ciaa_condition_that_is_no_name_is_refused_naming_the_key(value: str) -> None:
    message = _refused("ciaa-teleop", f"world.ciaa_conditions={value}")
    assert message.startswith(f"--set world.ciaa_conditions={value}: world.ciaa_conditions.0: should be "
                              "'no_assistance'"), message


def test_a_file_giving_a_list_as_a_ciaa_condition_is_named(tmp_path: Path) -> None:
    experiment = tmp_path / "c.toml"
    experiment.write_text('[experiment]\nname = "c"\n[world]\nkind = "ciaa"\n'
                          'ciaa_conditions = [["no_assistance"]]\n')
    line = one_error_line(nudge("simulate", experiment, "--out", tmp_path / "out").output)
    assert line.startswith(f"Error: {experiment}: world.ciaa_conditions.0: should be 'no_assistance'"), line
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(("setting", "advice"), [
    ("calibration.prompt_s=1e-9", "give prompt_s >= 0.1"),
    ("calibration.prompt_s=0.09", "give prompt_s >= 0.1, or rate_hz >= 11.1111"),
    ("calibration.blank_s=0.05", "give blank_s >= 0.1, or rate_hz >= 20"),
    ("calibration.rate_hz=0.5", "give blank_s >= 2, or rate_hz >= 0.666667"),  # the study's 1.5 s blank
])
def test_a_calibration_duration_under_one_sample_is_refused_at_load(setting: str, advice: str) -> None:
    message = _refused("smoke", setting)
    assert message.startswith(f"--set {setting}: calibration: "), message
    assert "shorter than one sample of the stream at rate_hz" in message and advice in message, message


def test_simulate_refuses_a_prompt_under_one_sample_before_a_folder_is_made(tmp_path: Path) -> None:
    line = one_error_line(nudge("simulate", "smoke", "--participants", "1", "--set",
                                "calibration.prompt_s=1e-9", "--out", tmp_path / "out").output)
    assert "calibration: prompt_s = 1e-09 s is shorter than one sample" in line, line
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(("rate_hz", "duration"), [(10.0, 0.1), (3.0, 0.333333), (1000.0, 0.001)])
def test_one_sample_is_taken_and_gives_every_prompt_a_sample(rate_hz: float, duration: float) -> None:
    # the bound as the message prints it passes, and it is enough: each prompt's window (the sample
    # nearest its showing up to the one nearest its blank) holds a sample
    calibration = CalibrationSection(rate_hz=rate_hz, prompt_s=duration, blank_s=duration,
                                     prompts_per_label=2)
    person = draw_participant(PopulationSection(), 0, np.random.default_rng(5))
    session = simulate_distortion_session(person, calibration, InterfaceSection(), np.random.default_rng(7))
    starts, ends = distortion_windows(session)
    assert (ends > starts).all()


@pytest.mark.parametrize("value", ['[""]', '["logs/p1", ""]'])
def test_an_empty_physiology_log_entry_is_refused_at_load(value: str) -> None:
    message = _refused("smoke", f"population.physiology_logs={value}")
    assert message.startswith(f"--set population.physiology_logs={value}: population.physiology_logs: "
                              f"entry [{value.count(',')}] is empty"), message


def test_a_folder_without_a_recording_is_named_by_the_key(tmp_path: Path) -> None:
    folder = tmp_path / "p1"
    folder.mkdir()
    setting = f'population.physiology_logs=["{folder}"]'
    line = one_error_line(nudge("simulate", "smoke", "--set", setting, "--out", tmp_path / "out").output)
    assert line.startswith(f"Error: --set {setting}: population.physiology_logs[0]: {folder}: no "
                           "p(phi_m | phi_i) session"), line
    experiment = tmp_path / "x.toml"
    experiment.write_text(f'[experiment]\nname = "x"\n[population]\nphysiology_logs = ["{folder}"]\n')
    line = one_error_line(nudge("simulate", experiment, "--out", tmp_path / "out").output)
    assert line.startswith(f"Error: {experiment}: population.physiology_logs[0]: {folder}: no "), line
    assert not (tmp_path / "out").exists()
