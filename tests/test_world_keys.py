"""A key the chosen world does not read is one ``Error:`` line, never a setting silently ignored
(``nudgecli.config_world``). The CIAA path world runs ``world.ciaa_conditions`` in its task's subject
blocks: it read no ``study.conditions`` (every run was ``no_assistance``: the 7 baselines' and a custom
policy's conditions too), no condition section, none of the grid's design keys, nor
``study.success_distance`` / ``interface.human_speed`` (its own are ``[world]``'s); the grid world reads
none of ``[world]``'s path keys. Each was accepted and ignored without a word."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import nudge, stderr_error_line

from nudgecli.config import (
    ExperimentConfig,
    StudySection,
    WorldSection,
    experiment_from_toml,
    load_experiment,
)
from nudgecli.config_files import list_presets
from nudgecli.errors import ConfigError

EXPERIMENTS = Path(__file__).resolve().parents[1] / "experiments"


def _refused(preset: str, *sets: str) -> str:
    with pytest.raises(ConfigError) as caught:
        load_experiment(preset, list(sets))
    return str(caught.value)


@pytest.mark.parametrize("text", [
    'study.conditions=["teleoperation", "blending"]', "study.success_distance=5.0",
    "interface.human_speed=10.0", "interface.human_turn_rate=1.0", "study.blocks_per_condition=1",
    "study.success_angle=0.5", 'study.goal_counts=[3]', 'study.counterbalancing="rotation"',
    "study.shared_layouts=2", 'study.start_modes=["x"]', 'study.corners=["tr"]'])
def test_a_key_the_ciaa_world_does_not_read_is_refused(text: str) -> None:
    message = _refused("ciaa-teleop", text)
    key = text.split("=")[0]
    assert message.startswith(f"--set {text}: {key} = "), message
    assert 'the ciaa world (world.kind = "ciaa") does not read it' in message, message
    assert "world.ciaa_conditions" in message and "remove it" in message and "\n" not in message


@pytest.mark.parametrize(("text", "instead"), [("interface.human_speed=10.0", "world.linear_speed"),
                                               ("study.success_distance=5.0", "reaching the goal waypoint")])
def test_the_refusal_names_what_the_ciaa_world_reads_instead(text: str, instead: str) -> None:
    assert f"and {instead}" in _refused("ciaa-teleop", text)


def test_a_single_ignored_condition_is_not_advised_a_second_one() -> None:
    # before: "only one condition ('teleoperation'); a study compares two or more", whose fix ran nothing new
    message = _refused("ciaa-teleop", 'study.conditions=["teleoperation"]')
    assert "world.ciaa_conditions" in message and "two or more" not in message, message


def test_the_baselines_in_the_ciaa_world_are_refused_naming_conditions_and_sections(tmp_path: Path) -> None:
    out = tmp_path / "bl"
    line = stderr_error_line(nudge("simulate", "baselines", "--participants", "2", "--set", "world.kind=ciaa",
                                   "--set", "study.time_limit_s=50", "--out", out))
    assert line.startswith("Error: --set world.kind=ciaa: [blending], [mode-switch], [hindsight], "
                           "study.conditions = "), line
    assert '"turn-taking"' in line and "remove them" in line and not out.exists()


def test_a_custom_policy_in_the_ciaa_world_is_refused_before_its_module_is_imported(tmp_path: Path) -> None:
    source = (EXPERIMENTS / "custom-policy.toml").read_text(encoding="utf-8")
    source = source.replace('conditions = ["disambiguation", "blending", "threshold"]',
                            'conditions = ["teleoperation", "threshold"]')
    source = source.replace('counterbalancing = "williams-pair"', "")
    source = source.replace('[blending]\ngate = "gap"\ngap = 0.4', "")
    experiment = tmp_path / "custom-ciaa.toml"
    experiment.write_text(source + '\n[world]\nkind = "ciaa"\n', encoding="utf-8")
    out = tmp_path / "run"
    line = stderr_error_line(nudge("simulate", experiment, "--participants", "2", "--out", out))
    assert line.startswith(f"Error: {experiment}: [policies], study.conditions = "), line
    assert "world.ciaa_conditions" in line and not out.exists()


@pytest.mark.parametrize("command", ["simulate", "replicate"])
def test_simulate_and_a_batch_refuse_before_a_folder_is_made(tmp_path: Path, command: str) -> None:
    out = tmp_path / "out"
    args = ("-R", "2") if command == "replicate" else ()
    line = stderr_error_line(nudge(command, "ciaa-teleop", "--participants", "2", *args, "--set",
                                   "study.success_distance=5.0", "--out", out))
    assert "study.success_distance = 5.0: the ciaa world" in line and not out.exists(), line


def test_a_section_made_in_python_is_refused_too() -> None:
    with pytest.raises(ValueError, match=r"study\.success_distance = 3\.0: the ciaa world"):
        ExperimentConfig(world=WorldSection(kind="ciaa"), study=StudySection(success_distance=3.0))


@pytest.mark.parametrize(("text", "instead"), [
    ("world.linear_speed=2.0", "interface.human_speed"), ("world.snap_tolerance=0.2", "no waypoints"),
    ('world.ciaa_conditions=["no_assistance", "no_assistance"]', "study.conditions"),
    ("world.success_distance=0.5", "study.success_distance"),
    ("world.heading_tolerance=0.3", "success_angle"),
    ("world.angular_speed=1.0", "interface.human_turn_rate")])
def test_a_path_world_key_in_a_grid_run_is_refused(text: str, instead: str) -> None:
    message = _refused("smoke", text)
    assert message.startswith(f"--set {text}: "), message
    assert 'the grid world (world.kind = "grid") does not read it' in message and instead in message, message


def test_a_file_giving_an_ignored_key_is_named(tmp_path: Path) -> None:
    experiment = tmp_path / "mine.toml"
    experiment.write_text('[study]\nsuccess_distance = 2.0\n\n[world]\nkind = "ciaa"\n', encoding="utf-8")
    with pytest.raises(ConfigError) as caught:
        load_experiment(str(experiment))
    message = str(caught.value)
    assert message.startswith(f"{experiment}: study.success_distance = 2.0: the ciaa world"), message


@pytest.mark.parametrize("preset", list_presets("experiments"))
def test_every_preset_and_its_run_folder_config_still_load(preset: str) -> None:
    config = load_experiment(preset)
    # a run folder's config.toml writes every key, those its world does not read at their defaults
    again = experiment_from_toml(config.to_toml())
    assert again == config.model_copy(update={"policy_search_path": None})


def test_a_key_given_at_its_default_is_taken() -> None:
    # the default changes nothing the world does; a run folder's config.toml gives every key so
    config = load_experiment("ciaa-teleop", ["study.blocks_per_condition=3", "interface.human_speed=3.0"])
    assert config.world.kind == "ciaa"
    load_experiment("smoke", ["world.linear_speed=1.6", "world.snap_tolerance=0.1"])


@pytest.mark.parametrize("args", [("run", "smoke"), ("study", "smoke", "--participant", "P01")])
def test_run_and_the_study_page_refuse_a_path_world_key(tmp_path: Path, args: tuple[str, ...]) -> None:
    out = tmp_path / "out"
    line = stderr_error_line(nudge(*args, "--set", "world.linear_speed=2.0", "--out", out))
    assert "world.linear_speed = 2.0: the grid world" in line and not out.exists(), line
