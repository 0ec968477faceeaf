"""The paper's simulation-based validation of the disambiguation metric D(s) (end of section 3.3).

The paper: "For a local neighborhood of each s in S, we computed s* using Eq. 16 and compared
it to a ground truth that was computed by picking the state in the same neighborhood that
provided maximum expected difference between first and second maxima of b_g^t over a single
timestep. We ran a total of 100 simulations for |G| ranging from 3 to 30 and |S| = 200, and
the match percentage was 100%." The paper does not describe its world further; this module's
world is the following (every choice is a setting of :class:`ValidationSettings`).

The validation world
--------------------
- A grid of ``W x H`` cells and two modes, ``x`` (Horizontal) and ``y`` (Vertical), so
  ``|S| = 2 W H`` (``--states 200`` is a 10 x 10 grid; ``W`` is the largest divisor of
  ``|S| / 2`` not above its square root, and both sides must be at least 3). The state
  ``(i, j, m)`` has the flat index ``(i H + j) 2 + m`` (C order, as in :mod:`nudgecli.model.world`).
- The sip-and-puff interface of :mod:`nudgecli.model.interface`: actions move_p / move_n move
  one cell along the active mode's axis, to_mode_r / to_mode_l switch the mode (with two modes
  both switch to the other one); the default noise tables (0.85 / 0.05) for ``p(phi_i | a, m)``
  and ``p(phi_m | phi_i)``.
- ``|G|`` goals on distinct cells drawn uniformly at random; a goal is its cell in any mode.
- One goal MDP per goal with the study's rules (DESIGN 2.3): move -10, mode switch -100, a bump
  into a wall or another goal's cell -100 (the state is unchanged), the step into the goal +100,
  the goal absorbing with +100 per step, other goals' cells self-looping with 0; discount 0.96.
  Solved by the model's batched value iteration (:mod:`nudgecli.model.mdp`, pymdptoolbox's
  stopping rule), greedy ties within 1e-9 to the first action (move_p, move_n, to_mode_r,
  to_mode_l); with two modes to_mode_r and to_mode_l tie, so a wanted switch is to_mode_r (Hard
  Puff). The human model is epsilon-greedy around it (paper Eq. 1, epsilon 0.1):
  ``p(a | s, g) = 0.925`` for the optimal action, 0.025 otherwise.
- ``p(phi_m | g, s) = sum_a sum_phi_i p(phi_m | phi_i) p(phi_i | a, m(s)) p(a | s, g)``: the
  likelihood ``(G, S, F)`` of DESIGN 2.5.

One simulation
--------------
One simulation ``k`` (randomness from ``nudgecli.rng.generator(seed, "validation", k)`` only):

1. ``|G| = min_goals + k mod (max_goals - min_goals + 1)``: the goal counts are stepped
   cyclically, so 100 simulations over 3..30 goals give 4 worlds for each of 3..18 goals and
   3 for each of 19..30.
2. Draw the world above (goal cells), solve the goal MDPs, build the likelihood.
3. Query every state that is not on a goal cell once (``|S| - 2 |G|`` queries). For each query
   state ``s`` draw a belief ``b ~ Dirichlet(c, ..., c)`` over the goals (``c = 1`` by default,
   ``--belief-concentration``). The neighbourhood
   (the candidates) is the 3 x 3 window of cells centred on ``s``'s cell, clipped at the grid
   edges, without goal cells, in both modes: 2 to 18 candidates, ``s`` itself included.
4. ``s*`` of the metric: the argmax over the candidates of D(s) = I(s) with lambda = 0 (the
   exact Eq. 13 mutual information, in nats), first candidate (lowest flat index) on ties.
5. Ground truth: the argmax of the expected one-step gap between the first and second maxima
   of the posterior, computed exactly by enumerating the four labels
   (:func:`expected_top_two_gap`), first on ties.
6. The query matches when the two argmaxes are the same state. It is a *near-tie* when the best
   two candidates under either criterion are within the tie tolerance of each other: then the
   winner is decided by the first-index rule, not by the criterion (mostly candidates whose
   likelihood columns are identical, i.e. every goal's optimal action is the same at both).
   Such structural ties are resolved identically under both criteria, so a *distinct near-tie*
   is also recorded: the chosen candidate and the best candidate with a different likelihood
   column are within the tolerance under either criterion (a genuinely arbitrary choice).
   Also recorded: whether the metric's choice attains the ground truth's maximum
   (``truth_optimal``) and how much expected gap it gives up (``truth_regret``).
   The paper's regularised variant (Eq. 15 with lambda = 1, ``R(s) = sum_g b_g ||g - q(s)||``
   in grid cells) is evaluated against the same ground truth and reported beside it.
7. Monte-Carlo convergence (a bounded subset): ``mc_queries`` queries in total (default 100),
   spread evenly over the simulations (``mc_queries // simulations`` each, one more for the
   first ``mc_queries % simulations``) and drawn at random within each. For every sample count
   ``N`` in ``mc_samples`` the study's per-sample estimator
   (:func:`nudgecli.model.disambiguation.monte_carlo_mutual_information`) is run on every
   candidate of those queries: its mean absolute error against the exact mutual information,
   and whether its argmax within the window is a maximiser of the exact value, for the study's
   unweighted KL average and for the belief-weighted one (both from the same samples). The
   ``N -> infinity`` limit of the unweighted variant (the plain mean over goals of the exact
   KL) is reported too: it is not Eq. 13, so its error does not vanish.

Ties: every argmax takes the first candidate within ``tie_tolerance * max(1, |max|)`` of the
maximum (the rule of ``first_argmax`` in the model), so states with identical likelihood
columns resolve identically under both criteria.

Why lambda = 0: the ground truth is a purely informational one-step look-ahead on the belief;
it has no notion of distance. Eq. 15's regulariser exists (paper) to break ties in a flat
information landscape; with lambda = 1 and distances in cells it is of the order of one unit
per neighbouring cell, while the information differs by fractions of a nat within a window, so
the regularised argmax mostly measures the distance to the goals. The validation therefore
compares the information term; the lambda = 1 match rate is reported beside it to show this.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.special import rel_entr

from nudgecli.errors import ConfigError
from nudgecli.model.disambiguation import (
    Weighting,
    monte_carlo_label_counts,
    mutual_information,
    mutual_information_from_counts,
    observation_likelihood,
)
from nudgecli.model.interface import (
    MOVE_N,
    MOVE_P,
    N_ACTIONS,
    TO_MODE_L,
    TO_MODE_R,
    default_distortion_table,
    default_mapping_table,
)
from nudgecli.model.mdp import action_likelihood, greedy_policy, value_iteration
from nudgecli.model.ties import first_argmax
from nudgecli.rng import generator
from nudgecli.store import write_text_atomic

#: Modes of the validation world: x (Horizontal) and y (Vertical).
N_VALIDATION_MODES = 2
#: Rewards and discount of the goal MDPs (DESIGN 2.3, study values).
MOVE_REWARD = -10.0
SWITCH_REWARD = -100.0
BUMP_REWARD = -100.0
GOAL_REWARD = 100.0
DISCOUNT = 0.96
#: Default Monte-Carlo sample counts of the convergence study.
DEFAULT_MC_SAMPLES: tuple[int, ...] = (10, 30, 100, 300, 1000, 3000, 10000)
#: Largest sample count accepted (the cost is linear in it).
MAX_MC_SAMPLES = 100_000
#: Variants of the Monte-Carlo estimate: the study's unweighted KL mean and the belief-weighted one.
MC_VARIANTS: tuple[Weighting, ...] = ("unweighted", "belief")


# --- settings ------------------------------------------------------------------------------


@dataclass(frozen=True)
class ValidationSettings:
    """Everything a validation run depends on (with the seed, it determines the result).

    Attributes
    ----------
    simulations
        Number of random worlds.
    min_goals, max_goals
        Range of ``|G|`` (inclusive), stepped cyclically over the simulations.
    states
        ``|S| = 2 W H`` (two modes on a ``W x H`` grid).
    seed
        Master seed; simulation ``k`` uses ``generator(seed, "validation", k)``.
    window
        Half-width of the neighbourhood in cells (1: a 3 x 3 window).
    epsilon
        Epsilon of the epsilon-greedy human model (paper Eq. 1).
    regularisation
        lambda of the reported regularised variant of Eq. 15 (distance in grid cells).
    tie_tolerance
        Relative tolerance under which the best two candidates count as a near-tie.
    mc_queries
        Queries (in total, spread over the simulations) used for the Monte-Carlo convergence
        study; 0 skips it.
    mc_samples
        Sample counts per state of the convergence study.
    belief_concentration
        The query beliefs are ``Dirichlet(c, ..., c)``: 1 spreads them evenly over the simplex,
        a large ``c`` makes them nearly uniform, a small one nearly certain.
    """

    simulations: int = 100
    min_goals: int = 3
    max_goals: int = 30
    states: int = 200
    seed: int = 0
    window: int = 1
    epsilon: float = 0.1
    regularisation: float = 1.0
    tie_tolerance: float = 1e-9
    mc_queries: int = 100
    mc_samples: tuple[int, ...] = DEFAULT_MC_SAMPLES
    belief_concentration: float = 1.0

    @property
    def grid_shape(self) -> tuple[int, int]:
        """``(W, H)``: the most square factorisation of ``states / 2`` (``W <= H``)."""
        cells = self.states // N_VALIDATION_MODES
        width = max(d for d in range(1, math.isqrt(max(cells, 1)) + 1) if cells % d == 0)
        return width, cells // width

    @property
    def n_cells(self) -> int:
        return self.states // N_VALIDATION_MODES

    def goal_counts(self) -> np.ndarray:
        """``(simulations,)`` the ``|G|`` of every simulation (stepped cyclically)."""
        span = self.max_goals - self.min_goals + 1
        return self.min_goals + np.arange(self.simulations) % span

    def check(self) -> ValidationSettings:
        """Raise :class:`ConfigError` naming the first option that is out of range."""
        if self.simulations < 1:
            raise ConfigError(f"--simulations must be at least 1 (got {self.simulations})")
        if self.seed < 0:
            raise ConfigError(f"--seed must be a non-negative integer (got {self.seed})")
        if self.min_goals < 2:
            raise ConfigError(
                f"--min-goals must be at least 2 (got {self.min_goals}): disambiguation needs two goals")
        if self.min_goals > self.max_goals:
            raise ConfigError(
                f"--min-goals ({self.min_goals}) is larger than --max-goals ({self.max_goals}); "
                "lower --min-goals or raise --max-goals")
        window_states = N_VALIDATION_MODES * (2 * self.window + 1) ** 2
        if self.states < window_states:
            raise ConfigError(
                f"--states {self.states} is fewer than one neighbourhood ({window_states} states: "
                f"{2 * self.window + 1} x {2 * self.window + 1} cells x {N_VALIDATION_MODES} modes); "
                f"use --states {window_states} or more")
        if self.states % N_VALIDATION_MODES:
            raise ConfigError(
                f"--states must be even (two modes x cells), got {self.states}; e.g. --states 200")
        width, height = self.grid_shape
        side = 2 * self.window + 1
        if width < side:
            raise ConfigError(
                f"--states {self.states} gives a {width} x {height} grid (2 x {self.n_cells} cells); "
                f"both sides must be at least {side}: use 2 x W x H states with W, H >= {side}, "
                "e.g. --states 200 (10 x 10)")
        if self.max_goals > self.n_cells // 2:
            raise ConfigError(
                f"--max-goals {self.max_goals} is too many for --states {self.states} "
                f"({self.n_cells} cells); use at most {self.n_cells // 2} goals (half the cells) "
                "or more states")
        if self.window < 1:
            raise ConfigError(f"window half-width must be at least 1 (got {self.window})")
        if not 0.0 <= self.epsilon <= 1.0:
            raise ConfigError(f"epsilon must lie in [0, 1] (got {self.epsilon})")
        if not self.belief_concentration > 0.0:
            raise ConfigError(f"--belief-concentration must be positive (got {self.belief_concentration}); "
                              "1 spreads beliefs evenly, larger values make them nearly uniform")
        if not self.tie_tolerance >= 0.0:
            raise ConfigError(f"tie tolerance must be non-negative (got {self.tie_tolerance})")
        if self.mc_queries < 0:
            raise ConfigError(f"--mc-queries must be 0 or more (got {self.mc_queries})")
        if self.mc_queries and not self.mc_samples:
            raise ConfigError("the Monte-Carlo sample counts are empty; give at least one or --mc-queries 0")
        for n in self.mc_samples:
            if not 1 <= n <= MAX_MC_SAMPLES:
                raise ConfigError(
                    f"Monte-Carlo sample counts must lie in 1..{MAX_MC_SAMPLES} (got {n})")
        return self

    def describe(self) -> dict[str, Any]:
        """The settings as JSON-ready values, with the derived world description."""
        data = asdict(self)
        data["mc_samples"] = list(self.mc_samples)
        width, height = self.grid_shape
        data.update({
            "grid": [width, height], "modes": N_VALIDATION_MODES, "window_cells": 2 * self.window + 1,
            "discount": DISCOUNT, "goal_counts": "cyclic: min_goals + k mod (max_goals - min_goals + 1)",
            "belief": f"Dirichlet({self.belief_concentration:g}) per query",
            "metric": "I(s), Eq. 13 (D(s) with lambda = 0)",
            "ground_truth": "E[max1(b') - max2(b')] over one observation, exact",
            "mc_scheme": ("per state N samples g ~ b, a ~ p(a|s,g), phi_i ~ p(phi_i|a,m), "
                          "phi_m ~ p(phi_m|phi_i)"),
        })
        return data


# --- the validation world ------------------------------------------------------------------


@dataclass(frozen=True)
class ValidationWorld:
    """One random world of the validation.

    Attributes
    ----------
    width, height
        Grid size ``W x H``.
    goal_cells
        ``(G, 2)`` goal cells ``(i, j)``.
    cells
        ``(S, 2)`` cell ``(i, j)`` of every state.
    modes
        ``(S,)`` mode of every state (0 x, 1 y).
    on_goal
        ``(S,)`` whether the state lies on a goal cell.
    policy
        ``(G, S, A)`` ``p(a | s, g)``, epsilon-greedy around the optimal policy.
    likelihood
        ``(G, S, F)`` ``p(phi_m | g, s)``.
    """

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
    """Cells and modes of every flat state index ``(i H + j) 2 + m``.

    Returns
    -------
    cells : np.ndarray
        ``(S, 2)`` integer ``(i, j)``.
    modes : np.ndarray
        ``(S,)`` integer mode.
    """
    i, j, m = np.unravel_index(np.arange(width * height * N_VALIDATION_MODES),
                               (width, height, N_VALIDATION_MODES))
    return np.column_stack([i, j]), np.asarray(m)


def goal_transitions(width: int, height: int, goal_cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Deterministic transitions and rewards of every goal MDP.

    Parameters
    ----------
    width, height
        Grid size.
    goal_cells
        ``(G, 2)`` distinct goal cells.

    Returns
    -------
    next_state : np.ndarray
        ``(G, S, A)`` the state after each action under each goal's MDP.
    reward : np.ndarray
        ``(G, S, A)`` its reward.
    """
    cells, modes = world_states(width, height)
    n_states = cells.shape[0]
    goals = np.asarray(goal_cells, dtype=int)
    n_goals = goals.shape[0]
    cell_id = cells[:, 0] * height + cells[:, 1]  # (S,)
    goal_id = goals[:, 0] * height + goals[:, 1]  # (G,)

    # Motion along the active axis (mode 0 moves i, mode 1 moves j); off-grid -> bump.
    target = np.repeat(cells[:, None, :], 2, axis=1)  # (S, 2 moves, 2 coords)
    rows = np.arange(n_states)
    target[rows, 0, modes] += 1
    target[rows, 1, modes] -= 1
    inside = ((target[..., 0] >= 0) & (target[..., 0] < width)
              & (target[..., 1] >= 0) & (target[..., 1] < height))  # (S, 2)
    target_cell = np.where(inside, target[..., 0] * height + target[..., 1], -1)
    move_next = np.where(inside, (target_cell * N_VALIDATION_MODES) + modes[:, None], rows[:, None])

    next_state = np.empty((n_goals, n_states, N_ACTIONS), dtype=np.int64)
    reward = np.empty((n_goals, n_states, N_ACTIONS))
    next_state[:, :, [MOVE_P, MOVE_N]] = move_next[None]
    switch_next = cells[:, 0:1] * 0 + (cell_id * N_VALIDATION_MODES)[:, None]
    next_state[:, :, TO_MODE_R] = (switch_next[:, 0] + (modes + 1) % N_VALIDATION_MODES)[None]
    next_state[:, :, TO_MODE_L] = (switch_next[:, 0] + (modes - 1) % N_VALIDATION_MODES)[None]

    is_goal_cell = target_cell[None, :, :] == goal_id[:, None, None]  # (G, S, 2): into goal g
    into_any_goal = np.isin(target_cell, goal_id)  # (S, 2)
    into_other = into_any_goal[None] & ~is_goal_cell  # (G, S, 2)
    moves = next_state[:, :, [MOVE_P, MOVE_N]]
    moves = np.where(into_other, rows[None, :, None], moves)
    next_state[:, :, [MOVE_P, MOVE_N]] = moves
    move_reward = np.where(~inside[None] | into_other, BUMP_REWARD,
                           np.where(is_goal_cell, GOAL_REWARD, MOVE_REWARD))
    reward[:, :, [MOVE_P, MOVE_N]] = move_reward
    reward[:, :, [TO_MODE_R, TO_MODE_L]] = SWITCH_REWARD

    # Goal states absorb with +100; other goals' cells are invalid for this MDP: self-loops, 0.
    own = cell_id[None, :] == goal_id[:, None]  # (G, S)
    other = np.isin(cell_id, goal_id)[None, :] & ~own
    next_state = np.where((own | other)[..., None], rows[None, :, None], next_state)
    reward = np.where(own[..., None], GOAL_REWARD, np.where(other[..., None], 0.0, reward))
    return next_state, reward


def solve_goal_policies(next_state: np.ndarray, reward: np.ndarray, epsilon: float,
                        discount: float = DISCOUNT) -> np.ndarray:
    """All goal MDPs by the model's batched value iteration, then the epsilon-greedy human model.

    :func:`nudgecli.model.mdp.value_iteration` (pymdptoolbox's span rule from ``V = 0``),
    :func:`~nudgecli.model.mdp.greedy_policy` (ties within ``1e-9`` relative go to the first
    action: move_p, move_n, to_mode_r, to_mode_l) and :func:`~nudgecli.model.mdp.action_likelihood`.

    Parameters
    ----------
    next_state
        ``(G, S, A)`` deterministic transitions.
    reward
        ``(G, S, A)`` rewards.
    epsilon
        Probability of a uniformly random action (paper Eq. 1).
    discount
        Discount factor.

    Returns
    -------
    np.ndarray
        ``(G, S, A)`` ``p(a | s, g) = (1 - eps) onehot(pi_g(s)) + eps / A``.
    """
    _, q_values, _ = value_iteration(np.swapaxes(next_state, 1, 2), np.swapaxes(reward, 1, 2), discount)
    return action_likelihood(greedy_policy(q_values), epsilon)


def sample_world(rng: np.random.Generator, n_goals: int, width: int, height: int,
                 epsilon: float = 0.1, mapping: np.ndarray | None = None,
                 distortion: np.ndarray | None = None) -> ValidationWorld:
    """Draw one validation world: ``n_goals`` distinct random goal cells, policies, likelihood.

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
        ``(M, A, F)`` and ``(F, F)`` tables; the defaults (0.85 / 0.05) when ``None``. Only the
        first two modes of ``mapping`` are used.
    """
    mapping = default_mapping_table() if mapping is None else np.asarray(mapping, dtype=float)
    distortion = default_distortion_table() if distortion is None else np.asarray(distortion, dtype=float)
    flat = rng.choice(width * height, size=n_goals, replace=False)
    goal_cells = np.column_stack([flat // height, flat % height])
    cells, modes = world_states(width, height)
    next_state, reward = goal_transitions(width, height, goal_cells)
    policy = solve_goal_policies(next_state, reward, epsilon)
    likelihood = observation_likelihood(policy, mapping, distortion, modes=modes)
    on_goal = np.isin(cells[:, 0] * height + cells[:, 1], flat)
    return ValidationWorld(width=width, height=height, goal_cells=goal_cells, cells=cells, modes=modes,
                           on_goal=on_goal, policy=policy, likelihood=likelihood)


def neighbourhoods(world: ValidationWorld, queries: np.ndarray, window: int = 1) -> np.ndarray:
    """The candidate states of each query: the window of cells around it, minus goal cells, all modes.

    Parameters
    ----------
    world
        The world.
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


# --- the two criteria ----------------------------------------------------------------------


def expected_top_two_gap(belief: np.ndarray, likelihood: np.ndarray) -> np.ndarray:
    """The ground truth: expected gap between the first and second maxima of the next belief.

    ``E_{phi_m ~ p(phi_m | s)} [max1(b') - max2(b')]`` with ``b' = bayes_update(b, p(phi_m | ., s))``
    and ``p(phi_m | s) = sum_g b_g p(phi_m | g, s)``, computed exactly by enumerating the labels.
    Because ``p(phi_m | s) b'_g = b_g p(phi_m | g, s)``, the expectation equals
    ``sum_f [max1_g - max2_g](b_g p(f | g, s))`` (no division).

    Parameters
    ----------
    belief
        ``(..., G)`` belief(s), ``G >= 2``.
    likelihood
        ``(..., G, C, F)`` ``p(phi_m | g, s)`` of the candidate states.

    Returns
    -------
    np.ndarray
        ``(..., C)`` expected gap per candidate.
    """
    b = np.asarray(belief, dtype=float)
    joint = b[..., :, None, None] * np.asarray(likelihood, dtype=float)  # (..., G, C, F)
    if joint.shape[-3] < 2:
        raise ValueError("the gap between the two largest beliefs needs at least two goals")
    top = np.partition(joint, joint.shape[-3] - 2, axis=-3)[..., -2:, :, :]
    return (top[..., 1, :, :] - top[..., 0, :, :]).sum(axis=-1)


def expected_goal_distance(belief: np.ndarray, goal_cells: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """The regulariser of Eq. 15, ``sum_g b_g ||g - q(s)||`` in grid cells.

    Parameters
    ----------
    belief
        ``(..., G)``.
    goal_cells
        ``(G, 2)``.
    cells
        ``(..., C, 2)`` cells of the candidates.

    Returns
    -------
    np.ndarray
        ``(..., C)``.
    """
    diff = np.asarray(cells, dtype=float)[..., None, :, :] - np.asarray(goal_cells, dtype=float)[:, None, :]
    dist = np.linalg.norm(diff, axis=-1)  # (..., G, C)
    return np.einsum("...g,...gc->...c", np.asarray(belief, dtype=float), dist)


def tolerant_argmax(values: np.ndarray, valid: np.ndarray | None = None,
                    tolerance: float = 1e-9) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """First maximum with ties up to a relative tolerance, the top-two margin and the near-tie flag.

    The choice is the first candidate whose value is within ``tolerance * max(1, |max|)`` of the
    maximum (the rule of :func:`nudgecli.model.ties.first_argmax`), so candidates with
    identical likelihood columns (whose computed values may differ in the last bit) resolve to
    the same, lowest-index state under every criterion.

    Parameters
    ----------
    values
        ``(Q, C)`` criterion values.
    valid
        ``(Q, C)`` mask of real candidates (``None``: all); every row needs two.
    tolerance
        Relative tolerance.

    Returns
    -------
    best : np.ndarray
        ``(Q,)`` column of the chosen candidate.
    margin : np.ndarray
        ``(Q,)`` maximum minus the second largest value.
    near_tie : np.ndarray
        ``(Q,)`` ``margin <= tolerance * max(1, |maximum|)``.
    """
    vals = np.asarray(values, dtype=float)
    masked = vals if valid is None else np.where(valid, vals, -np.inf)
    top = -np.sort(-masked, axis=1)[:, :2]
    slack = tolerance * np.maximum(1.0, np.abs(top[:, 0]))
    best = first_argmax(masked, tolerance)
    margin = top[:, 0] - top[:, 1]
    return best, margin, margin <= slack


def distinct_margin(values: np.ndarray, best: np.ndarray, equivalent: np.ndarray,
                    valid: np.ndarray) -> np.ndarray:
    """Best value minus the best value of a candidate that is not equivalent to the chosen one.

    Candidates with identical likelihood columns score identically under every criterion, and
    the first-index rule resolves them the same way; only a tie with a *different* candidate
    can make the choice arbitrary.

    Parameters
    ----------
    values
        ``(Q, C)``.
    best
        ``(Q,)`` chosen column.
    equivalent
        ``(Q, C, C)`` whether two candidates have the same likelihood column.
    valid
        ``(Q, C)``.

    Returns
    -------
    np.ndarray
        ``(Q,)``; ``inf`` when every candidate is equivalent to the chosen one.
    """
    rows = np.arange(values.shape[0])
    others = valid & ~equivalent[rows, best]
    runner_up = np.where(others, values, -np.inf).max(axis=1)
    return values[rows, best] - runner_up


# --- Monte-Carlo estimate (the study's per-sample scheme) -----------------------------------


def monte_carlo_estimates(rng: np.random.Generator, belief: np.ndarray, policy: np.ndarray,
                          modes: np.ndarray, mapping: np.ndarray, distortion: np.ndarray,
                          n_samples: int) -> dict[str, np.ndarray]:
    """The study's per-sample Monte-Carlo estimate of ``I(s)``, both weightings from the same samples.

    One call of :func:`nudgecli.model.disambiguation.monte_carlo_label_counts` (per state,
    ``n_samples`` draws ``g ~ b``, ``a ~ p(a | s, g)``, ``phi_i ~ p(phi_i | a, m)``,
    ``phi_m ~ p(phi_m | phi_i)``), then the KL of each sampled goal's label histogram to the
    pooled one, averaged plainly or weighted by belief.

    Parameters
    ----------
    rng
        Source of randomness.
    belief
        ``(G,)``.
    policy
        ``(G, C, A)`` ``p(a | s, g)`` of the states to estimate.
    modes
        ``(C,)`` their modes (0 x, 1 y).
    mapping
        ``(M, A, F)`` ``p(phi_i | a, m)``.
    distortion
        ``(F, F)`` ``p(phi_m | phi_i)``.
    n_samples
        Samples per state.

    Returns
    -------
    dict[str, np.ndarray]
        ``{"unweighted": (C,), "belief": (C,)}`` estimates in nats.
    """
    counts = monte_carlo_label_counts(belief, np.arange(policy.shape[1]), policy, mapping, distortion, rng,
                                      samples=n_samples, modes=modes)
    weights = np.asarray(belief, dtype=float) / np.sum(belief)
    return {variant: mutual_information_from_counts(counts, weights, variant) for variant in MC_VARIANTS}


def unweighted_limit(belief: np.ndarray, likelihood: np.ndarray) -> np.ndarray:
    """What the unweighted estimate converges to: the plain mean over goals with ``b_g > 0`` of
    ``KL(p(phi_m | g, s) || p(phi_m | s))``.

    Parameters
    ----------
    belief
        ``(..., G)``.
    likelihood
        ``(..., G, C, F)``.

    Returns
    -------
    np.ndarray
        ``(..., C)`` in nats.
    """
    b = np.asarray(belief, dtype=float)
    lik = np.asarray(likelihood, dtype=float)
    marginal = np.einsum("...g,...gcf->...cf", b, lik)
    kl = rel_entr(lik, marginal[..., None, :, :]).sum(axis=-1)  # (..., G, C)
    present = (b > 0).astype(float)
    return np.einsum("...g,...gc->...c", present, kl) / present.sum(axis=-1)[..., None]


# --- running the validation ----------------------------------------------------------------


#: Per-query columns of the result (and of validation.csv), in order.
QUERY_COLUMNS: tuple[str, ...] = (
    "simulation", "n_goals", "state", "cell_i", "cell_j", "mode", "n_candidates",
    "metric_choice", "truth_choice", "match", "near_tie", "distinct_near_tie", "truth_optimal",
    "metric_margin", "truth_margin", "truth_best", "truth_regret",
    "regularised_choice", "regularised_match",
)


@dataclass
class ValidationResult:
    """The outcome of :func:`run_validation`.

    Attributes
    ----------
    settings
        The settings it ran with.
    queries
        Per-query columns (``QUERY_COLUMNS``), each ``(Q,)``.
    convergence
        One record per (sample count, variant), see :func:`run_validation`.
    convergence_limit
        The same measures for ``N -> infinity`` (the unweighted estimator's bias floor; the
        weighted estimator converges to the exact value).
    """

    settings: ValidationSettings
    queries: dict[str, np.ndarray]
    convergence: list[dict[str, Any]] = field(default_factory=list)
    convergence_limit: dict[str, dict[str, Any]] = field(default_factory=dict)

    def summary(self) -> dict[str, Any]:
        """The JSON-ready summary (only reproducible values; no timings)."""
        q = self.queries
        by_goals: dict[str, dict[str, Any]] = {}
        for n in np.unique(q["n_goals"]):
            sel = q["n_goals"] == n
            by_goals[str(int(n))] = {"simulations": int(np.unique(q["simulation"][sel]).size),
                                     **_rates(q, sel)}
        return {
            "simulations": self.settings.simulations,
            "seed": self.settings.seed,
            **_rates(q, np.ones(q["match"].shape[0], dtype=bool)),
            "by_goals": by_goals,
            "convergence": self.convergence,
            "convergence_limit": self.convergence_limit,
            "settings": self.settings.describe(),
        }


def _rates(q: dict[str, np.ndarray], sel: np.ndarray) -> dict[str, Any]:
    """Match statistics of the selected queries."""
    match = q["match"][sel].astype(bool)
    tie = q["near_tie"][sel].astype(bool)
    distinct = q["distinct_near_tie"][sel].astype(bool)
    clear = ~tie
    missed = ~match
    best = q["truth_best"][sel]
    regret = q["truth_regret"][sel]
    relative = np.divide(regret, best, out=np.zeros_like(regret), where=best > 0)
    return {
        "queries": int(match.size),
        "match_rate": _mean(match),
        "near_ties": int(tie.sum()),
        "match_rate_excluding_near_ties": _mean(match[clear]),
        "match_rate_near_ties": _mean(match[tie]),
        "distinct_near_ties": int(distinct.sum()),
        "match_rate_excluding_distinct_near_ties": _mean(match[~distinct]),
        "truth_optimal_rate": _mean(q["truth_optimal"][sel].astype(bool)),
        "mismatch_relative_regret": _mean(relative[missed]) if missed.any() else 0.0,
        "regularised_match_rate": _mean(q["regularised_match"][sel].astype(bool)),
    }


def _mean(values: np.ndarray) -> float | None:
    """Mean as a float, ``None`` (JSON null) for an empty selection."""
    return float(np.mean(values)) if values.size else None


def _simulate(settings: ValidationSettings, k: int, n_goals: int, n_mc: int, mapping: np.ndarray,
              distortion: np.ndarray) -> tuple[dict[str, np.ndarray], list[dict[str, Any]]]:
    """Simulation ``k``: world, queries, both criteria; Monte-Carlo records for ``n_mc`` queries.

    Returns
    -------
    table : dict[str, np.ndarray]
        The ``QUERY_COLUMNS`` of its queries, each ``(Q,)``.
    records : list[dict]
        Per (Monte-Carlo query, sample count, variant) error sums and agreements.
    """
    rng = generator(settings.seed, "validation", k)
    width, height = settings.grid_shape
    world = sample_world(rng, n_goals, width, height, settings.epsilon, mapping, distortion)
    queries = np.flatnonzero(~world.on_goal)
    n_queries = queries.size
    beliefs = rng.dirichlet(np.full(n_goals, settings.belief_concentration), size=n_queries)  # (Q, G)
    cand = neighbourhoods(world, queries, settings.window)  # (Q, C)
    valid = cand >= 0
    safe = np.where(valid, cand, 0)
    lik = np.moveaxis(world.likelihood[:, safe, :], 0, 1)  # (Q, G, C, F)

    info = mutual_information(beliefs, lik)  # (Q, C): D(s) with lambda = 0
    truth = expected_top_two_gap(beliefs, lik)  # (Q, C)
    distance = expected_goal_distance(beliefs, world.goal_cells, world.cells[safe])  # (Q, C)
    regularised = info - settings.regularisation * distance

    tol = settings.tie_tolerance
    metric_best, metric_margin, metric_tie = tolerant_argmax(info, valid, tol)
    truth_best, truth_margin, truth_tie = tolerant_argmax(truth, valid, tol)
    # Candidates with the same likelihood column (every goal's action distribution equal).
    column = world.likelihood.transpose(1, 0, 2).reshape(world.n_states, -1)  # (S, G F)
    _, column_id = np.unique(np.round(column, 12), axis=0, return_inverse=True)
    cand_id = np.where(valid, column_id.ravel()[safe], -1)  # (Q, C)
    equivalent = cand_id[:, :, None] == cand_id[:, None, :]  # (Q, C, C)
    distinct_tie = np.zeros(n_queries, dtype=bool)
    for values, best in ((info, metric_best), (truth, truth_best)):
        margin = distinct_margin(values, best, equivalent, valid)
        distinct_tie |= margin <= tol * np.maximum(1.0, np.abs(values[np.arange(n_queries), best]))
    reg_best, _, _ = tolerant_argmax(regularised, valid, tol)
    rows = np.arange(n_queries)
    truth_max = truth[rows, truth_best]
    regret = truth_max - truth[rows, metric_best]
    cells = world.cells[queries]
    table = {
        "simulation": np.full(n_queries, k),
        "n_goals": np.full(n_queries, n_goals),
        "state": queries,
        "cell_i": cells[:, 0],
        "cell_j": cells[:, 1],
        "mode": world.modes[queries],
        "n_candidates": valid.sum(axis=1),
        "metric_choice": cand[rows, metric_best],
        "truth_choice": cand[rows, truth_best],
        "match": (metric_best == truth_best).astype(np.int64),
        "near_tie": (metric_tie | truth_tie).astype(np.int64),
        "distinct_near_tie": distinct_tie.astype(np.int64),
        "truth_optimal": (regret <= tol * np.maximum(1.0, np.abs(truth_max))).astype(np.int64),
        "metric_margin": metric_margin,
        "truth_margin": truth_margin,
        "truth_best": truth_max,
        "truth_regret": regret,
        "regularised_choice": cand[rows, reg_best],
        "regularised_match": (reg_best == truth_best).astype(np.int64),
    }

    records: list[dict[str, Any]] = []
    if n_mc:
        picked = np.sort(rng.choice(n_queries, size=min(n_mc, n_queries), replace=False))
        records = _convergence_records(rng, settings, world, cand[picked], valid[picked], beliefs[picked],
                                       info[picked], lik[picked], mapping, distortion)
    return table, records


def _convergence_records(rng: np.random.Generator, settings: ValidationSettings, world: ValidationWorld,
                         cand: np.ndarray, valid: np.ndarray, beliefs: np.ndarray, info: np.ndarray,
                         lik: np.ndarray, mapping: np.ndarray,
                         distortion: np.ndarray) -> list[dict[str, Any]]:
    """Monte-Carlo estimates of the selected queries' candidates, compared with the exact values.

    Parameters
    ----------
    cand, valid, info
        ``(Q', C)`` candidates, their mask and exact mutual information.
    beliefs
        ``(Q', G)``.
    lik
        ``(Q', G, C, F)``.

    Returns
    -------
    list[dict]
        Per (query, sample count, variant), and per query for the unweighted limit
        (``n_samples`` ``None``): ``abs_error_sum``, ``states``, ``agree``, ``agree_strict``, ``regret``.
    """
    tol = settings.tie_tolerance
    exact_best, _, _ = tolerant_argmax(info, valid, tol)
    records: list[dict[str, Any]] = []

    def record(n: int | None, variant: str, estimate: np.ndarray, exact: np.ndarray,
               q: int) -> dict[str, Any]:
        choice = int(tolerant_argmax(estimate[None, :], None, tol)[0][0])
        exact_max = float(exact.max())
        return {
            "n_samples": n, "variant": variant, "states": int(exact.size),
            "abs_error_sum": float(np.abs(estimate - exact).sum()),
            "agree": bool(exact[choice] >= exact_max - tol * max(1.0, abs(exact_max))),
            "agree_strict": bool(choice == exact_best[q]),
            "regret": exact_max - float(exact[choice]),
        }

    for q in range(cand.shape[0]):
        states = cand[q, valid[q]]
        exact = info[q, valid[q]]
        for n in settings.mc_samples:
            estimates = monte_carlo_estimates(rng, beliefs[q], world.policy[:, states, :],
                                              world.modes[states], mapping, distortion, n)
            for variant in MC_VARIANTS:
                records.append(record(n, variant, estimates[variant], exact, q))
        limit = unweighted_limit(beliefs[q], lik[q][:, valid[q], :])
        records.append(record(None, "unweighted", limit, exact, q))
    return records


def _pool(records: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Pooled measures of a group of per-query records."""
    states = sum(r["states"] for r in records)
    return {
        "mae": sum(r["abs_error_sum"] for r in records) / states,
        "argmax_agreement": sum(r["agree"] for r in records) / len(records),
        "argmax_agreement_strict": sum(r["agree_strict"] for r in records) / len(records),
        "mean_regret": sum(r["regret"] for r in records) / len(records),
        "queries": len(records),
        "states": int(states),
    }


def _aggregate_convergence(
        records: list[dict[str, Any]], sample_counts: Sequence[int],
) -> tuple[list[dict[str, Any]], dict[str, dict[str, Any]]]:
    """One row per (sample count, variant), in the given order, and the ``N -> infinity`` limits."""
    rows = []
    for n in sample_counts:
        for variant in MC_VARIANTS:
            group = [r for r in records if r["n_samples"] == n and r["variant"] == variant]
            if group:
                rows.append({"n_samples": int(n), "variant": variant, **_pool(group)})
    limits: dict[str, dict[str, Any]] = {}
    group = [r for r in records if r["n_samples"] is None]
    if group:
        limits["unweighted"] = _pool(group)
        limits["belief"] = {"mae": 0.0, "argmax_agreement": 1.0, "argmax_agreement_strict": 1.0,
                              "mean_regret": 0.0, "queries": len(group),
                              "states": int(sum(r["states"] for r in group))}
    return rows, limits


def run_validation(settings: ValidationSettings, mapping: np.ndarray | None = None,
                   distortion: np.ndarray | None = None,
                   progress: Callable[[int, int], None] | None = None) -> ValidationResult:
    """Run the whole validation (see the module docstring for what one simulation is).

    Parameters
    ----------
    settings
        Checked with :meth:`ValidationSettings.check` (``ConfigError`` when out of range).
    mapping, distortion
        ``(M, A, F)`` and ``(F, F)`` interface tables; the defaults (0.85 / 0.05) when ``None``.
    progress
        Called with (simulations done, simulations in all) after each simulation.

    Returns
    -------
    ValidationResult
        A pure function of ``settings`` and the tables: the same seed gives bit-identical
        numbers. Its convergence rows hold, per (sample count, variant): ``mae`` (mean absolute
        error against the exact mutual information over all candidates of the Monte-Carlo
        queries, nats), ``argmax_agreement`` (share of queries whose estimated argmax is a
        maximiser of the exact value, within the tie tolerance), ``argmax_agreement_strict``
        (the same state as the exact first-index argmax), ``mean_regret`` (exact information
        lost by the estimated choice, nats), ``queries`` and ``states``.
    """
    settings.check()
    mapping = default_mapping_table() if mapping is None else np.asarray(mapping, dtype=float)
    distortion = default_distortion_table() if distortion is None else np.asarray(distortion, dtype=float)
    per_sim = np.full(settings.simulations, settings.mc_queries // settings.simulations)
    per_sim[: settings.mc_queries % settings.simulations] += 1
    tables: list[dict[str, np.ndarray]] = []
    records: list[dict[str, Any]] = []
    for k, n_goals in enumerate(settings.goal_counts()):
        table, recs = _simulate(settings, k, int(n_goals), int(per_sim[k]), mapping, distortion)
        tables.append(table)
        records.extend(recs)
        if progress:
            progress(k + 1, settings.simulations)
    queries = {name: np.concatenate([t[name] for t in tables]) for name in QUERY_COLUMNS}
    convergence, limits = _aggregate_convergence(records, settings.mc_samples)
    return ValidationResult(settings=settings, queries=queries, convergence=convergence,
                            convergence_limit=limits)


# --- output --------------------------------------------------------------------------------


def _atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically (see :func:`nudgecli.store.write_text_atomic`)."""
    write_text_atomic(path, text)


def summary_json(result: ValidationResult) -> str:
    """The summary as JSON text (what ``--format json`` prints and validation.json holds)."""
    return json.dumps(result.summary(), indent=2, allow_nan=False) + "\n"


def queries_csv(result: ValidationResult) -> str:
    """The per-query table as CSV text (floats in shortest round-trip form)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(QUERY_COLUMNS)
    columns = [result.queries[name].tolist() for name in QUERY_COLUMNS]
    writer.writerows(zip(*columns, strict=True))
    return buffer.getvalue()


def save_validation(result: ValidationResult, out_dir: str | os.PathLike[str]) -> list[Path]:
    """Write ``validation.json`` and ``validation.csv`` (per query) into ``out_dir``, atomically.

    Returns
    -------
    list[Path]
        The files written.
    """
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(
            f"--out {out}: cannot create the folder ({exc.strerror}); choose another path") from exc
    if not out.is_dir():
        raise ConfigError(f"--out {out} is not a folder; choose a folder path")
    written = []
    for name, text in (("validation.json", summary_json(result)), ("validation.csv", queries_csv(result))):
        _atomic_write_text(out / name, text)
        written.append(out / name)
    return written


def _fmt(value: float | None, percent: bool = True) -> str:
    if value is None:
        return "-"
    return f"{100.0 * value:5.1f}%" if percent else f"{value:.4f}"


def format_summary(summary: dict[str, Any]) -> str:
    """A readable text summary of :meth:`ValidationResult.summary` (``--format table``)."""
    s = summary["settings"]
    lines = [
        f"Validation of D(s): {summary['simulations']} simulations, |G| {s['min_goals']}..{s['max_goals']}, "
        f"|S| = {s['states']} ({s['grid'][0]} x {s['grid'][1]} cells x {s['modes']} modes), "
        f"{s['window_cells']} x {s['window_cells']} window, beliefs {s['belief']}, seed {summary['seed']}",
        f"queries {summary['queries']}: match {_fmt(summary['match_rate'])}; "
        f"near-ties {summary['near_ties']} (match {_fmt(summary['match_rate_near_ties'])}), "
        f"excluding them {_fmt(summary['match_rate_excluding_near_ties'])}; "
        f"distinct near-ties {summary['distinct_near_ties']}, excluding them "
        f"{_fmt(summary['match_rate_excluding_distinct_near_ties'])}",
        f"metric's choice optimal for the ground truth: {_fmt(summary['truth_optimal_rate'])}; "
        f"mean relative loss of the expected gap on mismatches {_fmt(summary['mismatch_relative_regret'])}",
        f"regularised D(s) (lambda = {s['regularisation']:g}): "
        f"match {_fmt(summary['regularised_match_rate'])}",
        "",
        f"{'|G|':>4} {'sims':>5} {'queries':>8} {'match':>7} {'ties':>6} {'excl.':>7} {'optimal':>8} "
        f"{'lambda=1':>9}",
    ]
    for n, row in summary["by_goals"].items():
        lines.append(
            f"{n:>4} {row['simulations']:>5} {row['queries']:>8} {_fmt(row['match_rate']):>7} "
            f"{row['near_ties']:>6} {_fmt(row['match_rate_excluding_near_ties']):>7} "
            f"{_fmt(row['truth_optimal_rate']):>8} {_fmt(row['regularised_match_rate']):>9}")
    if summary["convergence"]:
        first = summary["convergence"][0]
        lines += ["", f"Monte-Carlo estimate vs exact I(s) ({first['queries']} queries, "
                      f"{first['states']} states):",
                  f"{'N':>7} {'variant':>11} {'MAE (nats)':>11} {'argmax':>7} {'strict':>7} {'regret':>8}"]
        rows = [*summary["convergence"]]
        rows += [{"n_samples": "inf", "variant": v, **r} for v, r in summary["convergence_limit"].items()]
        for row in rows:
            lines.append(
                f"{row['n_samples']!s:>7} {row['variant']:>11} {row['mae']:>11.4f} "
                f"{_fmt(row['argmax_agreement']):>7} {_fmt(row['argmax_agreement_strict']):>7} "
                f"{row['mean_regret']:>8.4f}")
    return "\n".join(lines)
