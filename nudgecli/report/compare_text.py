"""The text ``nudge compare`` prints (:func:`format_comparison`): the distances per metric and
condition, then each source's participants' medians; a condition paired by ``--match`` is named
by both its names (:func:`~nudgecli.report.compare.condition_pair`)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from nudgecli.report.compare import SOURCES, Comparison, condition_pair
from nudgecli.report.summary import format_level, format_p, format_value


def _interval(value: float, low: float, high: float) -> str:
    return f"{format_value(value)} [{format_value(low)}, {format_value(high)}]"


def _quartiles(row: Mapping[str, object], source: str) -> str:
    return (f"{format_value(row[f'median_{source}'])} [{format_value(row[f'q1_{source}'])}, "
            f"{format_value(row[f'q3_{source}'])}]")


def format_comparison(result: Comparison) -> str:
    """Plain-text tables: the distances per metric and condition, then the participants' medians."""
    level = format_level(result.options.level)
    header = ["metric", "condition", "n sim/real", "sim median [q1, q3]", "real median [q1, q3]",
              "real people", "sim inside", "KS [" + level + "]", "KS p", "Wasserstein [" + level + "]"]
    rows = []
    for row in result.table.to_dict(orient="records"):
        inside = row["simulated_inside_real_range"]
        rows.append([
            str(row["metric"]), condition_pair(str(row["simulated_condition"]), str(row["real_condition"])),
            f"{row['n_simulated']}/{row['n_real']}",
            _quartiles(row, "simulated"), _quartiles(row, "real"),
            f"{format_value(row['real_participant_min'])} to {format_value(row['real_participant_max'])}",
            "-" if not np.isfinite(inside) else f"{inside:.0%}",
            _interval(row["ks_statistic"], row["ks_low"], row["ks_high"]),
            format_p(row["ks_p"]),
            _interval(row["wasserstein"], row["wasserstein_low"], row["wasserstein_high"]),
        ])
    lines = [_render(header, rows), ""]
    lines.append("Per-participant medians (sorted):")
    medians = result.medians
    simulated_name = {label: key for key, label in result.match.items()}
    side = []
    for metric in result.metrics:
        for condition in result.conditions:
            own = medians[(medians["metric"] == metric) & (medians["condition"] == condition)]
            cells = [", ".join(format_value(v) for v in sorted(own.loc[own["source"] == source, "median"]))
                     or "-" for source in SOURCES]
            side.append([metric, condition_pair(simulated_name.get(condition, condition), condition), *cells])
    lines.append(_render(["metric", "condition", "simulated", "real"], side))
    lines.append("")
    lines.append(f"KS p assumes independent trials (optimistic: trials are nested in people); the intervals "
                 f"are {level} cluster-bootstrap percentiles over participants ({result.options.resamples} "
                 f"resamples, seed {result.options.seed}).")
    return "\n".join(lines)


def _render(header: list[str], rows: list[list[str]]) -> str:
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    lines = ["  ".join(cell.ljust(w) for cell, w in zip(header, widths, strict=True)).rstrip(),
             "  ".join("-" * w for w in widths)]
    lines += ["  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip() for row in rows]
    return "\n".join(lines)
