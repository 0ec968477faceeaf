"""Experiment files: presets, round trips, precedence and validation."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.config import ExperimentConfig, experiment_from_toml, load_experiment
from nudgecli.config_files import list_presets, parse_override
from nudgecli.errors import ConfigError


def test_the_shipped_presets_are_listed():
    assert set(list_presets("experiments")) == {"paper", "study-code", "smoke", "ciaa-teleop", "baselines",
                                                "custom-policy"}
    assert set(list_presets("analysis")) == {"paper", "study-code", "ciaa-teleop", "baselines",
                                             "custom-policy"}
    result = CliRunner().invoke(main, ["presets"])
    assert result.exit_code == 0
    for name in ("paper", "study-code", "smoke"):
        assert f"  {name} " in result.output
    assert "Kruskal-Wallis" in result.output  # the plans' descriptions are shown


@pytest.mark.parametrize("name", ["paper", "study-code", "smoke", "ciaa-teleop", "baselines"])
def test_a_resolved_experiment_round_trips_through_toml(name):
    config = load_experiment(name)
    assert experiment_from_toml(config.to_toml()) == config


def test_presets_hold_the_values_of_the_design():
    paper, study = load_experiment("paper"), load_experiment("study-code")
    assert (paper.disambiguation.window, study.disambiguation.window) == (3, 5)
    assert (paper.disambiguation.estimator, study.disambiguation.estimator) == ("exact", "monte_carlo")
    assert (study.disambiguation.mi_weight, study.disambiguation.distance_weight) == (0.5, 0.5)
    assert study.disambiguation.rotation_gate == 12.0 and paper.disambiguation.rotation_gate is None
    assert (paper.inference.decay, study.inference.decay) == (False, True)
    assert (paper.interface.soft_threshold, study.interface.soft_threshold) == (0.3, 0.4)
    assert study.assistance.startup_delay_s == 1.0 and study.assistance.distance_weighting
    assert paper.model.epsilon == 0.1 and paper.model.gamma == 0.96 and paper.inference.kappa == 0.65
    assert paper.study.participants == 9 and paper.study.trials_per_condition == 24


def test_overrides_win_over_the_file_and_later_overrides_win():
    config = load_experiment("paper", ["study.participants=4", "study.participants=5",
                                       "disambiguation.distance=to_mean"])
    assert config.study.participants == 5 and config.disambiguation.distance == "to_mean"


def test_override_values_are_read_as_toml_literals():
    assert parse_override("a.b=3") == (["a", "b"], 3)
    assert parse_override("a.b=0.5") == (["a", "b"], 0.5)
    assert parse_override("a.b=true") == (["a", "b"], True)
    assert parse_override("a.b=word") == (["a", "b"], "word")
    assert parse_override("a.b=[3, 4]") == (["a", "b"], [3, 4])


def test_a_flag_wins_over_the_experiment(tmp_path):
    result = CliRunner().invoke(main, ["simulate", "smoke", "--participants", "1", "--seed", "3",
                                       "--out", str(tmp_path / "r")])
    assert result.exit_code == 0, result.output
    saved = experiment_from_toml((tmp_path / "r" / "config.toml").read_text())
    assert saved.study.participants == 1


@pytest.mark.parametrize(("override", "message"), [
    ("study.goal_counts=[3, 9]", "goal_counts"),
    ("study.blocks_per_condition=5", "does not divide"),
    ("interface.soft_threshold=0.7", "zero_threshold < soft_threshold <= hard_threshold"),
    ("assistance.rho2_factor=1.0", "rho2_factor must be greater"),
    ("population.epsilon=[0.5, 0.1]", "epsilon must be [low, high]"),
    ("study.conditions=['control', 'control']", "without repeats"),
])
def test_inconsistent_values_are_rejected_with_the_field(override, message):
    with pytest.raises(ConfigError, match="--set") as info:
        load_experiment("paper", [override])
    assert message in str(info.value)


def test_defaults_alone_are_a_valid_experiment():
    assert ExperimentConfig().study.conditions == ("disambiguation", "control")


@pytest.mark.parametrize(("given", "recorded", "experiment", "expected"), [
    ("ciaa-teleop", "study-code", "baselines", "ciaa-teleop"),  # the plan given wins
    (None, "study-code", "baselines", "study-code"),  # else the run's recorded plan
    (None, None, "baselines", "baselines"),  # else the plan named like the experiment
    (None, "", "study-code", "study-code"),
    (None, None, "a-new-study", "paper"),  # else paper
    (None, None, None, "paper"),
])
def test_resolve_plan_is_the_one_rule(given: str | None, recorded: str | None, experiment: str | None,
                                      expected: str) -> None:
    from nudgecli.config_files import resolve_plan

    assert resolve_plan(given, recorded=recorded, experiment=experiment) == expected


@pytest.mark.parametrize("override", ["study.rate_hz=true", "study.time_limit_s=false",
                                      "population.hold_on_s=[0.1, true]", "model.epsilon=true"])
def test_true_or_false_for_a_number_is_refused(override: str) -> None:
    # pydantic alone reads true as 1 and false as 0: a study at 1 Hz without a word
    with pytest.raises(ConfigError, match="not true/false"):
        load_experiment("smoke", [override])


def test_true_and_false_still_set_switches() -> None:
    config = load_experiment("smoke", ["behaviour.hold_on=false", "behaviour.lean_on_blending=true"])
    assert config.behaviour.hold_on is False and config.behaviour.lean_on_blending is True


@pytest.mark.parametrize("override", [
    "interface.soft_threshold=0.5",  # soft_threshold <= hard_threshold (0.5): equal is allowed
    "study.goal_counts=[2, 8]",  # 2 to 8 goals, both ends included
])
def test_the_ends_of_an_inclusive_bound_are_accepted(override: str) -> None:
    load_experiment("paper", [override])


@pytest.mark.parametrize(("experiment", "override", "message"), [
    ("paper", "assistance.rho2_factor=1.1", "rho2_factor must be greater"),  # equal to rho1_factor
    ("paper", "behaviour.fine_position_tolerance=1.0", "fine_position_tolerance must be below"),
    ("paper", "behaviour.fine_heading_tolerance=0.2", "fine_heading_tolerance must be below"),
    ("paper", "study.goal_counts=[1, 3]", "use 2 to 8"),
    # 2.0 / 10 Hz = 0.2 units a step, exactly the snapping window 2 * 0.1: it could skip a waypoint
    ("ciaa-teleop", "world.linear_speed=2.0", "keep it below 2 * world.snap_tolerance"),
])
def test_the_end_of_a_strict_bound_is_refused(experiment: str, override: str, message: str) -> None:
    with pytest.raises(ConfigError, match="--set") as info:
        load_experiment(experiment, [override])
    assert message in str(info.value)


def test_an_override_must_name_a_section_and_a_key() -> None:
    with pytest.raises(ConfigError, match="name the section and the key"):
        parse_override("participants=3")
    assert parse_override("study.participants = 3") == (["study", "participants"], 3)


def test_an_unknown_key_suggests_the_nearest_of_its_own_section() -> None:
    suggestion = r"unknown key 'study.participnts' \(did you mean 'participants'\?\)"
    with pytest.raises(ConfigError, match=suggestion):
        load_experiment("paper", ["study.participnts=3"])
    with pytest.raises(ConfigError, match=r"unknown key 'study.zzz'; known keys: participants, "):
        load_experiment("paper", ["study.zzz=3"])


#: A few trials per condition of the custom-policy experiment, in an order whose first steps are no
#: valid experiment on their own (4 trials of a condition in 3 blocks) until the last one.
FEW_TRIALS = ("study.goal_counts=[3,4]", 'study.corners=["tr","bl"]', 'study.start_modes=["x"]',
              "study.shared_layouts=1", "study.blocks_per_condition=1")


@pytest.mark.parametrize("order", [FEW_TRIALS, FEW_TRIALS[::-1], FEW_TRIALS[2:] + FEW_TRIALS[:2]])
def test_overrides_are_applied_together_then_checked_once(order: tuple[str, ...]) -> None:
    # each was checked as it was applied: blocks_per_condition=1 had to come first
    config = load_experiment("custom-policy", order)
    assert config.study.trials_per_condition == 4 and config.study.blocks_per_condition == 1
    assert config == load_experiment("custom-policy", FEW_TRIALS[::-1])


def test_the_api_takes_the_overrides_in_any_order() -> None:
    import nudgecli

    config = nudgecli.experiment_config("custom-policy", overrides={
        "study.goal_counts": [3, 4], "study.corners": ["tr", "bl"], "study.start_modes": ["x"],
        "study.shared_layouts": 1, "study.blocks_per_condition": 1})
    assert config.study.corners == ("tr", "bl") and config.study.blocks_per_condition == 1


@pytest.mark.parametrize("first", [True, False])
def test_a_bad_override_is_named_wherever_it_stands(first: bool) -> None:
    overrides = ["study.participants=abc", "experiment.seed=3", "study.participnts=3"]
    with pytest.raises(ConfigError) as info:
        load_experiment("paper", overrides if first else overrides[::-1])
    assert str(info.value).startswith("--set study.participants=abc: study.participants: ")
    with pytest.raises(ConfigError) as info:
        load_experiment("paper", ["experiment.seed=3", "study.participnts=3", "study.shared_layouts=1"])
    assert str(info.value).startswith("--set study.participnts=3: unknown key 'study.participnts' "
                                      "(did you mean 'participants'?)")


def test_the_overrides_at_fault_together_are_named_and_the_others_not() -> None:
    # each alone divides the paper's 24 trials (3 blocks of 36, 8 of 24); together 8 blocks of 36 do not
    with pytest.raises(ConfigError) as info:
        load_experiment("paper", ["study.blocks_per_condition=8", "experiment.seed=3",
                                  "study.goal_counts=[3,4,5]"])
    assert str(info.value) == ("--set study.blocks_per_condition=8 and study.goal_counts=[3,4,5]: study: "
                               "blocks_per_condition=8 does not divide the 36 trials of each condition")
    # the same bad value twice: neither alone is at fault, both are named
    with pytest.raises(ConfigError) as info:
        load_experiment("paper", ["assistance.rho3=2", "experiment.seed=3", "assistance.rho3=2"])
    assert str(info.value).startswith("--set assistance.rho3=2 and assistance.rho3=2: assistance.rho3: ")


def test_the_last_override_of_a_key_wins() -> None:
    for first, last in (("abc", 3), (3, 5)):
        overrides = [f"study.participants={first}", f"study.participants={last}"]
        assert load_experiment("paper", overrides).study.participants == last


def test_a_policy_section_set_after_its_condition_is_taken() -> None:
    config = load_experiment("paper", ['study.conditions=["blending","control"]', "blending.gate=gap"])
    assert config.blending is not None and config.blending.gate == "gap"
    with pytest.raises(ConfigError) as info:
        load_experiment("paper", ['study.conditions=["blending","control"]', "experiment.seed=3"])
    message = str(info.value)
    assert message.startswith('--set study.conditions=["blending","control"]: ') and "before" not in message


@pytest.mark.parametrize("command", [["simulate"], ["replicate", "-R", "1"], ["power", "-R", "1"]])
def test_every_command_takes_the_overrides_in_any_order(command: list[str], tmp_path) -> None:
    sets = [word for text in FEW_TRIALS for word in ("--set", text)]
    result = CliRunner().invoke(main, [command[0], "custom-policy", *command[1:], "--participants", "2",
                                       *sets, "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output


def test_a_sweeps_set_and_parameters_are_taken_in_any_order(tmp_path) -> None:
    from nudgecli.runs.sweep import load_sweep

    path = tmp_path / "s.toml"
    # the fixed overrides first, then each point's parameters: all applied, then checked
    path.write_text(f'experiment = "custom-policy"\nreplications = 1\nset = {list(FEW_TRIALS)!r}\n'
                    '[design]\nmethod = "grid"\n[parameters]\n"study.participants" = [2, 3]\n')
    assert [point.config.study.trials_per_condition for point in load_sweep(str(path)).points] == [4, 4]


def test_a_sweeps_set_that_needs_the_points_parameters_is_taken(tmp_path) -> None:
    from nudgecli.runs.sweep import load_sweep

    path = tmp_path / "s.toml"
    # without blocks_per_condition, the set leaves 4 trials in 3 blocks: valid at every point only
    # together with the parameter; the plan is still the one named like the experiment
    fixed = [item for item in FEW_TRIALS if "blocks_per_condition" not in item]
    path.write_text(f'experiment = "custom-policy"\nreplications = 1\nset = {fixed!r}\n'
                    '[design]\nmethod = "grid"\n[parameters]\n"study.blocks_per_condition" = [1, 2, 4]\n')
    sweep = load_sweep(str(path))
    assert [point.config.study.blocks_per_condition for point in sweep.points] == [1, 2, 4]
    assert sweep.spec.plan == "custom-policy"
