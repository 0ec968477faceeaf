"""Goal MDPs over the 2400 discrete states, their values and policies, and a layout's solution.

One deterministic MDP per goal (DESIGN 2.3, study notes section 3):

- ``move_p`` / ``move_n`` change the coordinate of the active mode by one cell (x, y) or one
  heading index (theta, where ``move_p`` is clockwise, i.e. heading index ``- 1``, wrapping mod 8);
- ``to_mode_r`` / ``to_mode_l`` cycle the mode ``+1`` / ``-1`` (wrapping);
- a move that would leave the grid or enter another goal's ``(x, y)`` cell leaves the state
  unchanged and costs the bump reward;
- the goal pose (the goal's cell and heading, any mode) is absorbing and pays the goal reward on
  every step, as does the move that completes the pose;
- states inside another goal's cell (the robot can physically drive there, the MDP treats the
  cell as an obstacle) self-loop with reward 0 under every action, as in the study. Their
  Q-values therefore all tie and their greedy action is ``move_p``.

Transitions are stored as a next-state index table ``(G, A, S)`` and an outcome-kind table of
the same shape, so value iteration is a gather per sweep rather than a matrix product, and all
goals of a layout are solved together in one ``(G, S)`` computation. The study's rule is value
iteration to a span tolerance (:func:`value_iteration`); :func:`solve_layout` gets the same greedy
policy from the exact fixed point ``V*`` (:func:`goal_fixed_point`) wherever the two provably
agree, in about 20 sweeps instead of 305. The human's ε-greedy action model built on the policy
is :mod:`nudgecli.model.human_actions`.
"""

from __future__ import annotations

from dataclasses import InitVar, dataclass, field
from functools import lru_cache

import numpy as np

from nudgecli.model.human_actions import DEFAULT_HUMAN_EPSILON, DistinctActionRows
from nudgecli.model.interface import MOVE_N, MOVE_P, N_ACTIONS, TO_MODE_L, TO_MODE_R
from nudgecli.model.ties import DEFAULT_TIE_RTOL, first_argmax
from nudgecli.model.world import (
    N_CELLS_X,
    N_CELLS_Y,
    N_HEADINGS,
    N_MODES,
    N_STATES,
    all_state_coordinates,
    state_index,
)

DEFAULT_GAMMA = 0.96
#: pymdptoolbox's default ``epsilon``; VI stops when ``span(V_{k+1} - V_k) < eps (1 - gamma) / gamma``.
DEFAULT_SPAN_EPSILON = 0.01
#: Relative tolerance under which two Q-values count as tied in :func:`greedy_policy`.

# Outcome kinds of a (state, action) pair; each kind has one reward (see MDPRewards.by_kind).
OUTCOME_MOVE = 0  # a valid move to a non-goal state
OUTCOME_MODE_SWITCH = 1  # a mode change
OUTCOME_BUMP = 2  # a move into a wall or another goal's cell: stay
OUTCOME_GOAL_ENTRY = 3  # a move that completes the goal pose
OUTCOME_GOAL_ABSORBING = 4  # any action at the goal pose: stay
OUTCOME_INSIDE_OBSTACLE = 5  # any action inside another goal's cell: stay
OUTCOME_NAMES = ("move", "mode_switch", "bump", "goal_entry", "goal_absorbing", "inside_obstacle")


@dataclass(frozen=True)
class MDPRewards:
    """Rewards of the goal MDPs (study values by default).

    Attributes
    ----------
    move
        A valid ``move_p`` / ``move_n`` that does not complete the goal pose.
    mode_switch
        ``to_mode_r`` / ``to_mode_l``.
    bump
        A move into a wall or another goal's cell (the state does not change).
    goal
        Completing the goal pose, and every step spent in it (the goal is absorbing).
    inside_obstacle
        Every action of a state inside another goal's cell (a self-loop).
    """

    move: float = -10.0
    mode_switch: float = -100.0
    bump: float = -100.0
    goal: float = 100.0
    inside_obstacle: float = 0.0

    def by_kind(self) -> np.ndarray:
        """``(6,)`` reward of each outcome kind, indexed by the ``OUTCOME_*`` codes."""
        return np.array([self.move, self.mode_switch, self.bump, self.goal, self.goal,
                         self.inside_obstacle])


@dataclass(frozen=True)
class GoalTransitions:
    """Deterministic transitions of the goal MDPs of one layout.

    Attributes
    ----------
    next_state
        ``(G, A, S)`` int: the state reached from ``s`` by action ``a`` in goal ``g``'s MDP.
    outcome
        ``(G, A, S)`` int8: the ``OUTCOME_*`` kind of each transition.
    """

    next_state: np.ndarray
    outcome: np.ndarray

    def rewards(self, rewards: MDPRewards | None = None) -> np.ndarray:
        """``(G, A, S)`` reward of every transition under ``rewards`` (study values by default)."""
        return (rewards or MDPRewards()).by_kind()[self.outcome]


@dataclass(frozen=True)
class SolvedLayout:
    """The solved goal MDPs of one layout and the human action model derived from them.

    Attributes
    ----------
    policy
        ``(G, S)`` int greedy action per goal and state: the policy of value iteration's span rule.
    values
        ``(G, S)`` state values ``V``: ``V*`` where :func:`goal_fixed_point` applies, else the span
        rule's last sweep.
    p_a_given_sg
        ``(G, S, A)`` ε-greedy ``p(a | s, g)`` (Eq. 1).
    iterations
        Number of sweeps done (to the fixed point, or until the span criterion held).
    actions
        ``p_a_given_sg`` checked and as its distinct rows (derived; computed here once per layout,
        not once per participant's model of it).
    known_actions
        (Given at construction only.) Those rows where the caller has them already
        (:func:`solve_layout`: :meth:`DistinctActionRows.of_policy`); taken only when their table is
        ``p_a_given_sg`` itself.
    """

    policy: np.ndarray
    values: np.ndarray
    p_a_given_sg: np.ndarray
    iterations: int
    known_actions: InitVar[DistinctActionRows | None] = None
    actions: DistinctActionRows = field(init=False, repr=False, compare=False)

    def __post_init__(self, known_actions: DistinctActionRows | None) -> None:
        # ``known_actions``: the table's distinct rows where the caller has them (of the same table)
        if known_actions is None or known_actions.table is not self.p_a_given_sg:
            known_actions = DistinctActionRows.of(self.p_a_given_sg)
        object.__setattr__(self, "actions", known_actions)


def _validate_goals(goal_cells: np.ndarray, goal_headings: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    cells = np.asarray(goal_cells, dtype=int)
    headings = np.asarray(goal_headings, dtype=int)
    if cells.ndim != 2 or cells.shape[1] != 2 or cells.shape[0] == 0:
        raise ValueError(f"goal_cells must have shape (G, 2) with G >= 1, got {cells.shape}")
    if headings.shape != (cells.shape[0],):
        raise ValueError(f"goal_headings must have shape ({cells.shape[0]},), got {headings.shape}")
    if (np.any(cells[:, 0] < 0) or np.any(cells[:, 0] >= N_CELLS_X) or np.any(cells[:, 1] < 0)
            or np.any(cells[:, 1] >= N_CELLS_Y)):
        raise ValueError(f"goal cells must lie on the {N_CELLS_X} x {N_CELLS_Y} grid, got {cells.tolist()}")
    if np.any(headings < 0) or np.any(headings >= N_HEADINGS):
        raise ValueError(f"goal headings must be in 0..{N_HEADINGS - 1}, got {headings.tolist()}")
    if len({(int(i), int(j)) for i, j in cells}) != len(cells):
        # Another goal's cell is an obstacle, so two goals in one cell would make each
        # unreachable in the other's MDP.
        raise ValueError(f"two goals share a cell: {cells.tolist()}")
    return cells, headings


@lru_cache(maxsize=1)
def _open_grid() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The grid's transitions without goals, computed once (read-only arrays).

    Returns
    -------
    next_state, outcome
        ``(A, S)``: a move along the active coordinate (off the grid: a bump, the state stays),
        a mode switch cycles the mode.
    move_action, move_state, move_target_pose
        ``(2 S,)`` every move (``MOVE_P`` and ``MOVE_N`` from every state): its action, its state
        and the pose of its next state (``cell * N_HEADINGS + heading``, the mode left out: a goal
        pose holds in any mode), ordered by the cell of that next state (an off-grid bump's: its
        own), so the moves that end in one cell are consecutive.
    first_move
        ``(C + 1,)`` where each cell's moves start in that order: cell ``c``'s are
        ``first_move[c]:first_move[c + 1]``.
    """
    i, j, h, m = all_state_coordinates().T
    states = np.arange(N_STATES)
    next_state = np.empty((N_ACTIONS, N_STATES), dtype=np.int64)
    outcome = np.empty((N_ACTIONS, N_STATES), dtype=np.int8)
    # The move of each action along the active coordinate; theta's move_p is clockwise (h - 1).
    for action, step in ((MOVE_P, 1), (MOVE_N, -1)):
        ni = np.where(m == 0, i + step, i)
        nj = np.where(m == 1, j + step, j)
        nh = np.where(m == 2, (h - step) % N_HEADINGS, h)
        off_grid = (ni < 0) | (ni >= N_CELLS_X) | (nj < 0) | (nj >= N_CELLS_Y)
        next_state[action] = np.where(off_grid, states, state_index(np.where(off_grid, i, ni),
                                                                    np.where(off_grid, j, nj), nh, m))
        outcome[action] = np.where(off_grid, OUTCOME_BUMP, OUTCOME_MOVE)
    for action, step in ((TO_MODE_R, 1), (TO_MODE_L, -1)):
        next_state[action] = state_index(i, j, h, (m + step) % N_MODES)
        outcome[action] = OUTCOME_MODE_SWITCH
    # state_index's order, ((i * N_CELLS_Y + j) * N_HEADINGS + h) * N_MODES + m, without the mode
    target_pose = (next_state[[MOVE_P, MOVE_N]] // N_MODES).reshape(-1)
    by_cell = np.argsort(target_pose // N_HEADINGS, kind="stable")
    move_target_pose = target_pose[by_cell]
    first_move = np.searchsorted(move_target_pose // N_HEADINGS, np.arange(N_CELLS_X * N_CELLS_Y + 1))
    move_action = np.array([MOVE_P, MOVE_N])[by_cell // N_STATES]
    move_state = by_cell % N_STATES
    tables = (next_state, outcome, move_action, move_state, move_target_pose, first_move)
    for array in tables:
        array.setflags(write=False)
    return tables


def build_transitions(goal_cells: np.ndarray, goal_headings: np.ndarray) -> GoalTransitions:
    """The next-state and outcome tables of every goal's MDP.

    The open grid's tables (:func:`_open_grid`, computed once) with each goal's exceptions, which
    touch only the goals' cells and the moves into them (written where they are, not found by a
    pass over every state): a move that completes the goal pose enters the goal, a move into
    another goal's cell bumps, another goal's cell is an obstacle interior and the goal pose is
    absorbing (each rule overriding those before it).

    Parameters
    ----------
    goal_cells
        ``(G, 2)`` cell indices ``(i, j)`` of the goals (distinct cells).
    goal_headings
        ``(G,)`` heading indices of the goals.

    Returns
    -------
    GoalTransitions
        ``next_state`` and ``outcome``, both ``(G, A, S)``.
    """
    cells, headings = _validate_goals(goal_cells, goal_headings)
    n_goals = cells.shape[0]
    open_next, open_outcome, move_action, move_state, move_target_pose, first_move = _open_grid()
    flat_cells = (cells[:, 0] * N_CELLS_Y + cells[:, 1]).tolist()
    goal_poses = [cell * N_HEADINGS + int(h) for cell, h in zip(flat_cells, headings, strict=True)]
    # the moves that end in each goal's cell
    into = [slice(int(first_move[cell]), int(first_move[cell + 1])) for cell in flat_cells]
    cell_states = N_HEADINGS * N_MODES  # a cell's states are consecutive: cell * cell_states + ...
    next_state = np.repeat(open_next[None], n_goals, axis=0)
    outcome = np.repeat(open_outcome[None], n_goals, axis=0)
    for g in range(n_goals):
        nxt, kind = next_state[g], outcome[g]  # (A, S) views
        entering = into[g].start + np.flatnonzero(move_target_pose[into[g]] == goal_poses[g])
        kind[move_action[entering], move_state[entering]] = OUTCOME_GOAL_ENTRY
        others = [k for k in range(n_goals) if k != g]
        if others:
            bumped = np.concatenate([np.arange(into[k].start, into[k].stop) for k in others])
            actions, states = move_action[bumped], move_state[bumped]
            nxt[actions, states] = states
            kind[actions, states] = OUTCOME_BUMP
        for k in others:
            inside = slice(flat_cells[k] * cell_states, (flat_cells[k] + 1) * cell_states)
            nxt[:, inside] = np.arange(inside.start, inside.stop)
            kind[:, inside] = OUTCOME_INSIDE_OBSTACLE
        at_goal = slice(goal_poses[g] * N_MODES, (goal_poses[g] + 1) * N_MODES)
        nxt[:, at_goal] = np.arange(at_goal.start, at_goal.stop)
        kind[:, at_goal] = OUTCOME_GOAL_ABSORBING
    return GoalTransitions(next_state=next_state, outcome=outcome)


@dataclass(frozen=True)
class _BellmanSweep:
    """One Bellman backup of batched deterministic MDPs: ``Q = R + gamma V[next]``, ``V' = max_a Q``.

    The one owner of the sweep that :func:`value_iteration` and :func:`goal_fixed_point` repeat.
    """

    flat_next: np.ndarray  # (G * A * S,) gather indices into V.ravel(): goal g's states start at g * S
    reward: np.ndarray  # (G * A * S,)
    shape: tuple[int, int, int]  # (G, A, S)
    gamma: float

    @classmethod
    def of(cls, next_state: np.ndarray, reward: np.ndarray, gamma: float) -> _BellmanSweep:
        n_goals, n_actions, n_states = next_state.shape
        flat_next = (next_state + (np.arange(n_goals) * n_states)[:, None, None]).reshape(-1)
        return cls(flat_next, np.asarray(reward, dtype=float).reshape(-1), (n_goals, n_actions, n_states),
                   gamma)

    def __call__(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(Q (G, A, S), V' (G * S,))`` from the flat values ``V (G * S,)``."""
        # gamma * V[next] == (gamma * V)[next] elementwise, and scaling the G*S values before
        # the gather is A times less work than scaling the gathered G*A*S. The indices were checked
        # by the caller; mode="clip" skips numpy's per-element bounds error path (about 20% faster).
        # The array method and the ufunc's reduce are np.take's and ndarray.max's own work without
        # their Python wrappers (a sweep is a few tens of microseconds, run tens of times a layout).
        q_flat = (self.gamma * values).take(self.flat_next, mode="clip")
        q_flat += self.reward
        q = q_flat.reshape(self.shape)
        return q, np.maximum.reduce(q, axis=1).reshape(-1)


def value_iteration(next_state: np.ndarray, reward: np.ndarray, gamma: float = DEFAULT_GAMMA,
                    span_epsilon: float = DEFAULT_SPAN_EPSILON,
                    max_iterations: int = 100_000) -> tuple[np.ndarray, np.ndarray, int]:
    """Batched value iteration of deterministic MDPs, pymdptoolbox's stopping rule.

    Starting from ``V_0 = 0``, each sweep computes ``Q_k(g, s, a) = R(g, a, s) + gamma
    V_{k-1}(g, next(g, a, s))`` and ``V_k = max_a Q_k``, for all goals at once; it stops after the
    first sweep with ``span(V_k - V_{k-1}) < span_epsilon (1 - gamma) / gamma`` (the span taken
    over all goals and states together, so every goal gets at least the study's accuracy).

    Parameters
    ----------
    next_state
        ``(G, A, S)`` int next-state indices (any ``S``; the goal MDPs use 2400).
    reward
        ``(G, A, S)`` reward of each transition.
    gamma
        Discount factor in ``(0, 1)``.
    span_epsilon
        pymdptoolbox's ``epsilon``.
    max_iterations
        Safety cap on the number of sweeps.

    Returns
    -------
    V : np.ndarray
        ``(G, S)`` values after the last sweep.
    Q : np.ndarray
        ``(G, S, A)`` the Q-values of the last sweep (so ``V == Q.max(-1)`` exactly; the greedy
        policy of ``Q`` is the policy pymdptoolbox returns): a transposed view of the sweep's
        ``(G, A, S)`` array, not a copy (a maximum over its strided action axis runs along the
        states, 2-3 times faster than over the 4 contiguous values of each row).
    iterations : int
        Number of sweeps done.
    """
    nxt = np.asarray(next_state)
    rew = np.asarray(reward, dtype=float)
    if nxt.ndim != 3 or rew.shape != nxt.shape:
        raise ValueError(f"next_state and reward must both be (G, A, S); got {nxt.shape} and {rew.shape}")
    if not 0.0 < gamma < 1.0:
        raise ValueError(f"gamma must be in (0, 1), got {gamma}")
    n_goals, _, n_states = nxt.shape
    if nxt.size and (nxt.min() < 0 or nxt.max() >= n_states):
        raise ValueError(f"next_state indices must be in 0..{n_states - 1}")
    sweep = _BellmanSweep.of(nxt, rew, gamma)
    threshold = span_epsilon * (1.0 - gamma) / gamma
    values = np.zeros(n_goals * n_states)
    q = rew.copy()
    iterations = 0
    while iterations < max_iterations:
        iterations += 1
        q, new_values = sweep(values)
        change = new_values - values
        values = new_values
        if np.maximum.reduce(change) - np.minimum.reduce(change) < threshold:  # span, as max() - min()
            break
    return values.reshape(n_goals, n_states), q.transpose(0, 2, 1), iterations


#: Sweeps :func:`goal_fixed_point` makes before it leaves a layout to :func:`value_iteration` (the
#: study's layouts reach their fixed point in 18-26).
FIXED_POINT_MAX_SWEEPS = 100


@lru_cache(maxsize=32)
def self_loop_value(reward: float, gamma: float, max_steps: int = 100_000) -> float | None:
    """The float fixed point of ``v = reward + gamma v`` (an absorbing state's value), or ``None``.

    Iterated from 0 as a sweep computes it, so a state pinned at this value keeps it bit for bit in
    every sweep; ``None`` if the iteration has no fixed point within ``max_steps`` (a 2-cycle of
    roundings).
    """
    value = 0.0
    for _ in range(max_steps):
        following = reward + gamma * value
        if following == value:
            return value
        value = following
    return None


def goal_fixed_point(transitions: GoalTransitions, rewards: MDPRewards | None = None,
                     gamma: float = DEFAULT_GAMMA, span_epsilon: float = DEFAULT_SPAN_EPSILON,
                     max_sweeps: int = FIXED_POINT_MAX_SWEEPS) -> tuple[np.ndarray, np.ndarray, int] | None:
    """The goal MDPs' optimal values ``V*``, where their greedy policy is :func:`value_iteration`'s.

    The span rule's policy is the greedy policy of its last sweep's ``Q_K``. From ``V_0 = 0``,
    ``V_k(s)`` is the best ``k``-step return. When the goal pays and nothing else does (``goal > 0
    >= move, mode_switch, bump``), a path that does not reach the goal returns at most 0, so a
    state ``s`` whose optimal path reaches the goal within ``k`` steps and whose ``V*(s)`` exceeds
    ``c_k = goal gamma^k / (1 - gamma)`` (the goal's reward after step ``k``) has
    ``V_k(s) = V*(s) - c_k``: the same offset for every such state. Moves and mode switches are
    reversible, so every successor of such a state is one too, and ``Q_K(s, .) = Q*(s, .) - c_K``
    for all its actions: the same greedy actions and ties. Inside another goal's cell every action
    ties in both. The span rule stops only once ``goal gamma^(K-1)`` (a settled state's change)
    is below the threshold, i.e. ``c_(K-1) < span_epsilon / gamma``, against an obstacle
    interior's change of 0, or once every state has settled (one goal: all changes equal). So
    when every state outside the goal poses and obstacle interiors has ``V*(s) >
    span_epsilon / gamma``, the two policies agree; the test suite holds them together on
    thousands of layouts.

    ``V*`` is found by the same sweep from values below every return, the goal poses and obstacle
    interiors pinned at their self-loop values (:func:`self_loop_value`), until a sweep changes no
    value bit (about 20 sweeps on the study's layouts, against the span rule's 305: states are
    exact once their path to the goal fits in the sweeps, instead of a geometric approach).

    Parameters
    ----------
    transitions
        The layout's goal MDPs (:func:`build_transitions`).
    rewards
        Reward values (study defaults when ``None``).
    gamma
        Discount factor in ``(0, 1)``.
    span_epsilon
        The span rule's ``epsilon`` whose policy is to be matched.
    max_sweeps
        Sweeps to reach the fixed point before giving up.

    Returns
    -------
    tuple or None
        ``(V (G, S), Q (G, S, A), sweeps)`` as :func:`value_iteration` returns them, with
        ``V == Q.max(-1)`` exactly; ``None`` where the argument above does not apply: rewards of
        another sign structure, a state that cannot reach its goal (a cell walled in by other
        goals' cells and the grid's edge) or worth no more than ``span_epsilon / gamma``, or no
        fixed point within ``max_sweeps``. The caller then runs :func:`value_iteration`.
    """
    r = rewards or MDPRewards()
    if not (r.goal > 0.0 and max(r.move, r.mode_switch, r.bump) <= 0.0 and 0.0 < gamma < 1.0):
        return None
    goal_value = self_loop_value(r.goal, gamma)
    inside_value = self_loop_value(r.inside_obstacle, gamma)
    if goal_value is None or inside_value is None:
        return None
    kinds = transitions.outcome[:, 0, :]  # (G, S): absorbing and interior states are so for every action
    at_goal = kinds == OUTCOME_GOAL_ABSORBING
    inside = kinds == OUTCOME_INSIDE_OBSTACLE
    n_goals, _, n_states = transitions.next_state.shape
    start = np.full((n_goals, n_states), float(r.by_kind().min()) / (1.0 - gamma))  # below every return
    start[at_goal] = goal_value
    start[inside] = inside_value
    values = start.reshape(-1)
    sweep = _BellmanSweep.of(transitions.next_state, transitions.rewards(r), gamma)
    sweeps = 0
    while True:
        sweeps += 1
        q, new_values = sweep(values)
        if (new_values == values).all():  # no bit changed (np.array_equal of equal shapes): the fixed point
            break
        if sweeps >= max_sweeps:
            return None
        values = new_values
    free = ~(at_goal | inside).reshape(-1)
    if not (values[free] > span_epsilon / gamma).all():
        return None
    return values.reshape(n_goals, n_states), q.transpose(0, 2, 1), sweeps


def greedy_policy(q_values: np.ndarray, rtol: float = DEFAULT_TIE_RTOL) -> np.ndarray:
    """The greedy action of each state, ties broken by action order.

    An action is tied with the best when its Q-value is within ``rtol * max(1, |Q_max|)`` of the
    maximum; the lowest action index among the tied wins (move_p, move_n, to_mode_r,
    to_mode_l). The tolerance makes tie-breaking immune to the last-bit rounding differences of
    mathematically equal paths (e.g. turning clockwise or anticlockwise by 180 degrees), which
    pymdptoolbox's exact argmax would resolve arbitrarily.

    Parameters
    ----------
    q_values
        ``(..., A)`` Q-values, e.g. ``(G, S, A)``.
    rtol
        Relative tie tolerance.

    Returns
    -------
    np.ndarray
        ``(...)`` int action indices.
    """
    return first_argmax(q_values, rtol)


def solve_layout(goal_cells: np.ndarray, goal_headings: np.ndarray, rewards: MDPRewards | None = None,
                 gamma: float = DEFAULT_GAMMA, epsilon: float = DEFAULT_HUMAN_EPSILON,
                 span_epsilon: float = DEFAULT_SPAN_EPSILON) -> SolvedLayout:
    """Build and solve every goal's MDP of a layout and derive ``p(a | s, g)``.

    Parameters
    ----------
    goal_cells
        ``(G, 2)`` goal cells.
    goal_headings
        ``(G,)`` goal heading indices.
    rewards
        Reward values (study defaults when ``None``).
    gamma
        Discount factor.
    epsilon
        The human model's ε (Eq. 1).
    span_epsilon
        Value iteration's stopping ``epsilon`` (pymdptoolbox's rule).

    Returns
    -------
    SolvedLayout
        ``policy (G, S)``, ``values (G, S)``, ``p_a_given_sg (G, S, A)`` and ``iterations``. The
        policy is the greedy policy of :func:`value_iteration` (the span rule); it is computed from
        ``V*`` (:func:`goal_fixed_point`) wherever the two provably agree.
    """
    transitions = build_transitions(goal_cells, goal_headings)
    # V* where its greedy policy is provably the span rule's (about 15x fewer sweeps), else the rule
    solution = (goal_fixed_point(transitions, rewards, gamma, span_epsilon)
                or value_iteration(transitions.next_state, transitions.rewards(rewards), gamma=gamma,
                                   span_epsilon=span_epsilon))
    values, q_values, iterations = solution
    policy = greedy_policy(q_values)
    actions = DistinctActionRows.of_policy(policy, epsilon)
    return SolvedLayout(policy=policy, values=values, p_a_given_sg=actions.table, iterations=iterations,
                        known_actions=actions)

