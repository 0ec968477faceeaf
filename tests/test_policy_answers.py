"""Every answer of a researcher's policy is checked as the interface documents it (docs/policies.md,
'What it returns'): an AutonomyTurn's mode, goal, events and nudge, an Assistance's alpha and goal,
choose_mode's mode; a wrong one is one Error line naming the condition and the policy, exit 1."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from nudgecli.errors import PolicyError
from nudgecli.sim.policy_interface import Assistance, AutonomyTurn
from nudgecli.sim.policy_registry import CheckedPolicy, PolicySpec
from tests.test_custom_policy import GOOD, _experiment, _one_error_line, _simulate

DESCRIBED = "condition 'mine' (policy mymodule:Mine)"


def _checked(**hooks) -> CheckedPolicy:
    traits = {"infers": True, "takes_turns": True, "assist": None, "start_turn": None}
    return CheckedPolicy(SimpleNamespace(**{**traits, **hooks}), PolicySpec("mine", "mymodule:Mine"))


def _view() -> SimpleNamespace:
    return SimpleNamespace(step=0, goal_poses=np.zeros((3, 3)), u_h=(0.0, 0.0, 0.0))


def _turn(**fields) -> AutonomyTurn:
    plan = AutonomyTurn(None, **fields)
    return _checked(start_turn=lambda view: plan).start_turn(_view())


# --- the autonomy's turn ---------------------------------------------------------------------------

@pytest.mark.parametrize(("fields", "words"), [
    ({"nudge": "yes"}, ["start_turn returned nudge 'yes'", "True or False"]),
    ({"nudge": 5}, ["nudge 5", "True or False"]),
    ({"nudge": float("nan")}, ["nudge nan", "True or False"]),
    ({"nudge": 1}, ["nudge 1", "True or False"]),
    ({"mode": 2.0}, ["start_turn returned mode 2.0", "0, 1, 2 or None"]),
    ({"mode": True}, ["mode True"]),
    ({"mode": 3}, ["mode 3"]),
    ({"goal": 99}, ["start_turn returned goal 99", "-1 or a goal index below 3"]),
    ({"goal": True}, ["goal True"]),
    ({"goal": 1.0}, ["goal 1.0"]),
    ({"events": "nudge"}, ["start_turn returned events 'nudge'", "a tuple of event names"]),
    ({"events": 3}, ["events 3"]),
    ({"events": ("nudg",)}, ["event 'nudg'", "did you mean 'nudge'", "nudge, step, mode_select"]),
    ({"events": ("handover_to_autonomy",)}, ["event 'handover_to_autonomy'"]),
])
def test_a_wrong_autonomy_turn_is_a_policy_error(fields, words):
    with pytest.raises(PolicyError) as raised:
        _turn(**fields)
    assert str(raised.value).startswith(DESCRIBED)
    for word in words:
        assert word in str(raised.value), (word, str(raised.value))


def test_a_good_autonomy_turn_is_passed_on_in_plain_types():
    plan = _turn(mode=np.int64(1), goal=np.int64(2), events=["nudge"], nudge=np.bool_(True))
    assert plan == AutonomyTurn(None, 1, ("nudge",), 2, True)
    assert type(plan.mode) is int and type(plan.goal) is int and type(plan.nudge) is bool
    assert _turn() == AutonomyTurn.stay()


@pytest.mark.parametrize(("turn", "words"), [
    ('AutonomyTurn(None, nudge="yes")', ["start_turn returned nudge 'yes'"]),
    ("AutonomyTurn(None, mode=2.0)", ["start_turn returned mode 2.0"]),
    ("AutonomyTurn(None, goal=99)", ["start_turn returned goal 99"]),
    ('AutonomyTurn(None, events="nudge")', ["start_turn returned events 'nudge'"]),
])
def test_a_wrong_autonomy_turn_in_a_run_is_one_error_line(tmp_path, turn, words):
    module = GOOD.replace("takes_turns = False", "takes_turns = True").replace(
        "return AutonomyTurn.stay()", f"return {turn}")
    _, result = _simulate(tmp_path, _experiment(tmp_path, module))
    _one_error_line(result, DESCRIBED, *words)


# --- the person's turn: alpha is a weight from 0 to 1, a goal or a mode is an integer, not a bool ---

@pytest.mark.parametrize(("answer", "words"), [
    (Assistance((0.0, 0.0, 0.0), alpha=5.0), ["assist returned alpha 5.0", "from 0 to 1"]),
    (Assistance((0.0, 0.0, 0.0), alpha=-0.5), ["alpha -0.5"]),
    (Assistance((0.0, 0.0, 0.0), alpha=True), ["alpha True"]),
    (Assistance((0.0, 0.0, 0.0), goal=True), ["assist returned goal True"]),
])
def test_a_wrong_assistance_is_a_policy_error(answer, words):
    with pytest.raises(PolicyError) as raised:
        _checked(assist=lambda view: answer).assist(_view())
    assert str(raised.value).startswith(DESCRIBED)
    for word in words:
        assert word in str(raised.value), (word, str(raised.value))


@pytest.mark.parametrize("alpha", [0, 1, 0.5, np.float32(1.0)])
def test_an_alpha_from_0_to_1_is_passed_on(alpha):
    checked = _checked(assist=lambda view: Assistance((0.0, 0.0, 0.0), alpha=alpha, goal=np.int64(2)))
    answer = checked.assist(_view())
    assert answer.alpha == float(alpha) and answer.goal == 2


@pytest.mark.parametrize("mode", [True, 1.0, 3])
def test_choose_mode_answers_a_mode_not_a_bool(mode):
    checked = _checked(choose_mode=lambda view, requested: mode)
    assert checked.choose_mode is not None
    with pytest.raises(PolicyError, match=f"choose_mode returned {mode!r}"):
        checked.choose_mode(_view(), 1)


def test_an_alpha_out_of_range_in_a_run_is_one_error_line(tmp_path):
    module = GOOD.replace("return Assistance(view.u_h)", "return Assistance(view.u_h, alpha=5.0)")
    _, result = _simulate(tmp_path, _experiment(tmp_path, module))
    _one_error_line(result, DESCRIBED, "assist returned alpha 5.0")


def test_numpys_bools_are_true_or_false_as_pythons_are(tmp_path):
    module = "import numpy as np\n" + GOOD.replace("infers = True", "infers = np.bool_(True)").replace(
        "takes_turns = False", "takes_turns = np.bool_(False)")
    _, result = _simulate(tmp_path, _experiment(tmp_path, module))
    assert result.exit_code == 0, result.output


# --- a trait that raises when read (a property) ----------------------------------------------------

@pytest.mark.parametrize("name", ["takes_turns", "infers", "constant_metrics", "assist_quiet"])
def test_a_policy_attribute_that_raises_when_read_is_one_error_line(tmp_path, name):
    module = GOOD + f"""
    @property
    def {name}(self):
        raise RuntimeError("not ready")
"""
    module = module.replace(f"    {name} = ", f"    _{name} = ")
    out, result = _simulate(tmp_path, _experiment(tmp_path, module))
    _one_error_line(result, DESCRIBED, f"reading its {name} raised RuntimeError: not ready")
    assert not (out / "trials").exists()
