"""A policy's ``view`` shows its trial as it is now, and a policy cannot change the trial through it:
assigning or deleting any attribute of the view raises, and so does writing into its arrays (the
belief, the goal poses, the goal transition), each one policy error naming the condition, the policy
and what it wrote (docs/policies.md), never a teleported robot or a corrupted inference."""

from __future__ import annotations

import gc
import math
import sys
import weakref
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner, Result
from policy_helpers import policy_experiment

from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.model.disambiguation import DisambiguationModel
from nudgecli.model.interface import (
    HARD_PUFF,
    NO_INPUT,
    SOFT_PUFF,
    default_distortion_table,
    default_mapping_table,
    label_of_pressure,
)
from nudgecli.model.mdp import solve_layout
from nudgecli.model.path_world import PathWorld
from nudgecli.model.world import sample_layout
from nudgecli.rng import generator
from nudgecli.sim import protocol
from nudgecli.sim.policy_interface import Assistance, AtStep, AutonomyTurn, read_only_view
from nudgecli.sim.protocol import ProtocolSettings, TrialSession, TrialSpec
from tests.test_path_world import straight_layout

POLICY = """
from nudgecli.sim.policy_interface import Assistance, AutonomyTurn

class Writer:
    infers = True
    takes_turns = {takes_turns}

    def assist(self, view):
        {assist}
        return Assistance(view.u_h)

    def start_turn(self, view):
        {start_turn}
        return AutonomyTurn.stay()
{extra}"""

#: the optional hooks, each running ``{hook}``'s statement
CHOOSE_MODE = """
    def choose_mode(self, view, requested):
        {choose_mode}
        return None
"""
ASSIST_QUIET = """
    def assist_quiet(self, view, steps):
        {assist_quiet}
        return [(1, self.assist(view))]
"""


def _simulate(tmp_path: Path, *, takes_turns: bool = False, **statements: str) -> tuple[Path, Result]:
    """``nudge simulate`` of control and a ``writer`` policy whose hooks run ``statements``."""
    hooks = {"assist": "pass", "start_turn": "pass", "choose_mode": "pass", "assist_quiet": "pass",
             **statements}
    extra = "".join(text for name, text in (("choose_mode", CHOOSE_MODE), ("assist_quiet", ASSIST_QUIET))
                    if name in statements)
    module = POLICY.format(takes_turns=takes_turns, extra=extra.format(**hooks), **hooks)
    experiment = policy_experiment(tmp_path, {"writer": "writermodule:Writer"},
                                   modules={"writermodule.py": module})
    sys.modules.pop("writermodule", None)  # each test's module is its own
    out = tmp_path / "run"
    return out, CliRunner().invoke(main, ["simulate", str(experiment), "--out", str(out)])


def _error_line(result: Result) -> str:
    assert result.exit_code == 1, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert len(errors) == 1 and "Traceback" not in result.output, result.output
    return errors[0]


@pytest.mark.parametrize(("hook", "takes_turns"), [("assist", False), ("start_turn", True)])
def test_writing_into_the_views_belief_is_one_policy_error_line(tmp_path: Path, hook: str,
                                                               takes_turns: bool) -> None:
    _, result = _simulate(tmp_path, **{hook: "view.belief[:] = 0"}, takes_turns=takes_turns)
    error = _error_line(result)
    assert "condition 'writer' (policy writermodule:Writer)" in error
    assert f"{hook} raised ValueError" in error and "read-only" in error


@pytest.mark.parametrize(("hook", "takes_turns"), [("assist", False), ("start_turn", True),
                                                   ("choose_mode", False), ("assist_quiet", False)])
@pytest.mark.parametrize(("statement", "attribute"), [
    ("view.x = 0.0", "view.x"), ("view.mode = 2", "view.mode"), ("view.step += 1", "view.step"),
    ("view.leader = 0", "view.leader"), ("del view.theta", "view.theta"),
    ("view.extra = 1", "view.extra"),  # not one of the view's attributes either
])
def test_assigning_to_the_view_is_one_policy_error_line_naming_the_attribute(
        tmp_path: Path, hook: str, takes_turns: bool, statement: str, attribute: str) -> None:
    out, result = _simulate(tmp_path, **{hook: statement}, takes_turns=takes_turns)
    error = _error_line(result)
    assert "condition 'writer' (policy writermodule:Writer)" in error, error
    assert f"{hook} raised AttributeError: the view is read-only: a policy cannot set {attribute} " in error
    assert not (out / "trials").exists()  # the run stopped at the write: no table of a changed trial


@pytest.mark.parametrize(("statement", "what"), [("view.goal_poses[0, 0] = 9.0", "goal_poses"),
                                                 ("view.goal_poses[:] *= 0", "goal_poses"),
                                                 # cached on the model the participant's trials share
                                                 ("view.model.likelihood[...] = 0.25", "likelihood"),
                                                 ("view.model.mapping[0, 0] = 0.0", "mapping")])
def test_writing_into_the_goal_poses_is_one_policy_error_line(tmp_path: Path, statement: str,
                                                              what: str) -> None:
    _, result = _simulate(tmp_path, assist=statement)
    error = _error_line(result)
    assert "assist raised ValueError" in error and "read-only" in error, (what, error)


@pytest.mark.parametrize("quiet", [False, True])
def test_every_view_a_policy_is_handed_refuses_an_assignment(tmp_path: Path, quiet: bool) -> None:
    # every hook, on every call (the person's steps, the quiet runs one by one or at once, the
    # autonomy's turns, the mode switches): the policy fails the run where an assignment goes through
    refuse = ("try:\n            view.x = view.x\n        except AttributeError:\n            pass\n"
              "        else:\n            raise RuntimeError('a writable view')")
    hooks = {"assist": refuse, "start_turn": refuse, "choose_mode": refuse}
    if quiet:
        hooks["assist_quiet"] = refuse
    out, result = _simulate(tmp_path, takes_turns=True, **hooks)
    assert result.exit_code == 0, result.output
    assert (out / "trials").exists()


def test_every_belief_a_policy_sees_is_read_only_and_still_the_posterior(tmp_path: Path) -> None:
    # the policy refuses a writable belief, and one that is no distribution: the flag is set on
    # the first belief and on every update, and setting it changes no value
    check = ("assert not view.belief.flags.writeable, 'writable'; "
             "assert abs(float(view.belief.sum()) - 1.0) < 1e-9 and (view.belief >= 0).all(), 'not a belief'")
    out, result = _simulate(tmp_path, assist=check, start_turn=check, takes_turns=True)
    assert result.exit_code == 0, result.output
    assert (out / "trials").exists()


def test_a_read_only_belief_still_reads_as_numpy_reads_any_array() -> None:
    # the protocol and the built-in policies only read the belief: copying, argmax and arithmetic
    # of a read-only array give new arrays, as for a writable one
    belief = np.array([0.2, 0.5, 0.3])
    belief.setflags(write=False)
    assert int(np.argmax(belief)) == 1
    assert (belief * 2).flags.writeable and belief.copy().flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        belief[0] = 1.0


# --- the view of a session, step by step ----------------------------------------------------------

#: what docs/policies.md says a policy sees (StepView's attributes)
SEEN = ("x", "y", "theta", "mode", "state", "step", "turn", "goal_poses", "belief", "leader",
        "leader_probability", "entropy", "measured", "u_h", "initiated_at", "model", "goal_transition",
        "rng", "settings")


class Recorder:
    """A policy that, at every call, compares each attribute its view shows with the session's own
    at that moment, and tries to assign one."""

    infers = True
    takes_turns = True

    def __init__(self) -> None:
        self.session: TrialSession | None = None
        self.calls: list[str] = []

    def _see(self, hook: str, view: Any) -> None:
        assert self.session is not None and view is not self.session
        for name in SEEN:
            seen, own = getattr(view, name), getattr(self.session, name)
            assert seen is own or seen == own or np.array_equal(seen, own), (hook, name, seen, own)
        with pytest.raises(AttributeError, match=r"cannot set view\.x "):
            view.x = 1.0
        self.calls.append(hook)

    def assist(self, view: Any) -> Assistance:
        self._see("assist", view)
        return Assistance(view.u_h)

    def start_turn(self, view: Any) -> AutonomyTurn:
        self._see("start_turn", view)
        return AutonomyTurn(np.array([view.x + 0.5, view.y, view.theta]))

    def choose_mode(self, view: Any, requested: int) -> int | None:
        self._see("choose_mode", view)
        return None

    def assist_quiet(self, view: Any, steps: int) -> list[tuple[int, Assistance]]:
        self._see("assist_quiet", view)
        return [(steps, Assistance(view.u_h))]


def _session(monkeypatch: pytest.MonkeyPatch, policy: object, goal_stay: float = 0.9) -> TrialSession:
    """A trial of the paper's protocol on a 3-goal layout that runs ``policy``."""
    monkeypatch.setattr(protocol, "make_policy", lambda condition, settings: policy)
    settings = replace(ProtocolSettings.from_config(load_experiment("paper")), goal_stay=goal_stay)
    layout = sample_layout(generator(3, "layout", 0), "tr", 3, 0)
    solved = solve_layout(layout.goal_cells, layout.goal_headings)
    model = DisambiguationModel(layout.goal_cells, solved.p_a_given_sg, default_mapping_table(0.3),
                                default_distortion_table(0.3))
    spec = TrialSpec(participant=0, condition="recorder", block=0, trial=0, layout_index=0, layout=layout)
    return TrialSession(spec, settings, model, 3, np.random.default_rng(5))


def _pressure(settings: ProtocolSettings, label: int) -> float:
    """A pressure the driver measures as ``label``."""
    for pressure in np.linspace(-1.0, 1.0, 2001):
        if label_of_pressure(float(pressure), settings.soft_threshold, settings.hard_threshold,
                             settings.zero_threshold) == label:
            return float(pressure)
    raise AssertionError(label)


def test_the_view_shows_the_session_live_at_every_call_and_refuses_assignments(monkeypatch) -> None:
    recorder = Recorder()
    session = _session(monkeypatch, recorder)
    recorder.session = session
    soft, hard = _pressure(session.settings, SOFT_PUFF), _pressure(session.settings, HARD_PUFF)
    for pressure in [soft] * 4 + [0.0, hard, 0.0] + [soft] * 3:  # moves, a mode switch, moves
        session.human_step(NO_INPUT if pressure == 0.0 else label_of_pressure(
            pressure, session.settings.soft_threshold, session.settings.hard_threshold), pressure)
    while session.turn == "human" and not session.finished:  # idle until the handover
        session.quiet_human_steps(20)
    while session.turn == "autonomy" and not session.finished:
        session.autonomy_step()
    assert {"assist", "choose_mode", "assist_quiet", "start_turn"} <= set(recorder.calls), recorder.calls
    # the session itself stays the protocol's to change
    assert session.step == len(session.rows) and math.isfinite(session.x)


class ArrayWriter:
    """A policy that writes ``value`` into ``view.<name>[0, 0]`` at its first step."""

    takes_turns = False

    def __init__(self, name: str, infers: bool) -> None:
        self.name, self.infers = name, infers

    def assist(self, view: Any) -> Assistance:
        getattr(view, self.name)[0, 0] = 99.0
        return Assistance(view.u_h)


def test_the_goal_transition_a_policy_sees_is_read_only(monkeypatch) -> None:
    session = _session(monkeypatch, ArrayWriter("goal_transition", infers=True))
    before = np.array(session.goal_transition)
    with pytest.raises(ValueError, match="read-only"):
        session.human_step(NO_INPUT, 0.0)
    np.testing.assert_array_equal(session.goal_transition, before)


def test_a_path_worlds_goal_poses_are_read_only_to_the_policy_and_the_worlds_own_stay(monkeypatch) -> None:
    # the path world's own goal array is writable and its goal check reads it: a policy that wrote
    # into view.goal_poses would move the goal
    monkeypatch.setattr(protocol, "make_policy", lambda condition, settings: ArrayWriter("goal_poses", False))
    layout = straight_layout()
    world = PathWorld(layout)
    goal = np.array(world.goal_poses)
    spec = TrialSpec(participant=0, condition="writer", block=0, trial=0, layout_index=0, layout=layout)
    session = TrialSession(spec, ProtocolSettings.from_config(load_experiment("ciaa-teleop")), None, 3,
                           np.random.default_rng(0), world=world)
    with pytest.raises(ValueError, match="read-only"):
        session.human_step(NO_INPUT, 0.0)
    np.testing.assert_array_equal(world.goal_poses, goal)
    assert world.goal_poses.flags.writeable  # the world's own array is the world's


def test_a_finished_session_is_freed_without_the_garbage_collector(monkeypatch) -> None:
    # the view shares the session's attributes; held inside them it would be a reference cycle, and
    # every trial's rows would wait for a full collection
    session = _session(monkeypatch, Recorder())
    world = weakref.ref(session.world)
    gc.disable()
    try:
        del session
        assert world() is None, "the session's attributes outlived the session"
    finally:
        gc.enable()


def test_a_read_only_view_of_a_plain_object_reads_live_and_keeps_its_properties() -> None:
    class Source:
        def __init__(self) -> None:
            self.a = 1

        @property
        def twice(self) -> int:
            return 2 * self.a

    source = Source()
    view = read_only_view(source)
    source.a = 5  # the source changes; the view shows it
    assert (view.a, view.twice) == (5, 10)
    with pytest.raises(AttributeError, match=r"cannot set view\.a "):
        view.a = 2
    with pytest.raises(AttributeError, match=r"cannot set view\.a "):
        del view.a
    assert source.a == 5 and isinstance(view, Source)


def test_a_view_at_a_later_step_of_a_quiet_run_is_read_only_too() -> None:
    # what a policy's assist_quiet hands its own assist (AtStep) refuses assignments as the view does
    class Source:
        def __init__(self) -> None:
            self.x, self.step = 1.5, 3

    later = AtStep(read_only_view(Source()), 7)
    assert (later.x, later.step) == (1.5, 7)
    for name in ("x", "step"):
        with pytest.raises(AttributeError, match=rf"cannot set view\.{name} "):
            setattr(later, name, 0)


@pytest.mark.parametrize(("statement", "name"), [
    ("view.rows.append(view.rows[-1])", "rows"), ("view.rows.clear()", "rows"),
    ("view.pending_events.append('x')", "pending_events"),
    ("view.human_step(-1, 0.0)", "human_step"), ("view.autonomy_step()", "autonomy_step"),
    ("view._set_belief(view.belief)", "_set_belief"), ("view.summary()", "summary"),
])
def test_the_sessions_records_and_methods_are_not_in_the_view(tmp_path: Path, statement: str,
                                                              name: str) -> None:
    # a list the view handed out could be appended to, and a method called through the view would
    # act on the session (human_step appends its row before any assignment refuses)
    out, result = _simulate(tmp_path, assist=statement)
    error = _error_line(result)
    assert f"assist raised AttributeError: a policy's view has no {name}: " in error, error
    assert not (out / "trials").exists()


@pytest.mark.parametrize("statement", ["view.model.p_a_given_sg[0, 0, 0] = 1.0",
                                       "view.model.mapping[0, 0, 0] = 1.0",
                                       "view.model.goal_positions('world')[0, 0] = 9.0",
                                       "view.model.goal_cells[0, 0] = 3"])
def test_the_models_arrays_are_read_only_to_a_policy(tmp_path: Path, statement: str) -> None:
    # the model is shared by the participant's trials, and its action table by the layout's solution
    _, result = _simulate(tmp_path, assist=statement)
    error = _error_line(result)
    assert "assist raised ValueError" in error and "read-only" in error, error


def test_a_hidden_name_raises_on_reading_and_on_assigning() -> None:
    view = read_only_view(TrialSession.__new__(TrialSession))
    for name in ("human_step", "rows", "recording"):
        with pytest.raises(AttributeError, match=f"has no {name}"):
            getattr(view, name)
    with pytest.raises(AttributeError, match=r"cannot set view\.rows"):
        view.rows = []  # type: ignore[misc]
