"""The paper's grid world (``nudgecli.model.world.GridWorld``): its per-step queries answer as the
rules they stand for, whatever was asked before (each remembers its last answer)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from nudgecli.model.world import (
    HEADING_STEP,
    INTER_GOAL_MIN_CELLS,
    N_HEADINGS,
    X_MAX,
    X_MIN,
    Y_MAX,
    Y_MIN,
    GridWorld,
    cell_centre,
    discretise,
    sample_layout,
    state_index,
    turn_between,
)
from nudgecli.rng import generator

LAYOUT = sample_layout(generator(5, "grid-world-test"), "tl", 4, 0)
SUCCESS_DISTANCE, SUCCESS_ANGLE = 1.0, 0.3

coordinates = st.tuples(st.floats(X_MIN, X_MAX), st.floats(Y_MIN, Y_MAX), st.floats(0.0, 2 * math.pi - 1e-9))
# a goal's position among the queries, facing its heading or away, so some of them reach a goal
at_goals = st.builds(lambda goal, turn: (goal[0], goal[1], (goal[2] + turn) % (2 * math.pi)),
                     st.sampled_from([(float(x), float(y), float(t)) for x, y, t in LAYOUT.goal_poses]),
                     st.sampled_from([0.0, 0.2, math.pi]))
poses = st.one_of(coordinates, at_goals)


def goal_by_the_rule(x: float, y: float, theta: float) -> int:
    """The first goal within the success tolerance, read from the layout directly."""
    for index, (gx, gy, gth) in enumerate(LAYOUT.goal_poses):
        if math.hypot(gx - x, gy - y) <= SUCCESS_DISTANCE and abs(turn_between(gth, theta)) <= SUCCESS_ANGLE:
            return index
    return -1


@given(st.lists(st.tuples(poses, st.integers(0, 2)), min_size=1, max_size=30), st.data())
def test_state_and_goal_queries_answer_by_the_rule_in_any_order(queries: list, data: st.DataObject) -> None:
    world = GridWorld(LAYOUT, SUCCESS_DISTANCE, SUCCESS_ANGLE)
    # repeat some queries back to back, as a robot standing still does
    repeated = [q for q in queries for _ in range(data.draw(st.integers(1, 3)))]
    for (x, y, theta), mode in repeated:
        assert world.state(x, y, theta, mode) == state_index(*discretise(x, y, theta), mode)
        assert world.goal_reached(x, y, theta) == goal_by_the_rule(x, y, theta)


def test_the_same_pose_in_another_mode_is_another_state() -> None:
    world = GridWorld(LAYOUT, SUCCESS_DISTANCE, SUCCESS_ANGLE)
    x, y, theta = 0.1, 0.2, 0.3
    assert world.state(x, y, theta, 1) == world.state(x, y, theta, 0) + 1


cell_indices = st.one_of(st.integers(0, 9), hnp.arrays(np.int64, hnp.array_shapes(max_dims=2, max_side=4),
                                                       elements=st.integers(0, 9)))


@given(cell_indices, cell_indices)
def test_a_cells_centre_is_the_grids_rule_for_one_cell_or_many(i, j) -> None:
    # DESIGN: the workspace [3, 45] x [2, 36] in 10 x 10 cells of 4.2 x 3.4, a cell's centre half a
    # cell in from its corner; indices broadcast together (a number is one cell)
    try:
        i_b, j_b = np.broadcast_arrays(np.asarray(i), np.asarray(j))
    except ValueError:
        return  # shapes that do not broadcast: not a question cell_centre answers
    centre = cell_centre(i, j)
    assert centre.shape == (*i_b.shape, 2) and centre.dtype == np.float64
    for index in np.ndindex(i_b.shape):
        x = 3.0 + (45.0 - 3.0) / 10 * float(i_b[index]) + (45.0 - 3.0) / 10 / 2.0
        y = 2.0 + (36.0 - 2.0) / 10 * float(j_b[index]) + (36.0 - 2.0) / 10 / 2.0
        assert (centre[index][0], centre[index][1]) == (x, y)


def test_every_goal_count_the_configuration_allows_is_placed_in_every_corner() -> None:
    """Up to 8 goals (the configuration's limit) in every corner: the one-at-a-time draw ran out
    of cells in 19 % of 6-goal layouts and crashed a sweep over goal counts; the goals still keep
    their distance."""
    rng = generator(3, "goal-placement-test")
    for corner in ("tl", "tr", "bl", "br"):
        for _ in range(60):
            goals = sample_layout(rng, corner, 8, 0).goal_cells
            apart = np.linalg.norm(goals[:, None, :] - goals[None, :, :], axis=-1)
            assert (apart[~np.eye(8, dtype=bool)] > INTER_GOAL_MIN_CELLS).all()


def test_a_goal_count_no_region_holds_is_refused_by_name() -> None:
    with pytest.raises(ValueError, match="cannot place 21 goals in the region opposite tl"):
        sample_layout(generator(3, "goal-placement-test"), "tl", 21, 0)


@given(distance=st.one_of(st.floats(0.0, 60.0), st.sampled_from([0.0, 1.0, 2.1, 4.2, 1e-300])),
       goal=st.integers(0, 3), direction=st.one_of(st.floats(0.0, 2 * math.pi), st.sampled_from(
           [0.0, math.pi / 2, math.pi, 3 * math.pi / 2, math.pi / 4])),
       stretch=st.one_of(st.sampled_from([1.0, 1 + 2**-52, 1 - 2**-53, 1 + 2**-50, 1 + 1e-6, 1 - 1e-6,
                                          1 + 2e-6, 0.0, 2.0]), st.floats(1 - 1e-5, 1 + 1e-5)))
def test_a_goal_is_reached_by_the_rule_at_the_edge_of_the_tolerance(distance, goal, direction,
                                                                     stretch) -> None:
    # on the edge of the tolerance, a float either side and along the axes: the hypot rule's answer
    world = GridWorld(LAYOUT, distance, math.pi)
    gx, gy, gth = (float(v) for v in LAYOUT.goal_poses[goal])
    radius = distance * stretch
    x, y = gx + radius * math.cos(direction), gy + radius * math.sin(direction)
    expected = -1
    for index, (hx, hy, _) in enumerate(LAYOUT.goal_poses):
        if math.hypot(hx - x, hy - y) <= distance:
            expected = index
            break
    assert world.goal_reached(x, y, gth) == expected


def test_a_heading_a_last_bit_short_of_a_goals_heading_is_that_heading() -> None:
    # a turn onto pi/2 (heading 2, the lower edge of its bin) stops a last bit short of it: the robot
    # is at the goal's heading, not in the bin below; 2 pi less a bit is heading 0
    for h in range(N_HEADINGS):
        edge = h * HEADING_STEP
        for theta in (edge, math.nextafter(edge, -math.inf), math.nextafter(math.nextafter(edge, 0.0), 0.0),
                      math.nextafter(edge, math.inf)):
            assert discretise(20.0, 20.0, theta)[2] == h, (h, theta)
        # clearly below the edge stays below (a millionth of a radian is far from rounding)
        assert discretise(20.0, 20.0, edge - 1e-6)[2] == (h - 1) % N_HEADINGS
    assert discretise(20.0, 20.0, math.nextafter(2.0 * math.pi, 0.0))[2] == 0
