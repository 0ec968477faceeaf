"""A simulated calibration's size as a whole: each ``[calibration]`` key has its bound, but several at
their bounds together (1000 Hz, 1000 prompts per label, an hour a prompt and an hour a blank) ask
for 1000 x 4 x 1000 x 7200 = 2.9e10 samples and ran out of memory; one check of their product
refuses that, naming the keys and the product (the tested example: 3e7 samples)."""

from __future__ import annotations

from pathlib import Path

import pytest

from nudgecli.config import load_experiment
from nudgecli.config_files import list_presets
from nudgecli.config_people import MAX_CALIBRATION_SAMPLES, CalibrationSection
from nudgecli.errors import ConfigError


def test_keys_within_their_bounds_together_above_the_limit_are_refused() -> None:
    with pytest.raises(ConfigError) as raised:
        load_experiment("smoke", ["calibration.rate_hz=1000", "calibration.prompts_per_label=1000"])
    line = str(raised.value)
    assert "calibration.rate_hz=1000" in line and "calibration.prompts_per_label=1000" in line, line
    assert "rate_hz x 4 labels x prompts_per_label x (prompt_s + blank_s)" in line, line
    assert "1000 x 4 x 1000 x (6 + 1.5) = 30,000,000 samples" in line, line
    assert f"{MAX_CALIBRATION_SAMPLES:,}" in line and "\n" not in line, line


def test_the_limit_is_far_above_a_real_calibration() -> None:
    study = CalibrationSection()
    assert study.rate_hz * 4 * study.prompts_per_label * (study.prompt_s + study.blank_s) == 3600
    CalibrationSection(rate_hz=1000)  # the fastest stream with the study's prompts: 360,000 samples
    CalibrationSection(rate_hz=100, prompts_per_label=50, prompt_s=30, blank_s=10)  # 800,000


def test_the_limit_itself_is_accepted_and_a_sample_above_it_refused() -> None:
    at_limit = CalibrationSection(rate_hz=500, prompts_per_label=50, prompt_s=8.5, blank_s=1.5)
    assert at_limit.rate_hz * 4 * at_limit.prompts_per_label * (at_limit.prompt_s + at_limit.blank_s) \
        == MAX_CALIBRATION_SAMPLES
    with pytest.raises(ValueError, match=f"= 1,000,000 samples per calibration session, above the limit "
                                         f"of {MAX_CALIBRATION_SAMPLES:,}"):  # 1,000,000.1 samples
        CalibrationSection(rate_hz=500, prompts_per_label=50, prompt_s=8.5000001, blank_s=1.5)


@pytest.mark.parametrize("name", sorted(list_presets("experiments")))
def test_every_shipped_experiment_passes(name: str) -> None:
    calibration = load_experiment(name).calibration
    assert calibration.rate_hz * 4 * calibration.prompts_per_label * \
        (calibration.prompt_s + calibration.blank_s) <= MAX_CALIBRATION_SAMPLES


def test_a_file_names_itself(tmp_path: Path) -> None:
    experiment = tmp_path / "big.toml"
    experiment.write_text('extends = "smoke"\n[experiment]\nname = "big"\n'
                          "[calibration]\nrate_hz = 1000\nprompts_per_label = 1000\nprompt_s = 60\n")
    with pytest.raises(ConfigError) as raised:
        load_experiment(str(experiment))
    assert str(raised.value).startswith(f"{experiment}: calibration: rate_hz x 4 labels"), raised.value
