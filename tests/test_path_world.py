"""The CIAA path world (TASK.md of the sibling study's task data) and its `ciaa-teleop` preset."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.config import load_experiment
from nudgecli.errors import ConfigError
from nudgecli.model import interface
from nudgecli.model.interface import HARD_PUFF, HARD_SIP, NO_INPUT, SOFT_PUFF, SOFT_SIP
from nudgecli.model.path_world import PathLayout, PathWorld, build_waypoints, optimal_policy
from nudgecli.model.world import (
    GridWorld,
    Layout,
    angle_difference,
    clamp_position,
    discretise,
    state_index,
)
from nudgecli.rng import generator
from nudgecli.sim.behaviour import next_centre
from nudgecli.sim.ciaa import load_task, packaged_task, subject_schedule, task_layouts
from nudgecli.sim.participants import Participant, mapping_with_error
from nudgecli.sim.protocol import ProtocolSettings, TrialSession, TrialSpec
from nudgecli.sim.trials import run_world_trial

SHARED_TASK = Path(__file__).resolve().parents[2] / "shared" / "data" / "ciaa-task" / "layouts.json"
HALF_PI = math.pi / 2.0


@pytest.fixture(scope="module")
def ciaa():
    config = load_experiment("ciaa-teleop")
    return config, ProtocolSettings.from_config(config)


def straight_layout(**changes) -> PathLayout:
    """A hand-built path: +x 5 units (turn at waypoint 1, to +pi/2), then +y 5 units."""
    values = dict(index=0, condition="no_assistance",
                  waypoints=np.array([[10.0, 5.0], [15.0, 5.0], [15.0, 10.0]]), leg_modes=(0, 1),
                  leg_directions=(1, 1), turn_waypoint=1, goal_theta=HALF_PI, start_mode=0)
    values.update(changes)
    return PathLayout(**values)


# --- the task file ------------------------------------------------------------------------------

def test_packaged_task_is_the_shared_task_file():
    if not SHARED_TASK.is_file():
        pytest.skip(f"the task data are not at {SHARED_TASK}")
    assert packaged_task() == load_task(SHARED_TASK)


def test_waypoints_and_legs_rebuilt_from_the_trial_definitions_match_layouts_json():
    task = packaged_task()
    layouts = task_layouts(task)
    assert sorted(layouts) == list(range(36))
    for entry in task["layouts"]:
        layout = layouts[entry["trial_index"]]
        np.testing.assert_array_equal(layout.waypoints, np.array(entry["waypoints"]))
        for segment in entry["segments"]:
            j = segment["index"]
            assert "xyt"[layout.leg_modes[j]] == segment["mode"]
            assert layout.leg_directions[j] == segment["direction"]
        assert layout.turn_waypoint == entry["rotation"]["at_waypoint"]
        assert math.isclose(layout.goal_theta, entry["rotation"]["to_theta"] % (2 * math.pi))


def test_even_turn_counts_follow_task_section_3():
    # n = 2, first leg along x: k = 2, x steps (G - S)/2, y steps (G - S)/1 (worked by hand)
    points = build_waypoints((0.0, 0.0), (10.0, 6.0), 2, 0)
    np.testing.assert_array_equal(points, [[0, 0], [5, 0], [5, 6], [10, 6]])


def discrete_plan(layout: PathLayout) -> list[str]:
    """Follow the optimal policy on the discrete task (a useful move finishes its leg or turn)."""
    policy = optimal_policy(layout)
    location, turned, mode = 0, False, layout.start_mode
    plan: list[str] = []
    last = len(layout.waypoints) - 1
    while location < last:
        action = int(policy[(location * 2 + int(turned)) * 3 + mode])
        label = interface.LABELS[interface.TRUE_MAPPING[action]]
        plan.append(label)
        if action in (interface.TO_MODE_R, interface.TO_MODE_L):
            mode = interface.switch_mode(mode, int(interface.TRUE_MAPPING[action]))
        elif location == layout.turn_waypoint and not turned:
            turned = True
        else:
            location += 1
        assert len(plan) < 50
    return plan


def test_optimal_policy_reproduces_the_task_files_optimal_command_plans():
    # layouts.json's plans come from the task author's 0-1 breadth-first search (TASK.md section 8)
    task = packaged_task()
    layouts = task_layouts(task)
    for entry in task["layouts"]:
        expected = [step.split(" (")[0] for step in entry["optimal_command_plan"]]
        plan = discrete_plan(layouts[entry["trial_index"]])
        assert plan == expected, entry["trial_index"]
        assert sum(label.startswith("Hard") for label in plan) == entry["min_mode_switches"] == 5


def test_schedule_follows_the_subjects_no_assistance_blocks():
    task = packaged_task()
    for participant in range(12):
        subject = sorted(task["subject_blocks"])[participant % 10]
        blocks = sorted((b for name, b in task["subject_blocks"][subject].items() if name.startswith("no_")),
                        key=lambda b: b["session_position"])
        expected = [k for b in blocks for k in b["trial_indices_in_order"]]
        trials = subject_schedule(task, participant, ("no_assistance",))
        assert [t.layout_index for t in trials] == expected
        assert len(trials) == 12 and [t.block for t in trials] == [0] * 6 + [1] * 6



def test_schedule_orders_blocks_by_session_position_not_by_their_order_in_the_file():
    task = packaged_task()
    # the same task with every subject's blocks listed in reverse (a task file given by path
    # need not list them in session order)
    shuffled = {**task, "subject_blocks": {subject: dict(reversed(list(blocks.items())))
                                           for subject, blocks in task["subject_blocks"].items()}}
    conditions = ("no_assistance", "filter_assistance", "corrective_assistance")
    for participant in range(10):
        assert subject_schedule(shuffled, participant, conditions) == \
            subject_schedule(task, participant, conditions)
    # subject 001 ran no_assistance_1 first and no_assistance_0 fifth
    first = task["subject_blocks"]["001"]
    trials = subject_schedule(shuffled, 0, ("no_assistance",))
    assert [t.layout_index for t in trials] == [*first["no_assistance_1"]["trial_indices_in_order"],
                                               *first["no_assistance_0"]["trial_indices_in_order"]]

# --- kinematics and constraints ------------------------------------------------------------------

def test_a_leg_that_allows_plus_x_ignores_minus_x_y_and_theta_commands():
    world = PathWorld(straight_layout())
    for velocity in ([-1.6, 0, 0], [0, 1.6, 0], [0, -1.6, 0], [0, 0, 0.64], [0, 0, -0.64]):
        assert world.move(10.0, 5.0, 0.0, np.array(velocity, dtype=float), 0.1) == (10.0, 5.0, 0.0)
    x, y, theta = world.move(10.0, 5.0, 0.0, np.array([1.6, 0.0, 0.0]), 0.1)
    assert (x, y, theta) == pytest.approx((10.16, 5.0, 0.0)) and world.location == 0


def test_snapping_at_a_waypoint_and_only_within_the_tolerance():
    world = PathWorld(straight_layout())
    # 14.75 + 0.16 = 14.91: 0.09 short of the waypoint (< 0.1 on both axes) -> snapped onto it
    assert world.move(14.75, 5.0, 0.0, np.array([1.6, 0.0, 0.0]), 0.1) == (15.0, 5.0, 0.0)
    assert world.location == 1
    world = PathWorld(straight_layout())
    x, _, _ = world.move(14.7, 5.0, 0.0, np.array([1.6, 0.0, 0.0]), 0.1)  # 14.86: 0.14 short
    assert x == pytest.approx(14.86) and world.location == 0
    # overshooting within the window also snaps back onto the waypoint (15.06 -> 15)
    world = PathWorld(straight_layout())
    assert world.move(14.9, 5.0, 0.0, np.array([1.6, 0.0, 0.0]), 0.1) == (15.0, 5.0, 0.0)


def test_rotation_only_at_the_turn_waypoint_towards_the_goal_heading():
    world = PathWorld(straight_layout())
    assert world.allowed == (0, 1)
    assert world.move(12.0, 5.0, 0.0, np.array([0, 0, 0.64]), 0.1) == (12.0, 5.0, 0.0)  # not at the turn
    world.location = 1  # at the turn waypoint
    assert world.allowed == (2, 1)
    assert world.move(15.0, 5.0, 0.0, np.array([0, 0, -0.64]), 0.1) == (15.0, 5.0, 0.0)  # away from the goal
    assert world.move(15.0, 5.0, 0.0, np.array([0, 1.6, 0]), 0.1) == (15.0, 5.0, 0.0)  # the next leg waits
    x, y, theta = world.move(15.0, 5.0, 0.0, np.array([0, 0, 0.64]), 0.1)
    assert (x, y, theta) == pytest.approx((15.0, 5.0, 0.064)) and not world.turned
    # 1.45 + 0.064 = 1.514: 0.057 from pi/2 -> snapped, turn done, the next leg is allowed
    _, _, theta = world.move(15.0, 5.0, 1.45, np.array([0, 0, 0.64]), 0.1)
    assert theta == HALF_PI and world.turned and world.allowed == (1, 1)
    assert world.move(15.0, 5.0, theta, np.array([0, 1.6, 0]), 0.1) == pytest.approx((15.0, 5.16, HALF_PI))


def test_the_location_waits_at_the_turn_waypoint_until_the_turn_is_done():
    # a next waypoint within the snapping window of the turn waypoint (hand-built): not entered
    # before the rotation is done (TASK.md section 4, step 1), entered on the step that finishes it
    world = PathWorld(straight_layout(waypoints=np.array([[10.0, 5.0], [15.0, 5.0], [15.0, 5.05]])))
    world.location = 1
    assert world.move(15.0, 5.0, 0.0, np.zeros(3), 0.1) == (15.0, 5.0, 0.0) and world.location == 1
    world.turned = True
    assert world.move(15.0, 5.0, HALF_PI, np.zeros(3), 0.1) == (15.0, 5.05, HALF_PI) and world.location == 2


def test_clockwise_turn_wraps_and_snaps_to_minus_half_pi():
    world = PathWorld(straight_layout(goal_theta=3 * HALF_PI))
    world.location = 1
    assert world.allowed == (2, -1)
    _, _, theta = world.move(15.0, 5.0, 0.0, np.array([0, 0, -0.64]), 0.1)
    assert theta == pytest.approx(2 * math.pi - 0.064)
    _, _, theta = world.move(15.0, 5.0, 4.80, np.array([0, 0, -0.64]), 0.1)  # 4.736: 0.024 away
    assert theta == 3 * HALF_PI and world.turned


def test_goal_reached_only_at_the_last_waypoint():
    world = PathWorld(straight_layout())
    assert world.goal_reached(15.0, 10.0, HALF_PI) == -1  # right place, but the location is not the goal
    world.location, world.turned = 1, True
    assert world.move(15.0, 9.8, HALF_PI, np.array([0, 1.6, 0]), 0.1) == (15.0, 10.0, HALF_PI)
    assert world.location == 2 and world.goal_reached(15.0, 10.0, HALF_PI) == 0
    # at the goal nothing moves any more
    assert world.move(15.0, 10.0, HALF_PI, np.array([0, 1.6, 0]), 0.1) == (15.0, 10.0, HALF_PI)


def test_next_marks_are_the_waypoints_and_quarter_turns():
    world = PathWorld(straight_layout())
    assert world.next_mark(12.0, 1, 0) == 15.0
    assert world.next_mark(15.0, 1, 0) == math.inf
    assert world.next_mark(10.0, -1, 0) == -math.inf
    assert world.next_mark(5.0, 1, 1) == 10.0
    assert world.next_mark(0.0, 1, 2) == pytest.approx(HALF_PI)
    assert float(angle_difference(world.next_mark(0.0, -1, 2), 3 * HALF_PI)) == pytest.approx(0.0)


# --- the session in the path world ---------------------------------------------------------------

def session_for(layout: PathLayout, settings: ProtocolSettings, **world_kwargs) -> TrialSession:
    spec = TrialSpec(participant=0, condition="no_assistance", block=0, trial=0, layout_index=0,
                     layout=layout)
    return TrialSession(spec, settings, None, 15, generator(0, "test"),
                        world=PathWorld(layout, **world_kwargs))


def test_deadband_stops_the_robot_and_hard_blows_switch_once_each(ciaa):
    _, settings = ciaa
    session = session_for(straight_layout(), settings)
    session.human_step(SOFT_PUFF, -0.15)
    assert session.x == pytest.approx(10.16)
    session.human_step(SOFT_PUFF, -0.4)  # the puff deadband: the command is cleared
    assert session.x == pytest.approx(10.16)
    session.human_step(SOFT_PUFF, -0.15)
    assert session.x == pytest.approx(10.32)
    # a hard puff blow of four samples: one switch (x -> y), its soft tail is ignored
    for pressure in (-0.9, -0.95, -0.9, -0.2):
        session.human_step(HARD_PUFF, pressure)
    assert session.mode == 1 and session.human_switches == 1 and session.x == pytest.approx(10.32)
    session.human_step(NO_INPUT, 0.0)  # the blow ends
    session.human_step(HARD_SIP, 0.9)  # a hard sip steps the other way: y -> x
    session.human_step(HARD_SIP, 0.9)
    assert session.mode == 0 and session.human_switches == 2
    session.human_step(NO_INPUT, 0.0)
    session.human_step(HARD_SIP, 0.9)  # x -> theta
    assert session.mode == 2 and session.human_switches == 3
    steps = pd.DataFrame(session.columns)
    assert (steps["event"] == "mode_switch_human").sum() == 3
    assert session.turn == "human" and session.autonomy_turns == 0 and (steps["alpha"] == 0).all()


def test_the_trial_ends_at_the_time_limit_without_handing_over(ciaa):
    _, settings = ciaa
    session = session_for(straight_layout(), settings)
    session.human_step(SOFT_SIP, 0.15)  # an input, then idle for the rest of the trial
    while not session.finished:
        session.human_step(NO_INPUT, 0.0)
    summary = session.summary()
    assert session.step == 500 and summary["duration_s"] == 50.0
    assert summary["timed_out"] and not summary["success"] and summary["autonomy_turns"] == 0


def test_success_when_the_goal_waypoint_is_reached(ciaa):
    _, settings = ciaa
    session = session_for(straight_layout(start_mode=0), settings)
    # +x to the turn waypoint (snapped after 31 steps), then x -> y (Hard Puff) and back y -> x (Hard Sip)
    script = [(SOFT_PUFF, -0.15)] * 32
    script += [(NO_INPUT, 0.0), (HARD_PUFF, -0.9), (HARD_PUFF, -0.9), (NO_INPUT, 0.0)]
    script += [(NO_INPUT, 0.0), (HARD_SIP, 0.9), (NO_INPUT, 0.0)]
    for label, pressure in script:
        session.human_step(label, pressure)
    assert session.x == 15.0 and session.mode == 0
    for label, pressure in [(HARD_SIP, 0.9), (NO_INPUT, 0.0)]:  # x -> theta
        session.human_step(label, pressure)
    while not session.finished and session.theta != HALF_PI:
        session.human_step(SOFT_SIP, 0.15)  # anticlockwise
    for label, pressure in [(NO_INPUT, 0.0), (HARD_SIP, 0.9), (NO_INPUT, 0.0)]:  # theta -> y
        session.human_step(label, pressure)
    while not session.finished:
        session.human_step(SOFT_PUFF, -0.15)
    summary = session.summary()
    assert summary["success"] and (summary["final_x"], summary["final_y"]) == (15.0, 10.0)
    assert summary["final_theta"] == HALF_PI and summary["human_mode_switches"] == 4
    # 32 steps of 0.16 along 5 units, then 24 steps of 0.064 rad and 32 more along y (hand-counted)
    assert summary["duration_s"] < 50.0


def ideal_participant() -> Participant:
    """Noise-free and epsilon 0; no onset ramp, so a hard blow is hard from its first sample."""
    return Participant(index=0, seed_key="ideal", pressure_level=np.array([-0.8, 0.8, -0.15, 0.15]),
                       pressure_spread=np.zeros(4), mapping=mapping_with_error(0.0), epsilon=0.0,
                       rest_s=0.5, operate_s=3.0, action_pause_s=0.2, hard_blow_s=0.4, reaction_s=0.5,
                       planning_s=0.5, event_reaction_s=0.3, event_reaction_log_sd=0.0, hold_on_s=0.1)


def test_an_ideal_participant_completes_every_layout_with_the_minimum_switches(ciaa):
    _, settings = ciaa
    for index, layout in task_layouts(packaged_task()).items():
        spec = TrialSpec(participant=0, condition="no_assistance", block=0, trial=index, layout_index=index,
                         layout=layout)
        result = run_world_trial(spec, settings, PathWorld(layout), optimal_policy(layout), -1, None,
                                 ideal_participant(), generator(3, "ideal", index))
        summary = result.summary
        assert summary["success"], (index, summary)
        assert summary["human_mode_switches"] == 5, index
        # the pure motion alone is 25 units at 1.6 units/s plus pi/2 at 0.64 rad/s (TASK.md section 6)
        assert 25 / 1.6 + HALF_PI / 0.64 <= summary["duration_s"] < 30.0, index


# --- the grid world behind the interface ---------------------------------------------------------

@settings(max_examples=60, deadline=None)
@given(x=st.floats(0.0, 48.0), y=st.floats(0.0, 38.0), theta=st.floats(0.0, 6.28), mode=st.integers(0, 2),
       vx=st.floats(-5, 5), vy=st.floats(-5, 5), w=st.floats(-2, 2), direction=st.sampled_from([-1.0, 1.0]),
       axis=st.integers(0, 2))
def test_grid_world_is_the_module_functions(x, y, theta, mode, vx, vy, w, direction, axis):
    layout = Layout(goal_cells=np.array([[1, 1], [5, 2]]), goal_headings=np.array([0, 3]), start_cell=(8, 8),
                    start_heading=0, start_mode=0, corner="tr")
    world = GridWorld(layout, 1.0, 0.2)
    assert world.state(x, y, theta, mode) == state_index(*discretise(x, y, theta), mode)
    cx, cy = clamp_position(x + vx * 0.1, y + vy * 0.1)
    assert world.move(x, y, theta, np.array([vx, vy, w]), 0.1) == (cx, cy, (theta + w * 0.1) % (2 * math.pi))
    # brute force: the nearest mark strictly beyond the coordinate among the enumerated centres
    coordinate = (x, y, theta)[axis]
    origin, width = ((3.0 + 2.1, 4.2), (2.0 + 1.7, 3.4), (0.0, math.pi / 4))[axis]
    marks = origin + width * np.arange(-20, 40)
    beyond = marks[(marks - coordinate) * direction > 1e-9 * width]
    expected = beyond.min() if direction > 0 else beyond.max()
    assert world.next_mark(coordinate, direction, axis) == pytest.approx(expected, abs=1e-12)
    assert next_centre(coordinate, direction, axis) == world.next_mark(coordinate, direction, axis)
    i, j, h = world.cells(world.state(x, y, theta, mode))
    assert (i, j, h) == discretise(x, y, theta)
    # brute force of the success rule: within 1.0 unit and 0.2 rad of a goal pose
    near = [g for g, (gx, gy, gth) in enumerate(layout.goal_poses)
            if math.hypot(gx - x, gy - y) <= 1.0 and abs(float(angle_difference(gth, theta))) <= 0.2]
    assert world.goal_reached(x, y, theta) == (near[0] if near else -1)


def test_config_world_section_is_validated():
    with pytest.raises(ConfigError, match="did you mean 'snap_tolerance'"):
        load_experiment("ciaa-teleop", ["world.snap_tolerence=0.2"])
    with pytest.raises(ConfigError, match="skip waypoints"):
        load_experiment("ciaa-teleop", ["world.linear_speed=3.9"])
    with pytest.raises(ConfigError, match=r"world\.kind"):
        load_experiment("ciaa-teleop", ["world.kind=maze"])
    assert load_experiment("paper").world.kind == "grid"


def test_a_soft_command_turns_at_the_worlds_angular_speed(ciaa):
    # the CIAA world's wall-clock speeds (1.6 units/s, 0.64 rad/s) replace the interface's
    config, settings = ciaa
    assert config.interface.human_turn_rate != config.world.angular_speed
    session = session_for(straight_layout(start_mode=2), settings)
    world = session.world
    session.x, world.location = 15.0, 1  # at the turn waypoint, in the theta mode
    session.human_step(SOFT_SIP, 0.15)  # anticlockwise, the allowed way
    assert session.theta == pytest.approx(0.64 * 0.1, abs=1e-12)
    session.human_step(NO_INPUT, 0.0)
    assert session.x == 15.0 and session.mode == 2


def test_the_heading_snaps_only_strictly_within_the_tolerance():
    # TASK.md section 4, step 2: |theta - theta_goal| < 0.1 rad snaps; an error equal to the
    # tolerance does not
    from nudgecli.model.world import turn_between

    omega, dt = 0.64, 0.1
    error = abs(float(turn_between((omega * dt) % (2.0 * math.pi), HALF_PI)))
    for tolerance, snapped in ((error, False), (float(np.nextafter(error, np.inf)), True)):
        world = PathWorld(straight_layout(), heading_tolerance=tolerance)
        world.location = 1  # at the turn waypoint
        _, _, theta = world.move(15.0, 5.0, 0.0, (0.0, 0.0, omega), dt)
        assert world.turned is snapped and (theta == HALF_PI) is snapped


def test_goal_reached_is_reaching_the_goal_waypoint():
    # the snap that reaches the goal waypoint puts the robot exactly on the goal, so the study's
    # final-distance rule (0.1) holds there by construction and is no setting
    world = PathWorld(straight_layout())
    world.location, world.turned = 1, True  # on the last leg, short of the goal (15, 10)
    assert world.goal_reached(15.0, 9.95, HALF_PI) == -1
    x, y, theta = world.move(15.0, 9.95, HALF_PI, (0.0, 1.0, 0.0), 0.1)  # to 10.05: within the snap
    assert (x, y) == (15.0, 10.0) and world.goal_reached(x, y, theta) == 0


def test_holds_still_for_a_command_in_another_mode_or_against_the_leg():
    world = PathWorld(straight_layout())  # the first leg allows +x only
    assert world.holds_still(10.0, 5.0, 0.0, (0.0, 1.0, 0.0))  # y: another mode, masked
    assert world.holds_still(10.0, 5.0, 0.0, (0.0, 0.0, -1.0))  # theta: masked before the turn waypoint
    assert world.holds_still(10.0, 5.0, 0.0, (-1.0, 0.0, 0.0))  # -x: against the leg
    assert not world.holds_still(10.0, 5.0, 0.0, (1.0, 0.0, 0.0))
    for velocity in ((0.0, 1.0, 0.0), (-1.0, 0.0, 0.0), (1.0, 0.0, 0.0)):  # the world's move agrees
        probe = PathWorld(straight_layout())
        assert (probe.move(10.0, 5.0, 0.0, velocity, 0.1) == (10.0, 5.0, 0.0)) == world.holds_still(
            10.0, 5.0, 0.0, velocity)
