"""The disambiguation metric: p(phi_m | g, s), mutual information (Eq. 13, exact or Monte Carlo),
the distance regulariser, D(s) (Eq. 15), the candidate domains and s* (Eq. 16)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from scipy.special import rel_entr, xlogy

from nudgecli.errors import ProbabilityTableError
from nudgecli.model.inference import predict_belief
from nudgecli.model.interface import (
    N_ACTIONS,
    observation_model,
    validate_distortion_table,
    validate_mapping_table,
)
from nudgecli.model.ties import first_argmax
from nudgecli.model.world import (
    CELL_HEIGHT,
    CELL_WIDTH,
    N_CELLS_X,
    N_CELLS_Y,
    N_HEADINGS,
    N_MODES,
    X_MIN,
    Y_MIN,
    all_state_coordinates,
    cell_centre,
    state_coordinates,
    state_index,
)

#: Relative tolerance under which two D(s) values count as tied (first candidate wins).


def mutual_information(belief: np.ndarray, likelihood: np.ndarray,
                       goal_transition: np.ndarray | None = None) -> np.ndarray:
    """Exact conditional mutual information ``I(phi_m; g | s)`` of Eq. 13, in nats.

    ``I(s) = sum_g w_g sum_f p(f | g, s) log(p(f | g, s) / p(f | s))`` with
    ``w = belief @ goal_transition`` and ``p(f | s) = sum_g w_g p(f | g, s)``; terms with
    ``p(f | g, s) = 0`` contribute 0.

    Parameters
    ----------
    belief
        ``(G,)`` belief over goals, or ``(..., G)`` for many queries at once.
    likelihood
        ``(G, S, F)`` ``p(phi_m | g, s)``, or ``(..., G, S, F)`` matching a batch of beliefs.
    goal_transition
        ``(G, G)`` row-stochastic, or ``None`` for the identity.

    Returns
    -------
    np.ndarray
        ``(S,)`` mutual information per state, in nats (``(..., S)`` for a batch).
    """
    weights = predict_belief(belief, goal_transition)
    lik = np.asarray(likelihood, dtype=float)
    marginal = np.einsum("...g,...gsf->...sf", weights, lik)
    # sum_g w_g sum_f L log L  -  sum_f p(f) log p(f): H(phi_m | s) - H(phi_m | g, s) form.
    conditional = np.einsum("...g,...gsf->...s", weights, xlogy(lik, lik))
    info = conditional - xlogy(marginal, marginal).sum(axis=-1)
    return np.maximum(info, 0.0)


# --- observation model ------------------------------------------------------------------------

def _check_action_likelihood(p_a_given_sg: np.ndarray, name: str = "p(a | s, g)") -> np.ndarray:
    """Vectorised check of a ``(G, S, A)`` table: non-negative, finite, rows summing to 1."""
    arr = np.asarray(p_a_given_sg, dtype=float)
    if arr.ndim != 3 or arr.shape[2] != N_ACTIONS:
        raise ProbabilityTableError(f"{name}: expected shape (G, S, {N_ACTIONS}), got {arr.shape}")
    bad = ~np.isfinite(arr).all(axis=-1) | (arr < 0).any(axis=-1) | (np.abs(arr.sum(axis=-1) - 1.0) > 1e-6)
    if bad.any():
        g, s = (int(k) for k in np.argwhere(bad)[0])
        raise ProbabilityTableError(
            f"{name}: row (goal {g}, state {s}) = {arr[g, s].tolist()} is not a probability distribution")
    return arr


def observation_likelihood(p_a_given_sg: np.ndarray, mapping: np.ndarray,
                           distortion: np.ndarray, modes: np.ndarray | None = None) -> np.ndarray:
    """``p(phi_m | g, s) = sum_a sum_phi_i p(phi_m | phi_i) p(phi_i | a, m(s)) p(a | s, g)``.

    The mode of flat state ``s`` is ``m(s) = s % 3`` on the toolkit's grid, or ``modes[s]``.

    Parameters
    ----------
    p_a_given_sg
        ``(G, S, A)`` the human's action model.
    mapping
        ``(M, A, F)`` ``p(phi_i | a, m)``.
    distortion
        ``(F, F)`` ``p(phi_m | phi_i)`` (row intended, column measured).
    modes
        ``(S,)`` mode index of every state, for state spaces other than the 2400-state grid
        (``None``: ``s % 3``).

    Returns
    -------
    np.ndarray
        ``(G, S, F)``; each ``(g, s)`` row sums to 1.

    Raises
    ------
    ProbabilityTableError
        If a table has the wrong shape, a negative entry or a row not summing to 1 (naming it).
    """
    p_a = _check_action_likelihood(p_a_given_sg)
    measured_given_action = observation_model(validate_mapping_table(mapping),
                                              validate_distortion_table(distortion))  # (M, A, F)
    modes = np.arange(p_a.shape[1]) % N_MODES if modes is None else np.asarray(modes, dtype=int)
    if modes.shape != (p_a.shape[1],):
        raise ValueError(f"modes must have shape ({p_a.shape[1]},), got {modes.shape}")
    # (G, S, 1, A) @ (S, A, F) -> (G, S, 1, F)
    return (p_a[:, :, None, :] @ measured_given_action[modes])[:, :, 0, :]


# --- Monte-Carlo estimate (the study's scheme) ------------------------------------------------

Weighting = Literal["unweighted", "belief"]


def _normalised_belief(belief: np.ndarray) -> np.ndarray:
    b = np.asarray(belief, dtype=float)
    total = b.sum()
    # One sum and one min check everything (a NaN or inf makes the total non-finite).
    if b.ndim != 1 or b.size == 0 or not (np.isfinite(total) and total > 0) or b.min() < 0:
        raise ValueError(f"belief must be a non-negative (G,) vector with positive mass, got {b}")
    return b / total


def mutual_information_from_counts(counts: np.ndarray, belief: np.ndarray,
                                   weighting: Weighting = "unweighted") -> np.ndarray:
    """The study's MI estimate from sampled label histograms.

    With ``n_g`` the samples of goal ``g`` and ``N`` all samples of a state, the empirical
    ``p^(f | g, s) = counts[g, f] / n_g`` is compared with the pooled ``p^(f | s) = sum_g
    counts[g, f] / N`` by ``KL_g = sum_f rel_entr(p^(f | g, s), p^(f | s))``. ``"unweighted"`` is
    the study's plain mean of ``KL_g`` over the goals with ``n_g > 0`` (the belief enters only
    through how often each goal was sampled); ``"belief"`` is ``sum_g b_g KL_g`` over those goals,
    which converges to Eq. 13 as the samples grow. Histograms are float64 (the study's float32
    differs in the 7th digit).

    Parameters
    ----------
    counts
        ``(C, G, F)`` label counts per candidate state and sampled goal.
    belief
        ``(G,)`` belief (normalised here), used by ``"belief"`` weighting.
    weighting
        ``"unweighted"`` or ``"belief"``.

    Returns
    -------
    np.ndarray
        ``(C,)`` estimates in nats.
    """
    counts = np.asarray(counts, dtype=float)
    per_goal = counts.sum(axis=-1)  # (C, G)
    pooled = counts.sum(axis=-2)  # (C, F)
    pooled = pooled / pooled.sum(axis=-1, keepdims=True)
    appeared = per_goal > 0
    empirical = counts / np.where(appeared, per_goal, 1.0)[..., None]
    kl = rel_entr(empirical, pooled[:, None, :]).sum(axis=-1)  # (C, G); 0 for absent goals
    if weighting == "unweighted":
        return kl.sum(axis=-1) / appeared.sum(axis=-1)
    if weighting == "belief":
        return (kl * _normalised_belief(belief)).sum(axis=-1)
    raise ValueError(f"weighting must be 'unweighted' or 'belief', got {weighting!r}")


def monte_carlo_mutual_information_per_sample(
        belief: np.ndarray, states: np.ndarray, p_a_given_sg: np.ndarray, mapping: np.ndarray,
        distortion: np.ndarray, rng: np.random.Generator, samples: int = 250,
        weighting: Weighting = "unweighted") -> np.ndarray:
    """The study's per-sample Monte-Carlo MI estimate, one Python iteration per sample.

    For each state, ``samples`` one-step draws ``g ~ b``, ``a ~ p(a | s, g)``, ``phi_i ~ p(phi_i |
    a, m(s))``, ``phi_m ~ p(phi_m | phi_i)`` (each one ``rng.choice``, i.e. one uniform double
    each, in that order, state by state) fill the histograms of
    :func:`mutual_information_from_counts`. The study drew the ε-exploration coin and the random
    action separately; drawing ``a`` from the ε-greedy distribution is the same distribution.
    Deliberately unvectorised: it is the reference and the baseline of ``nudge bench``;
    :func:`monte_carlo_mutual_information` returns identical numbers for the same ``rng`` state.

    Parameters
    ----------
    belief
        ``(G,)`` belief (normalised here, as the study did).
    states
        ``(C,)`` flat state indices.
    p_a_given_sg
        ``(G, S, A)`` action model.
    mapping
        ``(M, A, F)`` ``p(phi_i | a, m)``.
    distortion
        ``(F, F)`` ``p(phi_m | phi_i)``.
    rng
        Source of randomness (consumes ``4 * samples * C`` doubles).
    samples
        Samples per state.
    weighting
        See :func:`mutual_information_from_counts`.

    Returns
    -------
    np.ndarray
        ``(C,)`` estimates in nats.
    """
    b = _normalised_belief(belief)
    p_a = np.asarray(p_a_given_sg, dtype=float)
    table_a = np.asarray(mapping, dtype=float)
    table_m = np.asarray(distortion, dtype=float)
    n_goals, n_labels = b.size, table_m.shape[-1]
    state_list = np.atleast_1d(np.asarray(states, dtype=int))
    estimates = np.empty(state_list.size)
    for c, s in enumerate(state_list):
        mode = int(s) % N_MODES
        counts = np.zeros((n_goals, n_labels))
        for _ in range(samples):
            g = rng.choice(n_goals, p=b)
            a = rng.choice(N_ACTIONS, p=p_a[g, s])
            phi_i = rng.choice(n_labels, p=table_a[mode, a])
            phi_m = rng.choice(n_labels, p=table_m[phi_i])
            counts[g, phi_m] += 1.0
        estimates[c] = mutual_information_from_counts(counts[None], b, weighting)[0]
    return estimates


def _inverse_cdf(cdf: np.ndarray, uniforms: np.ndarray) -> np.ndarray:
    """Index drawn by ``uniforms`` from rows ``cdf`` (``(..., K)``): exactly ``Generator.choice``'s
    ``cdf.searchsorted(u, side="right")``, so both implementations see the same draws."""
    return (cdf <= uniforms[..., None]).sum(axis=-1)


def _choice_cdf(p: np.ndarray) -> np.ndarray:
    """``Generator.choice``'s cdf of every row of ``p``: ``cumsum`` divided by its last entry."""
    cdf = np.cumsum(p, axis=-1)
    return cdf / cdf[..., -1:]


def monte_carlo_mutual_information(
        belief: np.ndarray, states: np.ndarray, p_a_given_sg: np.ndarray, mapping: np.ndarray,
        distortion: np.ndarray, rng: np.random.Generator, samples: int = 250,
        weighting: Weighting = "unweighted") -> np.ndarray:
    """Vectorised :func:`monte_carlo_mutual_information_per_sample`, identical numbers.

    All ``(C, samples, 4)`` uniforms are drawn in one call, in the per-sample version's order, and
    turned into draws by the same cdf comparison ``Generator.choice`` uses.

    Parameters
    ----------
    belief, states, p_a_given_sg, mapping, distortion, rng, samples, weighting
        As in :func:`monte_carlo_mutual_information_per_sample`.

    Returns
    -------
    np.ndarray
        ``(C,)`` estimates in nats.
    """
    counts = monte_carlo_label_counts(belief, states, p_a_given_sg, mapping, distortion, rng, samples)
    return mutual_information_from_counts(counts, _normalised_belief(belief), weighting)


def monte_carlo_label_counts(
        belief: np.ndarray, states: np.ndarray, p_a_given_sg: np.ndarray, mapping: np.ndarray,
        distortion: np.ndarray, rng: np.random.Generator, samples: int = 250,
        modes: np.ndarray | None = None) -> np.ndarray:
    """The sampled label histograms behind the Monte-Carlo estimate (the study's scheme).

    Per state, ``samples`` draws of ``g ~ b``, ``a ~ p(a | s, g)``, ``phi_i ~ p(phi_i | a, m(s))``,
    ``phi_m ~ p(phi_m | phi_i)``. Both weightings of :func:`mutual_information_from_counts` can be
    computed from the same counts.

    Parameters
    ----------
    belief
        ``(G,)`` belief (normalised here).
    states
        ``(C,)`` indices into the state axis of ``p_a_given_sg``.
    p_a_given_sg, mapping, distortion
        ``(G, S, A)``, ``(M, A, F)`` and ``(F, F)`` tables.
    rng
        Source of the ``(C, samples, 4)`` uniforms (one call).
    samples
        Samples per state.
    modes
        ``(C,)`` the mode of each of ``states`` (``None``: ``states % 3``, the toolkit's grid).

    Returns
    -------
    np.ndarray
        ``(C, G, F)`` float counts.
    """
    b = _normalised_belief(belief)
    state_list = np.atleast_1d(np.asarray(states, dtype=int))
    n_states = state_list.size
    n_goals = b.size
    cdf_goal = _choice_cdf(b)
    cdf_action = _choice_cdf(np.asarray(p_a_given_sg, dtype=float)[:, state_list])  # (G, C, A)
    cdf_intended = _choice_cdf(np.asarray(mapping, dtype=float))  # (M, A, F)
    cdf_measured = _choice_cdf(np.asarray(distortion, dtype=float))  # (F, F)
    n_labels = cdf_measured.shape[-1]
    state_modes = state_list % N_MODES if modes is None else np.atleast_1d(np.asarray(modes, dtype=int))
    if state_modes.shape != state_list.shape:
        raise ValueError(f"modes must match states ({state_list.shape}), got {state_modes.shape}")

    uniforms = rng.random((n_states, samples, 4))
    column = np.arange(n_states)[:, None]
    goal = _inverse_cdf(cdf_goal, uniforms[..., 0])  # (C, N)
    action = _inverse_cdf(cdf_action[goal, column], uniforms[..., 1])
    intended = _inverse_cdf(cdf_intended[state_modes[:, None], action], uniforms[..., 2])
    measured = _inverse_cdf(cdf_measured[intended], uniforms[..., 3])
    flat = (column * n_goals + goal) * n_labels + measured
    counts = np.bincount(flat.ravel(), minlength=n_states * n_goals * n_labels)
    return counts.reshape(n_states, n_goals, n_labels).astype(float)


# --- settings ----------------------------------------------------------------------------------

@dataclass(frozen=True)
class DisambiguationSettings:
    """How D(s) is computed and where s* is searched.

    Defaults follow the paper; :meth:`study` gives the original study software's choices.

    Attributes
    ----------
    estimator
        ``"exact"`` (Eq. 13 by enumeration) or ``"monte_carlo"`` (the study's sampling scheme).
    samples
        Monte-Carlo samples per candidate state.
    weighting
        How the Monte-Carlo estimate averages the per-goal KL: ``"belief"`` (Eq. 13/14) or
        ``"unweighted"`` (the study). The exact estimator is always belief-weighted.
    mi_weight
        ``w_I`` in ``D(s) = w_I I(s) - lambda R(s)``.
    distance_weight
        ``lambda``.
    distance
        ``"expected"``: ``R(s) = sum_g b_g ||g - q(s)||`` (Eq. 15); ``"to_mean"``:
        ``R(s) = ||q(s) - sum_g b_g g||`` (the study).
    distance_unit
        ``"cells"``: positions are cell indices ``(i, j)`` (one step along x or y is 1 whatever
        the cell's 4.2 x 3.4 size); ``"world"``: world units (see :func:`window_candidates`).
    window
        Side of the square window of cells around the current cell (odd: 3 or 5).
    domain
        ``"window"`` or ``"global"`` (every state off the goals' cells, all headings).
    rotation_gate
        Drop theta-mode candidates farther than this (world units) from the unweighted mean goal
        position; ``None`` keeps them all.
    scope
        ``"domain"``: the states of ``domain``; ``"mode-only"``: the states that differ from the
        current one in mode alone (:func:`mode_candidates`; the mode-switch policy's).
    """

    estimator: Literal["exact", "monte_carlo"] = "exact"
    samples: int = 250
    weighting: Weighting = "belief"
    mi_weight: float = 1.0
    distance_weight: float = 1.0
    distance: Literal["expected", "to_mean"] = "expected"
    distance_unit: Literal["cells", "world"] = "cells"
    window: int = 3
    domain: Literal["window", "global"] = "window"
    rotation_gate: float | None = None
    scope: Literal["domain", "mode-only"] = "domain"

    def __post_init__(self) -> None:
        choices = {"estimator": ("exact", "monte_carlo"), "weighting": ("unweighted", "belief"),
                   "distance": ("expected", "to_mean"), "distance_unit": ("cells", "world"),
                   "domain": ("window", "global"), "scope": ("domain", "mode-only")}
        for field_name, allowed in choices.items():
            if getattr(self, field_name) not in allowed:
                raise ValueError(f"{field_name} must be one of {allowed}, got {getattr(self, field_name)!r}")
        if self.window < 1 or self.window % 2 == 0:
            raise ValueError(f"window must be a positive odd number of cells (3 or 5), got {self.window}")
        if self.samples < 1:
            raise ValueError(f"samples must be at least 1, got {self.samples}")
        if self.rotation_gate is not None and self.rotation_gate < 0:
            raise ValueError(f"rotation_gate must be non-negative or None, got {self.rotation_gate}")

    @classmethod
    def study(cls) -> DisambiguationSettings:
        """The study software: MC 250 unweighted, 0.5 / 0.5, distance to the belief-weighted
        mean goal in world units, 5 x 5 window, theta candidates within 12 units of the goals."""
        return cls(estimator="monte_carlo", samples=250, weighting="unweighted", mi_weight=0.5,
                   distance_weight=0.5, distance="to_mean", distance_unit="world", window=5,
                   domain="window", rotation_gate=12.0)


# --- candidate domains -------------------------------------------------------------------------

@dataclass(frozen=True)
class Candidates:
    """The states s* is chosen from, in search order.

    Attributes
    ----------
    states
        ``(C,)`` flat state indices.
    cells
        ``(C, 2)`` cell indices ``(i, j)``.
    positions
        ``(C, 2)`` world positions used by world-unit distances and the rotation gate.
    """

    states: np.ndarray
    cells: np.ndarray
    positions: np.ndarray


def _goal_cell_ids(goal_cells: np.ndarray) -> np.ndarray:
    """``(N_X * N_Y,)`` bool: which flat cell ids ``i * N_Y + j`` hold a goal."""
    cells = np.asarray(goal_cells, dtype=int).reshape(-1, 2)
    occupied = np.zeros(N_CELLS_X * N_CELLS_Y, dtype=bool)
    occupied[cells[:, 0] * N_CELLS_Y + cells[:, 1]] = True
    return occupied


def _mean_goal_position(goal_cells: np.ndarray) -> np.ndarray:
    """``(2,)`` unweighted mean of the goals' cell centres (the rotation gate's reference)."""
    cells = np.asarray(goal_cells, dtype=int).reshape(-1, 2)
    return cell_centre(cells[:, 0], cells[:, 1]).mean(axis=0)


def _rotation_gate_keep(modes: np.ndarray, positions: np.ndarray, mean_goal: np.ndarray,
                        rotation_gate: float) -> np.ndarray:
    """``(C,)`` bool: False for theta-mode candidates farther than the gate from ``mean_goal``."""
    dx = positions[:, 0] - mean_goal[0]
    dy = positions[:, 1] - mean_goal[1]
    return (modes != N_MODES - 1) | (np.sqrt(dx * dx + dy * dy) <= rotation_gate)


class _WindowTable:
    """Every window slot's validity for every cell of one goal layout, built once.

    A slot is ``(dx, dy, mode)``, ordered row-major over dx, dy, mode. With the flat index
    ``((i * 10 + j) * 8 + h) * 3 + m``, the slot's state is ``cell_id * 24 + h * 3 +
    slot_offset`` with ``slot_offset = (dx * 10 + dy) * 24 + mode``, so a query is a row lookup
    and one masked add.
    """

    def __init__(self, goal_cells: np.ndarray, window: int) -> None:
        if window < 1 or window % 2 == 0:
            raise ValueError(f"window must be a positive odd number of cells, got {window}")
        half = window // 2
        dx, dy, mode = (a.ravel() for a in np.meshgrid(np.arange(-half, half + 1), np.arange(-half, half + 1),
                                                       np.arange(N_MODES), indexing="ij"))
        self.offsets = np.stack([dx, dy], axis=1)  # (K, 2)
        self.modes = mode
        self.slot_offset = (dx * N_CELLS_Y + dy) * (N_HEADINGS * N_MODES) + mode
        self.displacement = np.stack([dx * CELL_WIDTH, dy * CELL_HEIGHT], axis=1)
        i, j = np.divmod(np.arange(N_CELLS_X * N_CELLS_Y), N_CELLS_Y)
        ci = i[:, None] + dx[None, :]
        cj = j[:, None] + dy[None, :]
        on_grid = (ci >= 0) & (ci < N_CELLS_X) & (cj >= 0) & (cj < N_CELLS_Y)
        occupied = _goal_cell_ids(goal_cells)
        cell_ids = np.where(on_grid, ci * N_CELLS_Y + cj, 0)
        self.valid = on_grid & ~occupied[cell_ids]  # (cells, K)
        self.mean_goal = _mean_goal_position(goal_cells)

    def candidates(self, current_state: int, robot_position: np.ndarray | None,
                   rotation_gate: float | None) -> Candidates:
        # Integer arithmetic on the flat index (cheaper than np.unravel_index for one state).
        cell_id, rest = divmod(int(current_state), N_HEADINGS * N_MODES)
        i, j = divmod(cell_id, N_CELLS_Y)
        if robot_position is None:
            origin = np.array([X_MIN + CELL_WIDTH * (i + 0.5), Y_MIN + CELL_HEIGHT * (j + 0.5)])
        else:
            origin = np.asarray(robot_position, dtype=float)[:2]
        keep = self.valid[cell_id]
        positions = self.displacement + origin
        if rotation_gate is not None:
            keep = keep & _rotation_gate_keep(self.modes, positions, self.mean_goal, rotation_gate)
        base = cell_id * (N_HEADINGS * N_MODES) + (rest // N_MODES) * N_MODES
        return Candidates(states=self.slot_offset[keep] + base, cells=self.offsets[keep] + (i, j),
                          positions=positions[keep])


def window_candidates(current_state: int, goal_cells: np.ndarray, window: int = 3,
                      robot_position: np.ndarray | None = None,
                      rotation_gate: float | None = None) -> Candidates:
    """The ``window x window`` cells around the current cell, all modes, the current heading.

    Order: row-major over ``dx``, then ``dy``, then mode. Off-grid cells and goal cells are never
    candidates. A candidate's world position is the study's ``robot_position + (dx * 4.2, dy *
    3.4)`` (the cell centre when the robot sits at its cell's centre). Repeated queries on one
    layout are faster through :meth:`DisambiguationModel.candidates`, which keeps the tables.

    Parameters
    ----------
    current_state
        Flat index of the robot's discrete state.
    goal_cells
        ``(G, 2)`` goal cells.
    window
        Odd window side (3 or 5).
    robot_position
        ``(2,)`` continuous robot position; ``None`` uses the current cell's centre.
    rotation_gate
        See :class:`DisambiguationSettings`.

    Returns
    -------
    Candidates
    """
    return _WindowTable(goal_cells, int(window)).candidates(current_state, robot_position, rotation_gate)


def mode_candidates(current_state: int, robot_position: np.ndarray | None = None) -> Candidates:
    """The states that differ from ``current_state`` in mode alone: its cell and heading, every
    mode, in mode order (the current state included: keeping the mode is a choice too).

    Parameters
    ----------
    current_state
        Flat index of the robot's discrete state.
    robot_position
        ``(2,)`` continuous robot position (every candidate's); ``None`` uses the cell's centre.

    Returns
    -------
    Candidates
    """
    i, j, h, _ = (int(v) for v in state_coordinates(int(current_state)))
    modes = np.arange(N_MODES)
    position = cell_centre(i, j) if robot_position is None else np.asarray(robot_position, dtype=float)[:2]
    return Candidates(states=np.asarray(state_index(i, j, h, modes), dtype=np.int64),
                      cells=np.tile([i, j], (N_MODES, 1)), positions=np.tile(position, (N_MODES, 1)))


def global_candidates(goal_cells: np.ndarray, rotation_gate: float | None = None) -> Candidates:
    """Every state whose cell is not a goal cell (all headings and modes), in flat-index order.

    World positions are cell centres.

    Parameters
    ----------
    goal_cells
        ``(G, 2)`` goal cells.
    rotation_gate
        See :class:`DisambiguationSettings`.

    Returns
    -------
    Candidates
    """
    i, j, _, m = all_state_coordinates().T
    positions = cell_centre(i, j)
    keep = ~_goal_cell_ids(goal_cells)[i * N_CELLS_Y + j]
    if rotation_gate is not None:
        keep &= _rotation_gate_keep(m, positions, _mean_goal_position(goal_cells), rotation_gate)
    return Candidates(states=np.flatnonzero(keep), cells=np.column_stack([i[keep], j[keep]]),
                      positions=positions[keep])


# --- distance regulariser and D(s) --------------------------------------------------------------

def _distance(weights: np.ndarray, goals: np.ndarray, positions: np.ndarray, kind: str) -> np.ndarray:
    if kind == "expected":
        dx = positions[:, 0:1] - goals[:, 0]
        dy = positions[:, 1:2] - goals[:, 1]
        return np.sqrt(dx * dx + dy * dy) @ weights
    if kind == "to_mean":
        mean = weights @ goals
        dx = positions[:, 0] - mean[0]
        dy = positions[:, 1] - mean[1]
        return np.sqrt(dx * dx + dy * dy)
    raise ValueError(f"distance kind must be 'expected' or 'to_mean', got {kind!r}")


def distance_regulariser(belief: np.ndarray, goal_positions: np.ndarray, positions: np.ndarray,
                         kind: Literal["expected", "to_mean"] = "expected") -> np.ndarray:
    """``R(s)``: how far candidate positions are from the goals under the belief.

    Parameters
    ----------
    belief
        ``(G,)`` belief (normalised here).
    goal_positions
        ``(G, 2)`` goal positions, in the same unit as ``positions``.
    positions
        ``(C, 2)`` candidate positions ``q(s)``.
    kind
        ``"expected"``: ``sum_g b_g ||g - q(s)||``; ``"to_mean"``: ``||q(s) - sum_g b_g g||``.

    Returns
    -------
    np.ndarray
        ``(C,)``.
    """
    b = _normalised_belief(belief)
    goals = np.asarray(goal_positions, dtype=float).reshape(-1, 2)
    if goals.shape[0] != b.size:
        raise ValueError(f"{goals.shape[0]} goal positions for a belief over {b.size} goals")
    return _distance(b, goals, np.asarray(positions, dtype=float).reshape(-1, 2), kind)


@dataclass(frozen=True, eq=False)
class DisambiguationModel:
    """What D(s) needs about one layout and one participant model, computed once per trial.

    Construct it with the four inputs; the tables are validated and the rest is derived.

    Attributes
    ----------
    goal_cells
        ``(G, 2)`` goal cells.
    p_a_given_sg
        ``(G, S, A)`` the human action model.
    mapping
        ``(M, A, F)`` ``p(phi_i | a, m)``.
    distortion
        ``(F, F)`` ``p(phi_m | phi_i)``.
    likelihood
        ``(G, S, F)`` ``p(phi_m | g, s)`` (derived).
    """

    goal_cells: np.ndarray
    p_a_given_sg: np.ndarray
    mapping: np.ndarray
    distortion: np.ndarray
    likelihood: np.ndarray = field(init=False, repr=False)
    # State-major copies for fast gathers: (S, G * F) likelihood rows and (S, G) sum_f p log p,
    # the belief-independent half of Eq. 13.
    _likelihood_rows: np.ndarray = field(init=False, repr=False)
    _xlogx_rows: np.ndarray = field(init=False, repr=False)
    _goal_positions: dict[str, np.ndarray] = field(init=False, repr=False)
    _window_tables: dict[int, _WindowTable] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        cells = np.asarray(self.goal_cells, dtype=int).reshape(-1, 2)
        likelihood = observation_likelihood(self.p_a_given_sg, self.mapping, self.distortion)
        if likelihood.shape[0] != cells.shape[0]:
            raise ValueError(f"{cells.shape[0]} goal cells but p(a | s, g) has {likelihood.shape[0]} goals")
        set_ = object.__setattr__  # frozen dataclass: derived fields are set once, here
        set_(self, "goal_cells", cells)
        set_(self, "p_a_given_sg", np.asarray(self.p_a_given_sg, dtype=float))
        set_(self, "mapping", np.asarray(self.mapping, dtype=float))
        set_(self, "distortion", np.asarray(self.distortion, dtype=float))
        set_(self, "likelihood", likelihood)
        n_goals, n_states, n_labels = likelihood.shape
        set_(self, "_likelihood_rows",
             np.ascontiguousarray(likelihood.transpose(1, 0, 2)).reshape(n_states, n_goals * n_labels))
        set_(self, "_xlogx_rows", np.ascontiguousarray(xlogy(likelihood, likelihood).sum(axis=-1).T))
        set_(self, "_goal_positions", {"cells": cells.astype(float),
                                       "world": cell_centre(cells[:, 0], cells[:, 1])})
        set_(self, "_window_tables", {})

    @property
    def n_goals(self) -> int:
        return int(self.goal_cells.shape[0])

    def goal_positions(self, unit: Literal["cells", "world"]) -> np.ndarray:
        """``(G, 2)`` goal positions: cell indices (``"cells"``) or cell centres (``"world"``)."""
        return self._goal_positions[unit]

    def candidates(self, current_state: int, settings: DisambiguationSettings,
                   robot_position: np.ndarray | None = None) -> Candidates:
        """The candidates of ``settings.domain`` for this layout (:func:`window_candidates` or
        :func:`global_candidates`, or :func:`mode_candidates` for the mode-only scope), with the
        window tables kept between calls."""
        if settings.scope == "mode-only":
            return mode_candidates(current_state, robot_position)
        if settings.domain == "global":
            return global_candidates(self.goal_cells, settings.rotation_gate)
        table = self._window_tables.get(settings.window)
        if table is None:
            table = self._window_tables[settings.window] = _WindowTable(self.goal_cells, settings.window)
        return table.candidates(current_state, robot_position, settings.rotation_gate)

    def mutual_information(self, weights: np.ndarray, states: np.ndarray) -> np.ndarray:
        """Exact Eq. 13 at ``states``: the value of :func:`mutual_information`, from the
        precomputed tables.

        Parameters
        ----------
        weights
            ``(G,)`` normalised goal weights (already propagated through any goal transition).
        states
            ``(C,)`` flat state indices.

        Returns
        -------
        np.ndarray
            ``(C,)`` in nats.
        """
        rows = self._likelihood_rows.take(states, axis=0)  # (C, G * F)
        n_labels = self.likelihood.shape[2]
        # sum_g w_g p(f | g, s) as one product with the (G * F, F) matrix kron(w, I_F).
        spread = (weights[:, None, None] * np.eye(n_labels)).reshape(-1, n_labels)
        marginal = rows @ spread  # (C, F)
        conditional = self._xlogx_rows.take(states, axis=0) @ weights  # (C,)
        return np.maximum(conditional - xlogy(marginal, marginal).sum(axis=-1), 0.0)


@dataclass(frozen=True)
class DisambiguationScores:
    """D(s) and its two terms over a candidate set.

    Attributes
    ----------
    information
        ``(C,)`` ``I(s)`` in nats (exact or estimated).
    distance
        ``(C,)`` ``R(s)``.
    score
        ``(C,)`` ``D(s) = w_I I(s) - lambda R(s)``.
    """

    information: np.ndarray
    distance: np.ndarray
    score: np.ndarray


def disambiguation_scores(belief: np.ndarray, model: DisambiguationModel, candidates: Candidates,
                          settings: DisambiguationSettings | None = None,
                          rng: np.random.Generator | None = None,
                          goal_transition: np.ndarray | None = None) -> DisambiguationScores:
    """``D(s) = w_I I(s) - lambda R(s)`` (Eq. 15 and its study variant) for every candidate.

    Parameters
    ----------
    belief
        ``(G,)`` belief.
    model
        The layout's :class:`DisambiguationModel`.
    candidates
        From :meth:`DisambiguationModel.candidates` (or :func:`window_candidates`, :func:`global_candidates`).
    settings
        Paper defaults when ``None``.
    rng
        Required by the Monte-Carlo estimator.
    goal_transition
        ``(G, G)`` row-stochastic ``p(g_t | g_{t-1})`` of Eq. 13 (``None``: the identity). The
        distance term uses the belief itself, as in Eq. 15.

    Returns
    -------
    DisambiguationScores
    """
    settings = settings or DisambiguationSettings()
    b = _normalised_belief(belief)
    if b.size != model.n_goals:
        raise ValueError(f"belief over {b.size} goals for a layout with {model.n_goals}")
    weights = b if goal_transition is None else predict_belief(b, goal_transition)
    if settings.estimator == "exact":
        information = model.mutual_information(weights, candidates.states)
    else:
        if rng is None:
            raise ValueError("the Monte-Carlo estimator needs an rng (np.random.Generator)")
        information = monte_carlo_mutual_information(weights, candidates.states, model.p_a_given_sg,
                                                     model.mapping, model.distortion, rng,
                                                     settings.samples, settings.weighting)
    positions = candidates.cells if settings.distance_unit == "cells" else candidates.positions
    distance = _distance(b, model.goal_positions(settings.distance_unit), positions, settings.distance)
    score = settings.mi_weight * information - settings.distance_weight * distance
    return DisambiguationScores(information=information, distance=distance, score=score)


@dataclass(frozen=True)
class DisambiguationChoice:
    """The maximally disambiguating state and how it was chosen.

    Attributes
    ----------
    state
        Flat index of s*.
    index
        Position of s* in ``candidates``.
    candidates
        The candidate set searched.
    scores
        D(s) and its terms over the candidates.
    """

    state: int
    index: int
    candidates: Candidates
    scores: DisambiguationScores


def maximally_disambiguating_state(belief: np.ndarray, model: DisambiguationModel, current_state: int,
                                   settings: DisambiguationSettings | None = None,
                                   robot_position: np.ndarray | None = None,
                                   rng: np.random.Generator | None = None,
                                   goal_transition: np.ndarray | None = None) -> DisambiguationChoice:
    """``s* = argmax_s D(s)`` over the settings' domain (Eq. 16), first on ties.

    Parameters
    ----------
    belief
        ``(G,)`` belief.
    model
        The layout's :class:`DisambiguationModel`.
    current_state
        Flat index of the robot's discrete state.
    settings
        Paper defaults when ``None``.
    robot_position
        ``(2,)`` continuous robot position (world-unit distances and the rotation gate).
    rng
        Required by the Monte-Carlo estimator.
    goal_transition
        See :func:`disambiguation_scores`.

    Returns
    -------
    DisambiguationChoice

    Raises
    ------
    ValueError
        If the domain holds no candidate.
    """
    settings = settings or DisambiguationSettings()
    candidates = model.candidates(current_state, settings, robot_position)
    if candidates.states.size == 0:
        raise ValueError(f"no candidate state around state {current_state}")
    scores = disambiguation_scores(belief, model, candidates, settings, rng, goal_transition)
    index = int(first_argmax(scores.score))
    return DisambiguationChoice(state=int(candidates.states[index]), index=index, candidates=candidates,
                                scores=scores)
