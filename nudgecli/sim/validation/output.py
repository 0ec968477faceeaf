"""The validation's output: JSON summary, per-query CSV, and the text tables ``nudge validate`` prints."""

from __future__ import annotations

import csv
import io
import json
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from nudgecli.outputs import check_not_a_file, written_together
from nudgecli.sim.validation.runner import QUERY_COLUMNS, ValidationResult
from nudgecli.store import check_writable, write_text_atomic


def summary_json(result: ValidationResult) -> str:
    """The summary as JSON text (what ``--format json`` prints and validation.json holds)."""
    return json.dumps(result.summary(), indent=2, allow_nan=False) + "\n"


def queries_csv(result: ValidationResult) -> str:
    """The per-query table as CSV text (floats in shortest round-trip form)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(QUERY_COLUMNS)
    columns = [result.queries[name].tolist() for name in QUERY_COLUMNS]
    writer.writerows(zip(*columns, strict=True))
    return buffer.getvalue()


def prepare_out(out_dir: str | os.PathLike[str]) -> Path:
    """Check that the output folder can be written, making none (before any computing), or say why not.

    Raises
    ------
    DataError
        The path is a file (:func:`nudgecli.outputs.check_not_a_file`).
    WriteError
        The folder cannot be created or written (one ``Error:`` line naming the path and cause).
    """
    out = Path(out_dir)
    check_not_a_file(out)
    check_writable(out)  # a file is made and removed: read-only or full folders fail here, before any work
    return out


def save_validation(result: ValidationResult, out_dir: str | os.PathLike[str],
                    beside: Callable[[], list[Path]] | None = None) -> list[Path]:
    """Write ``validation.json`` and ``validation.csv`` (per query) into ``out_dir``, renamed into
    place together once ``beside`` (the figure's writer) has written its files too
    (:func:`~nudgecli.outputs.written_together`): a failure leaves the earlier files as they were."""
    out = prepare_out(out_dir)
    return written_together({out / "validation.json": summary_json(result),
                             out / "validation.csv": queries_csv(result)}, beside)


def readings_summary(results: Sequence[ValidationResult]) -> list[dict[str, Any]]:
    """One JSON-ready record per reading: its description, overall and per-|G| match rates."""
    out = []
    for result in results:
        summary = result.summary()
        out.append({
            "reading": summary["settings"]["reading"],
            "queries": summary["queries"],
            "match_rate": summary["match_rate"],
            "truth_optimal_rate": summary["truth_optimal_rate"],
            "near_ties": summary["near_ties"],
            "match_rate_by_goals": {n: row["match_rate"] for n, row in summary["by_goals"].items()},
            "settings": {k: v for k, v in summary["settings"].items() if k != "reading"},
        })
    return out


def save_readings(results: Sequence[ValidationResult], out_dir: str | os.PathLike[str]) -> list[Path]:
    """Write ``readings.json`` (:func:`readings_summary`) into ``out_dir``, atomically."""
    out = prepare_out(out_dir)
    path = out / "readings.json"
    write_text_atomic(path, json.dumps(readings_summary(results), indent=2, allow_nan=False) + "\n")
    return [path]


def _fmt(value: float | None, percent: bool = True) -> str:
    if value is None:
        return "-"
    return f"{100.0 * value:5.1f}%" if percent else f"{value:.4f}"


def _pct(value: float | None) -> str:
    return "-" if value is None else f"{100.0 * value:.0f}"


def format_readings(records: Sequence[dict[str, Any]]) -> str:
    """One row per reading: its overall match rate, then the match rate (%) for each |G|."""
    goals = sorted({int(n) for r in records for n in r["match_rate_by_goals"]})
    width = max(len(r["reading"]["name"]) for r in records)
    head = f"{'reading':<{width}} {'match':>6} " + " ".join(f"{g:>3}" for g in goals)
    lines = ["Match rate of s* against the ground truth, by reading (columns: |G|, in %)", head]
    for r in records:
        by = r["match_rate_by_goals"]
        lines.append(f"{r['reading']['name']:<{width}} {_fmt(r['match_rate']):>6} "
                     + " ".join(f"{_pct(by.get(str(g))):>3}" for g in goals))
    lines.append("")
    for r in records:
        reading = r["reading"]
        note = f" [100 % by construction: {reading['by_construction']}]" if reading["by_construction"] else ""
        lines.append(f"{reading['name']}: {reading['summary']}{note}")
    return "\n".join(lines)


def format_summary(summary: dict[str, Any]) -> str:
    """A readable text summary of :meth:`ValidationResult.summary` (``--format table``)."""
    s = summary["settings"]
    lines = [
        f"Validation of D(s), reading {summary['reading']!r}: {summary['simulations']} simulations, "
        f"|G| {s['min_goals']}..{s['max_goals']}, {s['world']} world "
        f"({s['grid'][0]} x {s['grid'][1]} cells x {s['modes']} modes), "
        f"{s['window_cells']} x {s['window_cells']} window, beliefs {s['belief']}, "
        f"seed {summary['seed']}",
        f"metric {s['metric']}; ground truth {s['ground_truth']}; match: {s['match']}",
        f"queries {summary['queries']}: match {_fmt(summary['match_rate'])}; "
        f"near-ties {summary['near_ties']} (match {_fmt(summary['match_rate_near_ties'])}), "
        f"excluding them {_fmt(summary['match_rate_excluding_near_ties'])}; "
        f"distinct near-ties {summary['distinct_near_ties']}, excluding them "
        f"{_fmt(summary['match_rate_excluding_distinct_near_ties'])}",
        f"metric's choice optimal for the ground truth: {_fmt(summary['truth_optimal_rate'])}; "
        f"mean relative loss of the expected gap on mismatches {_fmt(summary['mismatch_relative_regret'])}",
        f"regularised D(s) (lambda = {s['regularisation']:g}): "
        f"match {_fmt(summary['regularised_match_rate'])}",
        "",
        f"{'|G|':>4} {'sims':>5} {'queries':>8} {'match':>7} {'ties':>6} {'excl.':>7} {'optimal':>8} "
        f"{'lambda=1':>9}",
    ]
    for n, row in summary["by_goals"].items():
        lines.append(
            f"{n:>4} {row['simulations']:>5} {row['queries']:>8} {_fmt(row['match_rate']):>7} "
            f"{row['near_ties']:>6} {_fmt(row['match_rate_excluding_near_ties']):>7} "
            f"{_fmt(row['truth_optimal_rate']):>8} {_fmt(row['regularised_match_rate']):>9}")
    if summary["convergence"]:
        first = summary["convergence"][0]
        lines += ["", f"Monte-Carlo estimate vs exact I(s) ({first['queries']} queries, "
                      f"{first['states']} states):",
                  f"{'N':>7} {'variant':>11} {'MAE (nats)':>11} {'argmax':>7} {'strict':>7} {'regret':>8}"]
        rows = [*summary["convergence"]]
        rows += [{"n_samples": "inf", "variant": v, **r} for v, r in summary["convergence_limit"].items()]
        for row in rows:
            lines.append(
                f"{row['n_samples']!s:>7} {row['variant']:>11} {row['mae']:>11.4f} "
                f"{_fmt(row['argmax_agreement']):>7} {_fmt(row['argmax_agreement_strict']):>7} "
                f"{row['mean_regret']:>8.4f}")
    return "\n".join(lines)


__all__ = ["format_readings", "format_summary", "prepare_out", "queries_csv", "readings_summary",
           "save_readings", "save_validation", "summary_json"]
