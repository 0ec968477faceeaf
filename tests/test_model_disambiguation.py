"""Disambiguation: p(phi_m | g, s), exact MI (Eq. 13), the Monte-Carlo estimate, R(s), D(s) and s*."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rng_stubs import FixedUniform
from scipy.special import rel_entr

from nudgecli.errors import ProbabilityTableError
from nudgecli.model import candidates as cand
from nudgecli.model import disambiguation as dis
from nudgecli.model import information as mi
from nudgecli.model import portable_math
from nudgecli.model.human_actions import DistinctActionRows, action_likelihood
from nudgecli.model.interface import default_distortion_table, default_mapping_table, observation_model
from nudgecli.model.log_terms import xlogy as model_xlogy
from nudgecli.model.mdp import solve_layout
from nudgecli.model.world import (
    N_CELLS_X,
    N_CELLS_Y,
    N_STATES,
    cell_centre,
    state_coordinates,
    state_index,
)

GOAL_CELLS = np.array([[3, 1], [1, 2], [0, 0], [5, 0]])
GOAL_HEADINGS = np.array([6, 7, 3, 0])


@pytest.fixture(scope="module")
def model() -> dis.DisambiguationModel:
    solved = solve_layout(GOAL_CELLS, GOAL_HEADINGS)
    return dis.DisambiguationModel(GOAL_CELLS, solved.p_a_given_sg, default_mapping_table(0.3),
                                   default_distortion_table(0.25))


# --- brute-force references ------------------------------------------------------------------

def brute_force_likelihood(p_a: np.ndarray, mapping: np.ndarray, distortion: np.ndarray) -> np.ndarray:
    """p(phi_m | g, s) = sum_a sum_phi_i p(phi_m | phi_i) p(phi_i | a, m(s)) p(a | s, g), by loops."""
    n_goals, n_states, n_actions = p_a.shape
    out = np.zeros((n_goals, n_states, 4))
    for g in range(n_goals):
        for s in range(n_states):
            m = s % 3
            for f in range(4):
                out[g, s, f] = sum(distortion[i, f] * mapping[m, a, i] * p_a[g, s, a]
                                   for a in range(n_actions) for i in range(4))
    return out


def brute_force_mi(belief: np.ndarray, likelihood: np.ndarray, transition: np.ndarray | None) -> np.ndarray:
    """Eq. 13 with explicit sums: sum_g' b_g' sum_g p(g | g') sum_f L log(L / p(f | s))."""
    n_goals, n_states, n_labels = likelihood.shape
    trans = np.eye(n_goals) if transition is None else transition
    out = []
    for s in range(n_states):
        weights = [sum(belief[k] * trans[k][g] for k in range(n_goals)) for g in range(n_goals)]
        marginal = [sum(weights[g] * likelihood[g, s, f] for g in range(n_goals)) for f in range(n_labels)]
        total = 0.0
        for k in range(n_goals):
            for g in range(n_goals):
                for f in range(n_labels):
                    joint = belief[k] * trans[k][g] * likelihood[g, s, f]
                    if joint > 0:  # terms of zero joint probability contribute 0
                        total += joint * math.log(likelihood[g, s, f] / marginal[f])
        out.append(total)
    return np.array(out)


def random_likelihood(rng: np.random.Generator, n_goals: int, n_states: int,
                      zero_fraction: float) -> np.ndarray:
    lik = rng.random((n_goals, n_states, 4))
    lik[rng.random(lik.shape) < zero_fraction] = 0.0
    lik[..., 0] += 1e-3 * (lik.sum(axis=-1) == 0)  # keep every row a distribution
    return lik / lik.sum(axis=-1, keepdims=True)


def random_tables(rng: np.random.Generator, n_goals: int, n_states: int) -> tuple[np.ndarray, ...]:
    p_a = rng.dirichlet(np.ones(4), size=(n_goals, n_states))
    mapping = rng.dirichlet(np.ones(4) * 0.7, size=(3, 4))
    distortion = rng.dirichlet(np.ones(4) * 0.7, size=4)
    return p_a, mapping, distortion


# --- observation model and exact MI ------------------------------------------------------------

def test_observation_likelihood_equals_brute_force() -> None:
    rng = np.random.default_rng(1)
    p_a, mapping, distortion = random_tables(rng, 3, 9)
    np.testing.assert_allclose(dis.observation_likelihood(p_a, mapping, distortion),
                               brute_force_likelihood(p_a, mapping, distortion), rtol=0, atol=1e-14)


def test_model_likelihood_of_the_study_defaults(model: dis.DisambiguationModel) -> None:
    lik = model.likelihood
    assert lik.shape == (4, N_STATES, 4)
    np.testing.assert_allclose(lik.sum(axis=-1), 1.0)
    some = np.arange(0, N_STATES, 97)
    np.testing.assert_allclose(lik[:, some], _likelihood_at(model, some), rtol=0, atol=1e-14)


def _likelihood_at(model: dis.DisambiguationModel, states: np.ndarray) -> np.ndarray:
    """The brute-force sums at selected flat states (whose mode is state % 3)."""
    out = np.zeros((model.n_goals, states.size, 4))
    for c, s in enumerate(states):
        m = s % 3
        for g in range(model.n_goals):
            for f in range(4):
                out[g, c, f] = sum(model.distortion[i, f] * model.mapping[m, a, i]
                                   * model.p_a_given_sg[g, s, a] for a in range(4) for i in range(4))
    return out


@pytest.mark.parametrize("seed", range(12))
def test_mutual_information_equals_brute_force(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n_goals = int(rng.integers(2, 6))
    lik = random_likelihood(rng, n_goals, 7, zero_fraction=0.3)
    belief = rng.dirichlet(np.ones(n_goals))
    transition = rng.dirichlet(np.ones(n_goals), size=n_goals)
    np.testing.assert_allclose(mi.mutual_information(belief, lik), brute_force_mi(belief, lik, None),
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(mi.mutual_information(belief, lik, transition),
                               brute_force_mi(belief, lik, transition), rtol=0, atol=1e-9)


def test_mutual_information_of_a_certain_belief_is_zero() -> None:
    lik = random_likelihood(np.random.default_rng(3), 4, 5, zero_fraction=0.4)
    certain = np.array([0.0, 0.0, 1.0, 0.0])
    np.testing.assert_allclose(mi.mutual_information(certain, lik), 0.0, atol=1e-15)
    np.testing.assert_allclose(brute_force_mi(certain, lik, None), 0.0, atol=1e-15)


def test_model_fast_path_equals_public_function(model: dis.DisambiguationModel) -> None:
    belief = np.array([0.1, 0.2, 0.3, 0.4])
    states = np.arange(0, N_STATES, 7)
    np.testing.assert_allclose(model.mutual_information(belief, states),
                               mi.mutual_information(belief, model.likelihood[:, states]),
                               rtol=0, atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_model_marginal_is_the_kron_product_bit_for_bit(model: dis.DisambiguationModel, seed: int) -> None:
    """The tables' marginal sum_g w_g p(f | g, s) gives the bits of the product with kron(w, I_F)
    (portable_math.matmul: every other term an exact zero) the model computed before, so no
    simulated table changed when the cheaper sum replaced it."""
    rng = np.random.default_rng(seed)
    weights = rng.dirichlet(np.ones(4)) * (rng.random(4) > 0.2)
    weights = weights / weights.sum() if weights.sum() > 0 else np.full(4, 0.25)
    states = rng.choice(N_STATES, size=int(rng.integers(1, 300)), replace=False)
    rows_of = model._index.take(states, axis=1).T
    rows = model._distinct.take(rows_of, axis=0).reshape(len(states), -1)
    spread = (weights[:, None, None] * np.eye(4)).reshape(-1, 4)
    marginal = portable_math.matmul(rows, spread)
    conditional = portable_math.matmul(model._xlogx_distinct.take(rows_of), weights)
    before = np.maximum(conditional - model_xlogy(marginal, marginal).sum(axis=-1), 0.0)
    assert model.mutual_information(weights, states).tobytes() == before.tobytes()


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_goals=st.integers(2, 6),
       zero_fraction=st.sampled_from([0.0, 0.3, 0.6]), certain=st.booleans())
def test_mutual_information_bounds_and_goal_permutation(seed: int, n_goals: int, zero_fraction: float,
                                                        certain: bool) -> None:
    rng = np.random.default_rng(seed)
    lik = random_likelihood(rng, n_goals, 6, zero_fraction)
    belief = np.eye(n_goals)[rng.integers(n_goals)] if certain else rng.dirichlet(np.ones(n_goals))
    info = mi.mutual_information(belief, lik)
    entropy = -sum(p * math.log(p) for p in belief if p > 0)
    assert np.all(info >= 0)
    assert np.all(info <= min(entropy, math.log(4)) + 1e-12)
    perm = rng.permutation(n_goals)
    np.testing.assert_allclose(mi.mutual_information(belief[perm], lik[perm]), info, rtol=0, atol=1e-12)


# --- Monte-Carlo estimate ------------------------------------------------------------------------

@pytest.mark.parametrize("weighting", ["unweighted", "belief"])
def test_vectorised_monte_carlo_reproduces_the_per_sample_loop(weighting: str) -> None:
    rng = np.random.default_rng(11)
    p_a, mapping, distortion = random_tables(rng, 4, 30)
    belief = np.array([0.5, 0.3, 0.15, 0.05])
    states = np.array([0, 4, 17, 29, 8])
    slow = mi.monte_carlo_mutual_information_per_sample(belief, states, p_a, mapping, distortion,
                                                         np.random.default_rng(5), 60, weighting)
    fast = mi.monte_carlo_mutual_information(belief, states, p_a, mapping, distortion,
                                              np.random.default_rng(5), 60, weighting)
    np.testing.assert_array_equal(fast, slow)


def test_monte_carlo_draws_never_land_on_a_zero_probability_outcome() -> None:
    # Generator.choice's rule is cdf.searchsorted(u, side="right"): u = 0.0 skips the leading
    # outcomes of probability 0 (cdf 0.0) rather than drawing them
    p_a = np.zeros((2, 1, 4))
    p_a[:, 0, 1] = 1.0  # move_n for sure
    mapping = np.zeros((3, 4, 4))
    mapping[:, :, 3] = 1.0
    mapping[0, 1] = [0.0, 0.0, 1.0, 0.0]  # move_n in mode x: Soft Puff for sure
    distortion = np.eye(4)
    counts = mi.monte_carlo_label_counts(np.array([0.0, 1.0]), np.array([0]), p_a, mapping, distortion,
                                         FixedUniform(0.0), 5)  # type: ignore[arg-type]
    expected = np.zeros((1, 2, 4))
    expected[0, 1, 2] = 5.0  # every draw: goal 1, Soft Puff
    np.testing.assert_array_equal(counts, expected)


def test_monte_carlo_draws_stay_in_range_for_rows_within_the_tables_tolerance() -> None:
    # rows summing to 1 - 5e-7 pass validation (1e-6); as in Generator.choice, each cdf is divided by
    # its last entry, so the largest uniform below 1 draws the last outcome, never one past it
    p_a = np.full((1, 1, 4), 0.25)
    p_a[0, 0, 3] -= 5e-7
    mapping = default_mapping_table()
    mapping[0, 3] = [0.0, 0.0, 0.0, 1.0 - 5e-7]
    distortion = np.eye(4)
    distortion[3, 3] -= 5e-7
    largest_below_one = float(np.nextafter(1.0, 0.0))
    counts = mi.monte_carlo_label_counts(np.array([1.0]), np.array([0]), p_a, mapping, distortion,
                                         FixedUniform(largest_below_one), 3)  # type: ignore[arg-type]
    expected = np.zeros((1, 1, 4))
    expected[0, 0, 3] = 3.0  # to_mode_l -> Hard Sip, measured as itself
    np.testing.assert_array_equal(counts, expected)


@pytest.mark.parametrize("belief", [[0.5, -0.1, 0.6], [0.0, 0.0], [np.nan, 1.0], [np.inf, 1.0], [],
                                    [[0.5, 0.5]]])
def test_a_belief_that_is_not_a_distribution_is_refused(belief: list) -> None:
    with pytest.raises(ValueError, match="non-negative"):
        mi.normalised_belief(np.array(belief, dtype=float))


def test_belief_weighted_monte_carlo_converges_to_exact() -> None:
    # Study-like tables: ε-greedy actions of random policies, the default noise tables.
    rng = np.random.default_rng(2)
    p_a = action_likelihood(rng.integers(4, size=(3, 12)))
    mapping, distortion = default_mapping_table(), default_distortion_table()
    belief = np.array([0.5, 0.3, 0.2])
    states = np.arange(12)
    exact = mi.mutual_information(belief, dis.observation_likelihood(p_a, mapping, distortion))
    assert exact.max() > 0.2  # informative states, so the check has teeth

    def mean_error(samples: int) -> float:
        est = mi.monte_carlo_mutual_information(belief, states, p_a, mapping, distortion,
                                                 np.random.default_rng(7), samples, "belief")
        return float(np.abs(est - exact).mean())

    # Tolerance: every label has probability >= 0.05 under these tables and the ratios
    # p(f | g, s) / p(f | s) stay within [1/4, 4], so |log ratio| <= 1.4. A goal's plug-in KL
    # from n_g >= 0.2 N = 4000 samples then has a standard error <= 1.4 / sqrt(4000) = 0.022 and a
    # bias O(F / n_g) = 1e-3; the belief-weighted sum and the mean over 12 states only shrink the
    # noise, so 0.02 on the mean absolute error bounds it (about 0.004 is typical).
    large, small = mean_error(20_000), mean_error(50)
    assert large < 0.02
    assert large < small


def test_mutual_information_from_counts_hand_cases() -> None:
    # two goals with disjoint labels: pooled (1/2, 1/2); each KL = log 2
    counts = np.array([[[2, 0, 0, 0], [0, 2, 0, 0]]], dtype=float)
    belief = np.array([0.9, 0.1])
    assert mi.mutual_information_from_counts(counts, belief, "unweighted")[0] == pytest.approx(math.log(2))
    assert mi.mutual_information_from_counts(counts, belief, "belief")[0] == pytest.approx(math.log(2))
    # a goal that was never sampled is left out of the unweighted mean
    counts = np.array([[[3, 1, 0, 0], [1, 3, 0, 0], [0, 0, 0, 0]]], dtype=float)
    kl = 0.75 * math.log(0.75 / 0.5) + 0.25 * math.log(0.25 / 0.5)
    assert mi.mutual_information_from_counts(counts, np.ones(3), "unweighted")[0] == pytest.approx(kl)
    belief = np.array([0.5, 0.3, 0.2])
    assert mi.mutual_information_from_counts(counts, belief, "belief")[0] == pytest.approx(0.8 * kl)
    # the definition with scipy's rel_entr on an uneven case
    counts = np.array([[[5, 2, 1, 0], [0, 1, 1, 6], [2, 2, 2, 2]]], dtype=float)
    pooled = counts[0].sum(axis=0) / counts.sum()
    kls = [rel_entr(row / row.sum(), pooled).sum() for row in counts[0]]
    estimate = mi.mutual_information_from_counts(counts, np.ones(3), "unweighted")[0]
    assert estimate == pytest.approx(np.mean(kls))
    with pytest.raises(ValueError, match="weighting"):
        mi.mutual_information_from_counts(counts, np.ones(3), "median")  # type: ignore[arg-type]


def test_belief_weighted_estimate_normalises_the_belief() -> None:
    # sum_g b_g KL_g with b normalised here: a belief given as weights 2 : 1 : 1 is (0.5, 0.25, 0.25)
    counts = np.array([[[5, 2, 1, 0], [0, 1, 1, 6], [2, 2, 2, 2]]], dtype=float)
    pooled = counts[0].sum(axis=0) / counts.sum()
    kls = [rel_entr(row / row.sum(), pooled).sum() for row in counts[0]]
    expected = 0.5 * kls[0] + 0.25 * kls[1] + 0.25 * kls[2]
    for belief in (np.array([2.0, 1.0, 1.0]), np.array([0.5, 0.25, 0.25])):
        assert mi.mutual_information_from_counts(counts, belief, "belief")[0] == pytest.approx(expected)


# --- candidate domains --------------------------------------------------------------------------

def brute_force_window(current: int, goal_cells: np.ndarray, window: int) -> list[int]:
    i, j, h, _ = (int(v) for v in state_coordinates(current))
    goals = {(int(a), int(b)) for a, b in goal_cells}
    half = window // 2
    out = []
    for dx in range(-half, half + 1):
        for dy in range(-half, half + 1):
            ci, cj = i + dx, j + dy
            if not (0 <= ci < N_CELLS_X and 0 <= cj < N_CELLS_Y) or (ci, cj) in goals:
                continue
            out.extend(int(state_index(ci, cj, h, m)) for m in range(3))
    return out


@pytest.mark.parametrize("window", [3, 5])
@pytest.mark.parametrize("cell", [(0, 0), (9, 9), (2, 1), (4, 1), (6, 6), (0, 5)])
def test_window_candidates_equal_brute_force(window: int, cell: tuple[int, int]) -> None:
    current = int(state_index(cell[0], cell[1], 5, 2))
    cands = cand.window_candidates(current, GOAL_CELLS, window)
    assert cands.states.tolist() == brute_force_window(current, GOAL_CELLS, window)
    coords = np.array([state_coordinates(s) for s in cands.states]).reshape(-1, 4)
    np.testing.assert_array_equal(cands.cells, coords[:, :2])
    np.testing.assert_allclose(cands.positions, cell_centre(coords[:, 0], coords[:, 1]))


def test_rotation_gate_drops_far_theta_candidates() -> None:
    current = int(state_index(6, 6, 2, 0))
    robot = np.array([31.0, 24.5])
    gated = cand.window_candidates(current, GOAL_CELLS, 5, robot_position=robot, rotation_gate=12.0)
    full = cand.window_candidates(current, GOAL_CELLS, 5, robot_position=robot)
    mean_goal = cell_centre(GOAL_CELLS[:, 0], GOAL_CELLS[:, 1]).mean(axis=0)
    expected = [s for s, pos in zip(full.states, full.positions, strict=True)
                if s % 3 != 2 or np.linalg.norm(pos - mean_goal) <= 12.0]
    assert gated.states.tolist() == expected
    assert len(expected) < len(full.states)
    # study positions: robot position plus (dx * 4.2, dy * 3.4)
    first = full.positions[0]
    np.testing.assert_allclose(first, robot + np.array([-2 * 4.2, -2 * 3.4]))


def test_the_rotation_gate_keeps_a_theta_candidate_exactly_at_the_gate() -> None:
    # "farther than the gate" is dropped: a theta-mode candidate at exactly the gate's distance stays
    current = int(state_index(6, 6, 2, 0))
    robot = np.array([31.0, 24.5])
    full = cand.window_candidates(current, GOAL_CELLS, 3, robot_position=robot)
    mean_goal = cell_centre(GOAL_CELLS[:, 0], GOAL_CELLS[:, 1]).mean(axis=0)
    offset = full.positions - mean_goal
    distance = np.sqrt(offset[:, 0] * offset[:, 0] + offset[:, 1] * offset[:, 1])
    theta = np.flatnonzero(full.states % 3 == 2)
    k = theta[np.argmin(distance[theta])]  # the nearest theta-mode candidate
    at_gate = cand.window_candidates(current, GOAL_CELLS, 3, robot_position=robot,
                                     rotation_gate=float(distance[k]))
    assert full.states[k] in at_gate.states
    below = float(np.nextafter(distance[k], 0))
    assert full.states[k] not in cand.window_candidates(current, GOAL_CELLS, 3, robot_position=robot,
                                                         rotation_gate=below).states


def test_global_candidates_apply_the_rotation_gate() -> None:
    mean_goal = cell_centre(GOAL_CELLS[:, 0], GOAL_CELLS[:, 1]).mean(axis=0)
    goal_cells = set(map(tuple, GOAL_CELLS.tolist()))
    expected = []
    for s in range(N_STATES):  # brute force over the flat index
        i, j, _h, m = (int(v) for v in state_coordinates(s))
        if (i, j) in goal_cells:
            continue
        if m == 2 and np.linalg.norm(cell_centre(i, j) - mean_goal) > 12.0:
            continue
        expected.append(s)
    gated = cand.global_candidates(GOAL_CELLS, rotation_gate=12.0)
    assert gated.states.tolist() == expected
    assert len(expected) < N_STATES - len(GOAL_CELLS) * 24  # the gate dropped some


def test_global_candidates_exclude_goal_cells() -> None:
    cands = cand.global_candidates(GOAL_CELLS)
    assert cands.states.size == N_STATES - len(GOAL_CELLS) * 24
    assert not set(map(tuple, cands.cells.tolist())) & set(map(tuple, GOAL_CELLS.tolist()))


# --- distance, D(s), s* --------------------------------------------------------------------------

def test_distance_regulariser_kinds() -> None:
    goals = np.array([[0.0, 0.0], [4.0, 0.0]])
    belief = np.array([0.25, 0.75])
    q = np.array([[0.0, 3.0], [4.0, 0.0]])
    expected_dist = [0.25 * 3.0 + 0.75 * 5.0, 0.25 * 4.0]
    np.testing.assert_allclose(dis.distance_regulariser(belief, goals, q, "expected"), expected_dist)
    # belief-weighted mean goal (3, 0)
    np.testing.assert_allclose(dis.distance_regulariser(belief, goals, q, "to_mean"), [math.hypot(3, 3), 1.0])


def _flat_model() -> dis.DisambiguationModel:
    """Every goal has the same action model, so I(s) = 0 and D(s) = -lambda R(s)."""
    goal_cells = np.array([[0, 0], [2, 0]])
    p_a = np.repeat(action_likelihood(np.zeros((1, N_STATES), dtype=int)), 2, axis=0)
    return dis.DisambiguationModel(goal_cells, p_a, default_mapping_table(), default_distortion_table())


def test_s_star_on_a_hand_checkable_window() -> None:
    flat = _flat_model()
    current = int(state_index(1, 1, 4, 1))
    choice = dis.maximally_disambiguating_state(np.array([0.5, 0.5]), flat, current)
    # 3 x 3 window around (1, 1) minus the goal cells (0, 0) and (2, 0): 7 cells x 3 modes, in order
    cells = [(0, 1), (0, 2), (1, 0), (1, 1), (1, 2), (2, 1), (2, 2)]
    expected = [int(state_index(i, j, 4, m)) for i, j in cells for m in range(3)]
    assert choice.candidates.states.tolist() == expected
    np.testing.assert_allclose(choice.scores.information, 0.0, atol=1e-15)
    # expected distance in cells: (1, 0) is 1 from both goals, the minimum; its 3 modes tie -> mode 0
    np.testing.assert_allclose(choice.scores.distance[6:9], 1.0)
    assert choice.state == int(state_index(1, 0, 4, 0))
    assert choice.index == 6


def test_s_star_is_the_first_of_candidates_tied_up_to_rounding() -> None:
    # I(s) = 0; world-unit distance to the belief's mean goal, cell (6.5, 2.5): the cells (6, 5) and
    # (7, 5) are mirror images about it, equally near, but their computed D(s) differ in the last bit
    goal_cells = np.array([[5, 1], [8, 4]])
    p_a = np.repeat(action_likelihood(np.zeros((1, N_STATES), dtype=int)), 2, axis=0)
    flat = dis.DisambiguationModel(goal_cells, p_a, default_mapping_table(), default_distortion_table())
    settings_ = dis.DisambiguationSettings(distance_unit="world", distance="to_mean", window=5)
    choice = dis.maximally_disambiguating_state(np.array([0.5, 0.5]), flat, int(state_index(8, 7, 0, 0)),
                                                settings_)
    # by hand, in cell units (a uniform grid scales x and y by the cell sizes, not the order)
    width, height = cell_centre(1, 1) - cell_centre(0, 0)
    hand = [math.hypot((i - 6.5) * width, (j - 2.5) * height) for i, j in choice.candidates.cells]
    nearest = [k for k, d in enumerate(hand) if d <= min(hand) + 1e-9]
    assert {tuple(choice.candidates.cells[k]) for k in nearest} == {(6, 5), (7, 5)}
    assert choice.index == nearest[0] and choice.state == int(state_index(6, 5, 0, 0))


def test_s_star_respects_the_grid_edge() -> None:
    flat = _flat_model()
    current = int(state_index(9, 9, 0, 0))
    choice = dis.maximally_disambiguating_state(np.array([0.5, 0.5]), flat, current)
    assert {tuple(c) for c in choice.candidates.cells.tolist()} == {(8, 8), (8, 9), (9, 8), (9, 9)}
    assert choice.state == int(state_index(8, 8, 0, 0))  # nearest to both goals, first mode


def test_scores_combine_the_terms(model: dis.DisambiguationModel) -> None:
    belief = np.array([0.4, 0.3, 0.2, 0.1])
    current = int(state_index(6, 5, 3, 1))
    settings_ = dis.DisambiguationSettings(mi_weight=0.7, distance_weight=0.2, window=5)
    cands = model.candidates(current, settings_)
    scores = dis.disambiguation_scores(belief, model, cands, settings_)
    info = mi.mutual_information(belief, model.likelihood[:, cands.states])
    dist = [sum(belief[g] * math.dist(GOAL_CELLS[g], c) for g in range(4)) for c in cands.cells]
    np.testing.assert_allclose(scores.information, info, atol=1e-12)
    np.testing.assert_allclose(scores.distance, dist, atol=1e-12)
    np.testing.assert_allclose(scores.score, 0.7 * info - 0.2 * np.array(dist), atol=1e-12)
    # MI alone decides when lambda = 0: the first maximiser of the exact MI
    mi_only = dis.DisambiguationSettings(distance_weight=0.0, window=5)
    choice = dis.maximally_disambiguating_state(belief, model, current, mi_only)
    assert choice.state == int(cands.states[int(np.flatnonzero(info >= info.max() - 1e-12)[0])])


def test_scores_with_a_goal_transition_propagate_the_information_term_only(
        model: dis.DisambiguationModel) -> None:
    # Eq. 13 weighs the goals by the predicted belief b @ T; the distance term of Eq. 15 keeps b
    belief = np.array([0.7, 0.1, 0.15, 0.05])
    transition = np.array([[0.1, 0.6, 0.2, 0.1], [0.3, 0.3, 0.3, 0.1],
                           [0.25, 0.25, 0.25, 0.25], [0.7, 0.1, 0.1, 0.1]])
    current = int(state_index(6, 5, 3, 1))
    settings_ = dis.DisambiguationSettings(mi_weight=0.7, distance_weight=0.2, window=5)
    cands = model.candidates(current, settings_)
    scores = dis.disambiguation_scores(belief, model, cands, settings_, goal_transition=transition)
    info = brute_force_mi(belief, model.likelihood[:, cands.states], transition)
    assert np.abs(info - brute_force_mi(belief, model.likelihood[:, cands.states], None)).max() > 1e-3
    dist = [sum(belief[g] * math.dist(GOAL_CELLS[g], c) for g in range(4)) for c in cands.cells]
    np.testing.assert_allclose(scores.information, info, atol=1e-12)
    np.testing.assert_allclose(scores.distance, dist, atol=1e-12)
    np.testing.assert_allclose(scores.score, 0.7 * info - 0.2 * np.array(dist), atol=1e-12)


def test_study_variant_scores(model: dis.DisambiguationModel) -> None:
    belief = np.array([0.4, 0.3, 0.2, 0.1])
    current = int(state_index(6, 5, 3, 1))
    robot = np.array([30.0, 21.0])
    study = dis.DisambiguationSettings.study()
    choice = dis.maximally_disambiguating_state(belief, model, current, study, robot_position=robot,
                                                rng=np.random.default_rng(0))
    goals_world = cell_centre(GOAL_CELLS[:, 0], GOAL_CELLS[:, 1])
    mean = belief @ goals_world
    np.testing.assert_allclose(choice.scores.distance,
                               np.linalg.norm(choice.candidates.positions - mean, axis=1), atol=1e-12)
    expected_mi = mi.monte_carlo_mutual_information(belief, choice.candidates.states, model.p_a_given_sg,
                                                     model.mapping, model.distortion,
                                                     np.random.default_rng(0), 250, "unweighted")
    np.testing.assert_array_equal(choice.scores.information, expected_mi)
    np.testing.assert_allclose(choice.scores.score, 0.5 * expected_mi - 0.5 * choice.scores.distance)
    with pytest.raises(ValueError, match="rng"):
        dis.maximally_disambiguating_state(belief, model, current, study)


def test_settings_defaults_and_validation() -> None:
    paper = dis.DisambiguationSettings()
    assert (paper.estimator, paper.mi_weight, paper.distance_weight, paper.distance, paper.distance_unit,
            paper.window, paper.rotation_gate) == ("exact", 1.0, 1.0, "expected", "cells", 3, None)
    study = dis.DisambiguationSettings.study()
    assert (study.estimator, study.samples, study.weighting, study.mi_weight, study.distance_weight,
            study.distance, study.distance_unit, study.window, study.rotation_gate) == (
        "monte_carlo", 250, "unweighted", 0.5, 0.5, "to_mean", "world", 5, 12.0)
    with pytest.raises(ValueError, match="window"):
        dis.DisambiguationSettings(window=4)
    with pytest.raises(ValueError, match="estimator"):
        dis.DisambiguationSettings(estimator="sampling")  # type: ignore[arg-type]


@pytest.mark.parametrize("rows", ["epsilon-greedy", "a few", "all different"])
def test_model_tables_are_the_per_state_products_bit_for_bit(rows: str) -> None:
    """The model computes each distinct (mode, row) pair once and gathers; every table must be
    exactly the product of every state's own row (the runs' tables depend on the last bit)."""
    rng = np.random.default_rng(11)
    n_goals = len(GOAL_CELLS)
    if rows == "epsilon-greedy":
        p_a = action_likelihood(rng.integers(4, size=(n_goals, N_STATES)), 0.1)
    else:
        pool = rng.dirichlet(np.ones(4), size=5 if rows == "a few" else n_goals * N_STATES)
        p_a = pool[rng.integers(len(pool), size=(n_goals, N_STATES))] if rows == "a few" else \
            pool.reshape(n_goals, N_STATES, 4)
    mapping, distortion = rng.dirichlet(np.ones(4), size=(3, 4)), rng.dirichlet(np.ones(4), size=4)
    modes = np.arange(N_STATES) % 3
    # the products as the model makes them (portable_math.matmul: the same order of additions on
    # every CPU, which test_model_portable_math holds to loops); the claim here is the gather
    measured = observation_model(mapping, distortion)[modes]
    per_state = portable_math.matmul(p_a[:, :, None, :], measured)[:, :, 0, :]
    for table in (p_a, DistinctActionRows.of(p_a)):
        model = dis.DisambiguationModel(GOAL_CELLS, table, mapping, distortion)
        assert model.likelihood.tobytes() == per_state.tobytes()
        assert dis.observation_likelihood(table, mapping, distortion).tobytes() == per_state.tobytes()
        # one state's column, as the protocol's Bayesian update reads it
        for s_, label in zip(rng.integers(N_STATES, size=50), rng.integers(4, size=50), strict=True):
            assert model.label_likelihood(int(s_), int(label)).tobytes() == per_state[:, s_, label].tobytes()
        # the exact MI (Eq. 13) at candidate states, as computed from the per-state table's
        # state-major rows (kron(w, I_F) spreads the weights over the labels)
        states = np.r_[rng.integers(N_STATES, size=40), 7, 7]
        weights = rng.dirichlet(np.ones(n_goals))
        rows = per_state.transpose(1, 0, 2)[states].reshape(len(states), -1)
        marginal = portable_math.matmul(rows, (weights[:, None, None] * np.eye(4)).reshape(-1, 4))
        # the model's x log x (test_model_log_terms holds it to scipy's); the claim here is the
        # gather, not the logarithm
        conditional = portable_math.matmul(model_xlogy(per_state, per_state).sum(axis=-1).T[states], weights)
        expected = np.maximum(conditional - model_xlogy(marginal, marginal).sum(axis=-1), 0.0)
        assert model.mutual_information(weights, states).tobytes() == expected.tobytes()
        assert model.mutual_information(weights, np.array([], dtype=int)).shape == (0,)
        assert model.p_a_given_sg.tobytes() == p_a.tobytes()
    with pytest.raises(ValueError, match="modes"):
        dis.observation_likelihood(DistinctActionRows.of(p_a), mapping, distortion, modes=modes)


def test_a_models_tables_are_checked_every_time_though_their_product_is_made_once() -> None:
    # the (M, A, F) product of a participant's two tables is shared by their models of every
    # layout: a table with the same numbers in another shape, or a bad one, is still refused
    solved = solve_layout(GOAL_CELLS, GOAL_HEADINGS)
    mapping, distortion = default_mapping_table(0.2), default_distortion_table(0.15)
    first = dis.DisambiguationModel(GOAL_CELLS, solved.p_a_given_sg, mapping, distortion)
    second = dis.DisambiguationModel(GOAL_CELLS, solved.p_a_given_sg, mapping.copy(), distortion.copy())
    assert np.array_equal(second.likelihood, first.likelihood)
    expected = brute_force_likelihood(solved.p_a_given_sg, mapping, distortion)
    np.testing.assert_allclose(first.likelihood, expected, rtol=0, atol=1e-12)
    with pytest.raises(ProbabilityTableError, match="shape"):
        dis.DisambiguationModel(GOAL_CELLS, solved.p_a_given_sg, mapping.reshape(4, 3, 4), distortion)
    with pytest.raises(ProbabilityTableError, match="shape"):
        dis.DisambiguationModel(GOAL_CELLS, solved.p_a_given_sg, mapping, distortion.reshape(2, 8))
    bad = distortion.copy()
    bad[1] = [0.5, 0.5, 0.5, -0.5]
    with pytest.raises(ProbabilityTableError, match="Hard Sip"):
        dis.DisambiguationModel(GOAL_CELLS, solved.p_a_given_sg, mapping, bad)
    other = dis.DisambiguationModel(GOAL_CELLS, solved.p_a_given_sg, default_mapping_table(0.3), distortion)
    assert not np.array_equal(other.likelihood, first.likelihood)  # other tables, another product


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_layouts=st.integers(1, 6))
def test_a_participants_models_made_together_are_those_made_one_at_a_time(seed: int, n_layouts: int) -> None:
    # layouts of 1-5 goals with a few distinct random action rows each (so the stacked layouts
    # bring different numbers of rows), random tables, some layouts given as their distinct rows
    rng = np.random.default_rng(seed)
    cells, tables = [], []
    for _ in range(n_layouts):
        n_goals = int(rng.integers(1, 6))
        flat = rng.choice(N_CELLS_X * N_CELLS_Y, size=n_goals, replace=False)
        cells.append(np.column_stack([flat % N_CELLS_X, flat // N_CELLS_X]))
        pool = rng.dirichlet(np.ones(4), size=int(rng.integers(1, 6)))
        p_a = pool[rng.integers(len(pool), size=(n_goals, N_STATES))]
        tables.append(DistinctActionRows.of(p_a) if rng.random() < 0.5 else p_a)
    mapping, distortion = rng.dirichlet(np.ones(4), size=(3, 4)), rng.dirichlet(np.ones(4), size=4)
    together = dis.DisambiguationModel.of_layouts(cells, tables, mapping, distortion)
    assert len(together) == n_layouts
    states = rng.integers(N_STATES, size=30)
    for stacked, goal_cells, table in zip(together, cells, tables, strict=True):
        alone = dis.DisambiguationModel(goal_cells, table, mapping, distortion)
        for name in ("goal_cells", "p_a_given_sg", "mapping", "distortion", "_distinct", "_xlogx_distinct",
                     "_index", "likelihood"):
            mine, theirs = getattr(stacked, name), getattr(alone, name)
            assert mine.dtype == theirs.dtype and mine.shape == theirs.shape, name
            assert mine.tobytes() == theirs.tobytes(), name
        for unit in ("cells", "world"):
            assert stacked.goal_positions(unit).tobytes() == alone.goal_positions(unit).tobytes()
        weights = rng.dirichlet(np.ones(len(goal_cells)))
        assert (stacked.mutual_information(weights, states).tobytes()
                == alone.mutual_information(weights, states).tobytes())


def test_models_made_together_check_their_layouts() -> None:
    solved = solve_layout(GOAL_CELLS, GOAL_HEADINGS)
    mapping, distortion = default_mapping_table(0.2), default_distortion_table(0.15)
    assert dis.DisambiguationModel.of_layouts([], [], mapping, distortion) == []
    with pytest.raises(ValueError, match="2 layouts' goal cells but 1 action models"):
        dis.DisambiguationModel.of_layouts([GOAL_CELLS, GOAL_CELLS], [solved.actions], mapping, distortion)
    with pytest.raises(ValueError, match="3 goal cells but p"):
        dis.DisambiguationModel.of_layouts([GOAL_CELLS, GOAL_CELLS[:3]], [solved.actions, solved.actions],
                                           mapping, distortion)
    with pytest.raises(ProbabilityTableError, match="shape"):
        dis.DisambiguationModel.of_layouts([GOAL_CELLS], [solved.actions], mapping.reshape(4, 3, 4),
                                           distortion)


def test_bad_action_model_is_rejected_with_its_row() -> None:
    p_a = np.full((2, 5, 4), 0.25)
    p_a[1, 3] = [0.5, 0.5, 0.5, -0.5]
    with pytest.raises(ProbabilityTableError, match=r"goal 1, state 3"):
        dis.observation_likelihood(p_a, default_mapping_table(), default_distortion_table())
    with pytest.raises(ProbabilityTableError, match="shape"):
        dis.observation_likelihood(np.full((2, 5, 3), 1 / 3), default_mapping_table(),
                                   default_distortion_table())


def test_observation_likelihood_with_explicit_modes_equals_a_loop():
    # A state space other than the grid: 7 states whose modes are given, not s % 3.
    rng = np.random.default_rng(12)
    p_a = rng.dirichlet(np.ones(4), size=(3, 7))
    mapping = rng.dirichlet(np.ones(4), size=(3, 4))
    distortion = rng.dirichlet(np.ones(4), size=4)
    modes = np.array([1, 1, 0, 2, 0, 1, 2])
    fast = dis.observation_likelihood(p_a, mapping, distortion, modes=modes)
    for g in range(3):
        for s in range(7):
            for f in range(4):
                expected = sum(distortion[i, f] * mapping[modes[s], a, i] * p_a[g, s, a]
                               for a in range(4) for i in range(4))
                assert fast[g, s, f] == pytest.approx(expected, abs=1e-12)
    grid_default = dis.observation_likelihood(p_a, mapping, distortion)
    explicit = dis.observation_likelihood(p_a, mapping, distortion, modes=np.arange(7) % 3)
    np.testing.assert_array_equal(grid_default, explicit)


def test_mutual_information_of_a_batch_equals_one_query_at_a_time():
    rng = np.random.default_rng(13)
    beliefs = rng.dirichlet(np.ones(4), size=5)
    likelihood = rng.dirichlet(np.ones(4), size=(5, 4, 6))
    batched = mi.mutual_information(beliefs, likelihood)
    assert batched.shape == (5, 6)
    for q in range(5):
        single = mi.mutual_information(beliefs[q], likelihood[q])
        np.testing.assert_allclose(batched[q], single, rtol=1e-12)
