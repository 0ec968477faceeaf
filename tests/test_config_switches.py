"""A key its switch turns off is refused, not ignored (``nudgecli.config_switches``): the decay's
delay, rate and cap without ``inference.decay``, the Monte-Carlo ``samples`` and ``weighting`` with
the exact estimator, and the distance weight's knee and drop without
``assistance.distance_weighting``. Each was accepted and changed nothing: a smoke run with any of
them wrote tables byte-identical to the default's."""

from __future__ import annotations

import pytest
from cli_helpers import nudge, stderr_error_line

from nudgecli.config import ExperimentConfig, experiment_from_toml, load_experiment
from nudgecli.config_switches import SWITCHES
from nudgecli.errors import ConfigError

#: A non-default value of each dependent key, as ``--set`` writes it.
OTHER_VALUES = {"decay_delay": "0", "decay_rate": "0.9", "decay_cap": "5", "samples": "1",
                "weighting": '"unweighted"', "distance_knee": "1.0", "distance_drop": "0.9"}
#: Each switch's "on" as ``--set`` writes it.
ON = {"decay": "true", "estimator": '"monte_carlo"', "distance_weighting": "true"}
DEPENDENTS = [(switch.section, switch.key, key) for switch in SWITCHES for key in switch.dependents]


def _refused(preset: str, *sets: str) -> str:
    with pytest.raises(ConfigError) as caught:
        load_experiment(preset, list(sets))
    return str(caught.value)


def test_the_table_names_fields_of_the_sections_and_each_switch_is_off_by_default() -> None:
    defaults = ExperimentConfig()
    for switch in SWITCHES:
        section = getattr(defaults, switch.section)
        assert getattr(section, switch.key) == switch.off
        assert set(switch.dependents) <= set(type(section).model_fields)
    assert {key for _, _, key in DEPENDENTS} == set(OTHER_VALUES)


@pytest.mark.parametrize(("section", "switch", "key"), DEPENDENTS)
def test_a_dependent_key_with_its_switch_off_is_one_error_line_naming_the_switch(section, switch, key):
    text = f"{section}.{key}={OTHER_VALUES[key]}"
    message = _refused("smoke", text)
    on = ON[switch]
    head = f"--set {text}: {section}.{key}: {OTHER_VALUES[key]} is not used with {switch} = "
    assert message.startswith(head), message
    assert f"remove {key}, or set {section}.{switch} = {on} to " in message, message
    assert "\n" not in message
    # with the switch on, the key is the model's and taken
    config = load_experiment("smoke", [f"{section}.{switch}={on}", text])
    assert str(getattr(getattr(config, section), key)) == OTHER_VALUES[key].strip('"')


def test_two_dependent_keys_are_named_in_one_line() -> None:
    message = _refused("smoke", "inference.decay_rate=0.9", "inference.decay_delay=0")
    assert "inference.decay_delay: 0 is not used with decay = false, nor is decay_rate = 0.9; remove " \
           "decay_delay and decay_rate, or set inference.decay = true to " in message, message


def test_a_dependent_key_at_its_default_passes_as_a_run_folders_config_toml_writes_it() -> None:
    config = load_experiment("smoke", ["inference.decay_rate=0.008", "disambiguation.samples=250",
                                       'disambiguation.weighting="belief"', "assistance.distance_knee=35.0"])
    assert config == load_experiment("smoke")
    assert experiment_from_toml(config.to_toml()) == config  # every key, at its value
    text = config.to_toml().replace("decay_rate = 0.008", "decay_rate = 0.5")
    refused = r"^config\.toml: inference\.decay_rate: 0\.5 is not used with decay = false"
    with pytest.raises(ConfigError, match=refused):
        experiment_from_toml(text)


def test_a_set_turning_a_switch_off_takes_the_files_dependent_keys_with_it() -> None:
    # study-code writes weighting = "unweighted" for its Monte-Carlo estimator: a sweep over the
    # estimator (or this --set) runs the exact one, which has no weighting
    exact = load_experiment("study-code", ['disambiguation.estimator="exact"'])
    assert exact.disambiguation.weighting == "belief"
    assert load_experiment("study-code").disambiguation.weighting == "unweighted"
    message = _refused("study-code", 'disambiguation.estimator="exact"',
                       'disambiguation.weighting="unweighted"')
    assert 'disambiguation.weighting: "unweighted" is not used with estimator = "exact"' in message, message


def test_a_file_giving_a_dependent_key_without_its_switch_is_refused(tmp_path) -> None:
    path = tmp_path / "forget.toml"
    path.write_text("[inference]\ndecay = false\ndecay_rate = 0.9\n", encoding="utf-8")
    message = _refused(str(path))
    assert message.startswith(f"{path}: inference.decay_rate: 0.9 is not used with decay = false"), message


def test_simulate_refuses_it_before_running(tmp_path) -> None:
    out = tmp_path / "run"
    result = nudge("simulate", "smoke", "--participants", "1", "--out", out,
                   "--set", "assistance.distance_drop=0.9", "--set", "assistance.distance_knee=1.0")
    line = stderr_error_line(result)
    assert "set assistance.distance_weighting = true" in line and "nor is distance_drop = 0.9" in line, line
    assert not out.exists()
