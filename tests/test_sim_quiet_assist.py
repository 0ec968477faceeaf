"""A policy's answer to a whole quiet run (the optional ``assist_quiet``): the built-in policies'
answers are their ``assist`` at every step of the run, the protocol records what a hook answers as
it records the step-by-step ``assist``, and a policy without the hook still runs step by step."""

from __future__ import annotations

import functools
import math
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_sim_protocol import session_of

from nudgecli.config import load_experiment
from nudgecli.errors import PolicyError
from nudgecli.model import assistance
from nudgecli.model.inference import normalised_entropy
from nudgecli.model.interface import NO_COMMAND, NO_INPUT
from nudgecli.model.ties import unique_argmax
from nudgecli.sim.builtin_policies import BUILTIN_POLICIES
from nudgecli.sim.policy_interface import Assistance, AtStep
from nudgecli.sim.policy_registry import CheckedPolicy, PolicySpec
from nudgecli.sim.protocol import ProtocolSettings, TrialSession
from nudgecli.sim.study import build_layouts

# --- the start-up gate's end ----------------------------------------------------------------------


def _first_open_step(initiated_at: int, dt: float, delay: float) -> int:
    """The gate's end by brute force: assistance_alpha's own test, step after step."""
    step = initiated_at
    while (step - initiated_at) * dt < delay:
        step += 1
    return step


@settings(max_examples=300, deadline=None)
@given(initiated_at=st.integers(0, 5000),
       dt=st.sampled_from([0.1, 0.05, 0.01, 1 / 30, 0.2, 0.3]) | st.floats(1e-3, 1.0),
       delay=st.sampled_from([0.0, 0.1, 0.3, 0.35, 0.7, 1.0, 0.6000000000000001, 2.9999999999999996])
       | st.floats(-1.0, 5.0))
def test_the_start_up_gate_ends_at_the_first_step_the_gates_own_test_passes(initiated_at, dt, delay) -> None:
    assert assistance.startup_delay_end(initiated_at, dt, delay) == _first_open_step(initiated_at, dt, delay)


def test_the_start_up_gate_ends_where_alpha_first_acts() -> None:
    blending = assistance.BlendingSettings(rho1_factor=1.1, rho2_factor=1.2, rho3=0.8, entropy_gate=None,
                                           startup_delay=0.3, distance_weighting=False, distance_knee=35.0,
                                           distance_drop=0.4)
    # 0.1 * 3 = 0.30000000000000004: the gate opens at 3 steps after the first input, not 4
    opens = assistance.startup_delay_end(10, 0.1, 0.3)
    assert opens == 13
    alphas = [assistance.assistance_alpha(0.9, 4, 0.2, (step - 10) * 0.1, 5.0, blending)
              for step in range(10, 16)]
    assert alphas == [0.0, 0.0, 0.0, 0.8, 0.8, 0.8]
    # the estimate ceil(delay / dt) off either way: 0.9 / 0.3 = 3.0 but 3 * 0.3 = 0.8999999999999999
    # (a fourth step), and 0.3 / 0.1 = 2.9999999999999996 with 3 * 0.1 past 0.3 already
    assert assistance.startup_delay_end(0, 0.3, 0.9) == 4 and assistance.startup_delay_end(0, 0.1, 0.3) == 3
    with pytest.raises(ValueError, match="finite"):
        assistance.startup_delay_end(0, 0.1, math.inf)


# --- the built-in policies' answers against their assist at every step ----------------------------

#: Built-in policies and the ``--set`` overrides that give each of their assist rules.
POLICY_CASES = [
    ("disambiguation", ()), ("control", ()), ("turn-taking", ()), ("mode-switch", ()),
    ("blending", ()), ("blending", ("blending.gate=gap", "blending.gap=0.2")),
    ("blending", ("blending.kind=additive",)), ("teleoperation", ()),
    ("hindsight", ()), ("hindsight", ("hindsight.assist=on-command",)),
]


@functools.cache
def _settings(overrides: tuple[str, ...], delay: float, gate: bool, weighting: bool) -> ProtocolSettings:
    rules = (f"assistance.startup_delay_s={delay}", f"assistance.entropy_gate={str(gate).lower()}",
             f"assistance.distance_weighting={str(weighting).lower()}")
    return ProtocolSettings.from_config(load_experiment("paper", [*overrides, *rules]))


@st.composite
def _views(draw: st.DrawFn) -> SimpleNamespace:
    """A view of a quiet step: no input, a drawn pose, belief, step and first input."""
    n_goals = draw(st.integers(2, 4))
    weights = draw(st.lists(st.sampled_from([1.0, 2.0, 3.0, 8.0, 30.0]), min_size=n_goals, max_size=n_goals))
    belief = np.array(weights) / sum(weights)  # ties among the leaders drawn too
    coordinate = st.floats(2.0, 80.0)
    goal_poses = np.array([[draw(coordinate), draw(coordinate), draw(st.sampled_from([0.0, 0.785, 3.14]))]
                           for _ in range(n_goals)])
    step = draw(st.integers(0, 300))
    initiated_at = draw(st.sampled_from([-1, step, max(0, step - 1), max(0, step - 3), max(0, step - 20)]))
    heading = draw(st.sampled_from([0.0, 1.2, 4.0]))
    return SimpleNamespace(x=draw(coordinate), y=draw(coordinate), theta=heading, mode=0,
                           step=step, turn="human", goal_poses=goal_poses, belief=belief,
                           leader=unique_argmax(belief), leader_probability=float(belief.max()),
                           entropy=float(normalised_entropy(belief)), measured=NO_INPUT, u_h=NO_COMMAND,
                           initiated_at=initiated_at, model=None, goal_transition=None, rng=None)


def _expanded(runs: Any) -> list[Assistance]:
    return [assistance_ for count, assistance_ in runs for _ in range(count)]


def _plain(answer: Assistance) -> tuple[Any, ...]:
    """An assistance as exact floats (a command may be a tuple or an array)."""
    return (tuple(float(v) for v in answer.command), tuple(float(v) for v in answer.u_a), float(answer.alpha),
            int(answer.goal))


@settings(max_examples=60, deadline=None)
@given(case=st.sampled_from(POLICY_CASES), view=_views(), steps=st.integers(1, 40),
       delay=st.sampled_from([0.0, 0.3, 0.35, 1.0]), gate=st.booleans(), weighting=st.booleans())
def test_a_built_in_policys_quiet_answer_is_its_assist_at_every_step(case, view, steps, delay, gate,
                                                                    weighting) -> None:
    name, overrides = case
    protocol = _settings(overrides, delay, gate, weighting)
    view.settings = protocol
    answer = BUILTIN_POLICIES[name](protocol).assist_quiet(view, steps)
    assert all(count >= 1 for count, _ in answer) and sum(count for count, _ in answer) == steps
    every = BUILTIN_POLICIES[name](protocol)  # a fresh one: a policy remembers its last command
    expected = [every.assist(SimpleNamespace(**{**vars(view), "step": step}))
                for step in range(view.step, view.step + steps)]
    assert [_plain(a) for a in _expanded(answer)] == [_plain(a) for a in expected]


def test_a_run_where_the_start_up_gate_opens_is_two_answers() -> None:
    protocol = _settings((), 0.35, False, False)
    belief = np.array([0.7, 0.2, 0.1])
    view = SimpleNamespace(x=10.0, y=10.0, theta=0.0, mode=0, step=20, goal_poses=np.array(
        [[40.0, 30.0, 0.0], [5.0, 5.0, 0.0], [70.0, 10.0, 0.0]]), belief=belief, leader=0,
        leader_probability=0.7, entropy=float(normalised_entropy(belief)), u_h=NO_COMMAND, initiated_at=18,
        settings=protocol)
    answer = BUILTIN_POLICIES["disambiguation"](protocol).assist_quiet(view, 10)
    # 0.1 * 4 = 0.4 is the first time since the first input (step 18) not below 0.35: step 22
    assert [(count, a.alpha) for count, a in answer] == [(2, 0.0), (8, 0.8)]
    assert AtStep(view, 22).step == 22 and AtStep(view, 22).x == 10.0


# --- the protocol records a hook's answer as the step-by-step assist ------------------------------

class StepAlpha:
    """A test policy whose alpha is its step (/ 1000), so a record of the wrong step shows; ``u_a``
    points along x without moving the robot (the command stays none). From ``moves_at`` on its
    command moves the robot. ``answer`` is how its quiet hook answers: ``exact`` one stretch a step,
    ``short`` the first three steps only, ``long`` one stretch past the run's end (right only while
    its alpha does not change, so ``per_step`` off), ``empty-stretch`` a stretch of 0 steps."""

    infers = False
    takes_turns = False

    def __init__(self, answer: str, moves_at: int = 10**9, per_step: bool = True) -> None:
        self.answer, self.moves_at, self.per_step = answer, moves_at, per_step
        self.asked = 0

    def assist(self, view: Any) -> Assistance:
        self.asked += 1
        command = (1.0, 0.0, 0.0) if view.step >= self.moves_at else NO_COMMAND
        return Assistance(command, (0.5, 0.0, 0.0), view.step / 1000 if self.per_step else 0.25, 0)

    def assist_quiet(self, view: Any, steps: int) -> list[tuple[int, Assistance]]:
        if self.answer == "long":
            return [(steps + 7, self.assist(view))]
        if self.answer == "empty-stretch":
            return [(0, self.assist(view))]
        shown = min(steps, 3) if self.answer == "short" else steps
        return [(1, self.assist(AtStep(view, view.step + k))) for k in range(shown)]

    def start_turn(self, view: Any) -> Any:
        raise AssertionError("no turns")


@pytest.fixture(scope="module")
def paper():
    config = load_experiment("paper")
    return config, ProtocolSettings.from_config(config), build_layouts(config, 11)


def _session(paper: Any, policy: Any, hook: bool) -> TrialSession:
    session = session_of(paper, "teleoperation")
    session.policy = policy
    session.assist_quiet = policy.assist_quiet if hook else None
    session.initiated_at = 0  # the idle count counts
    return session


def _plain_rows(session: TrialSession) -> list[tuple[Any, ...]]:
    """The session's rows with the belief arrays as lists (exact floats either way)."""
    return [tuple(v.tolist() if isinstance(v, np.ndarray) else v for v in row) for row in session.rows]


def _quiet_steps(session: TrialSession, steps: int) -> list[int]:
    """``steps`` quiet steps as the trial loop runs them: a run, and the rest asked again."""
    ran: list[int] = []
    while sum(ran) < steps:
        ran.append(session.quiet_human_steps(steps - sum(ran)))
    return ran


@pytest.mark.parametrize(("answer", "moves_at", "per_step", "first_run"), [
    ("exact", 10**9, True, 25), ("short", 10**9, True, 4), ("long", 10**9, False, 25),
    ("exact", 6, True, 6), ("long", 1, False, 1),
])
def test_the_protocol_records_a_quiet_answer_as_it_records_assist_step_by_step(paper, answer, moves_at,
                                                                              per_step, first_run) -> None:
    hooked = _session(paper, StepAlpha(answer, moves_at, per_step), hook=True)
    one_by_one = _session(paper, StepAlpha(answer, moves_at, per_step), hook=False)
    hooked_runs, one_by_one_runs = _quiet_steps(hooked, 25), _quiet_steps(one_by_one, 25)
    # the first step in full, then at once as many as the hook covered, up to a moving command
    assert hooked_runs[0] == first_run
    if answer != "short":
        assert hooked_runs == one_by_one_runs
    assert len(hooked.rows) == 25 and _plain_rows(hooked) == _plain_rows(one_by_one)
    assert [row[12] for row in hooked.rows[:6]] == ([0.0, 0.001, 0.002, 0.003, 0.004, 0.005] if per_step
                                                    else [0.25] * 6)  # alpha: each step's own
    assert (hooked.step, hooked.idle, hooked.turn) == (one_by_one.step, one_by_one.idle, one_by_one.turn)
    assert (hooked.x, hooked.y, hooked.theta) == (one_by_one.x, one_by_one.y, one_by_one.theta)


def test_a_hook_asks_assist_once_a_run_and_a_policy_without_one_at_every_step(paper) -> None:
    hooked = _session(paper, StepAlpha("long", per_step=False), hook=True)
    one_by_one = _session(paper, StepAlpha("long", per_step=False), hook=False)
    hooked.quiet_human_steps(30)
    one_by_one.quiet_human_steps(30)
    assert (hooked.policy.asked, one_by_one.policy.asked) == (2, 30)  # the first step's own, and the run's


def test_a_stretch_of_no_steps_is_refused(paper) -> None:
    session = _session(paper, StepAlpha("empty-stretch"), hook=True)
    with pytest.raises(ValueError, match="stretch of 0 steps"):
        session.quiet_human_steps(5)


def test_a_built_in_policys_session_takes_its_hook() -> None:
    config = load_experiment("paper")
    paper = (config, ProtocolSettings.from_config(config), build_layouts(config, 11))
    for name in BUILTIN_POLICIES:
        session = session_of(paper, name)
        assert session.assist_quiet is not None and session.assist_quiet.__self__ is session.policy


# --- a researcher's policy: its hook checked like its assist --------------------------------------

def test_a_researchers_hook_is_checked_and_a_policy_without_one_runs_step_by_step() -> None:
    spec = PolicySpec("mine", "mymodule:Mine")
    view = SimpleNamespace(step=4, goal_poses=np.zeros((3, 3)), u_h=NO_COMMAND)
    checked = CheckedPolicy(StepAlpha("exact"), spec)
    assert checked.assist_quiet is not None
    assert checked.assist_quiet(view, 2) == [(1, Assistance((0.0, 0.0, 0.0), (0.5, 0.0, 0.0), 0.004, 0)),
                                             (1, Assistance((0.0, 0.0, 0.0), (0.5, 0.0, 0.0), 0.005, 0))]
    with pytest.raises(PolicyError, match=r"condition 'mine' \(policy mymodule:Mine\): assist_quiet gave"):
        CheckedPolicy(StepAlpha("empty-stretch"), spec).assist_quiet(view, 2)  # type: ignore[misc]
    broken = StepAlpha("long")
    broken.assist = lambda view: Assistance(NO_COMMAND, alpha=math.nan)  # type: ignore[method-assign]
    with pytest.raises(PolicyError, match="assist_quiet returned alpha nan"):
        CheckedPolicy(broken, spec).assist_quiet(view, 2)  # type: ignore[misc]
    failing = StepAlpha("long")
    failing.assist_quiet = lambda view, steps: 1 / 0  # type: ignore[method-assign]
    with pytest.raises(PolicyError, match="assist_quiet raised ZeroDivisionError"):
        CheckedPolicy(failing, spec).assist_quiet(view, 2)  # type: ignore[misc]
    without = SimpleNamespace(infers=False, takes_turns=False, assist=None, start_turn=None)
    assert CheckedPolicy(without, spec).assist_quiet is None
