"""``nudge compare``: simulated people beside real people, metric by metric.

Both inputs are tidy metrics tables (one row per trial: ``participant``, ``condition``, metric
columns), the simulated one usually computed from a run folder. For each metric the two tables
share and each condition they share (after ``condition_map`` renames simulated conditions):

- per-participant medians of each source (:func:`participant_medians`), and the real people's
  range of them (min-max), with the share of simulated participants whose median lies inside it;
- the pooled trial-level medians and quartiles (linear quantiles) of each source;
- two-sample distances between the pooled trial distributions: Kolmogorov-Smirnov
  (``scipy.stats.ks_2samp``: statistic and its p-value) and Wasserstein-1
  (``scipy.stats.wasserstein_distance``, in the metric's unit);
- a cluster-bootstrap percentile interval of each distance: each resample draws the simulated
  participants and, independently, the real participants with replacement and takes all their
  trials (trials are nested in people, so the KS p-value, which assumes independent trials, is
  optimistic; the interval is the honest uncertainty). Every participant of a source is drawn
  from, so one without a value for a metric and condition adds nothing to that resample. The
  resamples come from ``nudgecli.rng.generator(seed, "compare", source)``, the same for every
  metric.

A bootstrap distance is biased upwards (resampling adds noise to both ECDFs), so an interval can
exclude the observed value when the two distributions are close; read it as "how large the
difference could be", not as a test.

The functions above the "reading and writing" section take and return pandas DataFrames;
:func:`compare_sources` reads the two inputs (through :func:`nudgecli.report.analysis.load_source`,
so a run folder's metrics are the analysis plan's) and :func:`write_comparison` writes the result.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from nudgecli import command_defaults as defaults
from nudgecli.errors import DataError, did_you_mean, shell_words
from nudgecli.outputs import check_not_a_file, written_together
from nudgecli.report.analysis import load_source
from nudgecli.report.plan_filters import apply_plan_filters
from nudgecli.report.plans import AnalysisPlan, load_plan
from nudgecli.report.stats import order_conditions
from nudgecli.report.stats_document import json_ready
from nudgecli.rng import generator
from nudgecli.run_folder_names import METRICS_CSV
from nudgecli.store import is_run_folder

#: The two sources, in display order.
SOURCES = ("simulated", "real")
#: Largest number of (resample x trial) cells held in memory at once by the bootstrap.
_CHUNK_CELLS = 4_000_000

#: Columns of :func:`compare_tables`'s result, in order.
COMPARISON_COLUMNS = (
    "metric", "condition", "simulated_condition", "real_condition",
    "n_simulated", "n_real", "participants_simulated", "participants_real",
    "median_simulated", "q1_simulated", "q3_simulated",
    "median_real", "q1_real", "q3_real",
    "real_participant_min", "real_participant_max",
    "simulated_participant_min", "simulated_participant_max", "simulated_inside_real_range",
    "ks_statistic", "ks_p", "ks_low", "ks_high",
    "wasserstein", "wasserstein_low", "wasserstein_high", "valid_resamples",
)


@dataclass(frozen=True)
class CompareOptions:
    """Settings of :func:`compare_tables`.

    Attributes
    ----------
    resamples
        Cluster-bootstrap resamples (0 skips the intervals).
    level
        Level of the percentile intervals.
    seed
        Master seed of the resamples.
    """

    resamples: int = defaults.COMPARE_RESAMPLES
    level: float = defaults.COMPARE_LEVEL
    seed: int = defaults.COMPARE_SEED


def _numeric(series: pd.Series) -> pd.Series:
    """A float Series (booleans -> 0/1, nullable types -> NaN for missing)."""
    if pd.api.types.is_bool_dtype(series) or series.dtype == "boolean":
        return series.astype("Float64").astype(float)
    return pd.to_numeric(series, errors="coerce").astype(float)


Aligned = tuple[pd.DataFrame, pd.DataFrame, list[str]]


def align_conditions(simulated: pd.DataFrame, real: pd.DataFrame,
                     condition_map: Mapping[str, str] | None = None, *,
                     names: tuple[str, str] = ("simulated", "real"),
                     notes: list[str] | None = None) -> Aligned:
    """Rename the simulated conditions by ``condition_map`` and keep the conditions both tables hold.

    Parameters
    ----------
    simulated, real
        Metrics tables with a ``condition`` column.
    condition_map
        Simulated condition -> the real table's name for it (e.g. ``{"none": "no assistance"}``).
        A simulated condition not in it whose name a pairing gives another (``control`` beside
        ``{"disambiguation": "control"}``) is left out, not pooled with that other.
    names
        How the messages name the two sources (e.g. their paths).
    notes
        Receives a line for each condition one table holds alone and each simulated condition
        left out (neither is compared).

    Returns
    -------
    tuple[pd.DataFrame, pd.DataFrame, list[str]]
        Both tables restricted to the shared conditions (conditions as strings), and the shared
        conditions in :func:`~nudgecli.report.stats.order_conditions`' order: the paper's first,
        then the real table's order of first appearance.

    Raises
    ------
    DataError
        A ``condition_map`` key that is not a simulated condition or value that is not a real one,
        two pairings that name one real condition, two conditions left unpaired
        whose labels differ in case or spaces only (``control`` and ``Control ``: the same
        condition spelled two ways, which would be dropped silently), or no shared condition.
    """
    simulated = simulated.assign(condition=simulated["condition"].astype(str))
    real = real.assign(condition=real["condition"].astype(str))
    sim_conditions = list(dict.fromkeys(simulated["condition"]))
    real_conditions = list(dict.fromkeys(real["condition"]))
    mapping = dict(condition_map or {})
    _check_matches(mapping, sim_conditions, real_conditions, names)
    paired_with = {label: key for key, label in mapping.items()}  # real condition -> its simulated one
    left_out = [c for c in sim_conditions if c not in mapping and c in paired_with]  # else pooled
    if left_out:
        simulated = simulated[~simulated["condition"].isin(left_out)]
    simulated = simulated.assign(condition=simulated["condition"].map(lambda c: mapping.get(c, c)))
    renamed = {mapping.get(c, c): c for c in sim_conditions if c not in left_out}  # each simulated label
    real_only = [c for c in real_conditions if c not in renamed]
    sim_only = [c for c in renamed if c not in set(real_conditions)]
    _refuse_near_identical(sim_only, real_only, renamed, names)
    in_both = [c for c in real_conditions if c in renamed]
    shared = order_conditions(in_both, real_conditions)
    if not shared:
        raise DataError(f"no condition in common: simulated {', '.join(sim_conditions)}; real "
                        f"{', '.join(real_conditions)}; pair them with --match SIMULATED=REAL, e.g. "
                        f"--match {sim_conditions[0]}={real_conditions[0]}")
    if notes is not None:
        for c in sorted(real_only):  # --match SIMULATED=c is offered only while a simulated one is unpaired
            taken = shell_words(["--match", f"{c}={mapping.get(c)}"])  # the --match its namesake went to
            why = (f"is only in the real table ({names[1]}): not compared" if c not in mapping else
                   f"of the real table ({names[1]}) is not compared: {taken} compares the simulated {c!r} as "
                   f"the real {mapping[c]!r}")
            notes.append(f"condition {c!r} {why}" + ("" if not (sim_only or left_out)
                                                     else f"; pair it with --match SIMULATED={c}"))
        notes += [f"condition {renamed[c]!r} is only in the simulated source ({names[0]}): not compared; "
                  f"pair it with --match {renamed[c]}=REAL" for c in sorted(sim_only)]
        notes += [f"condition {c!r} of the simulated source ({names[0]}) is left out: "
                  f"{shell_words(['--match', f'{paired_with[c]}={c}'])} compares {paired_with[c]!r} as the "
                  f"real {c!r}; pair it with --match {c}=REAL to compare it too" for c in left_out]
    return (simulated[simulated["condition"].isin(shared)], real[real["condition"].isin(shared)], shared)


def _check_matches(mapping: Mapping[str, str], sim_conditions: Sequence[str], real_conditions: Sequence[str],
                   names: tuple[str, str]) -> None:
    """Refuse a ``--match SIMULATED=REAL`` whose SIMULATED the simulated table lacks, whose REAL
    the real table lacks (each with "did you mean"), or two that pair simulated conditions with
    one real condition (their trials would be pooled into one condition).

    Parameters
    ----------
    mapping
        Simulated condition -> real condition, as given.
    sim_conditions, real_conditions
        The conditions each table holds.
    names
        How the messages name the two sources.
    """
    for key, label in mapping.items():
        if key not in sim_conditions:
            raise DataError(f"--match {key}={label}: the simulated table has no condition {key!r}"
                            f"{did_you_mean(key, sim_conditions)}; its conditions: "
                            f"{', '.join(sim_conditions)}")
        if label not in real_conditions:
            raise DataError(f"--match {key}={label}: the real table ({names[1]}) has no condition {label!r}"
                            f"{did_you_mean(label, real_conditions)}; its conditions: "
                            f"{', '.join(real_conditions)}")
    paired: dict[str, list[str]] = {}  # real condition -> the simulated conditions matched with it
    for key, label in mapping.items():
        paired.setdefault(label, []).append(key)
    for label, pooled in paired.items():
        if len(pooled) > 1:
            given = " ".join(shell_words(["--match", f"{c}={label}"]) for c in pooled)
            listed = ", ".join(repr(c) for c in pooled[:-1]) + f" and {pooled[-1]!r}"
            raise DataError(f"{given}: the simulated conditions {listed} of {names[0]} would all be compared "
                            f"as the real condition {label!r}, their trials pooled into one; pair each "
                            "simulated condition with a real condition of its own")


def _same_label(label: str) -> str:
    """A condition label with case and runs of white space made alike."""
    return " ".join(label.split()).casefold()


def _refuse_near_identical(sim_only: Sequence[str], real_only: Sequence[str], renamed: Mapping[str, str],
                           names: tuple[str, str]) -> None:
    """Refuse an unpaired real condition whose label is an unpaired simulated one's but for case or
    spaces (``renamed``: the simulated label as given, by its name after ``--match``)."""
    by_form = {_same_label(c): c for c in sim_only}
    for label in real_only:
        twin = by_form.get(_same_label(label))
        if twin is not None:
            given = renamed[twin]
            raise DataError(f"{names[1]}: condition {label!r} differs from the condition {given!r} of "
                            f"{names[0]} in case or spaces only (did you mean {given!r}?); name them "
                            f"alike, or pair them with {shell_words(['--match', f'{given}={label}'])}")


def shared_metrics(simulated_metrics: Sequence[str], real_metrics: Sequence[str],
                   requested: Sequence[str] | None = None) -> list[str]:
    """The metrics both tables hold (in the real table's order), or the ``requested`` ones.

    Raises
    ------
    DataError
        A requested metric missing from either table, or no metric in common.
    """
    common = [m for m in real_metrics if m in set(simulated_metrics)]
    if requested:
        for name in requested:
            for source, names in (("simulated", simulated_metrics), ("real", real_metrics)):
                if name not in names:
                    raise DataError(f"--metric {name}: the {source} table has no metric {name!r}"
                                    f"{did_you_mean(name, names)}; shared metrics: "
                                    f"{', '.join(common) or 'none'}")
        return list(dict.fromkeys(requested))
    if not common:
        raise DataError(f"no metric in common: simulated {', '.join(simulated_metrics)}; real "
                        f"{', '.join(real_metrics)}; name the real table's columns like the simulated "
                        "metrics (e.g. completion_time, success, mode_switches)")
    return common


def participant_medians(simulated: pd.DataFrame, real: pd.DataFrame, metrics: Sequence[str],
                        condition_map: Mapping[str, str] | None = None) -> pd.DataFrame:
    """Per-participant medians of each metric and condition, both sources in one tidy table.

    Parameters
    ----------
    simulated, real
        Metrics tables, conditions already aligned (:func:`align_conditions`).
    metrics
        What to summarise.
    condition_map
        The ``--match`` pairs (simulated -> real condition) the rows' ``simulated_condition`` are of.

    Returns
    -------
    pd.DataFrame
        Columns ``source`` (simulated, real), ``metric``, ``condition`` (the real table's name),
        ``simulated_condition`` and ``real_condition`` (the compared pair, as in ``compare.csv``,
        on the rows of both sources), ``participant`` (as a string), ``n`` (trials with a value)
        and ``median``; participants without a value of the metric in a condition are left out.
    """
    simulated_name = {label: key for key, label in (condition_map or {}).items()}
    frames = []
    for source, table in zip(SOURCES, (simulated, real), strict=True):
        for metric in metrics:
            tidy = pd.DataFrame({"condition": table["condition"].astype(str),
                                 "participant": table["participant"].astype(str),
                                 "value": _numeric(table[metric])}).dropna(subset=["value"])
            grouped = tidy.groupby(["condition", "participant"], sort=True)["value"]
            summary = grouped.agg(n="size", median="median").reset_index()
            summary.insert(0, "metric", metric)
            summary.insert(0, "source", source)
            summary["simulated_condition"] = [simulated_name.get(c, c) for c in summary["condition"]]
            summary["real_condition"] = summary["condition"]
            frames.append(summary)
    columns = ["source", "metric", "condition", "simulated_condition", "real_condition", "participant", "n",
               "median"]
    return pd.concat(frames, ignore_index=True)[columns] if frames else pd.DataFrame(columns=columns)


def weighted_distances(values_a: np.ndarray, weights_a: np.ndarray, values_b: np.ndarray,
                       weights_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Kolmogorov-Smirnov and Wasserstein-1 distances between weighted samples, many weightings at once.

    With unit weights these are ``scipy.stats.ks_2samp(a, b).statistic`` and
    ``scipy.stats.wasserstein_distance(a, b)``.

    Parameters
    ----------
    values_a, values_b
        ``(n_a,)`` and ``(n_b,)`` finite values.
    weights_a, weights_b
        ``(B, n_a)`` and ``(B, n_b)`` non-negative weights (e.g. how often each trial's participant
        was drawn); rows with a zero total give ``nan``.

    Returns
    -------
    tuple[np.ndarray, np.ndarray]
        ``(B,)`` KS statistics (largest gap between the weighted ECDFs) and ``(B,)`` Wasserstein-1
        distances (area between them).
    """
    values = np.concatenate([values_a, values_b])
    order = np.argsort(values, kind="stable")
    ordered = values[order]
    # the last position of each run of equal values: the ECDFs are evaluated there
    last = np.flatnonzero(np.append(ordered[1:] != ordered[:-1], True))
    widths = np.diff(ordered[last])
    n_a = len(values_a)
    in_a = order < n_a
    n_rows = weights_a.shape[0]
    ks = np.empty(n_rows)
    w1 = np.empty(n_rows)
    step = max(1, _CHUNK_CELLS // max(len(values), 1))
    for start in range(0, n_rows, step):
        rows = slice(start, min(start + step, n_rows))
        pooled = np.zeros((rows.stop - rows.start, len(values)))
        pooled[:, in_a] = weights_a[rows][:, order[in_a]]
        cdf_a = np.cumsum(pooled, axis=1)[:, last]
        pooled[:] = 0.0
        pooled[:, ~in_a] = weights_b[rows][:, order[~in_a] - n_a]
        cdf_b = np.cumsum(pooled, axis=1)[:, last]
        with np.errstate(invalid="ignore", divide="ignore"):
            gap = np.abs(cdf_a / cdf_a[:, -1:] - cdf_b / cdf_b[:, -1:])
        ks[rows] = gap.max(axis=1)
        w1[rows] = (gap[:, :-1] * widths).sum(axis=1)
    return ks, w1


def _resample_weights(participants: np.ndarray, resamples: int, seed: int, source: str) -> np.ndarray:
    """``(resamples, P)``: how often each participant is drawn in each cluster resample."""
    n = len(participants)
    if n == 0 or resamples == 0:
        return np.zeros((resamples, n))
    draws = generator(seed, "compare", source).integers(0, n, size=(resamples, n))
    flat = (np.arange(resamples)[:, None] * n + draws).ravel()
    return np.bincount(flat, minlength=resamples * n).reshape(resamples, n).astype(float)


def _extreme(values: np.ndarray, how: Callable[[np.ndarray], float]) -> float:
    return float(how(values)) if values.size else math.nan


def _quantiles(values: np.ndarray) -> tuple[float, float, float]:
    if values.size == 0:
        return math.nan, math.nan, math.nan
    q1, median, q3 = np.quantile(values, [0.25, 0.5, 0.75])
    return float(median), float(q1), float(q3)


def compare_tables(simulated: pd.DataFrame, real: pd.DataFrame, metrics: Sequence[str],
                   conditions: Sequence[str], options: CompareOptions = CompareOptions(),
                   condition_map: Mapping[str, str] | None = None) -> pd.DataFrame:
    """The comparison of every metric and condition (see the module docstring).

    Parameters
    ----------
    simulated, real
        Metrics tables (``participant``, ``condition``, the ``metrics`` columns), conditions
        already aligned (:func:`align_conditions`).
    metrics, conditions
        What to compare.
    condition_map
        The ``--match`` pairs (simulated -> real condition) the rows' ``simulated_condition`` are of.

    Returns
    -------
    pd.DataFrame
        One row per (metric, condition), columns :data:`COMPARISON_COLUMNS`. Distances are
        ``nan`` where a source has no value.
    """
    simulated_name = {label: key for key, label in (condition_map or {}).items()}
    people = {source: np.array(sorted(table["participant"].astype(str).unique()))
              for source, table in zip(SOURCES, (simulated, real), strict=True)}
    weights = {source: _resample_weights(people[source], options.resamples, options.seed, source)
               for source in SOURCES}
    medians = participant_medians(simulated, real, metrics)
    tail = (1.0 - options.level) / 2.0
    rows = []
    for metric in metrics:
        for condition in conditions:
            data = {}
            for source, table in zip(SOURCES, (simulated, real), strict=True):
                subset = table[table["condition"].astype(str) == condition]
                values = _numeric(subset[metric]).to_numpy()
                keep = np.isfinite(values)
                owners = np.searchsorted(people[source], subset["participant"].astype(str).to_numpy()[keep])
                data[source] = (values[keep], owners)
            row: dict[str, object] = {"metric": metric, "condition": condition, "real_condition": condition,
                                      "simulated_condition": simulated_name.get(condition, condition)}
            for source in SOURCES:
                values, owners = data[source]
                median, q1, q3 = _quantiles(values)
                row.update({f"n_{source}": int(values.size),
                            f"participants_{source}": int(np.unique(owners).size),
                            f"median_{source}": median, f"q1_{source}": q1, f"q3_{source}": q3})
            own = medians[(medians["metric"] == metric) & (medians["condition"] == condition)]
            real_medians = own.loc[own["source"] == "real", "median"].to_numpy()
            sim_medians = own.loc[own["source"] == "simulated", "median"].to_numpy()
            low_real, high_real = _extreme(real_medians, np.min), _extreme(real_medians, np.max)
            inside = (float(np.mean((sim_medians >= low_real) & (sim_medians <= high_real)))
                      if sim_medians.size and real_medians.size else math.nan)
            row.update({"real_participant_min": low_real, "real_participant_max": high_real,
                        "simulated_participant_min": _extreme(sim_medians, np.min),
                        "simulated_participant_max": _extreme(sim_medians, np.max),
                        "simulated_inside_real_range": inside})
            (sim_values, sim_owners), (real_values, real_owners) = data["simulated"], data["real"]
            ks = ks_p = w1 = math.nan
            ks_low = ks_high = w_low = w_high = math.nan
            valid = 0
            if sim_values.size and real_values.size:
                import scipy.stats  # here, not at import: about 0.6 s of CPU for every command

                test = scipy.stats.ks_2samp(sim_values, real_values)
                ks, ks_p = float(test.statistic), float(test.pvalue)
                w1 = float(scipy.stats.wasserstein_distance(sim_values, real_values))
                if options.resamples:
                    boot_ks, boot_w1 = weighted_distances(
                        sim_values, weights["simulated"][:, sim_owners],
                        real_values, weights["real"][:, real_owners])
                    ok = np.isfinite(boot_ks) & np.isfinite(boot_w1)
                    valid = int(ok.sum())
                    if valid:
                        ks_low, ks_high = (float(q) for q in np.quantile(boot_ks[ok], [tail, 1 - tail]))
                        w_low, w_high = (float(q) for q in np.quantile(boot_w1[ok], [tail, 1 - tail]))
            row.update({"ks_statistic": ks, "ks_p": ks_p, "ks_low": ks_low, "ks_high": ks_high,
                        "wasserstein": w1, "wasserstein_low": w_low, "wasserstein_high": w_high,
                        "valid_resamples": valid})
            rows.append(row)
    return pd.DataFrame(rows, columns=list(COMPARISON_COLUMNS))


# --- reading and writing ------------------------------------------------------------------------

@dataclass(frozen=True)
class Comparison:
    """What :func:`compare_sources` computed.

    Attributes
    ----------
    simulated, real
        The two sources (paths as given).
    metrics, conditions
        What was compared.
    table
        :func:`compare_tables`'s result, one row per (metric, condition).
    medians
        :func:`participant_medians`'s result.
    options
        The bootstrap settings.
    trials
        The two aligned metrics tables (``{"simulated": ..., "real": ...}``), for the figure.
    match
        The ``--match`` pairs (simulated -> real condition).
    plan
        The analysis plan's name and where it came from (``source``: as given, or the one the
        simulated source picked; ``None`` for a plan object).
    drop_duplicates
        Whether repeated trial rows were dropped (``--drop-duplicates``).
    """

    simulated: str
    real: str
    metrics: list[str]
    conditions: list[str]
    table: pd.DataFrame
    medians: pd.DataFrame
    options: CompareOptions
    trials: dict[str, pd.DataFrame] = field(default_factory=dict, repr=False, compare=False)
    match: dict[str, str] = field(default_factory=dict)
    plan: dict[str, str | None] = field(default_factory=dict)
    drop_duplicates: bool = False

    def to_json(self) -> dict[str, object]:
        """The JSON document of ``--format json`` and ``compare.json`` (NaN as ``None``)."""
        return json_ready({
            "simulated": self.simulated, "real": self.real,
            "metrics": self.metrics, "conditions": self.conditions,
            "match": self.match, "plan": self.plan, "drop_duplicates": self.drop_duplicates,
            "bootstrap": {"resamples": self.options.resamples, "level": self.options.level,
                          "seed": self.options.seed, "unit": "participants (cluster bootstrap)"},
            "comparison": self.table.to_dict(orient="records"),
            "participant_medians": self.medians.to_dict(orient="records"),
        })


def compare_sources(simulated: str | Path, real: str | Path, plan: str | Path | AnalysisPlan | None = None,
                    metrics: Sequence[str] | None = None, condition_map: Mapping[str, str] | None = None,
                    options: CompareOptions = CompareOptions(), *, drop_duplicates: bool = False,
                    notes: list[str] | None = None) -> Comparison:
    """Read a simulated source (run folder or metrics table) and a real metrics table, and compare them.

    Parameters
    ----------
    simulated
        A run folder (its metrics computed with ``plan``) or a metrics table.
    real
        A metrics table of real trials (CSV or Parquet; one condition is enough).
    plan
        The analysis plan whose metric definitions and filters apply to both sources (``None``:
        the simulated run's, as ``nudge analyze`` picks it; ``paper`` for a table).
    metrics
        Only these metrics (default: every metric both hold).
    condition_map
        Simulated condition -> real condition name.
    drop_duplicates
        Keep the first of repeated trial rows of a table instead of refusing them (as
        ``nudge analyze --drop-duplicates``).
    notes
        Receives what was left out (duplicates dropped, stray parts of a run folder, the values the
        plan's filters removed from each source, a condition one source holds alone), a line each.

    Raises
    ------
    DataError, RunFolderError, ConfigError
        Unreadable sources, no shared metric or condition, an unknown metric.
    """
    from nudgecli.report.analysis import plan_of_source

    given = plan_of_source(simulated) if plan is None else plan
    chosen = load_plan(given)
    sim_table, sim_metrics, _ = load_source(Path(simulated), chosen, min_conditions=1,
                                            drop_duplicates=drop_duplicates, notes=notes, metrics=metrics)
    real_path = Path(real)
    if real_path.is_dir():
        raise DataError(_real_folder_message(real_path))
    real_table, real_metrics, _ = load_source(real_path, chosen, min_conditions=1,
                                              drop_duplicates=drop_duplicates, notes=notes, metrics=metrics)
    selected = shared_metrics(sim_metrics, real_metrics, metrics)
    sim_table = _filtered(sim_table, chosen, selected, simulated, notes)
    real_table = _filtered(real_table, chosen, selected, real, notes)
    sim_table, real_table, conditions = align_conditions(sim_table, real_table, condition_map,
                                                         names=(str(simulated), str(real)), notes=notes)
    table = compare_tables(sim_table, real_table, selected, conditions, options, condition_map)
    medians = participant_medians(sim_table, real_table, selected, condition_map)
    source = None if isinstance(given, AnalysisPlan) else str(given)
    return Comparison(str(simulated), str(real), selected, conditions, table, medians, options,
                      {"simulated": sim_table, "real": real_table}, dict(condition_map or {}),
                      {"name": chosen.name, "source": source}, drop_duplicates)


def _filtered(table: pd.DataFrame, plan: AnalysisPlan, compared: Sequence[str], source: str | Path,
              notes: list[str] | None) -> pd.DataFrame:
    """``table`` after ``plan``'s filters; the values they left out of the ``compared`` metrics are
    said in ``notes`` (a line naming ``source``), as ``nudge analyze`` says them."""
    filters = apply_plan_filters(table, plan, compared, changed=False)
    if filters.line and notes is not None:
        notes.append(f"{source}: {filters.line}")
    return filters.table


def condition_pair(simulated: str, real: str) -> str:
    """How a compared condition is named in print and in figure titles: ``real``, or
    ``simulated as real`` where ``--match`` paired two names (``disambiguation as control``)."""
    return real if simulated == real else f"{simulated} as {real}"


#: The tables :func:`write_comparison` writes (the figure is :mod:`nudgecli.report.compare_figure`'s).
COMPARISON_FILES = ("compare.csv", "participant_medians.csv", "compare.json")


def write_comparison(result: Comparison, out: str | Path,
                     beside: Callable[[], list[Path]] | None = None) -> list[Path]:
    """Write ``compare.csv``, ``participant_medians.csv`` and ``compare.json`` into ``out``, renamed
    into place together once ``beside`` (the figure's writer) has written its files too
    (:func:`~nudgecli.outputs.written_together`): a failure leaves the earlier files as they were."""
    import json

    folder = Path(out)
    check_not_a_file(folder)
    return written_together(dict(zip((folder / name for name in COMPARISON_FILES), (
        result.table.to_csv(index=False),
        result.medians.to_csv(index=False),
        json.dumps(result.to_json(), indent=2, allow_nan=False) + "\n",
    ), strict=True)), beside)


def _real_folder_message(path: Path) -> str:
    """The line for a folder given as REAL: a run folder's metrics table (``nudge analyze RUN``, with
    no --out, writes it into the run folder itself) is the REAL to give; another folder is none."""
    table = path / METRICS_CSV
    said = f"{path} is a folder; REAL must be a metrics table of real trials (.csv or .parquet"
    if not is_run_folder(path):
        return f"{said}, one row per trial with participant, condition and metric columns)"
    made = "" if table.is_file() else f"`{shell_words(['nudge', 'analyze', str(path)])}` writes it, then "
    return f"{said}): for the run's trials give its metrics table ({made}give {table})"
