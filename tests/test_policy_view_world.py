"""A policy's ``view.world`` shows its trial's world read-only (the goals, the start, the pure
queries of :class:`nudgecli.model.world.World`), never ``move`` or the world's own attributes (a
path world keeps the trial's waypoint and turn, which its moves update), and the view does not hand
out the policy object, its hooks or the trial's specification (the true goal): each attempt is
one policy error line naming it (docs/policies.md), never a changed trial."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from nudgecli.config import load_experiment
from nudgecli.model.interface import NO_INPUT
from nudgecli.model.path_world import PathWorld
from nudgecli.sim import protocol
from nudgecli.sim.policy_interface import Assistance, AutonomyTurn, WorldView
from nudgecli.sim.protocol import ProtocolSettings, TrialSession, TrialSpec
from tests.test_path_world import straight_layout
from tests.test_policy_view_readonly import _error_line, _session, _simulate


@pytest.mark.parametrize(("statement", "message"), [
    ("view.world.move(view.x, view.y, view.theta, (1.0, 0.0, 0.0), 0.1)",
     "AttributeError: a policy's view of the world has no move: "),
    ("view.world.layout.goal_cells", "AttributeError: a policy's view of the world has no layout: "),
    ("view.world.success_distance = 9.0",
     "AttributeError: the view is read-only: a policy cannot set view.world.success_distance "),
    ("del view.world.success_angle",
     "AttributeError: the view is read-only: a policy cannot set view.world.success_angle "),
    ("view.world = None", "AttributeError: the view is read-only: a policy cannot set view.world "),
    ("view.world.goal_poses[0, 0] = 9.0", "ValueError: assignment destination is read-only"),
    ("view.world.start_pose[0] = 9.0", "ValueError: assignment destination is read-only"),
    ("view.policy", "AttributeError: a policy's view has no policy: "),
    ("view.policy.threshold = 1.0", "AttributeError: a policy's view has no policy: "),
    ("view.choose_mode", "AttributeError: a policy's view has no choose_mode: "),
    ("view.assist_quiet(view, 5)", "AttributeError: a policy's view has no assist_quiet: "),
    # the trial's specification holds the true goal, which the agent never observes
    ("view.spec.true_goal", "AttributeError: a policy's view has no spec: "),
    ("view.columns", "AttributeError: a policy's view has no columns: "),  # the session's step log
])
def test_reaching_past_the_world_view_or_to_the_policy_is_one_policy_error_line(
        tmp_path: Path, statement: str, message: str) -> None:
    out, result = _simulate(tmp_path, assist=statement,
                            **({"assist_quiet": "pass"} if "assist_quiet" in statement else {}))
    error = _error_line(result)
    assert "condition 'writer' (policy writermodule:Writer)" in error, error
    assert f"assist raised {message}" in error, error
    assert not (out / "trials").exists()  # the run stopped there: no table of a changed trial


class PathMover:
    """A path-world policy that, at its first step, runs ``statement`` on its view."""

    infers = False
    takes_turns = False

    def __init__(self, statement: str) -> None:
        self.statement = statement

    def assist(self, view: Any) -> Assistance:
        exec(self.statement, {"view": view})  # the test's own statements
        return Assistance(view.u_h)


def _path_session(monkeypatch: pytest.MonkeyPatch, policy: object) -> tuple[TrialSession, PathWorld]:
    """A CIAA trial on the hand-built straight path that runs ``policy``, and its world."""
    monkeypatch.setattr(protocol, "make_policy", lambda condition, settings: policy)
    layout = straight_layout()
    world = PathWorld(layout)
    spec = TrialSpec(participant=0, condition="mover", block=0, trial=0, layout_index=0, layout=layout)
    session = TrialSession(spec, ProtocolSettings.from_config(load_experiment("ciaa-teleop")), None, 3,
                           np.random.default_rng(0), world=world)
    return session, world


@pytest.mark.parametrize(("statement", "match"), [
    # x = 15 snaps onto the first waypoint: the world's move would advance the trial's path
    ("view.world.move(view.x, view.y, view.theta, (50.0, 0.0, 0.0), 0.1)", "view of the world has no move"),
    ("view.world.location = 1", r"cannot set view\.world\.location "),
    ("view.world.turned = True", r"cannot set view\.world\.turned "),
    ("view.world.layout.waypoints[1, 0] = 10.0", "view of the world has no layout"),
])
def test_a_policy_cannot_change_its_path_worlds_trial_state(monkeypatch, statement: str, match: str) -> None:
    session, world = _path_session(monkeypatch, PathMover(statement))
    waypoints = np.array(world.layout.waypoints)
    with pytest.raises(AttributeError, match=match):
        session.human_step(NO_INPUT, 0.0)
    assert (world.location, world.turned) == (0, False)
    np.testing.assert_array_equal(world.layout.waypoints, waypoints)


class WorldReader:
    """A policy that checks, at each call, that its ``view.world`` answers as the trial's world."""

    takes_turns = True

    def __init__(self, infers: bool) -> None:
        self.infers = infers
        self.world: Any = None
        self.calls = 0

    def _check(self, view: Any) -> None:
        seen, world = view.world, self.world
        assert isinstance(seen, WorldView) and seen.n_goals == world.n_goals == len(view.goal_poses)
        for name in ("goal_poses", "start_pose"):
            array = getattr(seen, name)
            np.testing.assert_array_equal(array, getattr(world, name))
            assert not array.flags.writeable
        assert seen.start_mode == world.start_mode
        state = seen.state(view.x, view.y, view.theta, view.mode)
        assert state == view.state == world.state(view.x, view.y, view.theta, view.mode)
        assert seen.cells(state) == world.cells(state)
        for pose in [(view.x, view.y, view.theta), tuple(float(v) for v in world.goal_poses[0])]:
            assert seen.goal_reached(*pose) == world.goal_reached(*pose)
        for axis in range(3):
            assert seen.next_mark(1.0, 1.0, axis) == world.next_mark(1.0, 1.0, axis)
        for velocity in [(1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]:
            assert seen.holds_still(view.x, view.y, view.theta, velocity) == world.holds_still(
                view.x, view.y, view.theta, velocity)
        self.calls += 1

    def assist(self, view: Any) -> Assistance:
        self._check(view)
        return Assistance(view.u_h)

    def start_turn(self, view: Any) -> AutonomyTurn:
        self._check(view)
        return AutonomyTurn.stay()


def test_the_world_view_answers_as_the_grid_world_and_changes_nothing(monkeypatch) -> None:
    reader = WorldReader(infers=True)
    session = _session(monkeypatch, reader)
    reader.world = session.world
    for _ in range(5):
        session.human_step(NO_INPUT, 0.0)
    assert reader.calls == 5 and session.step == len(session.rows) == 5


def test_the_world_view_answers_as_the_path_world_and_changes_nothing(monkeypatch) -> None:
    reader = WorldReader(infers=False)
    session, world = _path_session(monkeypatch, reader)
    reader.world = world
    for _ in range(5):
        session.human_step(NO_INPUT, 0.0)
    assert reader.calls == 5 and (world.location, world.turned) == (0, False)
