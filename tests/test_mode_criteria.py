"""The mode-switch criteria of prior work (nudgecli.model.mode_criteria) against numbers worked by
hand from the sources' formulas, independent loops (itertools, scipy, the toolkit's own Bayes
update) and a shortest-path search over the mode-augmented space."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import entropy

from nudgecli.model.inference import bayes_update
from nudgecli.model.interface import HARD_PUFF, HARD_SIP, SOFT_PUFF, SOFT_SIP, switch_mode
from nudgecli.model.mode_criteria import (
    GOPINATH_KL_HORIZON_S,
    GOPINATH_LONG_HORIZON_S,
    GOPINATH_PROJECTION_DT_S,
    GOPINATH_SHORT_HORIZON_S,
    MOTION_LABELS,
    choose_mode,
    gopinath_disamb_metric,
    gopinath_disambiguation,
    herlant_time_optimal_mode,
    herlant_time_optimal_plan,
    horizon_steps,
    matlab_kl_bits,
    mode_switches_between,
    project_beliefs,
    projected_kl,
)
from nudgecli.model.world import N_MODES

# --- strategies ---------------------------------------------------------------------------------

def _normalised(weights: list[float]) -> np.ndarray:
    w = np.array(weights)
    return w / w.sum()


beliefs = st.lists(st.floats(0.01, 1.0), min_size=2, max_size=5).map(_normalised)


@st.composite
def projection_pairs(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray]:
    """Two ``(M, D, G)`` stacks of beliefs over the same goals."""
    n_goals = draw(st.integers(2, 5))
    stack = st.lists(st.floats(0.0, 1.0), min_size=n_goals, max_size=n_goals).filter(
        lambda w: sum(w) > 0.01).map(_normalised)
    short = np.array([[draw(stack) for _ in range(2)] for _ in range(N_MODES)])
    long = np.array([[draw(stack) for _ in range(2)] for _ in range(N_MODES)])
    return short, long


# --- Gopinath & Argall: the disambiguation metric ---------------------------------------------

def test_disamb_metric_two_goals_by_hand() -> None:
    # compute_disamb_metric(pg1, pg2) with w = 0.5; pdist of a column vector is |p_i - p_j|.
    # Positive motion: pg1 = (0.7, 0.3), pg2 = (0.8, 0.2)
    #   Gamma = 0.7, Omega = 0.7 - 0.3 = 0.4, Lambda = |0.7 - 0.3| = 0.4,
    #   pg2 - pg1 = (0.1, -0.1), Upsilon = |0.1 - (-0.1)| = 0.2
    #   D+ = 0.5 * 0.7 * 0.4 * 0.4 + 0.5 * 0.2 = 0.056 + 0.1 = 0.156
    # Negative motion: pg1 = (0.4, 0.6), pg2 = (0.35, 0.65)
    #   Gamma = 0.6, Omega = 0.2, Lambda = 0.2, pg2 - pg1 = (-0.05, 0.05), Upsilon = 0.1
    #   D- = 0.5 * 0.6 * 0.2 * 0.2 + 0.5 * 0.1 = 0.012 + 0.05 = 0.062
    # Mode score (compute_optimal_mode_DISAMB_R2: Dk = D+ + D-) = 0.218.
    # A mode whose projections stay uniform: Gamma 0.5, Omega 0, Lambda 0, Upsilon 0 -> 0.
    short = np.array([[[0.7, 0.3], [0.4, 0.6]], [[0.5, 0.5], [0.5, 0.5]]])
    long = np.array([[[0.8, 0.2], [0.35, 0.65]], [[0.5, 0.5], [0.5, 0.5]]])
    np.testing.assert_allclose(gopinath_disamb_metric(short, long), [[0.156, 0.062], [0.0, 0.0]],
                               atol=1e-15)
    np.testing.assert_allclose(gopinath_disambiguation(short, long), [0.218, 0.0], atol=1e-15)


def test_disamb_metric_three_goals_by_hand() -> None:
    # pg1 = (0.5, 0.3, 0.2): Gamma = 0.5; Omega = largest - second = 0.5 - 0.3 = 0.2 (not - smallest);
    #   Lambda = |0.5-0.3| + |0.5-0.2| + |0.3-0.2| = 0.2 + 0.3 + 0.1 = 0.6 (each pair once)
    # pg2 = (0.6, 0.3, 0.1): pg2 - pg1 = (0.1, 0, -0.1);
    #   Upsilon = |0.1-0| + |0.1+0.1| + |0+0.1| = 0.1 + 0.2 + 0.1 = 0.4 (of the change, not of pg2)
    # D = 0.5 * 0.5 * 0.2 * 0.6 + 0.5 * 0.4 = 0.03 + 0.2 = 0.23
    assert gopinath_disamb_metric(np.array([0.5, 0.3, 0.2]), np.array([0.6, 0.3, 0.1])) == pytest.approx(0.23)


def test_disamb_metric_needs_two_goals_and_matching_shapes() -> None:
    with pytest.raises(ValueError, match="two goals"):
        gopinath_disamb_metric(np.array([1.0]), np.array([1.0]))
    with pytest.raises(ValueError, match="shape"):
        gopinath_disamb_metric(np.array([0.5, 0.5]), np.array([0.2, 0.3, 0.5]))


def _metric_by_loops(pg1: list[float], pg2: list[float]) -> float:
    """The MATLAB formula with Python lists: sort, max, pairs from itertools."""
    ordered = sorted(pg1)
    change = [b - a for a, b in zip(pg1, pg2, strict=True)]
    lam = sum(abs(a - b) for a, b in itertools.combinations(pg1, 2))
    upsilon = sum(abs(a - b) for a, b in itertools.combinations(change, 2))
    return 0.5 * max(pg1) * (ordered[-1] - ordered[-2]) * lam + 0.5 * upsilon


@given(projection_pairs(), st.randoms(use_true_random=False))
def test_disambiguation_matches_loops_and_ignores_goal_order(pair: tuple[np.ndarray, np.ndarray],
                                                            random) -> None:
    short, long = pair
    scores = gopinath_disambiguation(short, long)
    expected = [sum(_metric_by_loops(list(short[m, d]), list(long[m, d])) for d in range(2))
                for m in range(N_MODES)]
    np.testing.assert_allclose(scores, expected, rtol=1e-12, atol=1e-15)
    assert np.isfinite(scores).all() and (scores >= 0).all()
    # every term is symmetric in the goals (max, sorted entries, sums over pairs)
    order = list(range(short.shape[-1]))
    random.shuffle(order)
    np.testing.assert_allclose(gopinath_disambiguation(short[..., order], long[..., order]), scores,
                               rtol=1e-12, atol=1e-15)


# --- the KL variant --------------------------------------------------------------------------

def test_projected_kl_by_hand() -> None:
    # compute_kl_div: -sum p log2(q / p), in bits. Current belief q = (0.5, 0.5).
    # Positive motion p = (0.75, 0.25): 0.75 log2(1.5) + 0.25 log2(0.5) = 0.75 * 0.5849625007 - 0.25
    #   = 0.1887218755 bits (the reverse direction, KL(q || p), would be 0.2075187496).
    # Negative motion p = (0.5, 0.5): 0.
    # compute_optimal_mode_KL_R2 averages the two (1/2 each): 0.0943609378.
    projected = np.array([[[0.75, 0.25], [0.5, 0.5]]])
    current = np.array([0.5, 0.5])
    kl_plus = 0.75 * math.log2(1.5) + 0.25 * math.log2(0.5)
    np.testing.assert_allclose(matlab_kl_bits(projected, current), [[kl_plus, 0.0]], atol=1e-15)
    np.testing.assert_allclose(projected_kl(projected, current), [kl_plus / 2], rtol=1e-14)
    assert kl_plus == pytest.approx(0.1887218755)


def test_matlab_kl_edges() -> None:
    # p = (1, 0), q = (0.5, 0.5): the p = 0 term is 0 * log2(inf) = NaN, dropped by nansum;
    # 1 * log2(0.5 / 1) = -1, so KL = 1 bit.
    assert matlab_kl_bits(np.array([1.0, 0.0]), np.array([0.5, 0.5])) == pytest.approx(1.0)
    # p = (0.5, 0.5), q = (1, 0): 0.5 log2(1 / 0.5) = 0.5 and 0.5 log2(0 + realmin) = 0.5 * -1022,
    # so KL = -(0.5 - 511) = 510.5 bits (finite where the exact divergence is infinite).
    assert matlab_kl_bits(np.array([0.5, 0.5]), np.array([1.0, 0.0])) == pytest.approx(510.5)


@given(beliefs, beliefs, st.randoms(use_true_random=False))
def test_projected_kl_properties(first: np.ndarray, second: np.ndarray, random) -> None:
    n_goals = min(first.size, second.size)
    p, q = _normalised(list(first[:n_goals])), _normalised(list(second[:n_goals]))
    projected = np.array([[p, q], [q, q], [p, p]])  # (M, D, G)
    scores = projected_kl(projected, q)
    # scipy's relative entropy in base 2, an independent computation (full support here)
    np.testing.assert_allclose(scores, [entropy(p, q, base=2) / 2, 0.0, entropy(p, q, base=2)],
                               rtol=1e-9, atol=1e-12)
    assert np.isfinite(scores).all() and (scores >= -1e-12).all()
    assert scores[1] == 0.0  # a projection that leaves the belief as it is scores nothing
    order = list(range(n_goals))
    random.shuffle(order)
    np.testing.assert_allclose(projected_kl(projected[..., order], q[order]), scores, rtol=1e-12, atol=1e-15)


# --- the projection --------------------------------------------------------------------------

#: p(phi_m | g, s_m) columns (Hard Puff, Hard Sip, Soft Puff, Soft Sip) of two goals in one mode:
#: goal 0 expects Soft Puff (0.6), goal 1 Soft Sip (0.6).
TWO_GOAL_LIKELIHOOD = np.array([[0.1, 0.1, 0.6, 0.2], [0.1, 0.1, 0.2, 0.6]])


def test_projection_by_hand() -> None:
    likelihood = np.stack([TWO_GOAL_LIKELIHOOD] * N_MODES)  # (M, G, F)
    belief = np.array([0.5, 0.5])
    # Soft Puff: (0.5 * 0.6, 0.5 * 0.2) = (0.3, 0.1) / 0.4 = (0.75, 0.25); Soft Sip the mirror.
    one = project_beliefs(belief, likelihood)
    assert one.shape == (N_MODES, 2, 2)
    np.testing.assert_allclose(one[0], [[0.75, 0.25], [0.25, 0.75]], rtol=1e-14)
    # two Soft Puffs: (0.5 * 0.36, 0.5 * 0.04) = (0.18, 0.02) / 0.2 = (0.9, 0.1)
    np.testing.assert_allclose(project_beliefs(belief, likelihood, steps=2)[1, 0], [0.9, 0.1], rtol=1e-14)
    # Eq. 6: the goal may change first. (0.8, 0.2) @ [[0.9, 0.1], [0.1, 0.9]] = (0.74, 0.26);
    # Soft Puff: (0.74 * 0.6, 0.26 * 0.2) = (0.444, 0.052) / 0.496
    transition = np.array([[0.9, 0.1], [0.1, 0.9]])
    moved = project_beliefs(np.array([0.8, 0.2]), likelihood, steps=1, goal_transition=transition)
    np.testing.assert_allclose(moved[2, 0], [0.444 / 0.496, 0.052 / 0.496], rtol=1e-14)
    assert MOTION_LABELS == (SOFT_PUFF, SOFT_SIP)


def test_projection_keeps_the_belief_for_a_label_no_goal_gives() -> None:
    likelihood = np.zeros((N_MODES, 2, 4))
    likelihood[..., HARD_PUFF] = 1.0  # Soft Puff and Soft Sip impossible under both goals
    belief = np.array([0.3, 0.7])
    np.testing.assert_array_equal(project_beliefs(belief, likelihood, steps=3),
                                  np.broadcast_to(belief, (N_MODES, 2, 2)))


@given(beliefs, st.integers(1, 4), st.data())
@settings(max_examples=50)
def test_projection_is_the_bayes_update_repeated(belief: np.ndarray, steps: int, data: st.DataObject) -> None:
    n_goals = belief.size
    rows = st.lists(st.floats(0.01, 1.0), min_size=4, max_size=4).map(_normalised)
    likelihood = np.array([[data.draw(rows) for _ in range(n_goals)] for _ in range(N_MODES)])
    projected = project_beliefs(belief, likelihood, steps=steps)
    for m in range(N_MODES):
        for d, label in enumerate((SOFT_PUFF, SOFT_SIP)):
            expected = belief
            for _ in range(steps):
                expected = bayes_update(expected, likelihood[m, :, label])
            np.testing.assert_allclose(projected[m, d], expected, rtol=1e-10)
    np.testing.assert_allclose(projected.sum(axis=-1), 1.0, rtol=1e-12)


def test_horizon_steps_count_the_matlab_loop() -> None:
    # t_stamps = 0:0.1:T has T / 0.1 + 1 entries and the loop makes one update between each two
    assert horizon_steps(GOPINATH_SHORT_HORIZON_S, GOPINATH_PROJECTION_DT_S) == 10
    assert horizon_steps(GOPINATH_LONG_HORIZON_S, GOPINATH_PROJECTION_DT_S) == 20
    assert horizon_steps(GOPINATH_KL_HORIZON_S, GOPINATH_PROJECTION_DT_S) == 10
    assert horizon_steps(0.3, 0.1) == 3  # 0.3 / 0.1 is 2.9999999999999996 in floats
    with pytest.raises(ValueError):
        horizon_steps(0.05, 0.1)
    with pytest.raises(ValueError):
        horizon_steps(1.0, 0.0)


# --- the house's choice ----------------------------------------------------------------------

def test_choose_mode_keeps_the_current_mode_on_a_tie() -> None:
    assert choose_mode(np.array([0.2, 0.5, 0.5]), current_mode=2) == 2
    assert choose_mode(np.array([0.5, 0.2, 0.5]), current_mode=1) == 0  # the first tied mode
    assert choose_mode(np.array([0.2, 0.5, 0.5 - 1e-13]), current_mode=2) == 2  # last-bit tie
    assert choose_mode(np.array([0.2, 0.5, 0.4]), current_mode=2) == 1


# --- Herlant et al.: time-optimal mode switching ------------------------------------------------

def test_every_other_mode_is_one_blow_away() -> None:
    for start, target in itertools.product(range(N_MODES), repeat=2):
        one_blow = any(switch_mode(start, label) == target for label in (HARD_PUFF, HARD_SIP))
        assert mode_switches_between(start, target) == (0 if start == target else 1)
        assert one_blow or start == target


SPEEDS = np.array([1.0, 1.0, 1.0])
TOLERANCE = np.array([0.5, 0.5, 0.1])


def test_herlant_hand_layouts() -> None:
    pose = np.array([10.0, 10.0, 0.0])
    # the goal differs only in y; in mode x the plan switches to y
    assert herlant_time_optimal_mode(pose, np.array([10.0, 20.0, 0.0]), 0, SPEEDS, 1.0, TOLERANCE) == 1
    # x and y left, already in y: (y, x) takes one switch, (x, y) two -> stay in y
    assert herlant_time_optimal_mode(pose, np.array([20.0, 20.0, 0.0]), 1, SPEEDS, 1.0, TOLERANCE) == 1
    # in theta with x and y left: (x, y) and (y, x) both take two switches -> mode order, x
    assert herlant_time_optimal_mode(pose, np.array([20.0, 20.0, 0.0]), 2, SPEEDS, 1.0, TOLERANCE) == 0
    # in y with x and theta left: y -> x and y -> theta are one blow each (Hard Sip, Hard Puff),
    # so both orders take two switches -> x (one-way cycling would make it theta)
    assert herlant_time_optimal_mode(pose, np.array([20.0, 10.0, 1.0]), 1, SPEEDS, 1.0, TOLERANCE) == 0
    # switches cost nothing: every order ties, and the current mode wins the tie
    assert herlant_time_optimal_mode(pose, np.array([20.0, 20.0, 0.0]), 1, SPEEDS, 0.0, TOLERANCE) == 1
    # at the goal: nothing to travel, no switch
    assert herlant_time_optimal_mode(pose, pose, 2, SPEEDS, 1.0, TOLERANCE) == 2
    # a dimension exactly at its tolerance counts as there (the world's success rule is <=)
    assert herlant_time_optimal_mode(pose, np.array([10.5, 20.0, 0.0]), 0, SPEEDS, 1.0, TOLERANCE) == 1


def test_herlant_turns_the_short_way() -> None:
    # heading 6.1 rad, goal 0.1 rad: the turn left is 0.1 + 2 pi - 6.1 = 0.2832 rad, within 0.3;
    # only x is left, so from theta the plan goes to x (a naive 6.0 rad difference would keep theta)
    pose = np.array([10.0, 10.0, 6.1])
    goal = np.array([20.0, 10.0, 0.1])
    assert herlant_time_optimal_mode(pose, goal, 2, SPEEDS, 1.0, np.array([0.5, 0.5, 0.3])) == 0


def test_herlant_plan_duration_by_hand() -> None:
    # From (10, 10, 0) in x to (14, 12, pi/2), speeds (2, 1, pi/4), 1.5 s a switch:
    # travel 4 / 2 + 2 / 1 + (pi/2) / (pi/4) = 2 + 2 + 2 = 6 s; starting in x, two switches = 3 s.
    # (x, y, theta) and (x, theta, y) tie at 9 s; mode order picks (x, y, theta).
    pose, goal = np.array([10.0, 10.0, 0.0]), np.array([14.0, 12.0, math.pi / 2])
    speeds = np.array([2.0, 1.0, math.pi / 4])
    duration, order = herlant_time_optimal_plan(pose, goal, 0, speeds, 1.5, TOLERANCE)
    assert duration == pytest.approx(9.0)
    assert order == (0, 1, 2)


def test_herlant_refuses_bad_settings() -> None:
    pose = np.zeros(3)
    with pytest.raises(ValueError, match="speeds"):
        herlant_time_optimal_mode(pose, pose, 0, np.array([1.0, 0.0, 1.0]), 1.0, TOLERANCE)
    with pytest.raises(ValueError, match="switch"):
        herlant_time_optimal_mode(pose, pose, 0, SPEEDS, -1.0, TOLERANCE)
    with pytest.raises(ValueError, match="tolerance"):
        herlant_time_optimal_mode(pose, pose, 0, SPEEDS, 1.0, np.array([0.1, -0.1, 0.1]))


def _search_next_mode(left: list[float], speeds: list[float], tolerance: list[float], mode: int,
                      switch_time: float) -> tuple[float, int]:
    """Shortest time to the goal over the mode-augmented graph, nodes (mode, dimensions done),
    edges a hard blow (switch_mode with Hard Puff or Hard Sip, ``switch_time``) or the travel of
    the current mode's dimension (``|left| / speed``); and the mode of the first travel on a
    shortest path (the current mode if one starts there, else the lowest)."""
    needed = frozenset(k for k in range(N_MODES) if abs(left[k]) > tolerance[k])
    nodes = [(m, frozenset(done)) for m in range(N_MODES) for r in range(len(needed) + 1)
             for done in itertools.combinations(sorted(needed), r)]

    def edges(node: tuple[int, frozenset[int]]) -> list[tuple[float, tuple[int, frozenset[int]], bool]]:
        m, done = node
        out = [(switch_time, (switch_mode(m, label), done), False) for label in (HARD_PUFF, HARD_SIP)]
        if m in needed and m not in done:
            out.append((abs(left[m]) / speeds[m], (m, done | {m}), True))
        return out

    # cost to go by Bellman-Ford (24 nodes; zero-cost cycles allowed when switch_time is 0)
    to_go = {node: (0.0 if node[1] == needed else math.inf) for node in nodes}
    for _ in range(len(nodes)):
        for node in nodes:
            for cost, nxt, _travel in edges(node):
                to_go[node] = min(to_go[node], cost + to_go[nxt])
    start: tuple[int, frozenset[int]] = (mode, frozenset())
    best = to_go[start]
    if not needed:
        return best, mode
    # switch-only distances from the start mode, then which first travels lie on a shortest path
    reach = {m: math.inf for m in range(N_MODES)}
    reach[mode] = 0.0
    for _ in range(N_MODES):
        for m in range(N_MODES):
            for label in (HARD_PUFF, HARD_SIP):
                reach[switch_mode(m, label)] = min(reach[switch_mode(m, label)], reach[m] + switch_time)
    slack = 1e-9 * max(1.0, best)
    first = [m for m in sorted(needed)
             if reach[m] + abs(left[m]) / speeds[m] + to_go[(m, frozenset({m}))] <= best + slack]
    return best, (mode if mode in first else first[0])


@given(st.lists(st.integers(-3, 3), min_size=3, max_size=3), st.integers(0, 2),
       st.lists(st.sampled_from([0.5, 1.0, 2.0]), min_size=3, max_size=3),
       st.sampled_from([0.0, 0.5, 1.0, 3.0]))
def test_herlant_matches_a_search_of_the_mode_augmented_space(left: list[int], mode: int, speeds: list[float],
                                                              switch_time: float) -> None:
    tolerance = [0.5, 0.5, 0.5]
    pose = np.array([20.0, 15.0, 1.0])
    goal = pose + np.array(left, dtype=float) * np.array([1.0, 1.0, 0.25])  # turns within (-pi, pi)
    remaining = [float(v) for v in goal - pose]
    best, expected_mode = _search_next_mode(remaining, speeds, tolerance, mode, switch_time)
    rates, bands = np.array(speeds), np.array(tolerance)
    duration, _ = herlant_time_optimal_plan(pose, goal, mode, rates, switch_time, bands)
    assert duration == pytest.approx(best, rel=1e-12, abs=1e-12)
    assert herlant_time_optimal_mode(pose, goal, mode, rates, switch_time, bands) == expected_mode
