"""Experiment values that cannot mean anything are refused in one line: inf and NaN in every float
field of every section, a reward, duration, rate or count past its documented bound, a key the CIAA
world never reads of ``[behaviour]``, a true/false key (or a sweep range's ``integer``) given text or
a number, and a repeated entry of the study's design lists.

Each test was seen failing with its fix removed (accepted, or a traceback)."""

from __future__ import annotations

import math
import re
import typing
from pathlib import Path
from typing import Any

import pytest
from pydantic import ValidationError

from nudgecli.config import (
    MAX_RATE_HZ,
    MAX_REWARD,
    MAX_TIME_LIMIT_S,
    ExperimentConfig,
    load_experiment,
)
from nudgecli.config_base import Section, admits
from nudgecli.config_people import MAX_CALIBRATION_REPEATS
from nudgecli.errors import ConfigError
from nudgecli.runs.sweep import load_sweep


def _section_classes() -> dict[str, type[Section]]:
    """Every section class of an experiment, by its key (``[policies.NAME]`` by ``policies``)."""
    found: dict[str, type[Section]] = {}
    for name, field in ExperimentConfig.model_fields.items():
        stack: list[Any] = [field.annotation]
        while stack:
            kind = stack.pop()
            if isinstance(kind, type) and issubclass(kind, Section):
                found[name] = kind
            else:
                stack.extend(typing.get_args(kind))
    return found


def _float_fields() -> list[tuple[str, str]]:
    """``(section, key)`` of every field that takes a float: a field added later is covered too."""
    return [(section, key) for section, cls in _section_classes().items()
            for key, field in cls.model_fields.items() if admits(field.annotation, float)]


def _with(default: Any, bad: float) -> Any:
    """``bad`` in the shape of ``default`` (a range or list gets it as its last entry)."""
    if isinstance(default, tuple | list) and default:
        return [*default[:-1], bad]
    return bad


def test_the_walk_finds_the_float_fields_of_every_section():
    fields = set(_float_fields())
    assert {("model", "move_reward"), ("population", "rest_s"), ("calibration", "prompt_s"),
            ("disambiguation", "rotation_gate"), ("world", "linear_speed")} <= fields
    assert len(fields) > 60


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf], ids=["nan", "inf", "-inf"])
@pytest.mark.parametrize(("section", "key"), _float_fields())
def test_every_float_field_refuses_inf_and_nan(section, key, bad):
    cls = _section_classes()[section]
    default = cls.model_fields[key].get_default(call_default_factory=True)
    # a key its switch turns off (inference.decay_rate without decay) is refused as unused first
    with pytest.raises(ValidationError, match=r"finite number|is not used with"):
        cls.model_validate({key: _with(default, bad)})


@pytest.mark.parametrize("setting", ["model.move_reward=nan", "model.goal_reward=inf",
                                     "interface.human_speed=inf", "study.success_angle=inf",
                                     "assistance.startup_delay_s=inf", "behaviour.max_hold_s=inf"])
def test_inf_or_nan_is_one_line_naming_the_key(setting):
    with pytest.raises(ConfigError) as error:
        load_experiment("smoke", [setting])
    message = str(error.value)
    key = setting.split("=")[0]
    assert "\n" not in message and f"{key}: " in message and "finite number" in message


@pytest.mark.parametrize(("setting", "bound"), [
    (f"model.mode_switch_reward={-MAX_REWARD * 10:g}", "at least"),
    (f"model.goal_reward={MAX_REWARD * 10:g}", "at most"),
    ("model.mode_switch_reward=-1e308", "at least"),
    ("behaviour.stall_s=1e300", "at most"), (f"behaviour.max_hold_s={MAX_TIME_LIMIT_S + 1}", "at most"),
    (f"calibration.rate_hz={MAX_RATE_HZ * 1.001}", "at most"), ("calibration.rate_hz=1e9", "at most"),
    (f"calibration.prompt_s={MAX_TIME_LIMIT_S + 1}", "at most"),
    (f"calibration.prompts_per_label={MAX_CALIBRATION_REPEATS + 1}", "at most"),
    ("calibration.mapping_blocks=100000000", "at most"),
])
def test_a_value_past_its_bound_is_refused(setting, bound):
    with pytest.raises(ConfigError, match=f"{setting.split('=')[0]}: must be {bound}"):
        load_experiment("smoke", [setting])


def test_the_monte_carlo_samples_are_bounded():
    monte_carlo = "disambiguation.estimator=monte_carlo"
    with pytest.raises(ConfigError, match=r"disambiguation\.samples: must be at most 100000"):
        load_experiment("smoke", [monte_carlo, "disambiguation.samples=1000000000"])
    at_bound = load_experiment("smoke", [monte_carlo, "disambiguation.samples=100000"])
    assert at_bound.disambiguation.samples == 100_000


def test_the_bounds_themselves_are_taken():
    config = load_experiment("smoke", [f"model.goal_reward={MAX_REWARD:g}",
                                       f"model.move_reward={-MAX_REWARD:g}",
                                       f"calibration.rate_hz={MAX_RATE_HZ}",
                                       f"behaviour.max_hold_s={MAX_TIME_LIMIT_S}",
                                       f"calibration.mapping_blocks={MAX_CALIBRATION_REPEATS}"])
    assert config.model.goal_reward == MAX_REWARD and config.calibration.rate_hz == MAX_RATE_HZ
    # apart: an hour's prompts at 1000 Hz, 12 per label, are above the calibration's samples limit
    longest = load_experiment("smoke", [f"calibration.prompt_s={MAX_TIME_LIMIT_S}",
                                        "calibration.prompts_per_label=1"])
    assert longest.calibration.prompt_s == MAX_TIME_LIMIT_S


@pytest.mark.parametrize("setting", ["behaviour.lean_on_blending=false",
                                     "behaviour.release_when_dragged=false",
                                     'behaviour.after_autonomy="resume"',
                                     "behaviour.fine_position_tolerance=0.05",
                                     "behaviour.fine_heading_tolerance=0.01"])
def test_the_ciaa_world_refuses_the_behaviour_keys_it_never_reads(setting):
    # traced and run: a CIAA trial has no goal cell (no fine positioning), no blending and no
    # autonomy turn; each of these gave tables identical to the defaults'
    key = setting.split("=")[0]
    with pytest.raises(ConfigError) as error:
        load_experiment("ciaa-teleop", [setting])
    message = str(error.value)
    assert "\n" not in message and f"{key} = " in message and "does not read it" in message


def test_the_ciaa_world_takes_the_behaviour_keys_it_reads():
    config = load_experiment("ciaa-teleop", ["behaviour.decisions=grid", "behaviour.stall_s=2",
                                             "behaviour.lean_on_blending=true"])
    assert config.behaviour.decisions == "grid"


@pytest.mark.parametrize("value", ["yes", '"true"', "1", "0"])
def test_a_true_false_key_refuses_text_and_numbers(value):
    with pytest.raises(ConfigError, match=r"decay = .*: give true or false"):
        load_experiment("smoke", [f"inference.decay={value}"])
    assert load_experiment("smoke", ["inference.decay=true"]).inference.decay is True


@pytest.mark.parametrize("setting", ["study.goal_counts=[3,3]", 'study.corners=["tr","tr"]',
                                     'study.start_modes=["x","y","x"]'])
def test_a_repeated_design_entry_is_refused(setting):
    key = setting.split("=")[0].split(".")[1]
    with pytest.raises(ConfigError, match=f"{key} must be a list without repeats"):
        load_experiment("smoke", [setting])



@pytest.mark.parametrize("value", ['"yes"', "1"])
def test_a_sweep_range_integer_refuses_text_and_numbers(tmp_path, value):
    sweep = (Path(__file__).parents[1] / "experiments" / "sweeps" / "example.toml").read_text()
    path = tmp_path / "s.toml"
    path.write_text(sweep.replace('"inference.kappa" = { low = 0.5, high = 0.8 }',
                                  f'"study.participants" = {{ low = 1, high = 3, integer = {value} }}'))
    # the experiment sections' rule of values as written (config_base.Section), naming key and value
    said = rf"parameters\.study\.participants: integer = {re.escape(value)}: give true or false \(no quotes\)"
    with pytest.raises(ConfigError, match=said):
        load_sweep(str(path))
