"""A checksum of the metrics that a ``stats.json`` was computed from.

``nudge analyze`` writes it into ``stats.json`` (key ``metrics_checksum``); ``nudge plot``
recomputes it from the metrics table it is about to draw and refuses a mismatch, so a stale or
hand-edited ``stats.json`` never puts brackets on data that do not support them.

The digest covers exactly what the box plots draw: the row order, each row's condition and
the value of every analysed metric column (as float64; booleans as 0/1, missing values as one
canonical NaN, ``-0.0`` as ``0.0``), after the plan's filters.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from nudgecli.errors import DataError

CHECKSUM_KEY = "metrics_checksum"
ALGORITHM = "sha256"
#: Rows whose condition labels are joined and hashed at once.
_LABEL_BLOCK_ROWS = 65_536


def _column_values(series: pd.Series) -> np.ndarray:
    """``(N,)`` float64 values of a metric column (booleans 0/1, anything unreadable NaN)."""
    try:
        values = series.to_numpy(dtype=float, na_value=np.nan)
    except (TypeError, ValueError):
        values = pd.to_numeric(series, errors="coerce").to_numpy(dtype=float, na_value=np.nan)
    values = np.where(np.isnan(values), np.nan, values + 0.0)  # one NaN, and -0.0 -> 0.0
    return np.ascontiguousarray(values, dtype="<f8")


def metrics_digest(table: pd.DataFrame, metrics: Sequence[str]) -> str:
    """The hex digest of the conditions and metric values of ``table`` (see the module docstring).

    Parameters
    ----------
    table
        One row per trial with ``condition`` and the ``metrics`` columns.
    metrics
        The metric columns, in the order they are hashed.
    """
    digest = hashlib.new(ALGORITHM)
    digest.update(json.dumps({"rows": len(table), "columns": list(metrics)}).encode("utf-8"))
    labels = table["condition"]
    # the labels joined by \x1f, hashed a block of rows at a time (the same bytes: a 3.5 M-row
    # table's labels as one string were 0.3 GB of Python strings at the analysis' peak)
    for start in range(0, len(labels), _LABEL_BLOCK_ROWS):
        block = "\x1f".join(labels.iloc[start:start + _LABEL_BLOCK_ROWS].astype(str).tolist())
        digest.update((block if start == 0 else "\x1f" + block).encode("utf-8"))
    for metric in metrics:
        digest.update(b"\x1e" + _column_values(table[metric]).tobytes())
    return digest.hexdigest()


def metrics_checksum(table: pd.DataFrame, metrics: Sequence[str],
                     filters: Mapping[str, float] | None = None) -> dict[str, Any]:
    """The ``stats.json`` record of the metrics its statistics were computed from.

    Parameters
    ----------
    table
        The metrics after the plan's filters.
    metrics
        The metric columns analysed.
    filters
        The plan's filters (``{metric: inclusive maximum}``), recorded so that a reader of the
        unfiltered table can apply them again.

    Returns
    -------
    dict
        ``algorithm``, ``rows``, ``columns``, ``filters`` and ``digest``.
    """
    return {"algorithm": ALGORITHM, "rows": len(table), "columns": list(metrics),
            "filters": dict(filters or {}), "digest": metrics_digest(table, metrics)}


def recorded_checksum(stats: Mapping[str, Any], where: str) -> dict[str, Any]:
    """The checksum record of a ``stats.json`` document, checked for form.

    Raises
    ------
    DataError
        It has none (written by an older ``nudge`` or by hand) or it is malformed.
    """
    record = stats.get(CHECKSUM_KEY)
    if not isinstance(record, Mapping):
        raise DataError(f"{where} has no checksum of the metrics it was computed from (written by an older "
                        "nudge, or by hand); run `nudge analyze` on the source again")
    well_formed = (record.get("algorithm") == ALGORITHM and isinstance(record.get("digest"), str)
                   and isinstance(record.get("columns"), list)
                   and isinstance(record.get("filters", {}), Mapping))
    if not well_formed:
        raise DataError(f"{where}: its `{CHECKSUM_KEY}` is malformed; "
                        "run `nudge analyze` on the source again")
    return dict(record)


def verify_metrics(stats: Mapping[str, Any], table: pd.DataFrame, where: str, table_name: str) -> None:
    """Refuse statistics that were not computed from ``table``.

    Parameters
    ----------
    stats
        The ``stats.json`` document.
    table
        The metrics about to be drawn (after the recorded filters).
    where, table_name
        The ``stats.json`` path and the table's, for the message.

    Raises
    ------
    DataError
        No checksum, a column missing from ``table``, or a digest that differs.
    """
    record = recorded_checksum(stats, where)
    missing = [c for c in ["condition", *record["columns"]] if c not in table.columns]
    if missing:
        raise DataError(f"{where} was computed from metric(s) {', '.join(missing)} that {table_name} "
                        "does not have; run `nudge analyze` on the source again")
    if len(table) != record.get("rows") or metrics_digest(table, record["columns"]) != record["digest"]:
        raise DataError(f"{where} does not match {table_name}: the statistics were computed from other "
                        "metrics (stale or edited); run `nudge analyze` on the source again before plotting")


__all__ = ["CHECKSUM_KEY", "metrics_checksum", "metrics_digest", "recorded_checksum", "verify_metrics"]
