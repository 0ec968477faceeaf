"""The CIAA path world refuses the agent's keys it does not read (``nudgecli.config_world``): its
``no_assistance`` infers no goal, disambiguates nothing and never assists, so it reads no key of
``[inference]``, ``[disambiguation]`` or ``[assistance]``, and of ``[model]`` only ``tables`` and
``default_table_noise`` (the agent tables each participant's record holds; the simulated person's
epsilon is their own). Each other key was accepted and ignored, and ``inference.goal_stay`` below 1
crashed the run at its first trial (a division by the one goal's zero other goals)."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import nudge, stderr_error_line

from nudgecli.config import ExperimentConfig, InferenceSection, WorldSection, load_experiment
from nudgecli.config_world import AGENT_SECTIONS, CIAA_AGENT_KEYS_READ
from nudgecli.errors import ConfigError
from nudgecli.sim.study import StudyPlan, simulate_participant_columns


def _refused(preset: str, *sets: str) -> str:
    with pytest.raises(ConfigError) as caught:
        load_experiment(preset, list(sets))
    return str(caught.value)


@pytest.mark.parametrize("text", [
    "model.epsilon=0.3", "model.gamma=0.5", "model.goal_reward=5.0", "inference.goal_stay=0.9",
    "inference.kappa=0.2", "inference.decay=true", 'inference.update="sample"',
    "disambiguation.mi_weight=3.0", 'disambiguation.estimator="monte_carlo"', "assistance.rho2_factor=9.0",
    "assistance.entropy_gate=true", "assistance.autonomy_speed=1.0", "assistance.arrival_tolerance=0.5"])
def test_an_agent_key_the_ciaa_world_does_not_read_is_refused(text: str) -> None:
    message = _refused("ciaa-teleop", text)
    key = text.split("=")[0]
    assert message.startswith(f"--set {text}: {key} = "), message
    assert 'the ciaa world (world.kind = "ciaa") does not read it' in message, message
    assert "no goal inference, disambiguation or assistance" in message, message
    assert "remove it" in message and "\n" not in message
    # a [model] key's line says which of its keys the world does read
    assert ("of [model] it reads tables and default_table_noise only" in message) == key.startswith("model.")


def test_the_model_keys_a_ciaa_run_reads_are_taken_and_change_its_record() -> None:
    # the agent's tables of each participant: not fitted from a calibration, and with this noise
    config = load_experiment("ciaa-teleop", ["study.participants=1", 'model.tables="default"',
                                             "model.default_table_noise=0.5"])
    fitted = simulate_participant_columns(StudyPlan.build(load_experiment("ciaa-teleop"), 2020), 0)
    default = simulate_participant_columns(StudyPlan.build(config, 2020), 0)
    assert default.calibration is None and fitted.calibration is not None
    assert default.record["agent_p_phi_given_a"] != fitted.record["agent_p_phi_given_a"]
    assert default.trials == fitted.trials  # no agent acts on them in this world
    assert set(CIAA_AGENT_KEYS_READ) == {"model.tables", "model.default_table_noise"}


def test_every_other_key_of_the_agent_sections_is_refused() -> None:
    sections = {name: type(getattr(ExperimentConfig(), name)) for name in AGENT_SECTIONS}
    for name, section in sections.items():
        for key, field in section.model_fields.items():
            dotted = f"{name}.{key}"
            if dotted in CIAA_AGENT_KEYS_READ:
                continue
            # any value other than the default is refused, before the section's own checks
            other = "changed" if not isinstance(field.default, bool) else not field.default
            with pytest.raises(ValueError, match=rf"{dotted} = .*: the ciaa world"):
                ExperimentConfig.model_validate({"world": {"kind": "ciaa"}, name: {key: other}})


@pytest.mark.parametrize("sets", [
    ("inference.decay=false", "assistance.entropy_gate=false", "assistance.distance_weighting=false"),
    ("model.epsilon=0.1", "inference.kappa=0.65", "assistance.rho2_factor=1.2", 'disambiguation.window=3')])
def test_an_agent_key_at_its_default_is_taken(sets: tuple[str, ...]) -> None:
    # a run folder's config.toml writes every key, false ones too
    assert load_experiment("ciaa-teleop", list(sets)).world.kind == "ciaa"


def test_the_grid_world_still_reads_the_agent_keys() -> None:
    config = load_experiment("smoke", ["model.epsilon=0.3", "inference.goal_stay=0.9", "assistance.rho3=0.5"])
    assert config.inference.goal_stay == 0.9 and config.model.epsilon == 0.3


def test_an_agent_section_in_a_ciaa_file_or_made_in_python_is_refused(tmp_path: Path) -> None:
    experiment = tmp_path / "mine.toml"
    experiment.write_text('[inference]\nkappa = 0.3\n\n[world]\nkind = "ciaa"\n', encoding="utf-8")
    message = _refused(str(experiment))
    assert message.startswith(f"{experiment}: inference.kappa = 0.3: the ciaa world"), message
    with pytest.raises(ValueError, match=r"inference\.goal_stay = 0\.9: the ciaa world"):
        ExperimentConfig(world=WorldSection(kind="ciaa"), inference=InferenceSection(goal_stay=0.9))


def test_simulate_refuses_a_goal_stay_that_crashed_the_ciaa_run(tmp_path: Path) -> None:
    # was: a ZeroDivisionError traceback at the first trial (goal_transition_matrix of one goal)
    out = tmp_path / "run"
    line = stderr_error_line(nudge("simulate", "ciaa-teleop", "--participants", "1", "--set",
                                   "inference.goal_stay=0.9", "--out", out))
    refusal = "Error: --set inference.goal_stay=0.9: inference.goal_stay = 0.9: the ciaa world"
    assert line.startswith(refusal), line
    assert not out.exists()
