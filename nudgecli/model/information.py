"""Mutual information between the measured label and the goal (Eq. 13): exact, from label
counts, and the study's Monte-Carlo estimate."""

from __future__ import annotations

import numpy as np

from nudgecli.model.disambiguation_settings import Weighting
from nudgecli.model.inference import predict_belief
from nudgecli.model.interface import N_ACTIONS
from nudgecli.model.log_terms import xlogy
from nudgecli.model.world import N_MODES


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


# --- Monte-Carlo estimate (the study's scheme) ------------------------------------------------



def normalised_belief(belief: np.ndarray) -> np.ndarray:
    """``(G,)`` the belief divided by its sum; ValueError unless it is a non-negative vector
    with positive, finite mass."""
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
    # imported here: only the study's Monte-Carlo estimate (`study-code`) needs it, and
    # a worker that never gets here loads no scipy (0.2 s)
    from scipy.special import rel_entr

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
        return (kl * normalised_belief(belief)).sum(axis=-1)
    raise ValueError(f"weighting must be 'unweighted' or 'belief', got {weighting!r}")


def monte_carlo_mutual_information_per_sample(
        belief: np.ndarray, states: np.ndarray, p_a_given_sg: np.ndarray, mapping: np.ndarray,
        distortion: np.ndarray, rng: np.random.Generator, samples: int,
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
    b = normalised_belief(belief)
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
        distortion: np.ndarray, rng: np.random.Generator, samples: int,
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
    return mutual_information_from_counts(counts, normalised_belief(belief), weighting)


def monte_carlo_label_counts(
        belief: np.ndarray, states: np.ndarray, p_a_given_sg: np.ndarray, mapping: np.ndarray,
        distortion: np.ndarray, rng: np.random.Generator, samples: int,
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
    b = normalised_belief(belief)
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
