"""The two criteria the validation compares, and how their argmaxes are taken.

- The metric: ``D(s) = I(s) - lambda R(s)``, the exact Eq. 13 mutual information
  (:func:`nudgecli.model.information.mutual_information`) and the model's expected distance
  (:func:`nudgecli.model.disambiguation.distance_regulariser`, in grid cells).
- The ground truth: a one-step look-ahead on the belief, computed exactly by enumerating the
  labels: the expected gap between the first and second maxima of the next belief
  (:func:`expected_top_two_gap`, the paper's words), or the expected fall of its entropy
  (:func:`expected_entropy_drop`).
"""

from __future__ import annotations

import numpy as np
from scipy.special import rel_entr

from nudgecli.model.disambiguation import distance_regulariser
from nudgecli.model.log_terms import xlogy
from nudgecli.model.ties import first_argmax


def expected_top_two_gap(belief: np.ndarray, likelihood: np.ndarray,
                         label_weights: np.ndarray | None = None) -> np.ndarray:
    """The ground truth: expected gap between the first and second maxima of the next belief.

    With ``b'(f) = bayes_update(b, p(f | ., s))`` and labels drawn from ``q(f)``:
    ``E_q[max1(b'(f)) - max2(b'(f))]``. By default ``q(f) = p(f | s) = sum_g b_g p(f | g, s)``
    (the expectation under the belief); since ``p(f | s) b'_g = b_g p(f | g, s)`` it equals
    ``sum_f [max1_g - max2_g](b_g p(f | g, s))`` (no division).

    Parameters
    ----------
    belief
        ``(..., G)`` belief(s), ``G >= 2``.
    likelihood
        ``(..., G, C, F)`` ``p(phi_m | g, s)`` of the candidate states.
    label_weights
        ``(..., C, F)`` ``q(f)`` per candidate (e.g. the true goal's ``p(f | g*, s)``), or
        ``None`` for ``p(f | s)``.

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
    gap = top[..., 1, :, :] - top[..., 0, :, :]  # (..., C, F): p(f | s) times the posterior gap
    if label_weights is None:
        return gap.sum(axis=-1)
    marginal = joint.sum(axis=-3)
    posterior_gap = np.divide(gap, marginal, out=np.zeros_like(gap), where=marginal > 0)
    return (np.asarray(label_weights, dtype=float) * posterior_gap).sum(axis=-1)


def expected_entropy_drop(belief: np.ndarray, likelihood: np.ndarray) -> np.ndarray:
    """Another ground truth: ``H(b) - E_{p(f | s)}[H(b'(f))]``, the expected one-step entropy fall.

    Parameters
    ----------
    belief
        ``(..., G)``.
    likelihood
        ``(..., G, C, F)``.

    Returns
    -------
    np.ndarray
        ``(..., C)`` in nats. (Algebraically this is the mutual information of Eq. 13; it is
        computed here from the posteriors, not from that formula.)
    """
    b = np.asarray(belief, dtype=float)
    joint = b[..., :, None, None] * np.asarray(likelihood, dtype=float)  # (..., G, C, F)
    marginal = joint.sum(axis=-3)  # (..., C, F)
    posterior = np.divide(joint, marginal[..., None, :, :], out=np.zeros_like(joint),
                          where=marginal[..., None, :, :] > 0)
    posterior_entropy = -xlogy(posterior, posterior).sum(axis=-3)  # (..., C, F)
    prior_entropy = -xlogy(b, b).sum(axis=-1)
    return prior_entropy[..., None] - (marginal * posterior_entropy).sum(axis=-1)


def expected_goal_distance(belief: np.ndarray, goal_cells: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """The regulariser of Eq. 16, ``sum_g b_g ||g - q(s)||`` in grid cells, per query.

    :func:`nudgecli.model.disambiguation.distance_regulariser` (``"expected"``) of each query.

    Parameters
    ----------
    belief
        ``(Q, G)``.
    goal_cells
        ``(G, 2)``.
    cells
        ``(Q, C, 2)`` cells of the candidates.

    Returns
    -------
    np.ndarray
        ``(Q, C)``.
    """
    goals = np.asarray(goal_cells, dtype=float)
    return np.stack([distance_regulariser(b, goals, np.asarray(c, dtype=float), "expected")
                     for b, c in zip(np.asarray(belief, dtype=float), cells, strict=True)])


def tolerant_argmax(values: np.ndarray, valid: np.ndarray | None = None,
                    tolerance: float = 1e-9) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """First maximum with ties up to a relative tolerance, the top-two margin and the near-tie flag.

    The choice is :func:`nudgecli.model.ties.first_argmax`: the first candidate within
    ``tolerance * max(1, |max|)`` of the maximum, so candidates with identical likelihood columns
    (whose computed values may differ in the last bit) resolve to the same, lowest-index state
    under every criterion.

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


def unweighted_limit(belief: np.ndarray, likelihood: np.ndarray) -> np.ndarray:
    """What the study's unweighted Monte-Carlo estimate converges to: the plain mean over goals with
    ``b_g > 0`` of ``KL(p(phi_m | g, s) || p(phi_m | s))``.

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


__all__ = ["distinct_margin", "expected_entropy_drop", "expected_goal_distance", "expected_top_two_gap",
           "tolerant_argmax", "unweighted_limit"]
