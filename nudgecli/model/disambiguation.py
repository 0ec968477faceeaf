"""The disambiguation metric: p(phi_m | g, s), exact mutual information (Eq. 13) and D(s)."""

from __future__ import annotations

import numpy as np
from scipy.special import xlogy

from nudgecli.model.inference import predict_belief


def mutual_information(belief: np.ndarray, likelihood: np.ndarray,
                       goal_transition: np.ndarray | None = None) -> np.ndarray:
    """Exact conditional mutual information ``I(phi_m; g | s)`` of Eq. 13, in nats.

    ``I(s) = sum_g w_g sum_f p(f | g, s) log(p(f | g, s) / p(f | s))`` with
    ``w = belief @ goal_transition`` and ``p(f | s) = sum_g w_g p(f | g, s)``; terms with
    ``p(f | g, s) = 0`` contribute 0.

    Parameters
    ----------
    belief
        ``(G,)`` belief over goals.
    likelihood
        ``(G, S, F)`` ``p(phi_m | g, s)``.
    goal_transition
        ``(G, G)`` row-stochastic, or ``None`` for the identity.

    Returns
    -------
    np.ndarray
        ``(S,)`` mutual information per state, in nats.
    """
    weights = predict_belief(belief, goal_transition)
    lik = np.asarray(likelihood, dtype=float)
    marginal = np.einsum("g,gsf->sf", weights, lik)
    # sum_g w_g sum_f L log L  -  sum_f p(f) log p(f): H(phi_m | s) - H(phi_m | g, s) form.
    conditional = np.einsum("g,gsf->s", weights, xlogy(lik, lik))
    info = conditional - xlogy(marginal, marginal).sum(axis=-1)
    return np.maximum(info, 0.0)
