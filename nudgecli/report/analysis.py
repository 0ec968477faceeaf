"""``nudge analyze``: a run folder or a metrics table + an analysis plan -> tables and files.

The source is either

- a run folder (DESIGN section 4): every ``trials/part-*.parquet`` and ``steps/part-*.parquet``
  is read and the plan's metrics are computed per trial (:mod:`nudgecli.report.metrics`); or
- a metrics table (CSV or Parquet): one row per trial with ``participant``, ``condition`` and
  metric columns (real study data). Every other column is a metric and must be numeric
  (booleans count as 0/1), except ``block``, ``trial``, ``layout``, ``n_goals`` and ``true_goal``.

The plan's filters apply, then the statistics (:mod:`nudgecli.report.stats`). Written
atomically (temporary file in the same folder, then ``os.replace``) to the run folder, the
table's folder, or ``out``: ``metrics.csv``, ``stats.json``, ``stats.csv``, ``summary.md`` and,
with questionnaires, ``questionnaires.csv``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from nudgecli.config import did_you_mean, list_presets
from nudgecli.errors import ConfigError, DataError, RunFolderError
from nudgecli.report.checksum import CHECKSUM_KEY, metrics_checksum
from nudgecli.report.metrics import (
    ID_COLUMNS,
    INPUT_STEP_COLUMNS,
    METRIC_NAMES,
    STEP_COLUMNS,
    TRIAL_COLUMNS,
    apply_filters,
    trial_metrics,
)
from nudgecli.report.plans import AnalysisPlan, load_plan
from nudgecli.report.questionnaires import questionnaire_scores, read_questionnaires, score_columns
from nudgecli.report.stats import (
    SINGLE_CONDITION_NOTE,
    ComparisonOptions,
    compare_conditions,
    json_ready,
    order_conditions,
    stats_table,
)
from nudgecli.store import RunFolder, write_text_atomic

#: Columns of a metrics table that describe the trial rather than measure it.
NON_METRIC_COLUMNS = (*ID_COLUMNS, "layout", "n_goals", "true_goal")
TABLE_SUFFIXES = (".csv", ".parquet", ".pq")
RUN_FOLDER_MARKERS = ("trials", "steps", "manifest.json", "config.toml")


@dataclass
class AnalysisResult:
    """What :func:`analyze` computed and where it wrote it.

    Attributes
    ----------
    out
        The folder the files went to.
    files
        The files written.
    metrics
        The per-trial metrics (after the plan's filters).
    stats
        The ``stats.json`` document (JSON-ready: NaN as ``None``).
    table
        ``stats.csv``: one row per metric x pair of conditions.
    summary
        ``summary.md``.
    questionnaires
        The questionnaire scores, if a questionnaire table was given.
    """

    out: Path
    files: list[Path]
    metrics: pd.DataFrame
    stats: dict[str, Any]
    table: pd.DataFrame
    summary: str
    questionnaires: pd.DataFrame | None = field(default=None)


# --- reading -----------------------------------------------------------------------------------


def is_run_folder(path: Path) -> bool:
    """Whether ``path`` is a folder that looks like a run folder (trials/, steps/ or a manifest)."""
    return path.is_dir() and any((path / marker).exists() for marker in RUN_FOLDER_MARKERS)


def read_run(folder: str | Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The trial table and step log of a run folder (only the columns the metrics use).

    Returns
    -------
    (pd.DataFrame, pd.DataFrame)
        ``trials`` with :data:`~nudgecli.report.metrics.TRIAL_COLUMNS`, ``steps`` with
        :data:`~nudgecli.report.metrics.STEP_COLUMNS`.

    Raises
    ------
    RunFolderError
        No trial parts yet, or no step parts.
    DataError
        A part is unreadable or lacks a column.
    """
    folder = Path(folder)
    run = RunFolder(folder)
    trials = run.read_table("trials", TRIAL_COLUMNS)
    if trials.empty:
        raise RunFolderError(f"{folder}: trials/part-*.parquet hold no trials yet; "
                             "run `nudge simulate` first")
    steps = run.read_table("steps", [*STEP_COLUMNS, *INPUT_STEP_COLUMNS])
    return trials, steps


def read_metrics_table(path: str | Path) -> pd.DataFrame:
    """Read a metrics table (CSV or Parquet) as it is.

    Raises
    ------
    DataError
        Not a CSV/Parquet file, empty, unreadable, or no rows.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in TABLE_SUFFIXES:
        raise DataError(f"{path} is neither a run folder nor a metrics table; give a run folder (with "
                        "trials/ and steps/) or a .csv/.parquet table with one row per trial")
    try:
        table = pd.read_csv(path) if suffix == ".csv" else pd.read_parquet(path)
    except pd.errors.EmptyDataError:
        raise DataError(f"{path} is empty; a metrics table needs a header (participant, condition, "
                        "metrics) and one row per trial") from None
    except (pd.errors.ParserError, UnicodeDecodeError, OSError, ValueError) as exc:
        raise DataError(f"{path} cannot be read as a {suffix[1:]} table: {exc}") from None
    if table.empty:
        raise DataError(f"{path} has no rows; a metrics table needs one row per trial")
    return table


def _is_numeric(series: pd.Series) -> bool:
    return pd.api.types.is_bool_dtype(series) or pd.api.types.is_numeric_dtype(series)


def _as_boolean(series: pd.Series) -> pd.Series | None:
    """A column of True/False with blanks (read by pandas as objects) as nullable booleans, else None."""
    values = series.dropna()
    if len(values) and all(isinstance(v, bool | np.bool_) for v in values):
        return series.astype("boolean")
    return None


def validate_metrics_table(table: pd.DataFrame, source: str, min_conditions: int = 1) -> list[str]:
    """Check a metrics table and return its metric columns.

    Boolean columns with blanks (``True``, ``False``, empty) are converted in place to nullable
    booleans.

    Parameters
    ----------
    min_conditions
        Fewest conditions the table must hold (2 to compare conditions; 1 for ``nudge compare``).

    Raises
    ------
    DataError
        A missing or incomplete ``participant``/``condition`` column, no metric column, a
        non-numeric metric column, or fewer than ``min_conditions`` conditions (a single
        condition is analysed descriptively).
    """
    for column in ("participant", "condition"):
        if column not in table.columns:
            hint = did_you_mean(column, [str(c) for c in table.columns])
            raise DataError(f"{source} has no {column!r} column{hint}; a metrics table needs "
                            "participant, condition and metric columns, one row per trial")
        empty = table[column].isna()
        if empty.any():
            row = int(empty.to_numpy().nonzero()[0][0])
            raise DataError(f"{source}: column {column!r} is empty in row {row + 2}; fill it in or "
                            "remove the row")
    metric_columns = [str(c) for c in table.columns if c not in NON_METRIC_COLUMNS]
    if not metric_columns:
        raise DataError(f"{source} has no metric columns; add one numeric column per metric "
                        f"(e.g. {', '.join(METRIC_NAMES[:3])})")
    for column in metric_columns:
        if table[column].dtype == object and (converted := _as_boolean(table[column])) is not None:
            table[column] = converted
        if not _is_numeric(table[column]):
            values = table[column].dropna()
            example = f" (e.g. {values.iloc[0]!r})" if len(values) else ""
            raise DataError(f"{source}: metric column {column!r} is not numeric{example}; make it numeric, "
                            "remove it, or pick the metrics with --metric")
    conditions = table["condition"].astype(str).unique()
    if len(conditions) < min_conditions:
        raise DataError(f"{source}: column 'condition' holds a single condition ({conditions[0]!r}); "
                        "comparing needs at least two conditions")
    return metric_columns


def _select_metrics(requested: Sequence[str] | None, available: Sequence[str]) -> list[str]:
    if not requested:
        return list(available)
    selected: list[str] = []
    for name in requested:
        if name not in available:
            raise DataError(f"unknown metric {name!r}{did_you_mean(name, available)}; available: "
                            f"{', '.join(available)}")
        if name not in selected:
            selected.append(name)
    return selected


def _check_filters(plan: AnalysisPlan, available: Sequence[str]) -> None:
    known = set(METRIC_NAMES) | set(available)
    for name in plan.filters:
        if name not in known:
            raise ConfigError(f"analysis plan {plan.name!r}: [filters] names unknown metric {name!r}"
                              f"{did_you_mean(name, sorted(known))}")


# --- writing -----------------------------------------------------------------------------------


# --- formatting --------------------------------------------------------------------------------


def format_value(value: Any) -> str:
    """A number for a table: ``-`` when missing, integers plain, else 3 significant digits."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    if isinstance(value, bool):
        return str(value)
    if float(value).is_integer() and abs(value) < 1e6:
        return str(int(value))
    if abs(value) >= 100:
        return f"{value:.1f}"
    return f"{value:.3g}"


def format_p(p: float | None) -> str:
    """A p-value for a table: ``<0.001`` below 0.001, else 3 decimals; ``-`` when missing."""
    if p is None or not math.isfinite(p):
        return "-"
    return "<0.001" if p < 0.001 else f"{p:.3f}"


def _median_iqr(entry: dict[str, Any], condition: str) -> str:
    return (f"{format_value(entry['median'][condition])} [{format_value(entry['q1'][condition])}, "
            f"{format_value(entry['q3'][condition])}]")


def _effect(entry: dict[str, Any]) -> str:
    effect = entry["effect_size"]
    symbol = "r" if effect["name"] == "rank_biserial" else "W"
    return f"{symbol}={format_value(effect['value'])}"


def _interval(pair: dict[str, Any]) -> str:
    return (f"{format_value(pair['difference'])} [{format_value(pair['low'])}, "
            f"{format_value(pair['high'])}]")


def _render(header: list[str], rows: list[list[str]], markdown: bool) -> str:
    if markdown:
        lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
        lines += ["| " + " | ".join(row) + " |" for row in rows]
        return "\n".join(lines)
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    lines = ["  ".join(cell.ljust(w) for cell, w in zip(header, widths, strict=True)).rstrip()]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip() for row in rows]
    return "\n".join(lines)


def format_table(stats: dict[str, Any]) -> str:
    """A plain-text table of ``stats.json``: one row per metric x pair of conditions.

    Columns: median [q1, q3] of both conditions, Kruskal-Wallis p, Conover p, stars, the
    participant-level p, the effect size and the median difference with its interval.
    """
    if len(stats["conditions"]) == 1:
        (c,) = stats["conditions"]
        rows = [[entry["metric"], str(entry["n"][c]), _median_iqr(entry, c), format_value(entry["mean"][c])]
                for entry in stats["metrics"]]
        return _render(["metric", "n", f"{c} median [q1, q3]", "mean"], rows, markdown=False) + \
            "\n(one condition: descriptive statistics only, no tests)"
    two = len(stats["conditions"]) == 2
    level = stats["metrics"][0]["ci"]["level"] if stats["metrics"] else 0.95
    if two:
        a, b = stats["conditions"]
        header = ["metric", f"{a} median [q1, q3]", f"{b} median [q1, q3]"]
    else:
        header = ["metric", "comparison", "a median [q1, q3]", "b median [q1, q3]"]
    header += ["KW p", "Conover p", "stars", "participant p", "effect", f"a-b [{level:.0%} CI]"]
    rows = []
    for entry in stats["metrics"]:
        posthoc = {(r["a"], r["b"]): r for r in entry["conover"]}
        stars = {(r["a"], r["b"]): r["stars"] for r in entry["stars"]}
        for pair in entry["ci"]["pairs"]:
            a, b = pair["a"], pair["b"]
            row = [entry["metric"]] + ([] if two else [f"{a} vs {b}"])
            row += [_median_iqr(entry, a), _median_iqr(entry, b), format_p(entry["kruskal"]["p"]),
                    format_p(posthoc[a, b]["p"]), stars[a, b] or "ns",
                    format_p(entry["participant_level"]["p"]),
                    _effect(entry), _interval(pair)]
            rows.append(row)
    return _render(header, rows, markdown=False)


def format_summary(stats: dict[str, Any], plan: AnalysisPlan, source: Path, n_trials: int,
                   n_participants: int) -> str:
    """``summary.md``: the settings, then per metric a line of tests and two markdown tables."""
    settings = plan.stats
    comparison = settings.star_comparison
    thresholds = ", ".join(f"{t:g}" for t in settings.star_thresholds)
    conditions = stats["conditions"]
    test = "Wilcoxon signed-rank" if len(conditions) == 2 else "Friedman"
    effect = "matched-pairs rank-biserial r of a - b" if len(conditions) == 2 else "Kendall's W"
    seed = stats["metrics"][0]["ci"]["seed"] if stats["metrics"] else plan.bootstrap.seed
    if len(conditions) == 1:
        return _descriptive_summary(stats, plan, source, n_trials, n_participants)
    lines = [
        "# Analysis summary",
        "",
        f"- source: `{source}`",
        f"- plan: {plan.name}; conditions: {', '.join(conditions)}; {n_trials} trials of "
        f"{n_participants} participants",
        f"- trial level: Kruskal-Wallis, then Conover's test ({settings.p_adjust} adjustment); stars "
        f"(one per threshold {thresholds}, p {comparison} threshold) from the Conover p, only when "
        f"Kruskal-Wallis p {comparison} {settings.kruskal_alpha:g}",
        f"- participant level: {test} on per-participant {settings.participant_aggregate}s; "
        f"effect size: {effect}",
        f"- interval: {plan.bootstrap.level:.0%} cluster bootstrap over participants of the difference of "
        f"trial medians ({plan.bootstrap.resamples} resamples, seed {seed})",
    ]
    for entry in stats["metrics"]:
        kruskal, level = entry["kruskal"], entry["participant_level"]
        lines += [
            "",
            f"## {entry['metric']}",
            "",
            f"Kruskal-Wallis H = {format_value(kruskal['statistic'])}, p = {format_p(kruskal['p'])}. "
            f"Participant level ({level['test']}, {level['n_participants']} participants): "
            f"statistic = {format_value(level['statistic'])}, p = {format_p(level['p'])}. "
            f"Effect size: {_effect(entry)}.",
        ]
        if level["note"]:
            lines += ["", f"Note: {level['note']}."]
        lines += ["", _render(
            ["condition", "n", "median [q1, q3]", "mean"],
            [[c, str(entry["n"][c]), _median_iqr(entry, c), format_value(entry["mean"][c])]
             for c in conditions],
            markdown=True)]
        posthoc = {(r["a"], r["b"]): r for r in entry["conover"]}
        stars = {(r["a"], r["b"]): r["stars"] for r in entry["stars"]}
        rows = [[f"{p['a']} - {p['b']}", format_p(posthoc[p["a"], p["b"]]["p"]),
                 format_p(posthoc[p["a"], p["b"]]["p_unadjusted"]), stars[p["a"], p["b"]] or "ns",
                 format_value(p["difference"]), f"[{format_value(p['low'])}, {format_value(p['high'])}]"]
                for p in entry["ci"]["pairs"]]
        lines += ["", _render(
            ["comparison", f"Conover p ({entry['p_adjust']})", "p unadjusted", "stars",
             "difference of medians", f"{entry['ci']['level']:.0%} CI"], rows, markdown=True)]
    return "\n".join(lines) + "\n"


def _descriptive_summary(stats: dict[str, Any], plan: AnalysisPlan, source: Path, n_trials: int,
                         n_participants: int) -> str:
    """``summary.md`` of a single condition: the descriptives per metric and a note (no tests)."""
    (condition,) = stats["conditions"]
    lines = [
        "# Analysis summary",
        "",
        f"- source: `{source}`",
        f"- plan: {plan.name}; condition: {condition}; {n_trials} trials of {n_participants} participants",
        f"- note: {SINGLE_CONDITION_NOTE} (the tests compare conditions)",
        "",
        _render(["metric", "n", "median [q1, q3]", "mean"],
                [[e["metric"], str(e["n"][condition]), _median_iqr(e, condition),
                  format_value(e["mean"][condition])]
                 for e in stats["metrics"]], markdown=True),
    ]
    return "\n".join(lines) + "\n"


# --- the analysis ------------------------------------------------------------------------------


def comparison_options(plan: AnalysisPlan, seed: int | None = None) -> ComparisonOptions:
    """The statistics settings of a plan (its [stats] and [bootstrap]; ``seed`` overrides the bootstrap's)."""
    return plan.comparison_options(seed)


def load_source(source: Path, plan: AnalysisPlan,
                min_conditions: int = 1) -> tuple[pd.DataFrame, list[str], Path]:
    """The metrics table, its metric columns and the default output folder of a source.

    A run folder's metrics are computed with ``plan``'s definitions; a table is validated
    (:func:`validate_metrics_table`, at least ``min_conditions`` conditions).
    """
    if not source.exists():
        raise DataError(f"{source} does not exist; give a run folder or a metrics table (.csv/.parquet)")
    if source.is_dir():
        if not is_run_folder(source):
            raise DataError(f"{source} is neither a run folder nor a metrics table: it has no trials/ or "
                            "steps/; give a folder made by `nudge simulate` or a .csv/.parquet table")
        trials, steps = read_run(source)
        definitions = plan.metrics
        metrics = trial_metrics(trials, steps, engagement=definitions.engagement,
                                strength=definitions.strength, mode_switches=definitions.mode_switches,
                                success=definitions.success, completion_time=definitions.completion_time)
        return metrics, list(definitions.include), source
    table = read_metrics_table(source)
    metric_columns = validate_metrics_table(table, str(source), min_conditions)
    return table, metric_columns, source.parent


def default_plan(source: str | Path) -> str:
    """The plan preset named like the run folder's experiment (e.g. ``ciaa-teleop``), else ``paper``."""
    folder = Path(source)
    if folder.is_dir() and (folder / "manifest.json").is_file():
        try:
            experiment = str(RunFolder(folder).read_manifest().get("experiment", ""))
        except (DataError, RunFolderError, OSError, ValueError):
            return "paper"
        if experiment in list_presets("analysis"):
            return experiment
    return "paper"


def analyze(source: str | Path, plan: str | Path | AnalysisPlan | None = "paper",
            out: str | Path | None = None,
            metrics: Sequence[str] | None = None, questionnaires: str | Path | None = None,
            seed: int | None = None) -> AnalysisResult:
    """Compute the metrics and statistics of a run or a metrics table and write them.

    Parameters
    ----------
    source
        A run folder (``trials/`` and ``steps/`` Parquet parts) or a metrics table (CSV or
        Parquet, one row per trial with ``participant``, ``condition`` and metric columns).
    plan
        An analysis plan: preset name (``paper``, ``study-code``, ``ciaa-teleop``), TOML path, or a
        plan; ``None``: :func:`default_plan` of the source.
    out
        Output folder; default the run folder, or the table's folder.
    metrics
        Only these metrics (trial metrics or questionnaire scores), in this order; default all
        of the plan's (run folder) or of the table's columns, then every questionnaire score.
    questionnaires
        A questionnaire CSV (:mod:`nudgecli.report.questionnaires`) analysed alongside.
    seed
        Bootstrap seed; default the plan's.

    Returns
    -------
    AnalysisResult

    Raises
    ------
    DataError, RunFolderError, ConfigError
        Invalid source, table, questionnaire table, metric name or plan (one clear message each).
    """
    plan = load_plan(default_plan(source) if plan is None else plan)
    source = Path(source)
    table, available, default_out = load_source(source, plan)
    _check_filters(plan, available)

    scores = None
    score_names: list[str] = []
    if questionnaires is not None:
        scores = questionnaire_scores(read_questionnaires(questionnaires), source=str(questionnaires))
        score_names = score_columns(scores)
        trial_conditions = set(table["condition"].astype(str))
        score_conditions = set(scores["condition"])
        if score_conditions != trial_conditions:
            raise DataError(f"{questionnaires}: conditions {sorted(score_conditions)} differ from those of "
                            f"{source} {sorted(trial_conditions)}; name the conditions the same way")

    selected = _select_metrics(metrics, [*available, *score_names])
    trial_selected = [m for m in selected if m in available]
    score_selected = [m for m in selected if m in score_names]

    filtered = apply_filters(table, plan.filters)
    conditions = order_conditions(filtered["condition"].astype(str), plan.conditions)
    options = comparison_options(plan, seed)
    stats = compare_conditions(filtered, trial_selected, conditions, options)
    if scores is not None and score_selected:
        stats["metrics"] += compare_conditions(scores, score_selected, conditions, options)["metrics"]
    stats[CHECKSUM_KEY] = metrics_checksum(filtered, trial_selected, plan.filters)
    stats = json_ready(stats)
    tidy = stats_table(stats)
    summary = format_summary(stats, plan, source, n_trials=len(filtered),
                             n_participants=filtered["participant"].nunique())

    out_dir = Path(out) if out is not None else default_out
    if out_dir.exists() and not out_dir.is_dir():
        raise DataError(f"--out {out_dir} is a file; give a folder")
    written: list[Path] = []
    metrics_path = out_dir / "metrics.csv"
    metrics_columns = [c for c in filtered.columns if c in NON_METRIC_COLUMNS or c in available]
    if not (source.is_file() and metrics_path.resolve() == source.resolve()):
        write_text_atomic(metrics_path, filtered[metrics_columns].to_csv(index=False))
        written.append(metrics_path)
    outputs = {
        "stats.json": json.dumps(stats, indent=2, allow_nan=False) + "\n",
        "stats.csv": tidy.to_csv(index=False),
        "summary.md": summary,
    }
    if scores is not None:
        outputs["questionnaires.csv"] = scores.to_csv(index=False)
    for name, text in outputs.items():
        write_text_atomic(out_dir / name, text)
        written.append(out_dir / name)
    return AnalysisResult(out=out_dir, files=written, metrics=filtered, stats=stats, table=tidy,
                          summary=summary, questionnaires=scores)
