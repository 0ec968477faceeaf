"""``nudge analyze``: a run folder or a metrics table + an analysis plan -> tables and files.

The source is either

- a run folder (DESIGN section 4): every ``trials/part-*.parquet`` and ``steps/part-*.parquet``
  is read and the plan's metrics are computed per trial (:mod:`nudgecli.report.metrics`); or
- a metrics table (CSV or Parquet): one row per trial with ``participant``, ``condition`` and
  metric columns (real study data). Every other column is a metric and must be numeric
  (booleans count as 0/1), except ``block``, ``trial``, ``layout``, ``n_goals`` and ``true_goal``.

A run folder must be complete: every participant its manifest promises has readable parts,
and the run finished (otherwise the error names what is missing and the ``nudge simulate ...
--resume`` command that restores it). Without ``--plan`` it is analysed with the plan recorded
in its manifest. A metrics table is checked before analysis: duplicate trials (same
participant, condition, block and trial) are an error unless ``drop_duplicates``, infinite
values are an error naming rows and columns, condition labels that differ only by case or
surrounding spaces are an error with a "did you mean"; a CSV's delimiter is sniffed.

The plan's filters apply, then the statistics (:mod:`nudgecli.report.stats`). Written
atomically (temporary file in the same folder, then ``os.replace``), while holding the folder's
lock (:func:`nudgecli.store.run_lock`), to the run folder, ``<table>-analysis/`` beside a table
(``study.csv`` gives ``study-analysis/``), or ``out``: ``stats.json``, ``stats.csv``,
``summary.md``, ``metrics.csv`` (for a run folder, or a table the analysis changed; a table
analysed as it is is not copied: ``stats.json``'s ``metrics_table`` names the table the
statistics came from) and, with questionnaires, ``questionnaires.csv``.
"""

from __future__ import annotations

import contextlib
import csv
import json
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from nudgecli.config_files import resolve_plan
from nudgecli.errors import ConfigError, DataError, RunFolderError, did_you_mean
from nudgecli.errors import WriteError as NudgeWriteError
from nudgecli.locks import run_lock
from nudgecli.report.checksum import CHECKSUM_KEY, metrics_checksum
from nudgecli.report.metrics import (
    ID_COLUMNS,
    INPUT_STEP_COLUMNS,
    METRIC_NAMES,
    METRIC_STEP_COLUMNS,
    TRIAL_COLUMNS,
    apply_filters,
    trial_metrics,
)
from nudgecli.report.plans import AnalysisPlan, load_plan
from nudgecli.report.questionnaires import (
    check_respondents,
    questionnaire_scores,
    read_questionnaires,
    score_columns,
)
from nudgecli.report.stats import (
    SINGLE_CONDITION_NOTE,
    ComparisonOptions,
    compare_conditions,
    condition_table,
    json_ready,
    order_conditions,
    stats_csv,
    stats_table,
)
from nudgecli.run_folder_names import METRICS_CSV, QUESTIONNAIRES_CSV, STATS_CSV, STATS_JSON, SUMMARY_MD
from nudgecli.store import RunFolder, is_run_folder, write_text_atomic

#: Columns of a metrics table that describe the trial rather than measure it.
NON_METRIC_COLUMNS = (*ID_COLUMNS, "layout", "n_goals", "true_goal")
TABLE_SUFFIXES = (".csv", ".parquet", ".pq")
#: The columns that identify one trial of a metrics table (those present are used).
TRIAL_KEY = ("participant", "condition", "block", "trial")
#: How many rows or pairs an error message lists.
_SHOWN = 5


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
    notes
        What was excluded or changed (duplicates dropped, participants left out of a test),
        one line each, for stderr.
    """

    out: Path
    files: list[Path]
    metrics: pd.DataFrame
    stats: dict[str, Any]
    table: pd.DataFrame
    summary: str
    questionnaires: pd.DataFrame | None = field(default=None)
    notes: list[str] = field(default_factory=list)


# --- reading -----------------------------------------------------------------------------------


def read_run(folder: str | Path, notes: list[str] | None = None) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The trial table and step log of a run folder (only the columns the metrics use).

    With a manifest, exactly the parts of the participants it promises are read, each verified
    against the SHA-256 the manifest recorded (:meth:`nudgecli.store.RunFolder.read_table`);
    stray parts and parts without a recorded checksum (an older nudge's run, still read) are
    reported in ``notes``.

    Returns
    -------
    (pd.DataFrame, pd.DataFrame)
        ``trials`` with :data:`~nudgecli.report.metrics.TRIAL_COLUMNS`, ``steps`` with
        :data:`~nudgecli.report.metrics.METRIC_STEP_COLUMNS`.

    Raises
    ------
    RunFolderError
        No trial parts yet, or no step parts, or (with a manifest) parts missing or unreadable or
        the run unfinished.
    DataError
        A part is unreadable or lacks a column.
    """
    folder = Path(folder)
    run = RunFolder(folder)
    if run.is_run():
        manifest = run.read_manifest()
        kept_metrics_only = (folder / METRICS_CSV).is_file() and \
            not any((folder / "steps").glob("part-*.parquet"))
        if "participants" in manifest and not kept_metrics_only:
            run.check_complete()
            if notes is not None:
                notes += run.integrity_notes(manifest)
    trials = run.read_table("trials", TRIAL_COLUMNS)
    if trials.empty:
        raise RunFolderError(f"{folder}: trials/part-*.parquet hold no trials yet; "
                             "run `nudge simulate` first")
    steps = run.read_table("steps", [*METRIC_STEP_COLUMNS, *INPUT_STEP_COLUMNS])
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
        if suffix == ".csv":
            delimiter = sniff_delimiter(path)
            check_unique_columns(_csv_header(path, delimiter), path)
            # conditions as categories: a large table's labels are not copied into millions of strings
            table = pd.read_csv(path, sep=delimiter, dtype={"condition": "category"})
        else:
            check_unique_columns(pq.read_schema(path).names, path)
            table = pd.read_parquet(path)
    except pd.errors.EmptyDataError:
        raise DataError(f"{path} is empty; a metrics table needs a header (participant, condition, "
                        "metrics) and one row per trial") from None
    except (pd.errors.ParserError, UnicodeDecodeError, OSError, ValueError, pa.ArrowException) as exc:
        raise DataError(f"{path} cannot be read as a {suffix[1:]} table: {exc}") from None
    if table.empty:
        raise DataError(f"{path} has no rows; a metrics table needs one row per trial")
    release_free_memory()
    return table


def _csv_header(path: Path, delimiter: str) -> list[str]:
    """The column names of a CSV file's first line, as written."""
    with open(path, encoding="utf-8-sig", errors="replace", newline="") as handle:
        return next(csv.reader(handle, delimiter=delimiter), [])


def check_unique_columns(names: Sequence[str], source: str | Path) -> None:
    """Refuse a table in which two columns share a name (pandas would rename the second
    ``name.1`` and analyse it as a metric of its own).

    Raises
    ------
    DataError
        Naming the column and its positions (1-based).
    """
    positions: dict[str, list[int]] = {}
    for position, name in enumerate(names, start=1):
        positions.setdefault(str(name), []).append(position)
    repeated = {name: where for name, where in positions.items() if len(where) > 1}
    if repeated:
        listed = "; ".join(f"{name!r} (columns {', '.join(map(str, where[:-1]))} and {where[-1]})"
                           for name, where in repeated.items())
        raise DataError(f"{source}: more than one column of one name: {listed}; rename or remove the "
                        "repeats so that each column has its own name")


def release_free_memory() -> None:
    """Hand the heap that parsing freed back to the operating system (glibc only; else nothing).

    The CSV parser makes and frees millions of small objects (one per label cell); glibc keeps
    that memory in the process unless asked, which for a table of millions of rows is a few
    hundred MB of resident memory that nothing uses.
    """
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    if name is None:  # pragma: no cover - not a C library ctypes can find
        return
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(name).malloc_trim(0)


def sniff_delimiter(path: Path, sample_bytes: int = 65536) -> str:
    """The field separator of a CSV file (``,``, ``;``, tab or ``|``), from its first 64 KiB.

    ``csv.Sniffer`` decides; a file it cannot decide (one column) is read with ``,``.
    """
    try:
        with open(path, encoding="utf-8", errors="replace", newline="") as handle:
            sample = handle.read(sample_bytes)
    except OSError:
        return ","  # pandas reports the problem when it reads the file
    lines = sample.splitlines()
    if len(sample) == sample_bytes and len(lines) > 1:
        sample = "\n".join(lines[:-1])  # the last line may be cut
    try:
        return csv.Sniffer().sniff(sample, delimiters=",;\t|").delimiter
    except csv.Error:
        return ","


def _rows(positions: Sequence[int], first_row: int) -> str:
    """Row numbers for a message: the first few, then how many more."""
    shown = ", ".join(str(int(i) + first_row) for i in positions[:_SHOWN])
    more = f" and {len(positions) - _SHOWN} more" if len(positions) > _SHOWN else ""
    return shown + more


def check_condition_labels(table: pd.DataFrame, source: str) -> None:
    """Refuse condition labels that differ only by case or surrounding spaces (``Control``, ``control ``).

    Raises
    ------
    DataError
        Naming the near-identical labels and the most frequent spelling as the one meant.
    """
    counts = table["condition"].value_counts()  # most frequent first
    groups: dict[str, list[str]] = {}
    for label in (str(value) for value, count in counts.items() if count > 0):
        groups.setdefault(label.strip().casefold(), []).append(label)
    for spellings in groups.values():
        if len(spellings) > 1:
            listed = ", ".join(repr(label) for label in spellings)
            raise DataError(f"{source}: condition labels {listed} differ only by case or surrounding spaces "
                            f"(did you mean {spellings[0]!r}?); spell each condition one way")


def find_duplicate_trials(table: pd.DataFrame) -> tuple[list[str], np.ndarray]:
    """The trial key columns present and a mask of rows repeating an earlier row's key.

    Returns
    -------
    (list of str, np.ndarray)
        The key columns used (``participant``, ``condition`` and whichever of ``block``,
        ``trial`` exist) and ``(n_rows,)`` booleans, True for each repeat after the first. No
        ``trial`` column: no key, nothing is a duplicate.
    """
    if "trial" not in table.columns:
        return [], np.zeros(len(table), dtype=bool)
    key = [c for c in TRIAL_KEY if c in table.columns]
    combined = np.zeros(len(table), dtype=np.int64)
    span = 1
    for column in key:  # one int64 code per row: far less memory than DataFrame.duplicated on a large table
        column_codes, uniques = pd.factorize(table[column], use_na_sentinel=False)
        size = max(1, len(uniques))
        span *= size
        if span >= 2**62:  # the combined code would overflow: let pandas hash the rows
            return key, table.duplicated(subset=key, keep="first").to_numpy()
        combined *= size
        combined += column_codes
        del column_codes
    order = np.argsort(combined, kind="stable")  # equal keys stay in row order: the first is kept
    ordered = combined[order]
    repeats = np.zeros(len(table), dtype=bool)
    repeats[order[1:][ordered[1:] == ordered[:-1]]] = True
    return key, repeats


def _check_finite(table: pd.DataFrame, metric_columns: Sequence[str], source: str, first_row: int) -> None:
    """Refuse infinite values in metric columns (missing values are allowed: they are left out)."""
    bad: list[str] = []
    positions: set[int] = set()
    for column in metric_columns:
        if pd.api.types.is_bool_dtype(table[column]):
            continue
        values = table[column].to_numpy(dtype=float, na_value=np.nan)
        infinite = np.flatnonzero(np.isinf(values))
        if infinite.size:
            bad.append(f"{column!r} (rows {_rows(list(infinite), first_row)})")
            positions.update(int(i) for i in infinite)
    if bad:
        raise DataError(f"{source}: infinite values in {len(positions)} row(s): {'; '.join(bad)}; "
                        "replace them with a number or leave the cell empty (a missing value)")


def _first_non_number(series: pd.Series, first_row: int) -> str:
    """`` (row R holds 'VALUE')``: the first cell of a non-numeric column that is not a number
    (a blank is a missing value, not the culprit); empty if none can be singled out."""
    present = series.notna().to_numpy()
    numbers = pd.to_numeric(series, errors="coerce").notna().to_numpy()
    culprits = np.flatnonzero(present & ~numbers)
    if not culprits.size:
        return ""
    more = f", and {culprits.size - 1} more cell(s)" if culprits.size > 1 else ""
    return f" (row {int(culprits[0]) + first_row} holds {series.iloc[int(culprits[0])]!r}{more})"


def _is_numeric(series: pd.Series) -> bool:
    return pd.api.types.is_bool_dtype(series) or pd.api.types.is_numeric_dtype(series)


def _as_boolean(series: pd.Series) -> pd.Series | None:
    """A column of True/False with blanks (read by pandas as objects) as nullable booleans, else None."""
    values = series.dropna()
    if len(values) and all(isinstance(v, bool | np.bool_) for v in values):
        return series.astype("boolean")
    return None


def validate_metrics_table(table: pd.DataFrame, source: str, first_row: int = 2,
                           min_conditions: int = 1) -> list[str]:
    """Check a metrics table and return its metric columns.

    Boolean columns with blanks (``True``, ``False``, empty) are converted in place to nullable
    booleans.

    Parameters
    ----------
    table
        The table as read.
    source
        Its name in messages.
    first_row
        The row number messages give the table's first row (2 for a CSV: line 1 is the header).
    min_conditions
        Fewest conditions the table must hold.

    Raises
    ------
    DataError
        A missing or incomplete ``participant``/``condition`` column, no metric column, a
        non-numeric metric column, an infinite value, condition labels differing only by case or
        surrounding spaces, or fewer than ``min_conditions`` conditions (a single condition is
        analysed descriptively).
    """
    for column in ("participant", "condition"):
        if column not in table.columns:
            hint = did_you_mean(column, [str(c) for c in table.columns])
            raise DataError(f"{source} has no {column!r} column{hint}; a metrics table needs "
                            "participant, condition and metric columns, one row per trial")
        empty = table[column].isna()
        if empty.any():
            row = int(empty.to_numpy().nonzero()[0][0])
            raise DataError(f"{source}: column {column!r} is empty in row {row + first_row}; fill it in "
                            "or remove the row")
    metric_columns = [str(c) for c in table.columns if c not in NON_METRIC_COLUMNS]
    if not metric_columns:
        raise DataError(f"{source} has no metric columns; add one numeric column per metric "
                        f"(e.g. {', '.join(METRIC_NAMES[:3])})")
    for column in metric_columns:
        if table[column].dtype == object and (converted := _as_boolean(table[column])) is not None:
            table[column] = converted
        if not _is_numeric(table[column]):
            culprit = _first_non_number(table[column], first_row)
            raise DataError(f"{source}: metric column {column!r} is not numeric{culprit}; make it numeric, "
                            "remove it, or pick the metrics with --metric")
    _check_finite(table, metric_columns, source, first_row)
    check_condition_labels(table, source)
    conditions = sorted({str(value) for value in table["condition"].dropna().unique()})
    if len(conditions) < min_conditions:
        raise DataError(f"{source}: column 'condition' holds {len(conditions)} condition(s); "
                        f"this needs at least {min_conditions}")
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


def _median_iqr(median: Any, q1: Any, q3: Any) -> str:
    return f"{format_value(median)} [{format_value(q1)}, {format_value(q3)}]"


def _effect(name: str, value: Any) -> str:
    symbol = "r" if name == "rank_biserial" else "W"
    return f"{symbol}={format_value(value)}"


def _interval(difference: Any, low: Any, high: Any) -> str:
    return f"{format_value(difference)} [{format_value(low)}, {format_value(high)}]"


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


def _descriptive_rows(table: pd.DataFrame, first: str) -> list[list[str]]:
    """Rows ``first, n, median [q1, q3], mean`` of :func:`~nudgecli.report.stats.condition_table`'s
    table; ``first`` names the column that opens each row (``metric`` or ``condition``)."""
    return [[str(row[first]), str(int(row["n"])), _median_iqr(row["median"], row["q1"], row["q3"]),
             format_value(row["mean"])] for row in table.to_dict("records")]


def format_table(table: pd.DataFrame, conditions: Sequence[str]) -> str:
    """A plain-text table of the statistics: one row per metric x pair of conditions.

    Parameters
    ----------
    table
        :func:`~nudgecli.report.stats.stats_table`'s tidy table of ``stats.json``.
    conditions
        ``stats.json``'s conditions, in order.

    Columns: median [q1, q3] of both conditions, Kruskal-Wallis p, Conover p, stars, the
    participant-level p, the effect size and the median difference with its interval.
    """
    if len(conditions) == 1:
        (c,) = conditions
        rows = _descriptive_rows(condition_table(table), "metric")
        return _render(["metric", "n", f"{c} median [q1, q3]", "mean"], rows, markdown=False) + \
            "\n(one condition: descriptive statistics only, no tests)"
    two = len(conditions) == 2
    level = table["ci_level"].iloc[0] if len(table) else 0.95
    if two:
        a, b = conditions
        header = ["metric", f"{a} median [q1, q3]", f"{b} median [q1, q3]"]
    else:
        header = ["metric", "comparison", "a median [q1, q3]", "b median [q1, q3]"]
    header += ["KW p", "Conover p", "stars", "participant p", "effect", f"a-b [{level:.0%} CI]"]
    rows = []
    for r in table.to_dict("records"):
        row = [r["metric"]] + ([] if two else [f"{r['a']} vs {r['b']}"])
        row += [_median_iqr(r["median_a"], r["q1_a"], r["q3_a"]),
                _median_iqr(r["median_b"], r["q1_b"], r["q3_b"]), format_p(r["kruskal_p"]),
                format_p(r["conover_p"]), r["stars"] or "ns", format_p(r["participant_p"]),
                _effect(r["effect_size_name"], r["effect_size"]),
                _interval(r["difference"], r["ci_low"], r["ci_high"])]
        rows.append(row)
    return _render(header, rows, markdown=False)


def format_summary(table: pd.DataFrame, conditions: Sequence[str], plan: AnalysisPlan, source: Path,
                   n_trials: int, n_participants: int) -> str:
    """``summary.md``: the settings, then per metric a line of tests and two markdown tables.

    ``table`` is :func:`~nudgecli.report.stats.stats_table`'s tidy table of ``stats.json``,
    ``conditions`` its conditions in order.
    """
    settings = plan.stats
    comparison = settings.star_comparison
    thresholds = ", ".join(f"{t:g}" for t in settings.star_thresholds)
    test = "Wilcoxon signed-rank" if len(conditions) == 2 else (
        f"Friedman, then Wilcoxon signed-rank for every pair ({settings.p_adjust} adjustment)")
    effect = "matched-pairs rank-biserial r of a - b" if len(conditions) == 2 else (
        "Kendall's W (Friedman), epsilon-squared (Kruskal-Wallis), matched-pairs rank-biserial r of a - b "
        "(each pair)")
    many = "pairwise_p" in table.columns  # more than two conditions: the pairs' own participant-level tests
    seed = table["ci_seed"].iloc[0] if len(table) else plan.bootstrap.seed
    if len(conditions) == 1:
        return _descriptive_summary(table, conditions, plan, source, n_trials, n_participants)
    resamples = table["ci_resamples"].iloc[0] if len(table) else plan.bootstrap.resamples
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
        f"trial medians ({resamples} resamples, seed {seed})",
    ]
    descriptives = condition_table(table)
    for metric, pairs_of_metric in table.groupby("metric", sort=False):
        first = pairs_of_metric.iloc[0]
        lines += [
            "",
            f"## {metric}",
            "",
            f"Kruskal-Wallis H = {format_value(first['kruskal_statistic'])}, "
            f"p = {format_p(first['kruskal_p'])}. "
            f"Participant level ({first['participant_test']}, {int(first['n_participants'])} participants): "
            f"statistic = {format_value(first['participant_statistic'])}, "
            f"p = {format_p(first['participant_p'])}. "
            f"Effect size: {_effect(first['effect_size_name'], first['effect_size'])}"
            + (f", epsilon-squared = {format_value(first['epsilon_squared'])}." if many else "."),
        ]
        if first["participant_note"]:
            lines += ["", f"Note: {first['participant_note']}."]
        lines += ["", _render(["condition", "n", "median [q1, q3]", "mean"],
                              _descriptive_rows(descriptives[descriptives["metric"] == metric], "condition"),
                              markdown=True)]
        rows = [[f"{r['a']} - {r['b']}", format_p(r["conover_p"]), format_p(r["conover_p_unadjusted"]),
                 r["stars"] or "ns", format_value(r["difference"]),
                 f"[{format_value(r['ci_low'])}, {format_value(r['ci_high'])}]"]
                + ([format_p(r["pairwise_p"]),
                    _effect(r["pairwise_effect_size_name"], r["pairwise_effect_size"])] if many else [])
                for r in pairs_of_metric.to_dict("records")]
        header = ["comparison", f"Conover p ({first['p_adjust']})", "p unadjusted", "stars",
                  "difference of medians", f"{first['ci_level']:.0%} CI"]
        if many:
            header += [f"Wilcoxon p ({first['p_adjust']})", "effect"]
        lines += ["", _render(header, rows, markdown=True)]
    return "\n".join(lines) + "\n"


def _descriptive_summary(table: pd.DataFrame, conditions: Sequence[str], plan: AnalysisPlan, source: Path,
                         n_trials: int, n_participants: int) -> str:
    """``summary.md`` of a single condition: the descriptives per metric and a note (no tests)."""
    (condition,) = conditions
    lines = [
        "# Analysis summary",
        "",
        f"- source: `{source}`",
        f"- plan: {plan.name}; condition: {condition}; {n_trials} trials of {n_participants} participants",
        f"- note: {SINGLE_CONDITION_NOTE} (the tests compare conditions)",
        "",
        _render(["metric", "n", "median [q1, q3]", "mean"],
                _descriptive_rows(condition_table(table), "metric"), markdown=True),
    ]
    return "\n".join(lines) + "\n"


# --- the analysis ------------------------------------------------------------------------------


def comparison_options(plan: AnalysisPlan, seed: int | None = None,
                       bootstrap: int | None = None) -> ComparisonOptions:
    """The statistics settings of a plan (its [stats] and [bootstrap]); ``seed`` and ``bootstrap``
    (the number of resamples) override the plan's."""
    options = plan.comparison_options(seed)
    return options if bootstrap is None else replace(options, bootstrap_resamples=bootstrap)


def analysed_metrics_path(folder: str | Path) -> Path | None:
    """The metrics table an analysis folder's statistics came from: its ``metrics.csv``, else the
    table ``stats.json``'s ``metrics_table`` names (a table analysed as it is is not copied);
    ``None`` when there is neither."""
    folder = Path(folder)
    if (folder / METRICS_CSV).is_file():
        return folder / METRICS_CSV
    try:
        named = json.loads((folder / STATS_JSON).read_text(encoding="utf-8")).get("metrics_table")
    except (OSError, ValueError, AttributeError):
        return None
    path = folder / named if isinstance(named, str) else None
    return path if path is not None and path.is_file() else None


def read_analysed_metrics(path: str | Path) -> pd.DataFrame:
    """Read the table :func:`analysed_metrics_path` names, conditions as plain strings."""
    path = Path(path)
    table = pd.read_csv(path) if path.name == METRICS_CSV else read_metrics_table(path)
    table["condition"] = table["condition"].astype(str)
    return table


def analysis_folder(table: Path) -> Path:
    """The default output folder of a metrics table: ``study.csv`` -> ``study-analysis/`` beside it."""
    return table.with_name(f"{table.stem}-analysis")


def drop_or_refuse_duplicates(table: pd.DataFrame, source: Path, first_row: int, drop_duplicates: bool,
                              notes: list[str]) -> tuple[pd.DataFrame, bool]:
    """``table`` without repeated trial rows (:func:`find_duplicate_trials`), and whether any were
    dropped: the one check of duplicated trials, for ``analyze`` and ``compare`` alike.

    Raises
    ------
    DataError
        Repeated trial rows and not ``drop_duplicates`` (naming the rows and the flag).
    """
    key, repeats = find_duplicate_trials(table)
    if not repeats.any():
        return table, False
    positions = np.flatnonzero(repeats)
    if not drop_duplicates:
        raise DataError(f"{source}: {positions.size} duplicate trial row(s) (same {', '.join(key)} as an "
                        f"earlier row): rows {_rows(list(positions), first_row)}; remove them, or pass "
                        "--drop-duplicates to keep the first of each")
    notes.append(f"{source}: dropped {positions.size} duplicate trial row(s) (same {', '.join(key)}; the "
                 f"first of each kept): rows {_rows(list(positions), first_row)}")
    return table.loc[~repeats].reset_index(drop=True), True


def _load_table(source: Path, drop_duplicates: bool,
                notes: list[str]) -> tuple[pd.DataFrame, list[str], bool]:
    """A checked metrics table, its metric columns, and whether duplicates were dropped."""
    table = read_metrics_table(source)
    first_row = 2 if source.suffix.lower() == ".csv" else 1
    metric_columns = validate_metrics_table(table, str(source), first_row)
    table, dropped = drop_or_refuse_duplicates(table, source, first_row, drop_duplicates, notes)
    return table, metric_columns, dropped


def _load_source(source: Path, plan: AnalysisPlan,
                 notes: list[str] | None = None) -> tuple[pd.DataFrame, list[str], Path]:
    """The metrics of a run folder, its metric columns and its default output folder (``notes``:
    :func:`read_run`'s)."""
    if not source.exists():
        raise DataError(f"{source} does not exist; give a run folder or a metrics table (.csv/.parquet)")
    if source.is_dir():
        if not is_run_folder(source):
            raise DataError(f"{source} is neither a run folder nor a metrics table: it has no trials/ or "
                            "steps/; give a folder made by `nudge simulate` or a .csv/.parquet table")
        trials, steps = read_run(source, notes)
        definitions = plan.metrics
        metrics = trial_metrics(trials, steps, engagement=definitions.engagement,
                                strength=definitions.strength, mode_switches=definitions.mode_switches,
                                success=definitions.success, completion_time=definitions.completion_time)
        return metrics, list(definitions.include), source
    raise AssertionError("_load_source takes run folders; tables go through _load_table")  # pragma: no cover


def load_source(source: Path, plan: AnalysisPlan, min_conditions: int = 1, *, drop_duplicates: bool = False,
                notes: list[str] | None = None) -> tuple[pd.DataFrame, list[str], Path]:
    """The metrics table, its metric columns and the default output folder of a source.

    A run folder's metrics are computed with ``plan``'s definitions; a table is read and checked
    as ``nudge analyze`` checks it (:func:`validate_metrics_table`, at least ``min_conditions``
    conditions; repeated trial rows refused, or dropped with ``drop_duplicates``:
    :func:`drop_or_refuse_duplicates`). What was left out goes to ``notes``.
    """
    notes = [] if notes is None else notes
    if not source.exists():
        raise DataError(f"{source} does not exist; give a run folder or a metrics table (.csv/.parquet)")
    if source.is_dir():
        return _load_source(source, plan, notes)
    table = read_metrics_table(source)
    first_row = 2 if source.suffix.lower() == ".csv" else 1
    metric_columns = validate_metrics_table(table, str(source), first_row, min_conditions)
    table, _ = drop_or_refuse_duplicates(table, source, first_row, drop_duplicates, notes)
    return table, metric_columns, analysis_folder(source)


def _study_conditions(manifest: dict[str, Any] | None) -> list[str]:
    """The conditions a run's experiment lists (``config.study.conditions`` of its manifest), in order."""
    study = ((manifest or {}).get("config") or {}).get("study") or {}
    listed = study.get("conditions") if isinstance(study, dict) else None
    return [str(c) for c in listed] if isinstance(listed, list | tuple) else []


def _plan_label(plan: str | Path | AnalysisPlan, loaded: AnalysisPlan) -> str:
    """How a plan is recorded in a manifest: a preset's name, or a plan file's absolute path."""
    if isinstance(plan, str | Path) and Path(plan).suffix.lower() == ".toml":
        return str(Path(plan).resolve())
    return loaded.name


def _excluded_notes(table: pd.DataFrame) -> list[str]:
    """The participant-level tests' exclusions, one line per distinct note with its metrics
    (``table``: :func:`~nudgecli.report.stats.stats_table`'s)."""
    by_note: dict[str, list[str]] = {}
    for row in table.drop_duplicates("metric").to_dict("records"):
        note = row["participant_note"]
        if note:
            by_note.setdefault(note, []).append(row["metric"])
    return [f"participant-level test of {', '.join(names)}: {note}" for note, names in by_note.items()]


def analyze(source: str | Path, plan: str | Path | AnalysisPlan | None = None, out: str | Path | None = None,
            metrics: Sequence[str] | None = None, questionnaires: str | Path | None = None,
            seed: int | None = None, *, bootstrap: int | None = None, drop_duplicates: bool = False,
            progress: Callable[[int, int], None] | None = None) -> AnalysisResult:
    """Compute the metrics and statistics of a run or a metrics table and write them.

    Parameters
    ----------
    source
        A run folder (``trials/`` and ``steps/`` Parquet parts) or a metrics table (CSV or
        Parquet, one row per trial with ``participant``, ``condition`` and metric columns).
    plan
        An analysis plan: preset name (``paper``, ``study-code``), TOML path, or a plan.
        Default: the plan recorded in a run folder's manifest (recorded there now if missing and
        the run folder is the output folder), else ``paper``.
    out
        Output folder; default the run folder, or ``<table>-analysis/`` beside a table.
    metrics
        Only these metrics (trial metrics or questionnaire scores), in this order; default all
        of the plan's (run folder) or of the table's columns, then every questionnaire score.
    questionnaires
        A questionnaire CSV (:mod:`nudgecli.report.questionnaires`) analysed alongside.
    seed
        Bootstrap seed; default the plan's.
    bootstrap
        Bootstrap resamples; default the plan's.
    drop_duplicates
        Drop repeated trial rows of a metrics table (keeping the first) instead of refusing them.
    progress
        Called with (metrics done, metrics in all) as the statistics proceed.

    Returns
    -------
    AnalysisResult

    Raises
    ------
    DataError, RunFolderError, ConfigError
        Invalid source, table, questionnaire table, metric name or plan (one clear message each).
    LockError
        Another command is writing the run folder or the output folder.
    WriteError
        The output folder cannot be written.
    """
    source = Path(source)
    if not source.exists():
        raise DataError(f"{source} does not exist; give a run folder or a metrics table (.csv/.parquet)")
    if bootstrap is not None and bootstrap < 1:
        raise ConfigError(f"--bootstrap must be at least 1, got {bootstrap}")
    out_dir = Path(out) if out is not None else (source if source.is_dir() else analysis_folder(source))
    if out_dir.exists() and not out_dir.is_dir():
        raise DataError(f"--out {out_dir} is a file; give a folder")
    made_out = not out_dir.exists()
    try:
        return _analyze_with_locks(source, plan, out_dir, metrics, questionnaires, seed, bootstrap,
                                   drop_duplicates, progress)
    except BaseException:
        if made_out and out_dir.is_dir() and not any(out_dir.iterdir()):
            out_dir.rmdir()  # made only for this analysis, which failed: leave nothing behind
        raise


def _analyze_with_locks(source: Path, plan: str | Path | AnalysisPlan | None, out_dir: Path,
                        metrics: Sequence[str] | None, questionnaires: str | Path | None, seed: int | None,
                        bootstrap: int | None, drop_duplicates: bool,
                        progress: Callable[[int, int], None] | None) -> AnalysisResult:
    """:func:`analyze` with the run folder's and the output folder's locks held."""
    with contextlib.ExitStack() as locks:
        if is_run_folder(source):
            try:
                locks.enter_context(run_lock(source))
            except NudgeWriteError:
                if out_dir.resolve() == source.resolve():
                    raise
                # a read-only run folder analysed elsewhere: nobody can be writing it
        locks.enter_context(run_lock(out_dir))
        return _analyze_locked(source, plan, out_dir, metrics, questionnaires, seed, bootstrap,
                               drop_duplicates, progress)
    raise AssertionError("unreachable")  # pragma: no cover - for type checkers


def _analyze_locked(source: Path, plan_arg: str | Path | AnalysisPlan | None, out_dir: Path,
                    metrics: Sequence[str] | None, questionnaires: str | Path | None, seed: int | None,
                    bootstrap: int | None, drop_duplicates: bool,
                    progress: Callable[[int, int], None] | None) -> AnalysisResult:
    """:func:`analyze` once the folders' locks are held."""
    notes: list[str] = []
    run = RunFolder(source) if source.is_dir() else None
    manifest = run.read_manifest() if run is not None and run.is_run() else None
    if plan_arg is None:
        known = manifest or {}
        plan_arg = resolve_plan(None, recorded=known.get("plan"), experiment=str(known.get("experiment", "")))
    plan = load_plan(plan_arg)
    changed = False
    if source.is_dir():
        table, available, _ = _load_source(source, plan, notes)
        changed = True
        # recorded for the next analysis only where this one writes: the run folder as its output
        if run is not None and manifest is not None and "participants" in manifest and \
                "plan" not in manifest and out_dir.resolve() == source.resolve():
            manifest["plan"] = _plan_label(plan_arg, plan)
            run.write_manifest(manifest)
    else:
        table, available, changed = _load_table(source, drop_duplicates, notes)
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
        check_respondents(scores, table["participant"], str(questionnaires), str(source))

    selected = _select_metrics(metrics, [*available, *score_names])
    trial_selected = [m for m in selected if m in available]
    score_selected = [m for m in selected if m in score_names]

    if any(name in table.columns for name in plan.filters):
        filtered = apply_filters(table, plan.filters)
        changed = changed or not filtered.equals(table)
    else:
        filtered = table  # nothing to filter: no copy of a large table
    if filtered["condition"].dtype != "category":
        filtered["condition"] = filtered["condition"].astype(str).astype("category")
    conditions = order_conditions(filtered["condition"].cat.categories,
                                  (*plan.conditions, *_study_conditions(manifest)))
    options = comparison_options(plan, seed, bootstrap)
    total = len(trial_selected) + (len(score_selected) if scores is not None else 0)
    entries = []
    for done, name in enumerate(trial_selected):
        if progress:
            progress(done, total)
        entries += compare_conditions(filtered, [name], conditions, options)["metrics"]
    stats: dict[str, Any] = {"conditions": list(conditions), "metrics": entries}
    if scores is not None and score_selected:
        stats["metrics"] += compare_conditions(scores, score_selected, conditions, options)["metrics"]
    if progress:
        progress(total, total)
    metrics_path = out_dir / METRICS_CSV
    stats["metrics_table"] = (METRICS_CSV if changed else
                              os.path.relpath(source.resolve(), out_dir.resolve()))
    stats[CHECKSUM_KEY] = metrics_checksum(filtered, trial_selected, plan.filters)
    stats = json_ready(stats)
    tidy = stats_table(stats)
    notes += _excluded_notes(tidy)
    summary = format_summary(tidy, stats["conditions"], plan, source, n_trials=len(filtered),
                             n_participants=filtered["participant"].nunique())

    written: list[Path] = []
    metrics_columns = [c for c in filtered.columns if c in NON_METRIC_COLUMNS or c in available]
    if changed:
        write_text_atomic(metrics_path, filtered[metrics_columns].to_csv(index=False))
        written.append(metrics_path)
    outputs = {STATS_JSON: json.dumps(stats, indent=2, allow_nan=False) + "\n", STATS_CSV: stats_csv(tidy),
               SUMMARY_MD: summary}
    if scores is not None:
        outputs[QUESTIONNAIRES_CSV] = scores.to_csv(index=False)
    for name, text in outputs.items():
        write_text_atomic(out_dir / name, text)
        written.append(out_dir / name)
    return AnalysisResult(out=out_dir, files=written, metrics=filtered, stats=stats, table=tidy,
                          summary=summary, questionnaires=scores, notes=notes)
