"""Property tests (hypothesis) of small helpers, each against a brute-force or algebraic rule."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.model import world
from nudgecli.model.candidates import window_candidates
from nudgecli.report.brackets import assign_levels
from nudgecli.report.participant_tests import rank_biserial
from nudgecli.sim.calibration_io import nearest_indices

spans = st.lists(st.tuples(st.integers(0, 6), st.integers(0, 6))
                 .map(lambda t: (float(min(t)), float(max(t)))), min_size=1, max_size=8)


@given(spans)
def test_assign_levels_never_stacks_touching_spans_on_one_level(intervals: list[tuple[float, float]]) -> None:
    levels = assign_levels(intervals)
    for a in range(len(intervals)):
        for b in range(a + 1, len(intervals)):
            (l1, r1), (l2, r2) = intervals[a], intervals[b]
            if l1 <= r2 and l2 <= r1:  # overlap or touch
                assert levels[a] != levels[b]
    # Lowest possible: each interval at level k > 0 meets one at every lower level.
    for a, level in enumerate(levels):
        for lower in range(level):
            (la, ra) = intervals[a]
            assert any(levels[b] == lower and la <= intervals[b][1] and intervals[b][0] <= ra
                       for b in range(len(intervals)) if b != a)


@given(st.integers(0, world.N_CELLS_X - 1), st.integers(0, world.N_CELLS_Y - 1),
       st.integers(0, world.N_HEADINGS - 1), st.integers(0, world.N_MODES - 1))
def test_state_index_round_trips_and_discretise_inverts_cell_centres(i: int, j: int, h: int, m: int) -> None:
    s = world.state_index(i, j, h, m)
    assert 0 <= s < world.N_STATES
    assert tuple(int(v) for v in world.state_coordinates(s)) == (i, j, h, m)
    x, y = world.cell_centre(i, j)
    theta = float(world.heading_angle(h)) + 0.5 * world.HEADING_STEP  # inside the heading's sector
    assert world.discretise(float(x), float(y), theta) == (i, j, h)


@given(st.lists(st.integers(0, 50), min_size=1, max_size=15).map(sorted),
       st.lists(st.floats(-5, 55, allow_nan=False), min_size=1, max_size=10))
def test_nearest_indices_is_the_first_argmin(times: list[int], targets: list[float]) -> None:
    got = nearest_indices(np.asarray(times, dtype=float), np.asarray(targets))
    expected = [int(np.argmin(np.abs(np.asarray(times, dtype=float) - t))) for t in targets]
    assert got.tolist() == expected


@given(st.lists(st.tuples(st.integers(-5, 5), st.integers(-5, 5)), min_size=1, max_size=12))
def test_rank_biserial_is_antisymmetric_and_bounded(pairs: list[tuple[int, int]]) -> None:
    x = np.array([p[0] for p in pairs], dtype=float)
    y = np.array([p[1] for p in pairs], dtype=float)
    r = rank_biserial(x, y)
    assert -1.0 <= r <= 1.0
    assert math.isclose(rank_biserial(y, x), -r, abs_tol=1e-12)
    if np.all(x > y):
        assert r == 1.0


@settings(max_examples=40, deadline=None)
@given(st.integers(0, world.N_STATES - 1), st.sets(st.integers(0, 99), min_size=1, max_size=6),
       st.sampled_from([3, 5]))
def test_window_candidates_over_every_cell_match_brute_force(state: int, goal_ids: set[int],
                                                             window: int) -> None:
    goals = np.array([[g // world.N_CELLS_Y, g % world.N_CELLS_Y] for g in sorted(goal_ids)])
    i, j, h, _ = (int(v) for v in world.state_coordinates(state))
    half = window // 2
    expected = [world.state_index(i + dx, j + dy, h, m)
                for dx in range(-half, half + 1) for dy in range(-half, half + 1)
                for m in range(world.N_MODES)
                if 0 <= i + dx < world.N_CELLS_X and 0 <= j + dy < world.N_CELLS_Y
                and (i + dx) * world.N_CELLS_Y + (j + dy) not in goal_ids]
    assert window_candidates(state, goals, window).states.tolist() == expected


@given(st.floats(-100, 100), st.floats(-100, 100), st.floats(-20, 20))
def test_clamp_and_discretise_are_the_min_max_rules(x: float, y: float, theta: float) -> None:
    """The step loop's comparisons are ``min(max(v, low), high)`` exactly (values and cells)."""
    low_x, high_x = world.X_MIN + world.ROBOT_RADIUS, world.X_MAX - world.ROBOT_RADIUS
    low_y, high_y = world.Y_MIN + world.ROBOT_RADIUS, world.Y_MAX - world.ROBOT_RADIUS
    assert world.clamp_position(x, y) == (min(max(x, low_x), high_x), min(max(y, low_y), high_y))
    i = min(max(math.floor((x - world.X_MIN) / world.CELL_WIDTH), 0), world.N_CELLS_X - 1)
    j = min(max(math.floor((y - world.Y_MIN) / world.CELL_HEIGHT), 0), world.N_CELLS_Y - 1)
    # a heading within 1e-9 of a bin's lower edge (in bins) is in that bin
    h = math.floor((theta % (2 * math.pi)) / world.HEADING_STEP + 1e-9) % world.N_HEADINGS
    assert world.discretise(x, y, theta) == (i, j, h)
