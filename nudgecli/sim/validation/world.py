"""The worlds of the validation, built from the model's own functions.

Two worlds (:attr:`~nudgecli.sim.validation.readings.Reading.world`):

- ``two-mode``: the paper's ``|S| = 200``: a ``W x H`` grid (10 x 10 by default) and the modes
  x (Horizontal) and y (Vertical), so ``|S| = 2 W H``; the state ``(i, j, m)`` has the flat
  index ``(i H + j) 2 + m``. Its goal MDPs are the study's (DESIGN 2.3) with the model's
  outcome kinds and rewards (:class:`nudgecli.model.mdp.GoalTransitions`,
  :class:`~nudgecli.model.mdp.MDPRewards`): a move changes the active coordinate by one cell,
  a move off the grid or into another goal's cell bumps (the state is unchanged), the step into
  the goal enters it, the goal absorbs, other goals' cells are self-loops. The model's
  ``model/mdp.py`` builds the same rules for the fixed 2400-state grid only, so the table is
  built here; solving, the human model and the likelihood are the model's
  (:func:`~nudgecli.model.mdp.value_iteration`, :func:`~nudgecli.model.mdp.greedy_policy`,
  :func:`~nudgecli.model.human_actions.action_likelihood`,
  :func:`~nudgecli.model.disambiguation.observation_likelihood`). The neighbourhood is the
  3 x 3 window of cells around the query, without goal cells, in both modes.
- ``three-mode``: the study's world, entirely the model's: goals on random distinct cells
  with random headings, :func:`~nudgecli.model.mdp.solve_layout`, the likelihood, and the
  candidates of :func:`~nudgecli.model.candidates.window_candidates` (3 x 3 cells, all
  three modes, the current heading).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nudgecli.model.candidates import window_candidates
from nudgecli.model.disambiguation import observation_likelihood
from nudgecli.model.human_actions import action_likelihood
from nudgecli.model.interface import (
    MOVE_N,
    MOVE_P,
    N_ACTIONS,
    TO_MODE_L,
    TO_MODE_R,
    default_distortion_table,
    default_mapping_table,
)
from nudgecli.model.mdp import (
    OUTCOME_BUMP,
    OUTCOME_GOAL_ABSORBING,
    OUTCOME_GOAL_ENTRY,
    OUTCOME_INSIDE_OBSTACLE,
    OUTCOME_MODE_SWITCH,
    OUTCOME_MOVE,
    GoalTransitions,
    MDPRewards,
    greedy_policy,
    solve_layout,
    value_iteration,
)
from nudgecli.model.world import N_CELLS_X, N_CELLS_Y, N_HEADINGS, N_MODES, all_state_coordinates, state_index

#: Modes of the two-mode world: x (Horizontal) and y (Vertical).
N_VALIDATION_MODES = 2


@dataclass(frozen=True)
class ValidationWorld:
    """One random world of the validation.

    Attributes
    ----------
    kind
        ``"two-mode"`` or ``"three-mode"``.
    width, height
        Grid size ``W x H`` in cells.
    goal_cells
        ``(G, 2)`` goal cells ``(i, j)``.
    cells
        ``(S, 2)`` cell ``(i, j)`` of every state.
    modes
        ``(S,)`` mode of every state.
    on_goal
        ``(S,)`` whether the state lies on a goal cell.
    policy
        ``(G, S, A)`` ``p(a | s, g)``, epsilon-greedy around the optimal policy.
    likelihood
        ``(G, S, F)`` ``p(phi_m | g, s)``.
    """

    kind: str
    width: int
    height: int
    goal_cells: np.ndarray
    cells: np.ndarray
    modes: np.ndarray
    on_goal: np.ndarray
    policy: np.ndarray
    likelihood: np.ndarray

    @property
    def n_goals(self) -> int:
        return int(self.goal_cells.shape[0])

    @property
    def n_states(self) -> int:
        return int(self.modes.shape[0])


def world_states(width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Cells ``(S, 2)`` and modes ``(S,)`` of the two-mode world's flat states ``(i H + j) 2 + m``."""
    i, j, m = np.unravel_index(np.arange(width * height * N_VALIDATION_MODES),
                               (width, height, N_VALIDATION_MODES))
    return np.column_stack([i, j]), np.asarray(m)


def goal_transitions(width: int, height: int, goal_cells: np.ndarray) -> GoalTransitions:
    """The two-mode world's goal MDPs in the model's form: next state and outcome kind, ``(G, A, S)``.

    Parameters
    ----------
    width, height
        Grid size.
    goal_cells
        ``(G, 2)`` distinct goal cells.

    Returns
    -------
    GoalTransitions
        ``next_state`` and ``outcome`` (the ``OUTCOME_*`` codes of :mod:`nudgecli.model.mdp`).
    """
    cells, modes = world_states(width, height)
    n_states = cells.shape[0]
    rows = np.arange(n_states)
    goals = np.asarray(goal_cells, dtype=int)
    cell_id = cells[:, 0] * height + cells[:, 1]  # (S,)
    goal_id = goals[:, 0] * height + goals[:, 1]  # (G,)

    next_state = np.empty((goals.shape[0], N_ACTIONS, n_states), dtype=np.int64)
    outcome = np.empty((goals.shape[0], N_ACTIONS, n_states), dtype=np.int8)
    for action, step in ((MOVE_P, 1), (MOVE_N, -1)):
        target = cells.copy()
        target[rows, modes] += step  # mode 0 moves i, mode 1 moves j
        inside = (target[:, 0] >= 0) & (target[:, 0] < width) & (target[:, 1] >= 0) & (target[:, 1] < height)
        target_cell = np.where(inside, target[:, 0] * height + target[:, 1], -1)  # (S,)
        enters = target_cell[None, :] == goal_id[:, None]  # (G, S): into this goal's cell
        into_other = np.isin(target_cell, goal_id)[None, :] & ~enters
        bump = ~inside[None, :] | into_other
        moved = target_cell * N_VALIDATION_MODES + modes
        next_state[:, action] = np.where(bump, rows[None, :], moved[None, :])
        outcome[:, action] = np.where(bump, OUTCOME_BUMP, np.where(enters, OUTCOME_GOAL_ENTRY, OUTCOME_MOVE))
    for action, step in ((TO_MODE_R, 1), (TO_MODE_L, -1)):
        next_state[:, action] = (cell_id * N_VALIDATION_MODES + (modes + step) % N_VALIDATION_MODES)[None, :]
        outcome[:, action] = OUTCOME_MODE_SWITCH
    # The goal absorbs; other goals' cells are self-loops (the model's two overrides).
    own = cell_id[None, :] == goal_id[:, None]  # (G, S)
    other = np.isin(cell_id, goal_id)[None, :] & ~own
    for mask, kind in ((own, OUTCOME_GOAL_ABSORBING), (other, OUTCOME_INSIDE_OBSTACLE)):
        next_state = np.where(mask[:, None, :], rows[None, None, :], next_state)
        outcome = np.where(mask[:, None, :], np.int8(kind), outcome)
    return GoalTransitions(next_state=next_state, outcome=outcome)


def solve_goal_policies(transitions: GoalTransitions, epsilon: float,
                        rewards: MDPRewards | None = None) -> np.ndarray:
    """``(G, S, A)`` epsilon-greedy ``p(a | s, g)`` of the goal MDPs, by the model's solver.

    :func:`~nudgecli.model.mdp.value_iteration` (pymdptoolbox's span rule, the model's discount),
    :func:`~nudgecli.model.mdp.greedy_policy` (ties to the first action: move_p, move_n,
    to_mode_r, to_mode_l) and :func:`~nudgecli.model.human_actions.action_likelihood`.
    """
    _, q_values, _ = value_iteration(transitions.next_state, transitions.rewards(rewards))
    return action_likelihood(greedy_policy(q_values), epsilon)


def sample_world(rng: np.random.Generator, n_goals: int, width: int, height: int, epsilon: float = 0.1,
                 mapping: np.ndarray | None = None, distortion: np.ndarray | None = None) -> ValidationWorld:
    """Draw one two-mode world: ``n_goals`` distinct random goal cells, their policies, the likelihood.

    Parameters
    ----------
    rng
        Source of randomness (only the goal cells are drawn).
    n_goals
        ``|G|``.
    width, height
        Grid size.
    epsilon
        Epsilon of the human model.
    mapping, distortion
        ``(M, A, F)`` and ``(F, F)`` tables (the defaults, 0.85 / 0.05, when ``None``); only the
        first two modes of ``mapping`` are used.
    """
    mapping = default_mapping_table() if mapping is None else mapping
    distortion = default_distortion_table() if distortion is None else distortion
    flat = rng.choice(width * height, size=n_goals, replace=False)
    goal_cells = np.column_stack([flat // height, flat % height])
    cells, modes = world_states(width, height)
    policy = solve_goal_policies(goal_transitions(width, height, goal_cells), epsilon)
    likelihood = observation_likelihood(policy, mapping, distortion, modes=modes)
    on_goal = np.isin(cells[:, 0] * height + cells[:, 1], flat)
    return ValidationWorld(kind="two-mode", width=width, height=height, goal_cells=goal_cells, cells=cells,
                           modes=modes, on_goal=on_goal, policy=policy, likelihood=likelihood)


def sample_study_world(rng: np.random.Generator, n_goals: int, epsilon: float, mapping: np.ndarray,
                       distortion: np.ndarray) -> ValidationWorld:
    """Draw one three-mode world (the study's 2400 states): goal cells and headings, then the model.

    Parameters
    ----------
    rng
        Source of randomness (goal cells, then goal headings).
    n_goals
        ``|G|`` (at most half of the 100 cells).
    epsilon
        Epsilon of the human model.
    mapping, distortion
        ``(3, A, F)`` and ``(F, F)`` tables.
    """
    flat = rng.choice(N_CELLS_X * N_CELLS_Y, size=n_goals, replace=False)
    goal_cells = np.column_stack([flat // N_CELLS_Y, flat % N_CELLS_Y])
    headings = rng.integers(0, N_HEADINGS, size=n_goals)
    solved = solve_layout(goal_cells, headings, epsilon=epsilon)
    likelihood = observation_likelihood(solved.p_a_given_sg, mapping, distortion)
    coords = all_state_coordinates()
    cells, modes = coords[:, :2], coords[:, 3]
    on_goal = np.isin(cells[:, 0] * N_CELLS_Y + cells[:, 1], flat)
    return ValidationWorld(kind="three-mode", width=N_CELLS_X, height=N_CELLS_Y, goal_cells=goal_cells,
                           cells=cells, modes=modes, on_goal=on_goal, policy=solved.p_a_given_sg,
                           likelihood=likelihood)


def neighbourhoods(world: ValidationWorld, queries: np.ndarray, window: int = 1) -> np.ndarray:
    """The candidate states of each query of the two-mode world: the window of cells around it,
    minus goal cells, both modes.

    Parameters
    ----------
    world
        A two-mode world.
    queries
        ``(Q,)`` query states.
    window
        Half-width in cells.

    Returns
    -------
    np.ndarray
        ``(Q, C)`` candidate state indices in increasing order, padded with ``-1``;
        ``C = 2 (2 window + 1)^2``.
    """
    offsets = np.arange(-window, window + 1)
    di, dj = np.meshgrid(offsets, offsets, indexing="ij")
    cell = world.cells[queries]  # (Q, 2)
    ci = cell[:, 0, None] + di.ravel()[None]  # (Q, K)
    cj = cell[:, 1, None] + dj.ravel()[None]
    inside = (ci >= 0) & (ci < world.width) & (cj >= 0) & (cj < world.height)
    cell_id = np.where(inside, ci * world.height + cj, 0)
    goal_id = world.goal_cells[:, 0] * world.height + world.goal_cells[:, 1]
    valid = inside & ~np.isin(cell_id, goal_id)
    states = cell_id[..., None] * N_VALIDATION_MODES + np.arange(N_VALIDATION_MODES)  # (Q, K, M)
    states = np.where(valid[..., None], states, -1).reshape(len(queries), -1)
    # Offsets are enumerated in (di, dj) order, so valid entries are already increasing.
    order = np.argsort(states < 0, axis=1, kind="stable")
    return np.take_along_axis(states, order, axis=1)


def study_queries(rng: np.random.Generator, world: ValidationWorld, window: int = 1) -> tuple[np.ndarray,
                                                                                             np.ndarray]:
    """Queries of a three-mode world and their candidates (the model's window).

    Every cell off the goals is queried once, at a random heading and a random mode.

    Parameters
    ----------
    rng
        Source of randomness (headings, then modes).
    world
        A three-mode world.
    window
        Half-width in cells (the model's window side is ``2 window + 1``).

    Returns
    -------
    queries : np.ndarray
        ``(Q,)`` query states.
    candidates : np.ndarray
        ``(Q, C)`` the candidates of :func:`~nudgecli.model.candidates.window_candidates`,
        in its order, padded with ``-1``; ``C = 3 (2 window + 1)^2``.
    """
    free = np.flatnonzero(~np.isin(np.arange(N_CELLS_X * N_CELLS_Y),
                                   world.goal_cells[:, 0] * N_CELLS_Y + world.goal_cells[:, 1]))
    headings = rng.integers(0, N_HEADINGS, size=free.size)
    modes = rng.integers(0, N_MODES, size=free.size)
    queries = np.asarray(state_index(free // N_CELLS_Y, free % N_CELLS_Y, headings, modes), dtype=np.int64)
    side = 2 * window + 1
    out = np.full((free.size, N_MODES * side * side), -1, dtype=np.int64)
    for q, state in enumerate(queries):
        states = window_candidates(int(state), world.goal_cells, side).states
        out[q, :states.size] = states
    return queries, out


__all__ = ["N_VALIDATION_MODES", "ValidationWorld", "goal_transitions", "neighbourhoods",
           "sample_study_world", "sample_world", "solve_goal_policies", "study_queries", "world_states"]
