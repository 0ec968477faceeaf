"""Recursive Bayesian goal inference (paper Eq. 6 and 7), entropy and the optional decay."""

from __future__ import annotations

import numpy as np


def predict_belief(belief: np.ndarray, goal_transition: np.ndarray | None = None) -> np.ndarray:
    """The prior for the next step, ``sum_g' b(g') p(g | g')`` (the bracket of Eq. 6).

    Parameters
    ----------
    belief
        ``(G,)`` current belief.
    goal_transition
        ``(G, G)`` row-stochastic ``p(g_t | g_{t-1})`` (row = previous goal), or ``None`` for
        the identity (Eq. 7).

    Returns
    -------
    np.ndarray
        ``(G,)``.
    """
    b = np.asarray(belief, dtype=float)
    return b if goal_transition is None else b @ np.asarray(goal_transition, dtype=float)


def bayes_update(belief: np.ndarray, likelihood: np.ndarray,
                 goal_transition: np.ndarray | None = None) -> np.ndarray:
    """One step of Eq. 6 (Eq. 7 when ``goal_transition`` is ``None``).

    Parameters
    ----------
    belief
        ``(G,)`` belief before the observation.
    likelihood
        ``(G,)`` ``p(phi_m | g, s)`` of the observed label at the current state.
    goal_transition
        ``(G, G)`` row-stochastic goal transition, or ``None`` for the identity.

    Returns
    -------
    np.ndarray
        ``(G,)`` the normalised posterior.

    Raises
    ------
    ValueError
        If every goal has zero posterior mass (the observation is impossible under the model).
    """
    unnormalised = predict_belief(belief, goal_transition) * np.asarray(likelihood, dtype=float)
    total = unnormalised.sum()
    if not total > 0.0:
        raise ValueError("the observation has zero probability under every goal")
    return unnormalised / total
