"""What ``nudge analyze`` did to the metrics table it read, recorded in ``stats.json``.

The record (key ``table_read``, written for a metrics table, not for a run folder) holds

- ``sha256``: the SHA-256 of the table's bytes, taken before the table was read (a table edited
  while it was read is then one ``nudge plot`` refuses, never one it takes for the analysed one);
- ``rows``: the rows the table held as read (before repeated trial rows were dropped);
- ``drop_duplicates``: whether ``--drop-duplicates`` was given;
- ``duplicates_dropped``: how many repeated trial rows were dropped;
- ``table``: the table's path as seen from the analysis folder (since 2026-11-28), so that
  ``nudge plot FOLDER --plan`` finds a changed table wherever the analysis was written.

``nudge plot TABLE`` draws a table only when its bytes are the ones analysed
(:func:`check_table_is_analysed`), so a row added afterwards, even one that exactly repeats a
trial's key and would be dropped again, is refused, with the ``nudge analyze`` command that
brings the analysis up to date. The rows drawn are then the analysis's own: its ``metrics.csv``
where it changed the table, else the table itself; no rule of the analysis is applied a second
time.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from nudgecli.errors import DataError
from nudgecli.report.analysis_folders import analysis_folder
from nudgecli.report.tables import find_duplicate_trials, read_metrics_table
from nudgecli.run_folder_record import file_sha256

TABLE_READ_KEY = "table_read"


def table_read_record(sha256: str, rows_read: int, drop_duplicates: bool, duplicates_dropped: int,
                      table: Path) -> dict[str, Any]:
    """The ``stats.json`` record of the table an analysis read (see the module docstring).

    Parameters
    ----------
    sha256
        The SHA-256 (hex) of the table's bytes, taken before it was read.
    rows_read
        The table's rows as read.
    drop_duplicates
        Whether repeated trial rows were to be dropped (``--drop-duplicates``).
    duplicates_dropped
        How many were.
    table
        The table's path relative to the analysis folder.
    """
    return {"sha256": sha256, "rows": int(rows_read), "drop_duplicates": bool(drop_duplicates),
            "duplicates_dropped": int(duplicates_dropped), "table": Path(table).as_posix()}


def recorded_table_read(stats: Mapping[str, Any], where: str) -> dict[str, Any] | None:
    """The ``table_read`` record of a ``stats.json`` document; ``None`` where it has none (written
    by an older nudge, or the analysis of a run folder).

    Raises
    ------
    DataError
        The record is malformed.
    """
    record = stats.get(TABLE_READ_KEY)
    if record is None:
        return None
    well_formed = (isinstance(record, Mapping) and isinstance(record.get("sha256"), str)
                   and isinstance(record.get("rows"), int) and isinstance(record.get("drop_duplicates"), bool)
                   and isinstance(record.get("duplicates_dropped"), int))
    if not well_formed:
        raise DataError(f"{where}: its `{TABLE_READ_KEY}` is malformed; "
                        "run `nudge analyze` on the table again")
    return dict(record)


def analyze_command(table: Path, folder: Path, drop_duplicates: bool) -> str:
    """The ``nudge analyze`` command that analyses ``table`` again into ``folder`` as before."""
    beside = folder.resolve() == analysis_folder(table.resolve())
    out = "" if beside else f" --out {folder}"
    return f"nudge analyze {table}{out}{' --drop-duplicates' if drop_duplicates else ''}"


def check_table_is_analysed(table: Path, record: Mapping[str, Any], stats_path: Path) -> None:
    """Refuse a table whose bytes are not those its analysis read.

    Parameters
    ----------
    table
        The metrics table about to be drawn.
    record
        :func:`recorded_table_read` of the analysis's ``stats.json``.
    stats_path
        That ``stats.json`` (its folder is the analysis folder), for the message.

    Raises
    ------
    DataError
        The table's SHA-256 differs from the recorded one: one line naming the table, what
        changed (its rows then and now, where it can still be read) and the command to run.
    """
    if file_sha256(table) == record["sha256"]:
        return
    repeated = bool(record["drop_duplicates"])
    try:
        now = read_metrics_table(table)
        rows_now = f"{len(now)} rows now"
        # the command must pass the refusal of repeated trial rows the table now holds
        repeated = repeated or bool(find_duplicate_trials(now)[1].any())
    except DataError:
        rows_now = "no longer a readable table"
    dropped = record["duplicates_dropped"]
    then = f"{record['rows']} rows when analysed"
    if dropped:
        then += f", {dropped} repeated trial row(s) dropped"
    raise DataError(f"{table} is not the table {stats_path} was computed from: edited since its analysis "
                    f"({then}; {rows_now}; its SHA-256 differs); run "
                    f"`{analyze_command(table, stats_path.parent, repeated)}` "
                    "again before plotting")


__all__ = ["TABLE_READ_KEY", "analyze_command", "check_table_is_analysed", "recorded_table_read",
           "table_read_record"]
