"""The equations of the prior-work assistance policies (arrays in, arrays out).

The policies themselves, one object per trial behind one interface, are
:mod:`nudgecli.sim.builtin_policies`; this module holds the mathematics they share with tests
and other callers: the confidence gap of ADA's arbitration, the first-order hindsight sum, and the
expected-posterior-entropy and pairwise-KL rankings of mode-only states.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from nudgecli.model.log_terms import xlogy

ModeCriterion = Literal["disamb", "entropy", "kl"]


def confidence_gap(belief: np.ndarray) -> float:
    """``p1 - p2``: the highest belief minus the second highest (a single goal's belief is its gap)."""
    b = np.asarray(belief, dtype=float)
    if b.size < 2:
        return float(b.max()) if b.size else 0.0
    top2 = np.partition(b, b.size - 2)[-2:]
    return float(top2[1] - top2[0])


def gap_gated_alpha(alpha: float, belief: np.ndarray, gap: float) -> float:
    """alpha, or 0 unless the confidence gap ``p1 - p2`` exceeds ``gap``.

    The arbitration gate of the open hindsight-optimisation code (assist only when the most
    likely goal leads the second by more than 0.4), applied to policy blending's alpha
    (Dragan & Srinivasa 2013, Eq. 1: ``u = alpha u_r + (1 - alpha) u_h``, alpha a function of the
    prediction's confidence).
    """
    return alpha if confidence_gap(belief) > gap else 0.0


def hindsight_assistance(belief: np.ndarray, goal_commands: np.ndarray, gain: float) -> np.ndarray:
    """The first-order hindsight-optimisation assistance: ``gain * sum_g b_g u_a^g``.

    Javdani et al. (2015, RSS; 2018, IJRR) choose the robot action maximising the belief-weighted
    sum of the per-goal action values, ``argmax_a sum_g b(g) Q_g(x, u, a)`` (the hindsight
    approximation of the POMDP's value); linearised around the user's input (their first-order
    approximation) the assistance is the belief-weighted sum of the per-goal autonomous
    commands, added to the user's command.

    Parameters
    ----------
    belief
        ``(G,)`` belief over goals (Eq. 7 here, in place of their max-ent IOC predictor).
    goal_commands
        ``(G, 3)`` the autonomous command ``u_a^g`` towards each goal.
    gain
        Scale of the sum (1: the sum itself).

    Returns
    -------
    np.ndarray
        ``(3,)``.
    """
    b = np.asarray(belief, dtype=float)
    commands = np.asarray(goal_commands, dtype=float).reshape(b.size, -1)
    return gain * (b @ commands)


def hindsight_command(u_h: np.ndarray, belief: np.ndarray, goal_commands: np.ndarray,
                      gain: float) -> np.ndarray:
    """``u_f = u_h + gain * sum_g b_g u_a^g`` (:func:`hindsight_assistance` added to the person's)."""
    return np.asarray(u_h, dtype=float) + hindsight_assistance(belief, goal_commands, gain)


def expected_posterior_entropy(weights: np.ndarray, likelihood: np.ndarray) -> np.ndarray:
    """``E_{phi ~ p(phi | s)} H(b'(. | phi, s))`` per candidate state, in nats.

    Parameters
    ----------
    weights
        ``(G,)`` normalised belief.
    likelihood
        ``(C, G, F)`` ``p(phi_m | g, s)`` at each candidate state.

    Returns
    -------
    np.ndarray
        ``(C,)``.
    """
    joint = np.asarray(weights, dtype=float)[None, :, None] * np.asarray(likelihood, dtype=float)  # (C, G, F)
    marginal = joint.sum(axis=1, keepdims=True)  # (C, 1, F)
    # sum_f p(f) H(b'|f) = -sum_{g,f} p(g, f) log p(g | f)
    posterior = np.divide(joint, marginal, out=np.zeros_like(joint), where=marginal > 0)
    return -xlogy(joint, posterior).sum(axis=(1, 2))


def weighted_pairwise_kl(weights: np.ndarray, likelihood: np.ndarray) -> np.ndarray:
    """``sum_{g != g'} b_g b_g' KL(p(. | g, s) || p(. | g', s))`` per candidate state, in nats.

    How far apart the goals' label distributions are at ``s``: the larger, the more the next
    label separates the goals the belief still holds.

    Parameters
    ----------
    weights
        ``(G,)`` normalised belief.
    likelihood
        ``(C, G, F)`` ``p(phi_m | g, s)``.

    Returns
    -------
    np.ndarray
        ``(C,)`` (``inf`` where a goal gives a label another goal never gives).
    """
    # imported here: only the mode-switch baseline's KL criterion needs it, and
    # a worker that never gets here loads no scipy (0.2 s)
    from scipy.special import rel_entr

    p = np.asarray(likelihood, dtype=float)
    w = np.asarray(weights, dtype=float)
    divergence = rel_entr(p[:, :, None, :], p[:, None, :, :]).sum(axis=-1)  # (C, G, G); diagonal 0
    pair_weights = np.outer(w, w)
    with np.errstate(invalid="ignore"):  # inf * 0 for a goal without belief: that pair counts 0
        terms = np.where(pair_weights > 0, divergence * pair_weights, 0.0)
    return terms.sum(axis=(1, 2))
