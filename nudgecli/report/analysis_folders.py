"""The analysis folder of a metrics table, and whose analysis such a folder holds.

``nudge analyze study.csv`` writes its files to ``study-analysis/`` beside the table
(:func:`analysis_folder`). ``study.csv`` and ``study.parquet`` would share that folder, so the
folder's ``stats.json`` is asked whose analysis it holds (:func:`analysed_table`): its
``metrics_table`` names the table analysed as it is, and for a table the analysis changed (its
rows are then in ``metrics.csv``) the SHA-256 of ``table_read``
(:mod:`nudgecli.report.table_read`) tells which table beside the folder it was. One table's
analysis never silently replaces another's (:func:`check_folder_is_the_tables`), and
``nudge plot FOLDER --plan PLAN`` knows which table to analyse again.
"""

from __future__ import annotations

import contextlib
import json
import os
from pathlib import Path

from nudgecli.errors import RunFolderError
from nudgecli.report.tables import TABLE_SUFFIXES
from nudgecli.run_folder_names import METRICS_CSV, STATS_JSON
from nudgecli.run_folder_record import file_sha256

#: What a table's default analysis folder adds to its stem: ``study.csv`` -> ``study-analysis/``.
ANALYSIS_FOLDER_SUFFIX = "-analysis"


def analysis_folder(table: Path) -> Path:
    """The default output folder of a metrics table: ``study.csv`` -> ``study-analysis/`` beside it."""
    return table.with_name(f"{table.stem}{ANALYSIS_FOLDER_SUFFIX}")


def tables_beside(folder: Path) -> list[Path]:
    """The metrics tables whose default analysis folder is ``folder`` (same folder, the stem it
    names, a table's suffix: ``study.csv``, ``study.parquet`` for ``study-analysis/``), sorted."""
    if not folder.name.endswith(ANALYSIS_FOLDER_SUFFIX) or not folder.parent.is_dir():
        return []
    stem = folder.name[:-len(ANALYSIS_FOLDER_SUFFIX)]
    return sorted(path for path in folder.parent.iterdir()
                  if path.stem == stem and path.suffix.lower() in TABLE_SUFFIXES and path.is_file())


def analysed_table(folder: Path) -> Path | None:
    """The metrics table whose analysis ``folder`` holds, as its ``stats.json`` records it.

    ``metrics_table`` names it (relative to the folder) when the table was analysed as it is. When
    it names the folder's own ``metrics.csv`` (the analysis changed the table), the table is the one
    ``table_read`` names (relative to the folder) while its SHA-256 is the record's, else (a record
    of an older nudge, or a table moved) the one beside the folder (:func:`tables_beside`) with it.

    Returns
    -------
    Path | None
        The table (it may since have been removed, when named); ``None`` without a readable
        ``stats.json``, for a run folder's analysis, or when no table beside the folder has the
        recorded bytes (edited since, or moved).
    """
    try:
        stats = json.loads((folder / STATS_JSON).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    named = stats.get("metrics_table") if isinstance(stats, dict) else None
    if not isinstance(named, str):
        return None
    if named != METRICS_CSV:
        return Path(os.path.normpath(folder / named))
    record = stats.get("table_read")
    sha256 = record.get("sha256") if isinstance(record, dict) else None
    if not isinstance(sha256, str):
        return None  # a run's analysis, or one of an older nudge: nothing says which table
    named = record.get("table") if isinstance(record, dict) else None
    candidates = [Path(os.path.normpath(folder / named))] if isinstance(named, str) else []
    candidates += tables_beside(folder)
    return next((table for table in candidates if table.is_file() and file_sha256(table) == sha256), None)


def _same_file(a: Path, b: Path) -> bool:
    """Whether two paths name one file (resolved, or the same inode: a hard link)."""
    if a.resolve() == b.resolve():
        return True
    with contextlib.suppress(OSError):
        return os.path.samefile(a, b)
    return False


def check_folder_is_the_tables(table: Path, folder: Path) -> None:
    """Refuse to analyse ``table`` into ``folder`` when the folder holds another table's analysis.

    Raises
    ------
    RunFolderError
        ``folder``'s ``stats.json`` records another metrics table (:func:`analysed_table`): one
        line naming the folder, that table and the fix (``--out`` or ``--force``).
    """
    other = analysed_table(folder)
    if other is None or _same_file(other, table):
        return
    own = table.with_name(f"{table.stem}-{table.suffix.lstrip('.').lower()}{ANALYSIS_FOLDER_SUFFIX}")
    raise RunFolderError(f"{folder} holds the analysis of {other}, not of {table}; analysing {table} "
                         f"there would replace it: give {table} a folder of its own with --out (e.g. "
                         f"--out {own}), or use --force to replace that analysis")


__all__ = ["ANALYSIS_FOLDER_SUFFIX", "analysed_table", "analysis_folder", "check_folder_is_the_tables",
           "tables_beside"]
