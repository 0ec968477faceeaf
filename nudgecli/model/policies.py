"""The equations of the prior-work assistance policies (arrays in, arrays out).

The policies themselves, one object per trial behind one interface, are
:mod:`nudgecli.sim.builtin_policies`; this module holds the mathematics they share with tests
and other callers: the confidence gap of ADA's arbitration and the
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
