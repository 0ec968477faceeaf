"""Summaries over replications: significance rates, pooled effects, power curves, sensitivity indices.

Each replication is analysed exactly as ``nudge analyze`` analyses a run
(:func:`analyse_replication`: the plan's filters, then
:func:`nudgecli.report.stats_document.compare_conditions`: trial-level Kruskal-Wallis and Conover,
participant-level Wilcoxon with the rank-biserial effect size, the bootstrap interval of the median
difference). This module only counts and pools those
results:

- every pair of conditions is reported (with ``k`` conditions, ``k (k - 1) / 2`` rows per metric
  and replication);
- a replication is *significant at the trial level* when the pair has a star in ``nudge
  analyze`` (:func:`nudgecli.report.stats.pair_stars`: Kruskal-Wallis passes the plan's
  ``kruskal_alpha``, then the pair's Conover p its first star threshold, with its comparison),
  *at the participant level* when the pair's paired test's p passes that first threshold (two
  conditions: the Wilcoxon test; more: the pair's post-hoc Wilcoxon test, adjusted as the
  Conover p); its
  *direction* is the sign of ``a - b`` (trial level: the difference of the conditions' mean ranks,
  which the two tests compare; participant level: the pair's rank-biserial r);
- pooled effect sizes are the mean over replications with the 2.5 and 97.5 percentiles of the
  replications' values (where 95 % of replications of this study land);
- power is the fraction of replications significant in the paper's direction (either
  direction for a metric where the paper reports none) with a Clopper-Pearson 95 % interval;
- a pair holding a condition left out of the metric's tests in a replication (not applicable to
  it, or without values there: :mod:`nudgecli.report.not_applicable`) was *not tested* in it
  (:func:`pair_tested`). A pair no replication tested has no rate and no power (NaN, no interval;
  ``smallest_n``'s ``status`` reads :data:`NOT_TESTED`), never a rate of 0. Where only some
  replications tested it, the rates and the power stay over all ``replications`` and count an
  untested replication as not significant: power is the chance that a study of this design finds
  the effect, and a study that could not test the pair did not find it (a rate over the tested
  ones alone would leave out the studies that failed, whose data differ: a condition without
  values). ``tested`` says how many replications tested the pair;
- sensitivity indices are SALib's (Sobol first and total order, Morris mu*, sigma) of the
  replication-mean difference of medians at each design point, with SALib's ``conf``: the
  half-width 1.96 x the bootstrap standard deviation of the index (NaN for Morris sigma and mu).

Their figures are :mod:`nudgecli.report.figures.replication`'s.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Collection, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from nudgecli.model.conditions import PAPER_CONDITIONS
from nudgecli.report.metrics import apply_filters
from nudgecli.report.plan_filters import filter_counts
from nudgecli.report.plans import AnalysisPlan
from nudgecli.report.stats import is_significant, order_conditions, pair_stars, star_rule
from nudgecli.report.stats_document import compare_conditions, condition_table, json_ready, stats_table
from nudgecli.rng import generator

#: The direction of Disambiguation - Control the paper reports (Section 6, Fig. 3 and 4): +1 higher
#: under Disambiguation, -1 lower; ``None`` where it reports no significant difference
#: (engagement, "no statistically significant difference") or no test (success: 93.05 % vs 90.2 %).
PAPER_DIRECTIONS: dict[str, int | None] = {
    "assistance_engagement": None,
    "assistance_strength": +1,   # "higher for Disambiguation ... (p < 0.01)"
    "mode_switches": -1,         # "statistically significant decrease in the number of mode switches"
    "human_effort": -1,          # "statistically significant decrease in the amount of time ... operating"
    "completion_time": -1,       # "task completion time is lower under the Disambiguation condition"
    "human_turns": -1,           # "subjects perform fewer turns under the Disambiguation condition"
    "success": None,
}
#: The paper's comparison, ``a - b`` (the one order of conditions puts it first wherever both are present).
PAPER_PAIR = PAPER_CONDITIONS
POWER_TARGET = 0.8
#: ``smallest_n``'s ``status`` of a pair: a count reaches the target, none of those tried does, or
#: no replication at any count tested the pair (a condition of it left out of the metric's tests).
REACHED, NOT_REACHED, NOT_TESTED = "reached", "not reached", "not tested"
#: The p-values of a pair's tests in :func:`replication_rows`.
_P_COLUMNS = ("kruskal_p", "conover_p", "participant_p")


def analyse_replication(metrics: pd.DataFrame, plan: AnalysisPlan, names: Sequence[str],
                        study_conditions: Sequence[str] = (),
                        not_applicable: Mapping[str, Collection[str]] | None = None) -> dict[str, Any]:
    """The ``stats.json`` document of one replication (as ``nudge analyze`` computes it).

    Parameters
    ----------
    metrics
        One row per trial: ``participant, condition`` and the metric columns.
    plan
        The analysis plan (filters, tests, bootstrap).
    names
        The metrics to analyse.
    study_conditions
        The experiment's ``study.conditions`` (their order follows the plan's in
        :func:`~nudgecli.report.stats.order_conditions`).
    not_applicable
        Metric -> the conditions its policies make constant, left out of its tests (as ``nudge
        analyze`` leaves them out).

    Returns
    -------
    dict
        The document, with ``filters`` (:func:`~nudgecli.report.plan_filters.filter_counts`) only
        where the plan's filters removed values of ``names``: the batch says so once
        (:func:`~nudgecli.report.plan_filters.replications_left_out_line`).
    """
    from nudgecli.report.analysis import comparison_options

    filtered = apply_filters(metrics, plan.filters)
    conditions = order_conditions(filtered["condition"].astype(str), (*plan.conditions, *study_conditions))
    options = comparison_options(plan, None)
    document = json_ready(compare_conditions(filtered, list(names), conditions, options,
                                             not_applicable=not_applicable or {}))
    removed = filter_counts(metrics, filtered, plan, names)
    return {**document, "filters": removed} if removed else document  # unfiltered: the document as before


def _sign(value: float | None) -> int:
    if value is None or not math.isfinite(value) or value == 0:
        return 0
    return 1 if value > 0 else -1


def trial_direction(row: Mapping[str, Any]) -> int:
    """The direction of a pair's trial-level tests: the sign of ``a - b`` of the conditions' mean
    ranks, which is what Kruskal-Wallis and Conover's test compare (+1, -1, or 0 for equal or
    missing).

    ``row`` is a :func:`~nudgecli.report.stats_document.stats_table` row. A document written before
    the mean ranks were recorded falls back to the difference of medians, then of means where the
    medians tie (with tied medians a few outliers can move the means against the ranks).
    """
    ranks = _difference(row.get("mean_rank_a"), row.get("mean_rank_b"))
    if ranks is not None and math.isfinite(ranks):
        return _sign(ranks)
    sign = _sign(_difference(row["median_a"], row["median_b"]))
    return sign if sign != 0 else _sign(_difference(row["mean_a"], row["mean_b"]))


def replication_rows(entries: pd.DataFrame, stats: Mapping[str, dict[str, Any]], plan: AnalysisPlan,
                     points: pd.DataFrame | None = None) -> pd.DataFrame:
    """One row per (entry, metric, pair of conditions): the replication's tests and their verdicts.

    Parameters
    ----------
    entries
        One row per (point, replication, participant count): ``point, replication, seed,
        participants, analysis``.
    stats
        Analysis key -> the replication's stats document (:func:`analyse_replication`).
    plan
        Gives the significance level and comparison.
    points
        Optional ``point`` + parameter columns, merged in after ``seed``.

    Returns
    -------
    pd.DataFrame
        ``point, replication, seed, [parameters...], participants, metric, a, b, median_a,
        median_b, difference, ci_low, ci_high, kruskal_p, conover_p, participant_p,
        effect_size_name, effect_size, trial_significant, trial_direction,
        participant_significant, participant_direction``; ``participant_p`` and the effect size
        are the pair's (its post-hoc Wilcoxon test and rank-biserial r with more than two
        conditions); every p is NaN for a pair holding a condition left out of the metric's tests
        (:mod:`nudgecli.report.not_applicable`), Kruskal-Wallis' too (it compared the others).
    """
    # significant as analyze's stars say it: the Kruskal-Wallis gate, then the first star's level
    rule, comparison = star_rule(plan.comparison_options()), plan.stats.star_comparison
    level = plan.stats.star_thresholds[0]
    rows = []
    for entry in entries.to_dict("records"):
        document = stats[entry["analysis"]]
        for row in stats_table(document).to_dict("records"):
            a, b = row["a"], row["b"]
            if "pairwise_p" in row:  # more than two conditions: the pair's post-hoc test, not the omnibus
                row.update(participant_p=row["pairwise_p"], effect_size_name=row["pairwise_effect_size_name"],
                           effect_size=row["pairwise_effect_size"])
            trial_sign = trial_direction(row)
            rows.append({
                "point": entry["point"], "replication": entry["replication"], "seed": entry["seed"],
                "participants": entry["participants"], "metric": row["metric"], "a": a, "b": b,
                "median_a": row["median_a"], "median_b": row["median_b"], "difference": row["difference"],
                "ci_low": row["ci_low"], "ci_high": row["ci_high"], "kruskal_p": row["kruskal_p"],
                "conover_p": row["conover_p"], "participant_p": row["participant_p"],
                "effect_size_name": row["effect_size_name"], "effect_size": row["effect_size"],
                "trial_significant": pair_stars(_nan(row["conover_p"]), _nan(row["kruskal_p"]), rule) != "",
                "trial_direction": trial_sign,
                "participant_significant": is_significant(_nan(row["participant_p"]), level, comparison),
                "participant_direction": _sign(row["effect_size"]),
            })
    return _with_point_parameters(pd.DataFrame(rows), points)


def _with_point_parameters(table: pd.DataFrame, points: pd.DataFrame | None) -> pd.DataFrame:
    """``table`` with each design point's parameter columns after ``point, replication, seed``."""
    if points is not None and len(points.columns) > 1 and not table.empty:
        table = table.merge(points, on="point", how="left")
        front = ["point", "replication", "seed", *[c for c in points.columns if c != "point"]]
        table = table[front + [c for c in table.columns if c not in front]]
    return table


def _nan(value: Any) -> float:
    return math.nan if value is None else float(value)


def _difference(a: Any, b: Any) -> float | None:
    return None if a is None or b is None else float(a) - float(b)


def condition_values(entries: pd.DataFrame, stats: Mapping[str, dict[str, Any]],
                     points: pd.DataFrame | None = None) -> pd.DataFrame:
    """The tidy table ``point, replication, seed, <parameters...>, participants, condition, metric,
    value``: each replication's median of the metric over the condition's trials."""
    rows = []
    for entry in entries.to_dict("records"):
        for row in condition_table(stats_table(stats[entry["analysis"]])).to_dict("records"):
            rows.append({"point": entry["point"], "replication": entry["replication"],
                         "seed": entry["seed"], "participants": entry["participants"],
                         "condition": row["condition"], "metric": row["metric"], "value": row["median"]})
    return _with_point_parameters(pd.DataFrame(rows), points)


def _percentiles(values: pd.Series) -> tuple[float, float, float]:
    """Mean, 2.5 and 97.5 percentiles over the replications; NaN where some replication's value is
    undefined (a mean of fewer would stand on other seeds than the point's ``replications``)."""
    finite = values.astype(float)
    if finite.empty or finite.isna().any():
        return math.nan, math.nan, math.nan
    return float(finite.mean()), float(np.percentile(finite, 2.5)), float(np.percentile(finite, 97.5))


def pair_tested(rows: pd.DataFrame) -> pd.Series:
    """Per row of :func:`replication_rows`: whether its replication tested its pair of conditions.

    A pair holding a condition left out of the metric's tests (not applicable to it, or without a
    value in that replication: :func:`~nudgecli.report.not_applicable.not_applicable_reasons`) was
    not tested: every p of it is NaN, and so is that condition's median. Every p NaN beside both
    medians is a pair the tests did compare, whose values were all equal (Kruskal-Wallis is then
    undefined): tested, and not significant. A table without the medians reads a pair whose p-values
    are all NaN as not tested; one without p-values (verdicts only) as tested.

    Returns
    -------
    pd.Series
        Booleans on ``rows``' index.
    """
    given = [c for c in _P_COLUMNS if c in rows.columns]
    if not given:
        return pd.Series(True, index=rows.index)
    untested = rows[given].astype(float).isna().all(axis=1)
    medians = [c for c in ("median_a", "median_b") if c in rows.columns]
    if medians:
        untested &= rows[medians].astype(float).isna().any(axis=1)
    return ~untested


def _tested_effect_size_name(names: pd.Series) -> str:
    """The effect size the replications that tested a pair computed: their first name other than
    ``none`` (a replication that could not test the pair names none; the first replication's name
    alone said ``none`` of a pair the others measured), else ``none``."""
    named = [str(name) for name in names if isinstance(name, str) and name != "none"]
    return named[0] if named else "none"


def _rate(flags: pd.Series, replications: int, tested_count: int) -> float:
    """The fraction of all ``replications`` ``flags`` counts; NaN where none tested the pair."""
    return float(flags.sum()) / replications if tested_count else math.nan


def summarise(rows: pd.DataFrame) -> pd.DataFrame:
    """Per (point, participants, metric, pair): rates of significance in each direction, median p,
    pooled effect sizes.

    Returns
    -------
    pd.DataFrame
        ``point, participants, metric, a, b, replications, tested`` (the replications that
        tested the pair: :func:`pair_tested`), ``trial_a_higher, trial_a_lower,
        participant_a_higher, participant_a_lower`` (fractions of all replications, an untested
        one not significant; NaN where none tested the pair: not tested, not never significant),
        ``median_kruskal_p, median_conover_p, median_participant_p``, ``effect_size`` (mean r)
        with ``effect_size_low/high`` (2.5/97.5 percentiles over replications) and ``difference``
        (mean difference of medians) with ``difference_low/high``. Each stands on all
        ``replications``: a median p or pooled value is NaN where the value is undefined (NaN)
        in some replication (``replications.csv`` shows which), never a summary of fewer.
    """
    out = []
    for (point, n, metric, a, b), group in rows.groupby(["point", "participants", "metric", "a", "b"],
                                                        sort=False):
        ran = pair_tested(group)
        count, total = int(ran.sum()), len(group)
        trial = group["trial_significant"].astype(bool) & ran
        level = group["participant_significant"].astype(bool) & ran
        effect, effect_low, effect_high = _percentiles(group["effect_size"])
        diff, diff_low, diff_high = _percentiles(group["difference"])
        out.append({
            "point": point, "participants": n, "metric": metric, "a": a, "b": b, "replications": total,
            "tested": count,
            "trial_a_higher": _rate(trial & (group["trial_direction"] > 0), total, count),
            "trial_a_lower": _rate(trial & (group["trial_direction"] < 0), total, count),
            "participant_a_higher": _rate(level & (group["participant_direction"] > 0), total, count),
            "participant_a_lower": _rate(level & (group["participant_direction"] < 0), total, count),
            "median_kruskal_p": float(group["kruskal_p"].astype(float).median(skipna=False)),
            "median_conover_p": float(group["conover_p"].astype(float).median(skipna=False)),
            "median_participant_p": float(group["participant_p"].astype(float).median(skipna=False)),
            "effect_size_name": _tested_effect_size_name(group["effect_size_name"]),
            "effect_size": effect, "effect_size_low": effect_low, "effect_size_high": effect_high,
            "difference": diff, "difference_low": diff_low, "difference_high": diff_high,
        })
    return pd.DataFrame(out)


def untested_notes(table: pd.DataFrame) -> list[str]:
    """The batch's notes (each a ``Note:`` line's text) on pairs of conditions some replications
    did not test, from :func:`summarise`'s or :func:`power_table`'s ``table`` (its ``replications``
    and ``tested``): how many no replication tested (their rates and power are NaN: "not tested",
    never 0), and how many only some did (their untested replications count as not significant)."""
    keys = [c for c in ("point", "participants", "metric", "a", "b") if c in table.columns]
    pairs = table.drop_duplicates(keys)
    per = "".join(f", {word}" for column, word in (("point", "design point"), ("participants", "count"))
                  if column in keys and pairs[column].nunique() > 1)
    never = pairs[pairs["tested"] == 0]
    some = pairs[(pairs["tested"] > 0) & (pairs["tested"] < pairs["replications"])]
    notes = []
    if len(never):
        first = never.iloc[0]
        notes.append(f"{len(never)} of {len(pairs)} pairs of conditions (per metric{per}) were tested in no "
                     f"replication (e.g. {first['metric']}: {first['a']} - {first['b']}): a condition of "
                     "theirs is left out of the metric's tests (not applicable to it, or without values), so "
                     f"their significance rates and power read NaN, {NOT_TESTED}, never 0")
    if len(some):
        first = some.iloc[0]
        at = f" at {first['participants']} participants" if "count" in per else ""
        many = len(some) > 1
        notes.append(f"{len(some)} pair{'s' if many else ''} of conditions (per metric{per}) "
                     f"{'were' if many else 'was'} tested in only some replications (e.g. {first['metric']}: "
                     f"{first['a']} - {first['b']}, {first['tested']} of {first['replications']}{at}; column "
                     "tested): a replication that could not test a pair counts as not significant in its "
                     "rates and power, which stay over all replications")
    return notes


def clopper_pearson(successes: int, trials: int, level: float = 0.95) -> tuple[float, float]:
    """The exact (Clopper-Pearson) binomial interval of ``successes / trials``."""
    if trials == 0:
        return math.nan, math.nan
    import scipy.stats  # here: importing it costs about 0.6 s of CPU, and only this needs it

    interval = scipy.stats.binomtest(successes, trials).proportion_ci(confidence_level=level, method="exact")
    return float(interval.low), float(interval.high)


def paper_direction(metric: str, a: str, b: str) -> int | None:
    """The paper's sign of ``a - b`` for the metric (``None``: either direction counts)."""
    sign = PAPER_DIRECTIONS.get(metric)
    if sign is None:
        return None
    if (a, b) == PAPER_PAIR:
        return sign
    if (b, a) == PAPER_PAIR:
        return -sign
    return None


def power_table(rows: pd.DataFrame, directions: Mapping[str, int | None] | None = None) -> pd.DataFrame:
    """The power curve of every metric at both levels of test.

    Parameters
    ----------
    rows
        :func:`replication_rows` (one point, several participant counts).
    directions
        Metric -> required sign of ``a - b`` (``None``: either); default the paper's
        (:func:`paper_direction`).

    Returns
    -------
    pd.DataFrame
        ``participants, metric, a, b, level (trial|participant), direction, replications, tested,
        significant, power, low, high`` with the Clopper-Pearson 95 % interval; ``tested``: the
        replications that tested the pair (:func:`pair_tested`). Power is over all ``replications``,
        an untested one not significant; NaN with no interval where none tested the pair.
    """
    out = []
    # pairs in the analysis' order of conditions (not by name) within each count and metric
    order = {pair: i for i, pair in enumerate(dict.fromkeys(zip(rows["a"], rows["b"], strict=True)))}
    ranked = rows.assign(_pair=[order[pair] for pair in zip(rows["a"], rows["b"], strict=True)])
    groups = ranked.groupby(["participants", "metric", "_pair", "a", "b"], sort=True)
    for (n, metric, _, a, b), group in groups:
        wanted = directions.get(metric) if directions is not None else paper_direction(metric, a, b)
        ran = pair_tested(group)
        count, total = int(ran.sum()), len(group)
        for level in ("trial", "participant"):
            significant = group[f"{level}_significant"].astype(bool) & ran
            if wanted is not None:
                significant &= group[f"{level}_direction"] == wanted
            k = int(significant.sum())
            low, high = clopper_pearson(k, total) if count else (math.nan, math.nan)
            out.append({"participants": int(n), "metric": metric, "a": a, "b": b, "level": level,
                        "direction": {None: "either", 1: "a > b", -1: "a < b"}[wanted],
                        "replications": total, "tested": count, "significant": k,
                        "power": _rate(significant, total, count), "low": low, "high": high})
    return pd.DataFrame(out)


def smallest_n(power: pd.DataFrame, target: float = POWER_TARGET) -> pd.DataFrame:
    """Per metric, pair of conditions and level (in :func:`power_table`'s order): the smallest
    participant count whose power reaches ``target``.

    Returns
    -------
    pd.DataFrame
        ``metric, a, b, level, participants, status``; ``participants`` an integer, or ``None``
        (an object column, so that the CSV writes ``9``, not ``9.0``, and an empty cell) where
        ``status`` is :data:`NOT_REACHED` (no count tried reaches it) or :data:`NOT_TESTED` (no
        replication at any count tested the pair: it has no power to reach); else
        :data:`REACHED`.
    """
    out = []
    for (metric, a, b, level), group in power.groupby(["metric", "a", "b", "level"], sort=False):
        reached = group.loc[group["power"] >= target, "participants"]
        never = "tested" in group.columns and not (group["tested"] > 0).any()
        status = REACHED if len(reached) else NOT_TESTED if never else NOT_REACHED
        out.append({"metric": metric, "a": a, "b": b, "level": level,
                    "participants": int(reached.min()) if len(reached) else None, "status": status})
    return pd.DataFrame(out, columns=["metric", "a", "b", "level", "participants", "status"], dtype=object)


# --- sensitivity -------------------------------------------------------------------------------

def point_outputs(rows: pd.DataFrame, value: str = "difference") -> pd.DataFrame:
    """Per (point, metric, pair of conditions ``a, b``): the mean of ``value`` (the model output Y)
    over the replications where it is finite at every point, so that Y stands on the same seeds
    everywhere (common random numbers), one output per pair (never pooled over the pairs of more
    conditions); ``replications`` counts them (NaN ``y`` where there are none)."""
    keys = ["point", "metric", "a", "b"]
    values = rows[value].astype(float)
    common = np.isfinite(values).groupby([rows[k] for k in ("metric", "a", "b", "replication")],
                                         sort=False).transform("all")
    kept = rows[keys].assign(y=values.where(common), replications=common.astype(int))
    pooled = kept.groupby(keys, sort=False).agg(y=("y", "mean"), replications=("replications", "sum"))
    return pooled.reset_index()


def sensitivity(method: str, problem: dict[str, Any], samples: np.ndarray, outputs: pd.DataFrame,
                levels: int = 4, seed: int = 0) -> pd.DataFrame:
    """Sensitivity indices of each output, with SALib's ``conf`` (half-width: 1.96 x the standard
    deviation of the index over its bootstrap; NaN for Morris sigma and mu).

    Parameters
    ----------
    method
        ``sobol`` (first order S1 and total order ST) or ``morris`` (mu*, sigma, mu).
    problem
        SALib's problem (``names``, ``bounds``, ``num_vars``).
    samples
        ``(n_points, D)`` the design in the problem's units, in point order.
    outputs
        ``point, metric, a, b, y, replications`` (:func:`point_outputs`): one output per metric, pair of
        conditions and point.
    levels
        Morris grid levels.
    seed
        The master seed of SALib's bootstrap of the intervals (the batch's): each metric's
        bootstrap draws from its own branch ``generator(seed, "sensitivity", metric)`` (the same
        for each pair of the metric), so equal seeds give equal intervals (SALib itself takes a
        seed of 0 for "unseeded").

    Returns
    -------
    pd.DataFrame
        ``metric, a, b, parameter, index, value, conf, replications`` (``index``: S1, ST or
        mu_star, sigma, mu; ``replications``: how many replications Y averages, the same at every
        point);
        a metric and pair whose output is undefined (or missing) at some point has its rows,
        with NaN indices.
    """
    out = []
    for (metric, a, b), group in outputs.groupby(["metric", "a", "b"], sort=False):
        y = group.sort_values("point")["y"].to_numpy(dtype=float)
        used = int(group["replications"].min()) if "replications" in group else math.nan
        rng = generator(seed, "sensitivity", str(metric))
        indices = _salib_indices(method, problem, samples, y, levels, rng)
        for k, name in enumerate(problem["names"]):
            for index, (values, conf) in indices.items():
                out.append({"metric": metric, "a": a, "b": b, "parameter": name, "index": index,
                            "value": float(values[k]), "conf": float(conf[k]), "replications": used})
    return pd.DataFrame(out, columns=["metric", "a", "b", "parameter", "index", "value", "conf",
                                      "replications"])


#: SALib's result keys of each index and of its ``conf`` (``None``: SALib gives none).
_INDICES: dict[str, dict[str, tuple[str, str | None]]] = {
    "sobol": {"S1": ("S1", "S1_conf"), "ST": ("ST", "ST_conf")},
    "morris": {"mu_star": ("mu_star", "mu_star_conf"), "sigma": ("sigma", None), "mu": ("mu", None)},
}


def _salib_indices(method: str, problem: dict[str, Any], samples: np.ndarray, y: np.ndarray, levels: int,
                   rng: np.random.Generator) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Index name -> (value, conf) per parameter of the output ``y`` (one value per design point);
    all NaN where ``y`` is undefined or missing at some point, and Sobol's where ``y`` is constant
    over the design (its shares of a zero variance are 0 / 0; SALib 1.6 returns 0 for them). Morris'
    elementary effects of a constant output are defined: 0."""
    wanted = _INDICES["sobol" if method == "sobol" else "morris"]
    undefined = np.full(problem["num_vars"], math.nan)
    if y.size != samples.shape[0] or not np.all(np.isfinite(y)) or (method == "sobol" and np.all(y == y[0])):
        return {index: (undefined, undefined) for index in wanted}
    # SALib warns (on stderr, mid-output) about degenerate outputs; silenced here
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        if method == "sobol":
            from SALib.analyze import sobol

            result = sobol.analyze(problem, y, calc_second_order=False, conf_level=0.95, seed=rng)
        else:
            from SALib.analyze import morris

            result = morris.analyze(problem, samples, y, num_levels=levels, conf_level=0.95, seed=rng)
    return {index: (np.asarray(result[key], dtype=float),
                    np.asarray(result[conf], dtype=float) if conf else undefined)
            for index, (key, conf) in wanted.items()}
