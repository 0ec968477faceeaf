"""Goal MDPs: transitions, value iteration (golden case and optimality), tie-breaking, p(a | s, g)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from nudgecli.config import ExperimentConfig, load_experiment
from nudgecli.errors import ProbabilityTableError
from nudgecli.model import human_actions, mdp
from nudgecli.model.interface import MOVE_N, MOVE_P, TO_MODE_L, TO_MODE_R
from nudgecli.model.world import (
    CORNERS,
    N_HEADINGS,
    N_STATES,
    all_state_coordinates,
    sample_layout,
    state_index,
)
from nudgecli.sim.study import build_layouts, solve_layouts

GOAL_CELLS = np.array([[3, 1], [1, 2], [0, 0], [5, 0]])
GOAL_HEADINGS = np.array([6, 7, 3, 0])


@pytest.fixture(scope="module")
def transitions() -> mdp.GoalTransitions:
    return mdp.build_transitions(GOAL_CELLS, GOAL_HEADINGS)


@pytest.fixture(scope="module")
def solved() -> tuple[np.ndarray, np.ndarray, int]:
    tr = mdp.build_transitions(GOAL_CELLS, GOAL_HEADINGS)
    return mdp.value_iteration(tr.next_state, tr.rewards())


Pose = tuple[int, int, int, int]


def brute_force_transition(g: int, i: int, j: int, h: int, m: int, a: int,
                           goal_cells: np.ndarray = GOAL_CELLS,
                           goal_headings: np.ndarray = GOAL_HEADINGS) -> tuple[Pose, str]:
    """The MDP rules of the study written out state by state, independently of the vectorised code."""
    own = (int(goal_cells[g, 0]), int(goal_cells[g, 1]))
    others = {(int(x), int(y)) for k, (x, y) in enumerate(goal_cells) if k != g}
    if (i, j) in others:
        return (i, j, h, m), "inside_obstacle"
    if (i, j) == own and h == goal_headings[g]:
        return (i, j, h, m), "goal_absorbing"
    if a == TO_MODE_R:
        return (i, j, h, (m + 1) % 3), "mode_switch"
    if a == TO_MODE_L:
        return (i, j, h, (m - 1) % 3), "mode_switch"
    step = 1 if a == MOVE_P else -1
    ni, nj, nh = i, j, h
    if m == 0:
        ni += step
    elif m == 1:
        nj += step
    else:
        nh = (h - step) % 8  # move_p turns clockwise: heading index - 1
    if not (0 <= ni < 10 and 0 <= nj < 10) or (ni, nj) in others:
        return (i, j, h, m), "bump"
    if (ni, nj) == own and nh == goal_headings[g]:
        return (ni, nj, nh, m), "goal_entry"
    return (ni, nj, nh, m), "move"


def test_transitions_equal_the_rules_state_by_state(transitions: mdp.GoalTransitions) -> None:
    coords = all_state_coordinates()
    for g in range(len(GOAL_CELLS)):
        for a in range(4):
            for s in range(N_STATES):
                (ni, nj, nh, nm), kind = brute_force_transition(g, *(int(v) for v in coords[s]), a)
                assert transitions.next_state[g, a, s] == state_index(ni, nj, nh, nm)
                assert mdp.OUTCOME_NAMES[transitions.outcome[g, a, s]] == kind


@settings(max_examples=6, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 9), st.integers(0, 9), st.integers(0, 7)), min_size=1, max_size=5,
                unique_by=lambda goal: goal[:2]))
def test_transitions_equal_the_rules_on_any_layout(goals: list[tuple[int, int, int]]) -> None:
    # goals anywhere: on the grid's edges, side by side, walling cells in
    cells = np.array([goal[:2] for goal in goals])
    headings = np.array([goal[2] for goal in goals])
    transitions = mdp.build_transitions(cells, headings)
    coords = all_state_coordinates().tolist()
    for g in range(len(goals)):
        for a in range(4):
            expected = [brute_force_transition(g, *coords[s], a, cells, headings) for s in range(N_STATES)]
            assert transitions.next_state[g, a].tolist() == [state_index(*pose) for pose, _ in expected]
            assert [mdp.OUTCOME_NAMES[k] for k in transitions.outcome[g, a]] == [kind for _, kind in expected]


def test_transition_examples(transitions: mdp.GoalTransitions) -> None:
    nxt = transitions.next_state
    # walls: leaving the grid in x or y stays put
    assert nxt[0, MOVE_N, state_index(0, 5, 2, 0)] == state_index(0, 5, 2, 0)
    assert nxt[0, MOVE_P, state_index(9, 5, 2, 0)] == state_index(9, 5, 2, 0)
    assert nxt[0, MOVE_P, state_index(4, 9, 2, 1)] == state_index(4, 9, 2, 1)
    # another goal's cell: goal 1 sits at (1, 2); in goal 0's MDP it is a wall, in goal 1's it is not
    assert nxt[0, MOVE_P, state_index(0, 2, 5, 0)] == state_index(0, 2, 5, 0)
    assert nxt[1, MOVE_P, state_index(0, 2, 5, 0)] == state_index(1, 2, 5, 0)
    # headings wrap; move_p is clockwise (index - 1)
    assert nxt[0, MOVE_P, state_index(7, 7, 0, 2)] == state_index(7, 7, 7, 2)
    assert nxt[0, MOVE_N, state_index(7, 7, 7, 2)] == state_index(7, 7, 0, 2)
    # modes cycle both ways
    assert nxt[0, TO_MODE_R, state_index(7, 7, 3, 2)] == state_index(7, 7, 3, 0)
    assert nxt[0, TO_MODE_L, state_index(7, 7, 3, 0)] == state_index(7, 7, 3, 2)
    # rewards by kind
    rewards = transitions.rewards()
    assert rewards[0, MOVE_N, state_index(0, 5, 2, 0)] == -100.0
    assert rewards[0, MOVE_P, state_index(7, 7, 0, 2)] == -10.0
    assert rewards[0, TO_MODE_R, state_index(7, 7, 3, 2)] == -100.0
    goal0 = state_index(3, 1, 6, 1)
    assert rewards[0, MOVE_P, state_index(3, 1, 7, 2)] == 100.0  # the turn that completes the pose
    assert np.all(nxt[0, :, goal0] == goal0) and np.all(rewards[0, :, goal0] == 100.0)
    inside = state_index(1, 2, 4, 1)  # goal 1's cell in goal 0's MDP
    assert np.all(nxt[0, :, inside] == inside) and np.all(rewards[0, :, inside] == 0.0)


def test_custom_rewards_are_applied(transitions: mdp.GoalTransitions) -> None:
    rewards = transitions.rewards(mdp.MDPRewards(move=-1.0, mode_switch=-2.0, bump=-3.0, goal=4.0,
                                                 inside_obstacle=-5.0))
    expected = np.array([-1.0, -2.0, -3.0, 4.0, 4.0, -5.0])[transitions.outcome]
    np.testing.assert_array_equal(rewards, expected)


def test_duplicate_or_bad_goals_are_rejected() -> None:
    with pytest.raises(ValueError, match="share a cell"):
        mdp.build_transitions(np.array([[1, 1], [1, 1]]), np.array([0, 4]))
    with pytest.raises(ValueError, match="grid"):
        mdp.build_transitions(np.array([[10, 1]]), np.array([0]))
    with pytest.raises(ValueError, match="headings"):
        mdp.build_transitions(np.array([[1, 1]]), np.array([8]))


def corridor() -> tuple[np.ndarray, np.ndarray]:
    """A 1-D corridor: state 0 is the goal (absorbing, +100 per step), states 1..4 lie in a row,
    state 5 is an obstacle interior (self-loop, reward 0). Action 0 steps towards the goal (-10,
    or +100 when it enters the goal), action 1 away (-10; at state 4 it bumps: stay, -100)."""
    n = 6
    nxt = np.zeros((1, 2, n), dtype=int)
    rew = np.zeros((1, 2, n))
    nxt[0, :, 0] = 0
    rew[0, :, 0] = 100.0
    for s in range(1, 5):
        nxt[0, 0, s] = s - 1
        rew[0, 0, s] = 100.0 if s == 1 else -10.0
        nxt[0, 1, s] = s + 1 if s < 4 else s
        rew[0, 1, s] = -10.0 if s < 4 else -100.0
    nxt[0, :, 5] = 5
    return nxt, rew


def test_value_iteration_golden_corridor() -> None:
    # Closed form. From V_0 = 0, after k sweeps V_k is the best k-step discounted return.
    #   goal:         V_k(0) = 100 (1 - g^k) / (1 - g)
    #   s in 1..4:    go towards the goal: s - 1 moves at -10, the entering move at +100, then the
    #                 goal for the remaining k - s steps, so for k >= s
    #                 V_k(s) = -10 (1 - g^(s-1)) / (1 - g) + 100 g^(s-1) + g^s V_(k-s)(0)
    #   obstacle:     V_k(5) = 0.
    # Sweep k changes the goal by 100 g^(k-1), every s <= 4 < k by g^s 100 g^(k-s-1) = 100 g^(k-1)
    # too, and the obstacle by 0, so span(V_k - V_(k-1)) = 100 g^(k-1) and VI stops at the first
    # k with 100 g^(k-1) < 0.01 (1 - g) / g (k = 305 for g = 0.96, as the study measured).
    gamma = 0.96
    threshold = 0.01 * (1 - gamma) / gamma
    k = next(k for k in range(5, 10_000) if 100 * gamma ** (k - 1) < threshold)
    values, q, iterations = mdp.value_iteration(*corridor(), gamma=gamma)
    assert iterations == k == 305

    def goal_value(steps: int) -> float:
        return 100 * (1 - gamma ** steps) / (1 - gamma)

    expected = [goal_value(k)]
    for s in range(1, 5):
        expected.append(-10 * (1 - gamma ** (s - 1)) / (1 - gamma) + 100 * gamma ** (s - 1)
                        + gamma ** s * goal_value(k - s))
    expected.append(0.0)
    np.testing.assert_allclose(values[0], expected, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(values, q.max(axis=-1))
    # towards the goal everywhere; the goal and the obstacle tie all actions -> action 0
    np.testing.assert_array_equal(mdp.greedy_policy(q)[0], [0, 0, 0, 0, 0, 0])


def test_goal_value_and_obstacle_value(solved: tuple[np.ndarray, np.ndarray, int]) -> None:
    values, _, iterations = solved
    assert 300 <= iterations <= 310  # the study measured 305-307
    goal0 = state_index(3, 1, 6, 0)
    assert values[0, goal0] == pytest.approx(2500.0, abs=0.02)  # 100 / (1 - 0.96), truncated
    assert values[0, state_index(1, 2, 0, 0)] == 0.0  # inside goal 1's cell


def _evaluate_policy(nxt: np.ndarray, rew: np.ndarray, policy: np.ndarray, gamma: float,
                     sweeps: int = 1500) -> np.ndarray:
    goals, states = np.indices(policy.shape)
    next_pi = nxt[goals, policy, states]
    reward_pi = rew[goals, policy, states]
    v = np.zeros(policy.shape)
    for _ in range(sweeps):  # gamma^1500 * 2500 < 1e-20
        v = reward_pi + gamma * v[goals, next_pi]
    return v


def test_greedy_policy_is_optimal(transitions: mdp.GoalTransitions,
                                  solved: tuple[np.ndarray, np.ndarray, int]) -> None:
    values, q, iterations = solved
    rewards = transitions.rewards()
    policy = mdp.greedy_policy(q)
    goals, states = np.indices(policy.shape)
    # Bellman residual of the returned V under its greedy policy: since V = max Q(V_prev) it is
    # gamma * (V - V_prev) at the next state, bounded by gamma * max |V - V_prev|.
    previous = mdp.value_iteration(transitions.next_state, rewards, max_iterations=iterations - 1)[0]
    last_change = np.abs(values - previous).max()
    assert last_change < 1e-3
    next_pi = transitions.next_state[goals, policy, states]
    backed_up = rewards[goals, policy, states] + 0.96 * values[goals, next_pi]
    assert np.abs(backed_up - values).max() <= 0.96 * last_change + 1e-9
    # The greedy policy's own value equals the optimal value (VI run to a far tighter tolerance).
    optimal = mdp.value_iteration(transitions.next_state, rewards, span_epsilon=1e-12)[0]
    np.testing.assert_allclose(_evaluate_policy(transitions.next_state, rewards, policy, 0.96), optimal,
                               atol=1e-6)
    # solve_layout returns exactly the greedy policy of the span rule's Q, from V* (goal_fixed_point)
    layout = mdp.solve_layout(GOAL_CELLS, GOAL_HEADINGS)
    np.testing.assert_array_equal(layout.policy, policy)
    np.testing.assert_allclose(layout.values, optimal, rtol=0, atol=1e-9)
    assert layout.iterations < 40 < iterations


def test_ties_break_by_action_order(solved: tuple[np.ndarray, np.ndarray, int]) -> None:
    _, q, _ = solved
    policy = mdp.greedy_policy(q)
    gi, gj = GOAL_CELLS[0]
    gh = int(GOAL_HEADINGS[0])
    # In the goal's cell, theta mode, heading opposite the goal's: four turns either way tie.
    opposite = state_index(gi, gj, (gh + 4) % N_HEADINGS, 2)
    assert q[0, opposite, MOVE_P] == pytest.approx(q[0, opposite, MOVE_N], rel=1e-12)
    assert policy[0, opposite] == MOVE_P
    # Three turns clockwise (move_p, index - 1) beat five anticlockwise, and vice versa.
    assert policy[0, state_index(gi, gj, (gh + 3) % N_HEADINGS, 2)] == MOVE_P
    assert policy[0, state_index(gi, gj, (gh - 3) % N_HEADINGS, 2)] == MOVE_N
    # Explicit ties on a hand-made Q table, including last-bit differences.
    q_hand = np.array([[1.0, 1.0, 0.0, 0.0], [0.0, 2.0, 2.0 + 1e-13, 1.0], [0.0, 0.0, 0.0, 5.0]])
    np.testing.assert_array_equal(mdp.greedy_policy(q_hand), [0, 1, 3])


def test_action_likelihood() -> None:
    policy = np.array([[0, 3, 2], [1, 1, 0]])
    p = human_actions.action_likelihood(policy, 0.1)
    assert p.shape == (2, 3, 4)
    np.testing.assert_allclose(p.sum(axis=-1), 1.0)
    assert p[0, 1, 3] == pytest.approx(0.925) and p[0, 1, 0] == pytest.approx(0.025)
    np.testing.assert_array_equal(p.argmax(axis=-1), policy)
    with pytest.raises(ValueError):
        human_actions.action_likelihood(policy, 1.5)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_actions=st.integers(1, 6),
       shape=st.sampled_from([(0,), (5,), (2, 7), (3, 2, 4)]),
       epsilon=st.one_of(st.sampled_from([0.0, 0.1, 1.0, 1 / 3]), st.floats(0.0, 1.0)))
@example(seed=1, n_actions=5, shape=(2, 7), epsilon=0.1)  # 0.1 / 5 is not 0.1 * (1 / 5)
def test_action_likelihood_is_eq1_on_every_one_hot_row_bit_for_bit(seed: int, n_actions: int,
                                                                    shape: tuple[int, ...],
                                                                    epsilon: float) -> None:
    # Eq. 1 written out on the whole one-hot table; the function gathers the A rows it can take
    policy = np.random.default_rng(seed).integers(0, n_actions, size=shape)
    onehot = (policy[..., None] == np.arange(n_actions)).astype(float)
    expected = (1.0 - epsilon) * onehot + epsilon / n_actions
    got = human_actions.action_likelihood(policy, epsilon, n_actions)
    assert got.shape == expected.shape and got.tobytes() == expected.tobytes()


def test_default_epsilon_is_the_papers() -> None:
    # DESIGN 2.3: epsilon = 0.1, so 0.925 for the optimal action and 0.025 for each other; the
    # config's default [model] epsilon reads the same constant
    p = human_actions.action_likelihood(np.array([[2]]))
    np.testing.assert_allclose(p[0, 0], [0.025, 0.025, 0.925, 0.025], rtol=0, atol=1e-15)
    assert ExperimentConfig().model.epsilon == 0.1


def test_solve_layout_human_model_matches_policy() -> None:
    layout = mdp.solve_layout(GOAL_CELLS[:3], GOAL_HEADINGS[:3], gamma=0.9, epsilon=0.2)
    assert layout.p_a_given_sg.shape == (3, N_STATES, 4)
    expected = 0.8 * np.eye(4)[layout.policy] + 0.05
    np.testing.assert_allclose(layout.p_a_given_sg, expected)
    assert math.isfinite(layout.values.max())


def test_distinct_action_rows_rebuild_the_table_and_its_modes() -> None:
    layout = mdp.solve_layout(GOAL_CELLS[:3], GOAL_HEADINGS[:3], gamma=0.9, epsilon=0.2)
    actions = layout.actions
    assert actions.table is layout.p_a_given_sg
    # every (goal, state) row, its bytes included, is its pair's row; the pair's mode is the state's
    assert actions.rows[actions.index].tobytes() == layout.p_a_given_sg.tobytes()
    np.testing.assert_array_equal(actions.row_modes[actions.index], np.broadcast_to(np.arange(N_STATES) % 3,
                                                                                     actions.index.shape))
    # epsilon-greedy: one row per (mode, greedy action), no two pairs alike
    pairs = {(int(m), tuple(row)) for m, row in zip(actions.row_modes, actions.rows.tolist(), strict=True)}
    assert len(pairs) == len(actions.rows) <= 3 * 4
    assert len(actions.rows) == len({(s % 3, int(a)) for (_, s), a in np.ndenumerate(layout.policy)})


def test_distinct_action_rows_keep_rows_apart_by_bytes_and_by_mode() -> None:
    table = np.full((2, 6, 4), 0.25)
    table[1, 2] = [0.5, 0.5, 0.0, -0.0]  # the same values as row (0, 2) below but another sign of zero
    table[0, 2] = [0.5, 0.5, 0.0, 0.0]
    actions = human_actions.DistinctActionRows.of(table, modes=np.array([0, 0, 1, 1, 2, 2]))
    # (mode 0, uniform), (mode 1, uniform), (mode 2, uniform), two mode-1 rows of (0.5, 0.5, 0, +-0)
    assert len(actions.rows) == 5
    assert actions.index[0, 2] != actions.index[1, 2] and actions.index[0, 0] != actions.index[0, 2]
    assert actions.rows[actions.index].tobytes() == table.tobytes()


def test_distinct_action_rows_name_the_first_bad_row_in_table_order() -> None:
    table = np.full((2, 6, 4), 0.25)
    table[1, 0] = [-0.5, 0.5, 0.5, 0.5]  # sorts before every other row (mode 0, a negative entry)
    table[0, 4] = [0.9, 0.9, 0.0, 0.0]  # but this one comes first in the table
    with pytest.raises(ProbabilityTableError, match=r"p\(a \| s, g\): row \(goal 0, state 4\) = \[0\.9"):
        human_actions.DistinctActionRows.of(table)
    table[0, 4] = np.nan
    with pytest.raises(ProbabilityTableError, match=r"my table: row \(goal 0, state 4\)"):
        human_actions.DistinctActionRows.of(table, name="my table")
    with pytest.raises(ProbabilityTableError, match="shape"):
        human_actions.DistinctActionRows.of(np.full((2, 6, 3), 1 / 3))
    with pytest.raises(ValueError, match="modes"):
        human_actions.DistinctActionRows.of(np.full((2, 6, 4), 0.25), modes=np.zeros(5))


def test_value_iteration_rejects_bad_input() -> None:
    nxt, rew = corridor()
    with pytest.raises(ValueError):
        mdp.value_iteration(nxt, rew[:, :1])
    with pytest.raises(ValueError):
        mdp.value_iteration(nxt, rew, gamma=1.0)
    bad = nxt.copy()
    bad[0, 0, 1] = 6
    with pytest.raises(ValueError, match="indices"):
        mdp.value_iteration(bad, rew)


# --- the fixed point V* and the span rule's policy ----------------------------------------------

def _span_rule_policy(goal_cells: np.ndarray, goal_headings: np.ndarray,
                      rewards: mdp.MDPRewards | None = None, gamma: float = 0.96) -> np.ndarray:
    tr = mdp.build_transitions(goal_cells, goal_headings)
    return mdp.greedy_policy(mdp.value_iteration(tr.next_state, tr.rewards(rewards), gamma=gamma)[1])


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(CORNERS), st.integers(1, 4), st.integers(0, 2))
def test_solve_layout_has_the_span_rules_policy(seed: int, corner: str, n_goals: int, mode: int) -> None:
    # goal_fixed_point's argument, checked where the study draws its layouts (3,000 more drawn
    # offline agreed): the policy from V* is the policy of value iteration to the span rule
    layout = sample_layout(np.random.default_rng(seed), corner, n_goals, mode)
    solved = mdp.solve_layout(layout.goal_cells, layout.goal_headings)
    np.testing.assert_array_equal(solved.policy, _span_rule_policy(layout.goal_cells, layout.goal_headings))


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 4), st.sampled_from([0.9, 0.95, 0.97, 0.99]),
       st.sampled_from([0.0, -1.0, -10.0, -25.0]), st.sampled_from([0.0, -10.0, -100.0, -250.0]),
       st.sampled_from([0.0, -100.0, -400.0]), st.sampled_from([1.0, 50.0, 100.0, 400.0]))
def test_the_span_rules_policy_under_other_rewards_and_discounts(
        seed: int, n_goals: int, gamma: float, move: float, mode_switch: float, bump: float,
        goal: float) -> None:
    # a sweep may set the model's rewards and discount: wherever goal_fixed_point answers, its
    # policy is still the span rule's (2,000 such layouts agreed offline)
    layout = sample_layout(np.random.default_rng(seed), CORNERS[seed % 4], n_goals, seed % 3)
    rewards = mdp.MDPRewards(move=move, mode_switch=mode_switch, bump=bump, goal=goal)
    transitions = mdp.build_transitions(layout.goal_cells, layout.goal_headings)
    result = mdp.goal_fixed_point(transitions, rewards, gamma)
    if result is not None:
        expected = _span_rule_policy(layout.goal_cells, layout.goal_headings, rewards, gamma)
        np.testing.assert_array_equal(mdp.greedy_policy(result[1]), expected)


@pytest.mark.parametrize("gamma", [0.9, 0.95, 0.99])
@pytest.mark.parametrize("rewards", [
    mdp.MDPRewards(move=-1.0, mode_switch=-10.0, bump=-10.0),
    mdp.MDPRewards(move=0.0, mode_switch=0.0, bump=0.0, goal=1.0),
    mdp.MDPRewards(goal=400.0, bump=-400.0, inside_obstacle=3.0),
])
def test_goal_fixed_point_answers_for_other_rewards_and_discounts(
        transitions: mdp.GoalTransitions, rewards: mdp.MDPRewards, gamma: float) -> None:
    result = mdp.goal_fixed_point(transitions, rewards, gamma)
    assert result is not None
    np.testing.assert_array_equal(mdp.greedy_policy(result[1]),
                                  _span_rule_policy(GOAL_CELLS, GOAL_HEADINGS, rewards, gamma))


def test_goal_fixed_point_is_the_bellman_fixed_point(transitions: mdp.GoalTransitions,
                                                     solved: tuple[np.ndarray, np.ndarray, int]) -> None:
    result = mdp.goal_fixed_point(transitions)
    assert result is not None
    values, q, sweeps = result
    assert sweeps < 40
    # one more backup changes no bit, and V is the maximum of the returned Q
    rewards = transitions.rewards()
    goals = np.indices(transitions.next_state.shape)[0]
    backed_up = (rewards + 0.96 * values[goals, transitions.next_state]).max(axis=1)
    np.testing.assert_array_equal(backed_up, values)
    np.testing.assert_array_equal(values, q.max(axis=-1))
    # V*: value iteration to a far tighter tolerance, and the greedy policy's own value
    optimal = mdp.value_iteration(transitions.next_state, rewards, span_epsilon=1e-12)[0]
    np.testing.assert_allclose(values, optimal, rtol=0, atol=1e-9)
    policy = mdp.greedy_policy(q)
    np.testing.assert_allclose(_evaluate_policy(transitions.next_state, rewards, policy, 0.96), values,
                               rtol=0, atol=1e-9)
    # the span rule's V is V* less the goal's reward after its last sweep, c_K = 100 g^K / (1 - g)
    span_values, _, k = solved
    reachable = values > 1.0
    np.testing.assert_allclose(values[reachable] - span_values[reachable], 100 * 0.96 ** k / 0.04,
                               rtol=1e-6)


def test_self_loop_value_is_the_float_fixed_point() -> None:
    for reward, gamma in ((100.0, 0.96), (100.0, 0.9), (-3.0, 0.5), (0.0, 0.96)):
        value = mdp.self_loop_value(reward, gamma)
        assert value is not None
        assert reward + gamma * value == value
        assert value == pytest.approx(reward / (1 - gamma), rel=1e-12)


# Cell (0, 0) is walled in by goals at (1, 0) and (0, 1) and the grid's corner: its states cannot
# reach goal 2 (they turn in place for ever), so the argument does not cover them.
WALLED_IN = (np.array([[1, 0], [0, 1], [6, 6]]), np.array([0, 3, 5]))


@pytest.mark.parametrize(("goal_cells", "goal_headings", "rewards", "why"), [
    (*WALLED_IN, None, "a walled-in cell"),
    (GOAL_CELLS, GOAL_HEADINGS, mdp.MDPRewards(bump=1.0), "a bump that pays"),
    (GOAL_CELLS, GOAL_HEADINGS, mdp.MDPRewards(goal=-1.0), "a goal that costs"),
    # a fixed point, but far states are worth less than 0 (about -62)
    (GOAL_CELLS, GOAL_HEADINGS, mdp.MDPRewards(goal=10.0, mode_switch=-10.0), "far states below 0"),
])
def test_goal_fixed_point_declines_where_its_argument_does_not_hold(
        goal_cells: np.ndarray, goal_headings: np.ndarray, rewards: mdp.MDPRewards | None, why: str) -> None:
    transitions = mdp.build_transitions(goal_cells, goal_headings)
    assert mdp.goal_fixed_point(transitions, rewards) is None, why
    # solve_layout then runs the span rule itself: its values, sweeps and policy
    values, q, iterations = mdp.value_iteration(transitions.next_state, transitions.rewards(rewards))
    layout = mdp.solve_layout(goal_cells, goal_headings, rewards)
    np.testing.assert_array_equal(layout.values, values)
    np.testing.assert_array_equal(layout.policy, mdp.greedy_policy(q))
    assert layout.iterations == iterations


def test_goal_fixed_point_gives_up_after_max_sweeps(transitions: mdp.GoalTransitions) -> None:
    sweeps = mdp.goal_fixed_point(transitions)[2]  # type: ignore[index]
    assert mdp.goal_fixed_point(transitions, max_sweeps=sweeps - 1) is None
    assert mdp.goal_fixed_point(transitions, max_sweeps=sweeps) is not None


def test_the_paper_studys_layouts_get_the_span_rules_policy() -> None:
    config = load_experiment("paper")
    layouts = build_layouts(config, config.experiment.seed)
    solved = solve_layouts(config, layouts)
    # 47 from V*; one walls cell (0, 7) in with goals at (0, 8), (1, 7) and (0, 6): the span rule
    assert sorted(item.iterations for item in solved)[-2:] == [26, 307]
    for item, layout in zip(layouts, solved, strict=True):
        policy = _span_rule_policy(item.layout.goal_cells, item.layout.goal_headings)
        np.testing.assert_array_equal(layout.policy, policy)


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 4), st.integers(1, 30), st.integers(0, 2**32 - 1),
       st.sampled_from([0.0, 0.1, 0.25, 1.0, 1 / 3]), st.booleans(), st.booleans())
def test_distinct_rows_of_a_policy_are_those_of_its_table(n_goals: int, n_states: int, seed: int,
                                                          epsilon: float, one_action: bool,
                                                          grid_modes: bool) -> None:
    rng = np.random.default_rng(seed)
    policy = (np.full((n_goals, n_states), int(rng.integers(4))) if one_action
              else rng.integers(0, 4, size=(n_goals, n_states)))
    modes = None if grid_modes else rng.integers(0, 3, size=n_states)
    table = human_actions.action_likelihood(policy, epsilon)
    expected = human_actions.DistinctActionRows.of(table, modes=modes)
    got = human_actions.DistinctActionRows.of_policy(policy, epsilon, modes=modes)
    assert got.table.tobytes() == expected.table.tobytes()
    assert got.rows.tobytes() == expected.rows.tobytes()  # the same rows in the same order
    np.testing.assert_array_equal(got.row_modes, expected.row_modes)
    np.testing.assert_array_equal(got.index, expected.index)
    assert got.index.dtype == expected.index.dtype and got.row_modes.dtype == expected.row_modes.dtype


def test_solved_layout_keeps_distinct_rows_of_its_own_table() -> None:
    layout = mdp.solve_layout(GOAL_CELLS, GOAL_HEADINGS)
    expected = human_actions.DistinctActionRows.of(layout.p_a_given_sg)
    assert layout.actions.table is layout.p_a_given_sg
    assert layout.actions.rows.tobytes() == expected.rows.tobytes()
    np.testing.assert_array_equal(layout.actions.index, expected.index)
    # rows of another table are not taken: the layout's own are found
    other = human_actions.DistinctActionRows.of_policy(np.zeros_like(layout.policy), 0.1)
    rebuilt = mdp.SolvedLayout(layout.policy, layout.values, layout.p_a_given_sg, layout.iterations,
                               known_actions=other)
    np.testing.assert_array_equal(rebuilt.actions.index, expected.index)
