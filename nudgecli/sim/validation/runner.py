"""Running the validation: settings, one simulation per world, the result and its summary.

One simulation ``k`` (randomness from ``nudgecli.rng.generator(seed, "validation", k)`` only):

1. ``|G| = min_goals + k mod (max_goals - min_goals + 1)``: the goal counts are stepped
   cyclically, so 100 simulations over 3..30 goals give 4 worlds for each of 3..18 goals and
   3 for each of 19..30.
2. Draw the reading's world (:mod:`nudgecli.sim.validation.world`): goal cells, the goal MDPs,
   the likelihood ``p(phi_m | g, s)``.
3. Queries: in the two-mode world every state off the goal cells (``|S| - 2 |G|``); in the
   three-mode world every cell off the goals at a random heading and mode. Each query gets a
   belief (the reading's: ``Dirichlet(c)``, or split between two goals) and its neighbourhood.
4. ``s*``: the argmax over the candidates of ``D(s) = I(s) - lambda R(s)`` (the reading's
   lambda), first candidate on ties (:func:`nudgecli.model.ties.first_argmax`).
5. The ground truth (:mod:`nudgecli.sim.validation.criteria`): the argmax of the reading's
   one-step look-ahead, first on ties.
6. The match (the reading's rule); near-ties, distinct near-ties, whether s* attains the
   ground truth's maximum (``truth_optimal``) and the expected gap it gives up (``truth_regret``)
   are recorded beside it, and so is the match of the lambda = ``regularisation`` variant.
7. Monte-Carlo convergence (``mc_queries`` queries spread over the simulations): the study's
   per-sample estimator at each sample count against the exact mutual information.

The settings are in :mod:`nudgecli.sim.validation.settings`, the convergence study (step 7) in
:mod:`nudgecli.sim.validation.convergence`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from nudgecli.model.information import mutual_information
from nudgecli.model.interface import default_distortion_table, default_mapping_table
from nudgecli.rng import generator
from nudgecli.sim.validation.convergence import aggregate_convergence, convergence_records
from nudgecli.sim.validation.criteria import (
    distinct_margin,
    expected_entropy_drop,
    expected_goal_distance,
    expected_top_two_gap,
    tolerant_argmax,
)
from nudgecli.sim.validation.readings import READINGS, TWO_GOAL_REST, TWO_GOAL_SPLIT, Reading, get_reading
from nudgecli.sim.validation.settings import ValidationSettings
from nudgecli.sim.validation.world import (
    ValidationWorld,
    neighbourhoods,
    sample_study_world,
    sample_world,
    study_queries,
)

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
    mc_queries_run
        The queries the Monte-Carlo convergence study ran: ``settings.mc_queries``, or fewer where
        a simulation's world holds fewer queries than its share of them.
    """

    settings: ValidationSettings
    queries: dict[str, np.ndarray]
    convergence: list[dict[str, Any]] = field(default_factory=list)
    convergence_limit: dict[str, dict[str, Any]] = field(default_factory=dict)
    mc_queries_run: int = 0

    def summary(self) -> dict[str, Any]:
        """The JSON-ready summary (only reproducible values; no timings)."""
        q = self.queries
        by_goals: dict[str, dict[str, Any]] = {}
        for n in np.unique(q["n_goals"]):
            sel = q["n_goals"] == n
            by_goals[str(int(n))] = {"simulations": int(np.unique(q["simulation"][sel]).size),
                                     **_rates(q, sel)}
        return {
            "reading": self.settings.reading,
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
    missed = ~match
    best = q["truth_best"][sel]
    regret = q["truth_regret"][sel]
    relative = np.divide(regret, best, out=np.zeros_like(regret), where=best > 0)
    return {
        "queries": int(match.size),
        "match_rate": _mean(match),
        "near_ties": int(tie.sum()),
        "match_rate_excluding_near_ties": _mean(match[~tie]),
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


# --- one simulation --------------------------------------------------------------------------------


def query_beliefs(rng: np.random.Generator, reading: Reading, n_goals: int, n_queries: int,
                  concentration: float) -> np.ndarray:
    """``(Q, G)`` the reading's query beliefs.

    ``dirichlet``: ``Dirichlet(c, ..., c)``. ``two-goal``: two distinct random goals share
    ``1 - TWO_GOAL_REST`` (the larger share uniform in ``TWO_GOAL_SPLIT``, given to either goal
    at random), the other goals share ``TWO_GOAL_REST`` evenly (all of it goes to the pair when
    ``|G| = 2``).
    """
    if reading.belief == "dirichlet":
        return rng.dirichlet(np.full(n_goals, concentration), size=n_queries)
    first = rng.integers(0, n_goals, size=n_queries)
    second = (first + rng.integers(1, n_goals, size=n_queries)) % n_goals
    share = rng.uniform(TWO_GOAL_SPLIT[0], TWO_GOAL_SPLIT[1], size=n_queries)
    rest = TWO_GOAL_REST if n_goals > 2 else 0.0
    beliefs = np.full((n_queries, n_goals), rest / max(n_goals - 2, 1))
    rows = np.arange(n_queries)
    beliefs[rows, first] = (1.0 - rest) * share
    beliefs[rows, second] = (1.0 - rest) * (1.0 - share)
    return beliefs


def _ground_truth(rng: np.random.Generator, reading: Reading, beliefs: np.ndarray,
                  lik: np.ndarray) -> np.ndarray:
    """``(Q, C)`` the reading's ground truth of every candidate."""
    if reading.truth == "entropy-drop":
        return expected_entropy_drop(beliefs, lik)
    if reading.expectation == "belief":
        return expected_top_two_gap(beliefs, lik)
    # The true goal of each query, drawn from its belief; its labels weight the expectation.
    cumulative = np.cumsum(beliefs, axis=1)
    uniforms = np.asarray(rng.random(beliefs.shape[0]))
    true_goal = np.minimum((uniforms[:, None] * cumulative[:, -1:] >= cumulative).sum(axis=1),
                           beliefs.shape[1] - 1)
    label_weights = lik[np.arange(beliefs.shape[0]), true_goal]  # (Q, C, F)
    return expected_top_two_gap(beliefs, lik, label_weights)


#: Worlds already drawn, by (simulation, |G|, world, grid, epsilon, seed), with the state of their
#: generator just after the draw: readings that share a world reuse it (:func:`run_all_readings`).
WorldCache = dict[tuple[Any, ...], tuple[ValidationWorld, Mapping[str, Any]]]


def _sample(settings: ValidationSettings, reading: Reading, rng: np.random.Generator, n_goals: int,
            mapping: np.ndarray, distortion: np.ndarray, key: tuple[Any, ...],
            cache: WorldCache | None) -> tuple[ValidationWorld, np.ndarray, np.ndarray, np.ndarray]:
    """World, queries ``(Q,)``, beliefs ``(Q, G)`` and candidates ``(Q, C)`` of one simulation.

    With a cache, a world drawn before under the same key is reused and ``rng`` continues from
    where that draw left it, so the result is bit-identical to drawing it again.
    """
    if reading.world == "two-mode":
        width, height = settings.grid_shape
        if cache is not None and key in cache:
            world, state = cache[key]
            rng.bit_generator.state = state
        else:
            world = sample_world(rng, n_goals, width, height, settings.epsilon, mapping, distortion)
            if cache is not None:
                cache[key] = (world, rng.bit_generator.state)
        queries = np.flatnonzero(~world.on_goal)
        beliefs = query_beliefs(rng, reading, n_goals, queries.size, settings.belief_concentration)
        return world, queries, beliefs, neighbourhoods(world, queries, settings.window)
    world = sample_study_world(rng, n_goals, settings.epsilon, mapping, distortion)
    queries, cand = study_queries(rng, world, settings.window)
    beliefs = query_beliefs(rng, reading, n_goals, queries.size, settings.belief_concentration)
    return world, queries, beliefs, cand


def simulate(settings: ValidationSettings, k: int, n_goals: int, n_mc: int, mapping: np.ndarray,
             distortion: np.ndarray,
             cache: WorldCache | None = None) -> tuple[dict[str, np.ndarray], list[dict[str, Any]]]:
    """Simulation ``k``: world, queries, both criteria; Monte-Carlo records for ``n_mc`` queries.

    ``cache`` (optional) shares the two-mode worlds between readings of the same settings.

    Returns
    -------
    table : dict[str, np.ndarray]
        The ``QUERY_COLUMNS`` of its queries, each ``(Q,)``.
    records : list[dict]
        Per (Monte-Carlo query, sample count, variant) error sums and agreements.
    """
    reading = get_reading(settings.reading)
    rng = generator(settings.seed, "validation", k)
    key = (k, n_goals, reading.world, settings.grid_shape, settings.epsilon, settings.seed)
    world, queries, beliefs, cand = _sample(settings, reading, rng, n_goals, mapping, distortion, key, cache)
    n_queries = queries.size
    valid = cand >= 0
    safe = np.where(valid, cand, 0)
    lik = np.moveaxis(world.likelihood[:, safe, :], 0, 1)  # (Q, G, C, F)

    info = mutual_information(beliefs, lik)  # (Q, C)
    truth = _ground_truth(rng, reading, beliefs, lik)  # (Q, C)
    distance = expected_goal_distance(beliefs, world.goal_cells, world.cells[safe])  # (Q, C)
    metric = info - reading.regularisation * distance
    regularised = info - settings.regularisation * distance

    tol = settings.tie_tolerance
    metric_best, metric_margin, metric_tie = tolerant_argmax(metric, valid, tol)
    truth_best, truth_margin, truth_tie = tolerant_argmax(truth, valid, tol)
    # Candidates with the same likelihood column (every goal's action distribution equal).
    column = world.likelihood.transpose(1, 0, 2).reshape(world.n_states, -1)  # (S, G F)
    _, column_id = np.unique(np.round(column, 12), axis=0, return_inverse=True)
    cand_id = np.where(valid, column_id.ravel()[safe], -1)  # (Q, C)
    equivalent = cand_id[:, :, None] == cand_id[:, None, :]  # (Q, C, C)
    distinct_tie = np.zeros(n_queries, dtype=bool)
    for values, best in ((metric, metric_best), (truth, truth_best)):
        margin = distinct_margin(values, best, equivalent, valid)
        distinct_tie |= margin <= tol * np.maximum(1.0, np.abs(values[np.arange(n_queries), best]))
    reg_best, _, _ = tolerant_argmax(regularised, valid, tol)
    rows = np.arange(n_queries)
    truth_max = truth[rows, truth_best]
    regret = truth_max - truth[rows, metric_best]
    optimal = regret <= tol * np.maximum(1.0, np.abs(truth_max))
    match = optimal if reading.match == "reaches-maximum" else metric_best == truth_best
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
        "match": match.astype(np.int64),
        "near_tie": (metric_tie | truth_tie).astype(np.int64),
        "distinct_near_tie": distinct_tie.astype(np.int64),
        "truth_optimal": optimal.astype(np.int64),
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
        records = convergence_records(rng, settings, world, cand[picked], valid[picked], beliefs[picked],
                                       info[picked], lik[picked], mapping, distortion)
    return table, records


# --- the whole run -------------------------------------------------------------------------------


def run_validation(settings: ValidationSettings, mapping: np.ndarray | None = None,
                   distortion: np.ndarray | None = None,
                   progress: Callable[[int, int], None] | None = None,
                   cache: WorldCache | None = None) -> ValidationResult:
    """Run the whole validation of one reading (see the module docstring for one simulation).

    Parameters
    ----------
    settings
        Checked with :meth:`ValidationSettings.check` (``ConfigError`` when out of range).
    mapping, distortion
        ``(M, A, F)`` and ``(F, F)`` interface tables; the defaults (0.85 / 0.05) when ``None``.
    progress
        Called with (simulations done, simulations in all) after each simulation.
    cache
        Worlds shared with other runs of the same settings (see :func:`run_all_readings`).

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
        table, recs = simulate(settings, k, int(n_goals), int(per_sim[k]), mapping, distortion, cache)
        tables.append(table)
        records.extend(recs)
        if progress:
            progress(k + 1, settings.simulations)
    queries = {name: np.concatenate([t[name] for t in tables]) for name in QUERY_COLUMNS}
    convergence, limits = aggregate_convergence(records, settings.mc_samples)
    # a simulation's share of --mc-queries is capped at its world's queries (simulate's draw)
    ran = sum(min(int(share), len(table["match"])) for share, table in zip(per_sim, tables, strict=True))
    return ValidationResult(settings=settings, queries=queries, convergence=convergence,
                            convergence_limit=limits, mc_queries_run=ran)


def mc_queries_notes(results: Sequence[ValidationResult]) -> list[str]:
    """A note (without its ``Note:``) for each result whose convergence study ran fewer queries than
    ``--mc-queries`` asked: each simulation's share is capped at its world's queries."""
    notes = []
    for result in results:
        asked, ran = result.settings.mc_queries, result.mc_queries_run
        if ran < asked:
            fewest = int(np.bincount(result.queries["simulation"]).min())
            notes.append(f"--mc-queries {asked}: the Monte-Carlo convergence study ran {ran}: each of the "
                         f"{result.settings.simulations} simulation(s) draws its share of them from its own "
                         f"world's queries ({fewest} in the smallest), no more; give more --simulations "
                         "for more")
    return notes


def all_readings_mc_note(mc_queries: int | None) -> str | None:
    """A note (without its ``Note:``) for ``--mc-queries`` given beside ``--all-readings``, which
    skips the Monte-Carlo convergence study (:func:`run_all_readings`), the default's value given
    too; ``None`` for 0 (the study skipped, as asked) or ``None`` (not given)."""
    if not mc_queries:
        return None
    return (f"--mc-queries {mc_queries} is not used with --all-readings: the Monte-Carlo convergence study "
            "does not depend on the reading and runs only with one reading (leave out --all-readings)")


def run_all_readings(settings: ValidationSettings, readings: Sequence[str] = tuple(READINGS),
                     progress: Callable[[int, int], None] | None = None) -> list[ValidationResult]:
    """Every reading on the same settings and seed (so the two-mode readings share their worlds).

    The Monte-Carlo convergence study is skipped (it does not depend on the reading). The
    two-mode readings draw each world once and share it (bit-identical to drawing it again).

    Parameters
    ----------
    settings
        The common settings (their ``reading`` is replaced).
    readings
        Names of the readings, in order.
    progress
        Called with (simulations done, simulations in all) over all readings.
    """
    total = settings.simulations * len(readings)
    cache: WorldCache = {}
    results = []
    for i, name in enumerate(readings):
        def step(done: int, _: int, offset: int = i * settings.simulations) -> None:
            if progress:
                progress(offset + done, total)
        results.append(run_validation(replace(settings, reading=name, mc_queries=0), progress=step,
                                      cache=cache))
    return results


__all__ = ["QUERY_COLUMNS", "ValidationResult", "all_readings_mc_note", "mc_queries_notes", "query_beliefs",
           "run_all_readings", "run_validation", "simulate"]
