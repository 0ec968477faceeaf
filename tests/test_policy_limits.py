"""A researcher's policy is held to what docs/policies.md documents: a turn's target the robot can
reach, a command within the speed limit, commands and targets of exactly three real numbers,
parameters JSON records unchanged (no TOML dates), the shipped example naming the metric it makes
constant, and the view's ``turn`` as a policy sees it."""

from __future__ import annotations

import datetime
import inspect
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from nudgecli.config import load_experiment
from nudgecli.errors import PolicyError
from nudgecli.runs.study import run_study
from nudgecli.sim import protocol
from nudgecli.sim.policy_interface import Assistance, AutonomyTurn, StepView, checked_command, checked_pose
from nudgecli.sim.policy_registry import CheckedPolicy, PolicySpec, command_limits, constant_metrics_of
from tests.test_custom_policy import GOOD, _experiment, _one_error_line, _simulate

ROOT = Path(__file__).resolve().parents[1]
DESCRIBED = "condition 'mine' (policy mymodule:Mine)"
#: A policy that takes any parameters.
KEYWORDS = GOOD.replace("weight=0.5):\n        self.weight = weight",
                        "**params):\n        self.params = params")
#: The protocol's settings a check reads: the paper's speeds and arrival tolerance.
SETTINGS = SimpleNamespace(human_speed=3.0, human_turn_rate=1.95, autonomy_speed=5.0, autonomy_turn_rate=1.5,
                           arrival_tolerance=0.1)


def _checked(**hooks) -> CheckedPolicy:
    traits = {"infers": True, "takes_turns": True, "assist": None, "start_turn": None}
    return CheckedPolicy(SimpleNamespace(**{**traits, **hooks}), PolicySpec("mine", "mymodule:Mine"))


def _view() -> SimpleNamespace:
    return SimpleNamespace(step=0, goal_poses=np.zeros((3, 3)), u_h=(0.0, 0.0, 0.0), settings=SETTINGS)


def _error(call) -> str:
    with pytest.raises(PolicyError) as raised:
        call()
    message = str(raised.value)
    assert message.startswith(DESCRIBED) and "\n" not in message
    return message


# --- 1. a turn's target the robot can reach ---------------------------------------------------------

@pytest.mark.parametrize("target", [(100.0, 100.0, 0.0), (44.9, 20.0, 0.0), (20.0, 1.0, 0.0),
                                    (-5.0, 20.0, 1.0)])
def test_a_turns_target_the_robot_cannot_reach_is_refused_naming_the_bounds(target):
    checked = _checked(start_turn=lambda view: AutonomyTurn(np.array(target)))
    message = _error(lambda: checked.start_turn(_view()))
    for words in (f"start_turn returned target {tuple(float(v) for v in target)} outside the workspace",
                  "x 3.7 to 44.3, y 2.7 to 35.3", "the workspace x 3 to 45, y 2 to 36",
                  "arrival_tolerance 0.1"):
        assert words in message, (words, message)


@pytest.mark.parametrize("target", [(3.7, 2.7, 0.0), (44.3, 35.3, 6.0), (44.35, 20.0, 0.0),
                                    (20.0, 20.0, -1.0)])
def test_a_turns_target_within_reach_is_passed_on(target):
    plan = AutonomyTurn(np.array(target), nudge=True)
    assert _checked(start_turn=lambda view: plan).start_turn(_view()) == plan


def test_a_turn_beyond_the_walls_in_a_run_is_one_error_line(tmp_path):
    module = "import numpy as np\n" + GOOD.replace("takes_turns = False", "takes_turns = True").replace(
        "return AutonomyTurn.stay()", "return AutonomyTurn(np.array([100.0, 100.0, 0.0]))")
    _, result = _simulate(tmp_path, _experiment(tmp_path, module))
    _one_error_line(result, DESCRIBED, "target (100.0, 100.0, 0.0) outside the workspace", "x 3.7 to 44.3")


# --- 2. a command within the speed limit ----------------------------------------------------------

@pytest.mark.parametrize(("command", "words"), [
    ((3000.0, 0.0, 0.0), ["assist returned command (3000.0, 0.0, 0.0)", "speed 3000 units/s",
                          "at most 8 units/s", "at most 3.45 rad/s"]),
    ((6.0, 6.0, 0.0), ["speed 8.48528 units/s"]),
    ((0.0, 0.0, -3.5), ["turn 3.5 rad/s"]),
    ((8.0 * (1 + 1e-6), 0.0, 0.0), ["at most 8 units/s"]),
])
def test_a_command_faster_than_the_limit_is_refused_naming_it(command, words):
    message = _error(lambda: _checked(assist=lambda view: Assistance(command)).assist(_view()))
    for word in words:
        assert word in message, (word, message)


@pytest.mark.parametrize("command", [(8.0, 0.0, 3.45), (0.0, -8.0 * (1 + 1e-12), -3.45 * (1 + 1e-12)),
                                     (4.8, 6.4, 0.0), (-3.0, 0.0, 1.95)])
def test_a_command_within_the_limit_is_passed_on(command):
    assert _checked(assist=lambda view: Assistance(command)).assist(_view()).command == command


def test_the_limit_is_the_persons_full_command_plus_the_autonomys():
    assert command_limits(SETTINGS) == (8.0, 3.45)  # type: ignore[arg-type]


def test_a_command_too_fast_in_a_run_is_one_error_line(tmp_path):
    module = GOOD.replace("return Assistance(view.u_h)",
                          "return Assistance(tuple(1000.0 * v for v in view.u_h))")
    _, result = _simulate(tmp_path, _experiment(tmp_path, module))
    _one_error_line(result, DESCRIBED, "assist returned command", "at most 8 units/s")


def test_every_built_in_policy_passes_the_same_checks_on_the_baselines(tmp_path, monkeypatch):
    """The built-ins (hindsight's additive turn the fastest, at 98% of the limit) run through the
    checks a researcher's policy gets: their commands, targets, alphas and goals all pass."""
    made = protocol.make_policy
    conditions = set()

    def checked(condition, settings):
        conditions.add(condition)
        return CheckedPolicy(made(condition, settings), PolicySpec(condition, f"builtin:{condition}"))

    config = load_experiment("baselines", ["study.goal_counts=[3]", 'study.corners=["tr"]',
                                           'study.start_modes=["x"]', "study.blocks_per_condition=1"])
    monkeypatch.setattr(protocol, "make_policy", checked)
    run_study(config, tmp_path / "checked", participants=1, workers=1)
    assert conditions == set(config.study.conditions)


# --- 5. exactly three real numbers ------------------------------------------------------------------

@pytest.mark.parametrize(("value", "words"), [
    (np.zeros((3, 1)), "of shape (3,), got shape (3, 1)"),
    (np.zeros((1, 3)), "of shape (3,), got shape (1, 3)"),
    ([[1.0], [2.0], [3.0]], "of shape (3,), got shape (3, 1)"),
    ((True, False, False), "not true/false"),
    (np.array([True, False, False]), "not true/false"),
    ((1.0, np.bool_(True), 0.0), "not true/false"),
    ((1.0, "2", 0.0), "not true/false or text"),
    ((1.0, 2.0), "got 2"),
    (None, "got None"),
])
def test_a_command_or_target_is_exactly_three_real_numbers(value, words):
    for check in (checked_command, checked_pose):
        with pytest.raises(ValueError, match="must be three numbers") as raised:
            check(value, "its command")
        assert words in str(raised.value), (words, str(raised.value))


@pytest.mark.parametrize("value", [(1.0, 2.0, 3.0), [1, 2, 3], np.array([1.0, 2.0, 3.0]), np.arange(3),
                                   (np.float32(1.0), np.int64(2), 3.0),
                                   np.array([1.0, 2.0, 3.0], dtype=np.float32)])
def test_three_real_numbers_are_a_tuple_of_floats(value):
    command = checked_command(value, "its command")
    assert command == (1.0, 2.0, 3.0) or command == (0.0, 1.0, 2.0)
    assert all(type(v) is float for v in command)


@pytest.mark.parametrize("command", [np.reshape((1.0, 0.0, 0.0), (3, 1)), (True, False, False)])
def test_a_column_or_bools_from_a_policy_is_a_policy_error(command):
    message = _error(lambda: _checked(assist=lambda view: Assistance(command)).assist(_view()))
    assert "assist: its command must be three numbers (vx, vy, omega)" in message


# --- 3. parameters JSON holds unchanged -------------------------------------------------------------

@pytest.mark.parametrize(("params", "words"), [
    ("{ since = 2026-01-31 }", ['since = 2026-01-31: give text in quotes, not a date or time',
                                'e.g. since = "2026-01-31"']),
    ("{ at = 10:30:00 }", ['at = 10:30:00', 'e.g. at = "10:30:00"']),
    ("{ when = 2026-01-31T10:30:00Z }", ['e.g. when = "2026-01-31T10:30:00+00:00"']),
    ('{ days = [2026-01-31, "x"] }', ['days = [2026-01-31, "x"]', 'e.g. days = ["2026-01-31", "x"]']),
    ("{ t = { from = 2026-01-31 } }", ['e.g. t = {from = "2026-01-31"}']),
])
def test_a_date_or_time_parameter_is_refused_with_what_to_write(tmp_path, params, words):
    out, result = _simulate(tmp_path, _experiment(tmp_path, KEYWORDS,
                                                  params=params))
    _one_error_line(result, "policies.mine.params:", "JSON, which has no dates or times", *words)
    assert not out.exists()


def test_text_numbers_and_flags_are_taken_as_parameters(tmp_path):
    experiment = _experiment(tmp_path, KEYWORDS,
                             params='{ since = "2026-01-31", n = 2, on = true, xs = [0.5, 1] }')
    config = load_experiment(str(experiment))
    assert config.policies is not None
    assert config.policies["mine"].params == {"since": "2026-01-31", "n": 2, "on": True, "xs": [0.5, 1]}
    assert not any(isinstance(v, datetime.date) for v in config.policies["mine"].params.values())


# --- 4. the shipped example names the metric it makes constant ---------------------------------------

def test_the_threshold_example_names_its_constant_strength():
    config = load_experiment(str(ROOT / "experiments" / "custom-policy.toml"))
    assert "assistance_strength" in constant_metrics_of(config)["threshold"]
    assert 'constant_metrics = frozenset({"assistance_strength"})' in (ROOT / "experiments" / "policies"
                                                            / "threshold.py").read_text()


# --- 6, 7. what the documentation says a policy sees -----------------------------------------------

def test_the_page_says_a_private_unseeded_generator_is_not_detected():
    page = (ROOT / "docs" / "policies.md").read_text()
    box = page[page.index("> **Draw only from `view.rng`.**"):page.index("What it returns:")]
    assert "np.random.default_rng()" in box and "not detected" in box


def test_a_policy_sees_only_the_persons_turn_and_the_documentation_says_so(tmp_path):
    asserted = "assert view.turn == 'human', view.turn\n        "
    module = GOOD.replace("takes_turns = False", "takes_turns = True").replace(
        "return Assistance(view.u_h)", asserted + "return Assistance(view.u_h)").replace(
        "return AutonomyTurn.stay()", asserted + "return AutonomyTurn.stay()")
    out, result = _simulate(tmp_path, _experiment(tmp_path, module))
    assert result.exit_code == 0, result.output
    trials = pd.read_parquet(out / "trials")
    assert trials.loc[trials["condition"] == "mine", "autonomy_turns"].sum() > 0  # start_turn was asked
    documented = inspect.getdoc(StepView) or ""
    assert '``"human"`` or ``"autonomy"``' not in documented and 'Always ``"human"``' in documented
    assert 'always `"human"` for a policy' in (ROOT / "docs" / "policies.md").read_text()
