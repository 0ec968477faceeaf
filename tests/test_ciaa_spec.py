"""The CIAA task world as its specification (TASK.md of the task data) says: no setting silently
ignored (``world.success_distance``), tolerances bounded by the task's geometry, a device that reads
at most full scale, a time limit never overrun, the documented pure motion time, the sibling study's
calibration protocol in its preset, and its unsimulated conditions named."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from nudgecli.config import InterfaceSection, load_experiment
from nudgecli.errors import ConfigError
from nudgecli.model.interface import HARD_PUFF, HARD_SIP
from nudgecli.model.path_world import ROTATION, SHORTEST_LEG, PathWorld
from nudgecli.sim.calibration_sessions import event_driven_stream
from nudgecli.sim.ciaa import packaged_task, task_layouts
from nudgecli.sim.protocol import ProtocolSettings

PEOPLE_DOC = Path(__file__).resolve().parents[1] / "docs" / "people.md"


def _refused(*sets: str) -> str:
    with pytest.raises(ConfigError) as caught:
        load_experiment("ciaa-teleop", list(sets))
    message = str(caught.value)
    assert "\n" not in message, message
    return message


# --- 1. world.success_distance changes nothing, so it is refused but at its default ---------------

def test_success_distance_is_refused_at_any_value_but_its_default():
    for value in ("0.2", "0.05"):
        message = _refused(f"world.success_distance={value}")
        assert "world.success_distance" in message and "goal waypoint" in message, message
    assert load_experiment("ciaa-teleop", ["world.success_distance=0.1"]).world.success_distance == 0.1


# --- 2. the tolerances stay below half the shortest leg and half the turn ------------------------

def test_the_task_geometry_behind_the_bounds():
    layouts = task_layouts(packaged_task()).values()
    legs = [float(np.abs(np.diff(layout.waypoints, axis=0)).sum(axis=1).min()) for layout in layouts]
    assert min(legs) == SHORTEST_LEG
    turns = {abs(math.remainder(layout.goal_theta, 2 * math.pi)) for layout in layouts}
    assert turns == {ROTATION}


@pytest.mark.parametrize(("text", "bound"), [("world.snap_tolerance=2.5", "2.5"),
                                             ("world.snap_tolerance=8.0", "2.5"),
                                             ("world.heading_tolerance=0.7854", "pi/4"),
                                             ("world.heading_tolerance=2.0", "pi/4")])
def test_a_tolerance_past_half_a_leg_or_half_the_turn_is_refused(text: str, bound: str):
    message = _refused(text)
    assert message.startswith(f"--set {text}: {text.split('=')[0]}: "), message
    assert f"give less than {bound}" in message, message


def test_tolerances_below_the_bounds_are_taken():
    config = load_experiment("ciaa-teleop", ["world.snap_tolerance=2.4", "world.heading_tolerance=0.78"])
    assert (config.world.snap_tolerance, config.world.heading_tolerance) == (2.4, 0.78)


# --- 3. the event-driven device reads at most full scale -----------------------------------------

@pytest.mark.parametrize(("sign", "hard"), [(1.0, HARD_SIP), (-1.0, HARD_PUFF)])
def test_a_saturated_blow_reads_full_scale_not_past_it(sign: float, hard: int):
    times = np.array([0.0, 0.1, 0.2, 0.3])
    pressure = sign * np.array([0.0, 1.0, 1.0, 0.0])  # round(1 / 0.0109) = 92 levels: 1.0028
    _, readings, codes = event_driven_stream(times, pressure, InterfaceSection())
    assert np.abs(readings).max() == 1.0
    assert codes[np.argmax(np.abs(readings))] == hard


# --- 4. a trial runs the whole steps within its time limit, never past it ------------------------

@pytest.mark.parametrize(("limit", "steps"), [(50.06, 500), (50.0, 500), (50.1, 501), (120.0, 1200)])
def test_the_time_limit_is_never_overrun(limit: float, steps: int):
    config = load_experiment("ciaa-teleop", [f"study.time_limit_s={limit}"])
    assert ProtocolSettings.from_config(config).time_limit_steps == steps


# --- 5. the pure motion time the docs state is the path world's ----------------------------------

def _pure_motion_steps(layout, dt: float) -> int:
    world = PathWorld(layout)
    x, y, theta = layout.start_pose
    steps = 0
    while world.goal_reached(x, y, theta) < 0 and steps < 1000:
        mode, direction = world.allowed
        velocity = [0.0, 0.0, 0.0]
        velocity[mode] = direction * (1.6 if mode < 2 else 0.64)  # the preset's full speeds
        x, y, theta = world.move(x, y, theta, tuple(velocity), dt)
        steps += 1
    return steps


def test_the_documented_pure_motion_time_is_the_path_worlds():
    config = load_experiment("ciaa-teleop")
    assert (config.world.linear_speed, config.world.angular_speed) == (1.6, 0.64)
    dt = config.study.dt
    counts = {_pure_motion_steps(layout, dt) for layout in task_layouts(packaged_task()).values()}
    assert len(counts) == 1
    steps = counts.pop()
    text = " ".join(PEOPLE_DOC.read_text(encoding="utf-8").split())
    found = re.search(r"The pure motion of every layout takes ([\d.]+) s \((\d+) steps", text)
    assert found is not None
    assert (float(found.group(1)), int(found.group(2))) == (round(steps * dt, 1), steps)


# --- 6. the preset calibrates as the sibling study did -------------------------------------------

def test_the_ciaa_preset_calibrates_with_the_sibling_studys_protocol():
    calibration = load_experiment("ciaa-teleop").calibration
    assert (calibration.stream, calibration.prompt_s, calibration.blank_s) == ("event_driven", 4.0, 1.0)


# --- 7. the study's assistance conditions are named as not simulated -----------------------------

@pytest.mark.parametrize("name", ["filter_assistance", "corrective_assistance"])
def test_an_unsimulated_condition_is_named_so(name: str):
    message = _refused(f'world.ciaa_conditions=["{name}"]')
    assert "not simulated" in message and "TASK.md section 9" in message, message
    assert "did you mean" not in message, message
