"""Mode-switch criteria of prior work, as their sources define them (pure functions, arrays in
and out).

- :func:`gopinath_disambiguation`: Gopinath & Argall (RSS 2017)'s disambiguation metric per
  control mode, as the authors' MATLAB computes it;
- :func:`projected_kl`: the KL variant of the same code, ``KL(projected belief || current)``;
- :func:`project_beliefs`: this toolkit's projection of the belief that both consume;
- :func:`herlant_time_optimal_mode`: Herlant, Holladay & Srinivasa (HRI 2016)'s automatic
  time-optimal mode switching;
- :func:`choose_mode`: the chosen mode from per-mode scores, with the house's tie rule.

The seed paper's own criterion (Eq. 13's mutual information over the states that differ from
the robot's in mode alone) is :mod:`nudgecli.model.information` with the ``mode-only`` scope.

The MATLAB read is the public repository deepakgopinath/information_theoretic_intent_disambiguation
(commit 9b76e6c), folder ``PointRobotSimulation``: ``Utils/compute_disamb_metric.m`` (the metric),
``Utils/compute_kl_div.m`` (the divergence), ``R2/compute_disamb_heuristic_R2.m`` and
``R2/compute_projected_kl_R2.m`` (the projection horizons), ``R2/compute_optimal_mode_DISAMB_R2.m``
and ``R2/compute_optimal_mode_KL_R2.m`` (how the directions and dimensions of a mode combine),
``R2/compute_pg_projection_R2.m`` (the projection loop). Every constant below names the file and
the statement it comes from. The repository holds the point-robot simulations of the authors'
later paper (its README: the ICRA 2020 submission "Information Theoretic Characterization of Control
Modes for Intent Disambiguation"); its ``compute_disamb_metric`` computes the 2017 paper's metric,
and the KL variant is one of that later paper's criteria beside it.
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Sequence

import numpy as np

from nudgecli.model import portable_math
from nudgecli.model.inference import predict_belief
from nudgecli.model.interface import HARD_PUFF, HARD_SIP, SOFT_PUFF, SOFT_SIP, switch_mode
from nudgecli.model.ties import DEFAULT_TIE_RTOL, tied_with_max
from nudgecli.model.world import N_MODES, angle_difference

# --- constants of the MATLAB ------------------------------------------------------------------

#: ``w = 0.5`` in ``Utils/compute_disamb_metric.m``: the weight of the short-term term
#: ``Gamma * Omega * Lambda``; the long-term term ``Upsilon`` gets ``1 - w``.
GOPINATH_SHORT_TERM_WEIGHT = 0.5
#: ``projection_time = 1`` (first projection, ``pg1``) in ``R2/compute_disamb_heuristic_R2.m``, seconds.
GOPINATH_SHORT_HORIZON_S = 1.0
#: ``projection_time = 2`` (second projection, ``pg2``) in ``R2/compute_disamb_heuristic_R2.m``, seconds.
GOPINATH_LONG_HORIZON_S = 2.0
#: ``projection_time = 1`` in ``R2/compute_projected_kl_R2.m``: the KL variant's one horizon, seconds.
GOPINATH_KL_HORIZON_S = 1.0
#: ``delta_t = 0.1`` in ``R2/SimulateTraj_R2_With_Blending.m``: the step of the projection loop of
#: ``R2/compute_pg_projection_R2.m`` (``t_stamps = 0:delta_t:projection_time``, one update a step):
#: the projections' update interval whatever the study's step rate (``select_mode``).
GOPINATH_PROJECTION_DT_S = 0.1
#: MATLAB's ``realmin`` (``2^-1022``, the smallest normal double), which ``Utils/compute_kl_div.m``
#: adds to the ratio inside the logarithm: a goal the projection holds and the current belief
#: rules out costs ``-log2(realmin) = 1022`` bits per unit of projected mass, not infinity.
MATLAB_REALMIN = float(np.finfo(np.float64).tiny)

#: The labels of a small positive and a small negative motion along a mode's dimension, the
#: toolkit's stand-ins for the MATLAB's ``uh = +0.2`` and ``uh = -0.2`` along that dimension
#: (``R2/compute_optimal_mode_DISAMB_R2.m``, ``R2/compute_optimal_mode_KL_R2.m``). Soft Puff moves
#: +x, +y, or turns clockwise in the theta mode (:func:`nudgecli.model.interface.human_command`).
MOTION_LABELS = (SOFT_PUFF, SOFT_SIP)


def horizon_steps(horizon_s: float, dt: float) -> int:
    """The number of belief updates a projection of ``horizon_s`` seconds makes at one label every
    ``dt`` seconds (the MATLAB's loop: ``numel(0:delta_t:projection_time) - 1`` updates).

    Raises
    ------
    ValueError
        Unless ``horizon_s`` and ``dt`` are positive and the horizon holds at least one step.
    """
    if not (horizon_s > 0 and dt > 0):
        raise ValueError(f"horizon and step must be positive, got {horizon_s} and {dt}")
    # the slack counts 0.3 / 0.1 (2.9999999999999996) as the 3 steps MATLAB's colon operator makes
    steps = int(np.floor(horizon_s / dt + 1e-9))
    if steps < 1:
        raise ValueError(f"a horizon of {horizon_s} s holds no step of {dt} s")
    return steps


# --- the projection ---------------------------------------------------------------------------

def project_beliefs(belief: np.ndarray, likelihood: np.ndarray, labels: Sequence[int] = MOTION_LABELS,
                    steps: int = 1, goal_transition: np.ndarray | None = None) -> np.ndarray:
    """The belief after ``steps`` measured labels ``labels[d]`` in each mode ``m``: Eq. 7 (Eq. 6
    with ``goal_transition``), ``b' ∝ b * p(phi_m = labels[d] | g, s_m)``, repeated.

    This is the harness's projection, the closest analogue of the MATLAB's
    (``R2/compute_pg_projection_R2.m``, its ``bayes`` branch): there the robot is moved by a
    constant velocity ``uh`` along one dimension for ``projection_time`` seconds and the belief is
    updated at every ``delta_t`` by the point robot's own likelihood of ``uh``. Here beliefs change
    only through Eq. 7 on measured labels, so the motion along mode ``m``'s dimension is the label
    that produces it (Soft Puff one way, Soft Sip the other), and its likelihood is
    ``p(phi_m | g, s_m)`` at the state ``s_m`` that differs from the robot's in mode alone. Two
    differences remain. The state is held at ``s_m`` for all the steps, where the MATLAB moves the
    robot and re-evaluates the likelihood at each one (at the default 3 units/s and 1.95 rad/s a
    person crosses up to a cell or two, or a few headings, in the MATLAB's 1 s and 2 s). And the
    MATLAB's ``prior + 0.01 * rand`` against a collapsing posterior is left out: it needs a random
    draw, and the projection here is deterministic.

    Parameters
    ----------
    belief
        ``(G,)`` the current belief (normalised).
    likelihood
        ``(M, G, F)`` ``p(phi_m | g, s_m)``: row ``m`` at the state with mode ``m``
        (``model.likelihood[:, states, :].transpose(1, 0, 2)`` for the mode-only candidates).
    labels
        ``(D,)`` the measured labels of the directions (default Soft Puff, Soft Sip).
    steps
        Updates per projection (:func:`horizon_steps`), at least 1.
    goal_transition
        ``(G, G)`` row-stochastic ``p(g_t | g_{t-1})``, or ``None`` for Eq. 7's identity.

    Returns
    -------
    np.ndarray
        ``(M, D, G)`` projected beliefs, each normalised. Where a label has zero probability
        under every goal the projection keeps the belief it had (the model cannot explain the
        label, so it teaches nothing) instead of dividing by zero.
    """
    if steps < 1:
        raise ValueError(f"a projection makes at least one update, got steps={steps}")
    b = np.asarray(belief, dtype=float)
    lik = np.asarray(likelihood, dtype=float)
    label_lik = lik[:, :, list(labels)].transpose(0, 2, 1)  # (M, D, G)
    projected = np.broadcast_to(b, label_lik.shape).copy()
    for _ in range(steps):
        unnormalised = predict_belief(projected, goal_transition) * label_lik
        total = unnormalised.sum(axis=-1, keepdims=True)
        projected = np.divide(unnormalised, total, out=projected.copy(), where=total > 0)
    return projected


# --- Gopinath & Argall (2017): the disambiguation metric and its KL variant ---------------------

def _sum_of_pairwise_gaps(values: np.ndarray) -> np.ndarray:
    """``sum_{i<j} |v_i - v_j|`` over the last axis: MATLAB's ``sum(pdist(v))`` of a column
    vector (``pdist`` of scalars is their absolute differences, each pair once)."""
    gaps = np.abs(values[..., :, None] - values[..., None, :])  # (..., G, G), each pair twice
    return gaps.sum(axis=(-2, -1)) / 2.0


def gopinath_disamb_metric(short: np.ndarray, long: np.ndarray) -> np.ndarray:
    """``compute_disamb_metric(pg1, pg2)`` of ``Utils/compute_disamb_metric.m``, for any batch.

    ``D = w Gamma Omega Lambda + (1 - w) Upsilon`` with, for the short projection ``pg1``,
    ``Gamma = max pg1`` (how confident), ``Omega`` = the largest minus the second largest entry
    (how separated the leader is), ``Lambda = sum_{i<j} |pg1_i - pg1_j|`` (how spread), and for
    the change to the long projection ``pg2``, ``Upsilon = sum_{i<j} |(pg2 - pg1)_i - (pg2 - pg1)_j|``
    (how differently the goals keep moving); ``w = 0.5``. The current belief does not enter:
    it is only where both projections start.

    Parameters
    ----------
    short, long
        ``(..., G)`` projected beliefs at the short and the long horizon, ``G >= 2``.

    Returns
    -------
    np.ndarray
        ``(...)``, non-negative.
    """
    pg1 = np.asarray(short, dtype=float)
    pg2 = np.asarray(long, dtype=float)
    if pg1.shape != pg2.shape:
        raise ValueError(f"the two projections differ in shape: {pg1.shape} and {pg2.shape}")
    if pg1.shape[-1] < 2:  # the MATLAB indexes the second largest entry, pg1_sorted(end-1)
        raise ValueError(f"the metric needs at least two goals, got {pg1.shape[-1]}")
    ascending = np.sort(pg1, axis=-1)
    gamma = ascending[..., -1]
    omega = ascending[..., -1] - ascending[..., -2]
    lam = _sum_of_pairwise_gaps(pg1)
    upsilon = _sum_of_pairwise_gaps(pg2 - pg1)
    w = GOPINATH_SHORT_TERM_WEIGHT
    return w * gamma * omega * lam + (1.0 - w) * upsilon


def gopinath_disambiguation(short: np.ndarray, long: np.ndarray) -> np.ndarray:
    """Gopinath & Argall (2017)'s disambiguation score of each control mode.

    As ``R2/compute_optimal_mode_DISAMB_R2.m`` combines :func:`gopinath_disamb_metric`: per
    dimension ``k`` the metric of the positive motion plus the metric of the negative motion,
    ``D_k = D(pg1+, pg2+) + D(pg1-, pg2-)`` (a sum, not a mean), and per mode the sum of ``D_k``
    over its dimensions (``Dcm(i) = sum(Dk(cm{i}))``). Every mode of this toolkit moves one
    dimension, so a mode's score is its ``D_k``. The MATLAB's two horizons are 1 s and 2 s
    (:data:`GOPINATH_SHORT_HORIZON_S`, :data:`GOPINATH_LONG_HORIZON_S`).

    Parameters
    ----------
    short
        ``(M, D, G)`` the beliefs projected to the short horizon, for each mode ``m`` and
        direction ``d`` (:func:`project_beliefs` with the short horizon's steps).
    long
        ``(M, D, G)`` the same at the long horizon.

    Returns
    -------
    np.ndarray
        ``(M,)`` scores; the larger, the more the mode's motions disambiguate.
    """
    return gopinath_disamb_metric(short, long).sum(axis=-1)


def matlab_kl_bits(projected: np.ndarray, baseline: np.ndarray) -> np.ndarray:
    """``compute_kl_div(pg_projected, pg_baseline)`` of ``Utils/compute_kl_div.m``, in bits:
    ``-nansum(p .* log2(q ./ p + realmin))`` over the last axis.

    Its edge cases follow from MATLAB's arithmetic: a goal with ``p = 0`` gives ``0 * log2(inf)``
    or ``0 * log2(NaN)``, NaN, which ``nansum`` drops (the usual ``0 log 0 = 0``); a goal with
    ``p > 0`` and ``q = 0`` gives ``p log2(realmin) = -1022 p`` (finite) where the exact
    divergence is infinite.

    Parameters
    ----------
    projected, baseline
        ``(..., G)`` beliefs ``p`` and ``q``.

    Returns
    -------
    np.ndarray
        ``(...)`` the divergence ``KL(p || q)`` in bits.
    """
    p = np.asarray(projected, dtype=float)
    q = np.asarray(baseline, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        terms = p * portable_math.log2(q / p + MATLAB_REALMIN)
    return -np.nansum(terms, axis=-1)


def projected_kl(projected: np.ndarray, current: np.ndarray) -> np.ndarray:
    """The KL variant's score of each control mode: ``KL(projected || current)`` in bits, averaged
    over the directions.

    As ``R2/compute_optimal_mode_KL_R2.m`` combines ``R2/compute_projected_kl_R2.m``: for a mode of
    one dimension, ``EID(i) = sum_j (1 / 2) KL(pg(uh_j) || pg)`` over ``uh_j = -0.2, +0.2`` (a
    mean, unlike the disambiguation metric's sum), with the belief projected for
    :data:`GOPINATH_KL_HORIZON_S` = 1 s and the divergence of :func:`matlab_kl_bits`.

    Parameters
    ----------
    projected
        ``(M, D, G)`` the beliefs projected for each mode and direction (:func:`project_beliefs`).
    current
        ``(G,)`` the belief now (the MATLAB's ``pg``, ``varargin{3}``).

    Returns
    -------
    np.ndarray
        ``(M,)`` scores in bits; 0 for a mode whose motions leave the belief as it is.
    """
    return matlab_kl_bits(projected, np.asarray(current, dtype=float)).mean(axis=-1)


def choose_mode(scores: np.ndarray, current_mode: int, rtol: float = DEFAULT_TIE_RTOL) -> int:
    """The mode with the highest score; the current mode wins a tie (no needless switch), else
    the first tied mode in mode order (x, y, theta).

    Ties are :func:`nudgecli.model.ties.tied_with_max`'s (within ``rtol * max(1, |max|)``). The
    MATLAB's ``Utils/compute_best_mode.m`` differs: it counts modes within ``1e-3`` of each other,
    relative to the largest ``|score|``, as equivalent and keeps the current mode only when all
    modes are equivalent.

    Parameters
    ----------
    scores
        ``(M,)`` a score per mode, higher is better.
    current_mode
        The mode the robot is in.
    rtol
        Relative tie tolerance.

    Returns
    -------
    int
    """
    tied = tied_with_max(np.asarray(scores, dtype=float), rtol)
    if tied[current_mode]:
        return int(current_mode)
    return int(np.flatnonzero(tied)[0])


# --- Herlant, Holladay & Srinivasa (2016): automatic time-optimal mode switching ----------------

@functools.cache
def mode_switches_between(start: int, target: int) -> int:
    """The fewest hard blows that take the interface from mode ``start`` to mode ``target``.

    A breadth-first search over :func:`nudgecli.model.interface.switch_mode` with Hard Puff
    (one mode on) and Hard Sip (one mode back): with three modes every other mode is one blow
    away (two only for someone who cycles the long way with one kind of blow).
    """
    blows = 0
    reached = {start}
    frontier = {start}
    while target not in frontier:
        blown = {switch_mode(mode, label) for mode in frontier for label in (HARD_PUFF, HARD_SIP)}
        frontier = blown - reached
        if not frontier:
            raise ValueError(f"mode {target} cannot be reached from mode {start}")
        reached |= frontier
        blows += 1
    return blows


def _remaining(pose: np.ndarray, goal_pose: np.ndarray) -> np.ndarray:
    """``(3,)`` what is left to travel along x, y and theta (the shortest turn: a person can turn
    either way)."""
    left = np.asarray(goal_pose, dtype=float) - np.asarray(pose, dtype=float)
    left[2] = float(angle_difference(goal_pose[2], pose[2]))
    return left


def herlant_time_optimal_plan(pose: np.ndarray, goal_pose: np.ndarray, mode: int, speeds: np.ndarray,
                              switch_time: float, tolerance: np.ndarray) -> tuple[float, tuple[int, ...]]:
    """The time-optimal plan to the goal in the mode-augmented space: its duration and the order
    in which it visits the dimensions.

    Herlant, Holladay & Srinivasa (2016, HRI; author manuscript PMC6053067) model mode switching
    by time optimality, a mode switch costing time, and intervene by switching modes
    automatically. Only the paper's abstract and introduction were at hand: the plan below is
    this toolkit's reading of that model in its own world, not a transcription. In this world a
    mode moves the robot along its one dimension (x, y or the heading) at that mode's speed and
    the kinematics of the three are independent, so a plan is an order of the dimensions still to
    travel; a dimension within its tolerance needs no visit. Its duration is the travel,
    ``sum_k |remaining_k| / speeds_k`` (the same for every order), plus ``switch_time`` per hard
    blow: from ``mode`` to the first dimension and between consecutive ones
    (:func:`mode_switches_between`). All orders are tried (at most six). Among plans tied in
    duration (:func:`nudgecli.model.ties.tied_with_max`), one starting in the current mode wins,
    else the first in mode order x, y, theta.

    Parameters
    ----------
    pose, goal_pose
        ``(3,)`` ``(x, y, theta)`` of the robot and of the goal the plan drives to.
    mode
        The mode the robot is in.
    speeds
        ``(3,)`` the speed along x and y (units/s) and the turn rate (rad/s), all positive.
    switch_time
        Seconds one mode switch (one hard blow) takes, ``>= 0``.
    tolerance
        ``(3,)`` how far from the goal along x, y (units) and in heading (rad) counts as there.

    Returns
    -------
    duration : float
        Seconds, travel and switches.
    order : tuple of int
        The dimensions in the order the plan visits them (empty when every one is within tolerance).
    """
    rates = np.asarray(speeds, dtype=float)
    bands = np.asarray(tolerance, dtype=float)
    if rates.shape != (N_MODES,) or not (rates > 0).all():
        raise ValueError(f"speeds must be {N_MODES} positive numbers, got {speeds}")
    if bands.shape != (N_MODES,) or not (bands >= 0).all():
        raise ValueError(f"tolerance must be {N_MODES} non-negative numbers, got {tolerance}")
    if not switch_time >= 0:
        raise ValueError(f"a mode switch takes a non-negative time, got {switch_time}")
    left = np.abs(_remaining(np.asarray(pose, dtype=float), np.asarray(goal_pose, dtype=float)))
    to_visit = [int(k) for k in np.flatnonzero(left > bands)]
    if not to_visit:
        return 0.0, ()
    travel = float((left[to_visit] / rates[to_visit]).sum())
    orders = list(itertools.permutations(to_visit))  # lexicographic: mode order on ties
    switches = [sum(mode_switches_between(a, b) for a, b in itertools.pairwise((mode, *order)))
                for order in orders]
    durations = travel + switch_time * np.array(switches, dtype=float)
    tied = np.flatnonzero(tied_with_max(-durations))  # the shortest, within the house's tolerance
    best = next((i for i in tied if orders[i][0] == mode), tied[0])
    return float(durations[best]), orders[best]


def herlant_time_optimal_mode(pose: np.ndarray, goal_pose: np.ndarray, mode: int, speeds: np.ndarray,
                              switch_time: float, tolerance: np.ndarray) -> int:
    """The mode Herlant et al.'s automatic switching puts the robot in: the mode the time-optimal
    plan to the goal (:func:`herlant_time_optimal_plan`) uses next, or the current mode when the
    plan starts in it or nothing is left to travel.

    Parameters and ties as :func:`herlant_time_optimal_plan`; ``goal_pose`` is the goal the
    autonomy drives to (the source assumes it known).

    Returns
    -------
    int
        A mode index (0 x, 1 y, 2 theta).
    """
    _, order = herlant_time_optimal_plan(pose, goal_pose, mode, speeds, switch_time, tolerance)
    return order[0] if order else int(mode)
