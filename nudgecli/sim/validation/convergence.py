"""The Monte-Carlo convergence study of the validation (step 7 of
:mod:`nudgecli.sim.validation.runner`): the study's per-sample estimator at each sample count
against the exact mutual information, per query and pooled over the run."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from nudgecli.model.information import (
    monte_carlo_label_counts,
    mutual_information_from_counts,
)
from nudgecli.sim.validation.criteria import (
    tolerant_argmax,
    unweighted_limit,
)
from nudgecli.sim.validation.settings import MC_VARIANTS, ValidationSettings
from nudgecli.sim.validation.world import ValidationWorld


def monte_carlo_estimates(rng: np.random.Generator, belief: np.ndarray, policy: np.ndarray,
                          modes: np.ndarray, mapping: np.ndarray, distortion: np.ndarray,
                          n_samples: int) -> dict[str, np.ndarray]:
    """The study's per-sample Monte-Carlo estimate of ``I(s)``, both weightings from the same samples.

    One call of :func:`nudgecli.model.information.monte_carlo_label_counts`, then the KL of
    each sampled goal's label histogram to the pooled one, averaged plainly or weighted by belief.

    Parameters
    ----------
    rng
        Source of randomness.
    belief
        ``(G,)``.
    policy
        ``(G, C, A)`` ``p(a | s, g)`` of the states to estimate.
    modes
        ``(C,)`` their modes.
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


def convergence_records(rng: np.random.Generator, settings: ValidationSettings, world: ValidationWorld,
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


def aggregate_convergence(
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


__all__ = ["aggregate_convergence", "convergence_records", "monte_carlo_estimates"]
