"""What ``nudge analyze`` did to the metrics table it read, recorded in ``stats.json``.

The record (key ``table_read``, written for a metrics table, not for a run folder) holds

- ``sha256``: the SHA-256 of the table's bytes, taken before the table was read (a table edited
  while it was read is then one ``nudge plot`` refuses, never one it takes for the analysed one);
- ``rows``: the rows the table held as read (before repeated trial rows were dropped);
- ``drop_duplicates``: whether ``--drop-duplicates`` was given;
- ``duplicates_dropped``: how many repeated trial rows were dropped;
- ``table``: the table's path as seen from the analysis folder (since 2026-11-28), so that
  ``nudge plot FOLDER --plan`` finds a changed table wherever the analysis was written;
- ``plan``: the plan as ``--plan`` takes it: a preset's name, or its file's path as seen from the
  analysis folder; ``null`` for a plan built in code, which no ``--plan`` names
  (:func:`~nudgecli.report.plans.plan_argument`); ``questionnaires``: the ``--questionnaires``
  answers file as seen from there, or ``null`` (both since 2026-11-28; a record without them names
  neither).

``nudge plot TABLE`` draws a table only when its bytes are the ones analysed
(:func:`check_table_is_analysed`), so a row added afterwards, even one that exactly repeats a
trial's key and would be dropped again, is refused, with the ``nudge analyze`` command that
brings the analysis up to date (:func:`analyze_again`: the plan and questionnaires file the
analysis used, ``--drop-duplicates`` where it was given or is now needed; the call from Python for a
plan built in code; a record that does not name the plan says so, never naming one). The rows drawn are then
the analysis's own: its ``metrics.csv`` where it changed the table, else the table itself; no rule
of the analysis is applied a second time.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from nudgecli.config_files import resolve_plan
from nudgecli.errors import DataError, shell_words
from nudgecli.report.analysis_folders import analysis_folder
from nudgecli.report.tables import find_duplicate_trials, read_metrics_table
from nudgecli.run_folder_names import STATS_JSON
from nudgecli.run_folder_record import file_sha256

TABLE_READ_KEY = "table_read"


def table_read_record(sha256: str, rows_read: int, drop_duplicates: bool, duplicates_dropped: int,
                      table: Path, plan: str | None = "paper",
                      questionnaires: Path | None = None) -> dict[str, Any]:
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
    plan, questionnaires
        The plan (``None``: built in code) and the answers file analysed, relative to the analysis
        folder (:func:`analysed_inputs`).
    """
    return {"sha256": sha256, "rows": int(rows_read), "drop_duplicates": bool(drop_duplicates),
            "duplicates_dropped": int(duplicates_dropped), "table": Path(table).as_posix(), "plan": plan,
            "questionnaires": None if questionnaires is None else Path(questionnaires).as_posix()}


def analysed_inputs(folder: Path, plan_label: str | None,
                    questionnaires: str | Path | None) -> tuple[str | None, Path | None]:
    """The ``plan`` and ``questionnaires`` of :func:`table_read_record` for an analysis written into
    ``folder``: a plan read from a file (its label an absolute path) and the answers file as seen
    from ``folder``, so that the record names no machine's path and holds wherever both are moved
    (``plan_label`` ``None``: a plan built in code, recorded so)."""
    base = Path(folder).resolve()

    def seen(path: str | Path) -> Path:
        return Path(os.path.relpath(Path(path).resolve(), base))

    plan = plan_label
    # "./" before a file's name alone: never taken for a preset's
    if plan_label is not None and Path(plan_label).is_absolute():
        plan = seen(plan_label).as_posix()
        plan = plan if "/" in plan else f"./{plan}"
    return plan, None if questionnaires is None else seen(questionnaires)


def plan_seen_from_here(folder: Path, plan: str) -> str:
    """The plan an analysis in ``folder`` records (:func:`analysed_inputs`' ``plan``) as ``--plan``
    names it from here: a file's path joined to ``folder`` (it has a ``/``), else a preset's name."""
    return os.path.normpath(folder / plan) if "/" in plan else plan


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
                   and isinstance(record.get("duplicates_dropped"), int)
                   and isinstance(record.get("plan", ""), str | None)
                   and isinstance(record.get("questionnaires"), str | None))
    if not well_formed:
        raise DataError(f"{where}: its `{TABLE_READ_KEY}` is malformed; "
                        "run `nudge analyze` on the table again")
    return dict(record)


def analyze_command(table: Path, folder: Path, drop_duplicates: bool,
                    record: Mapping[str, Any] | None = None) -> str:
    """The ``nudge analyze`` command that analyses ``table`` again into ``folder`` as before: with
    the plan and the questionnaires file ``record`` (:func:`recorded_table_read`) names, as seen
    from where ``folder`` is seen (a table's default plan, ``paper``, is not named), and ``--force``
    with an ``--out`` other than ``<table>-analysis/`` (``nudge plot TABLE`` finds no other than the
    table's own folder, which holds the table)."""
    words = ["nudge", "analyze", str(table)]
    if folder.resolve() != analysis_folder(table.resolve()):  # the table's own folder: never empty
        words += ["--out", str(folder), "--force"]
    plan = (record or {}).get("plan")
    if plan and plan != resolve_plan(None):
        words += ["--plan", plan_seen_from_here(folder, plan)]
    questionnaires = (record or {}).get("questionnaires")
    if questionnaires:
        words += ["--questionnaires", os.path.normpath(folder / questionnaires)]
    return shell_words(words + (["--drop-duplicates"] if drop_duplicates else []))


def analyze_again(table: Path, folder: Path, drop_duplicates: bool,
                  record: Mapping[str, Any] | None = None) -> str:
    """What to do to analyse ``table`` again into ``folder`` as before, for a message to go on with
    ``before plotting``: run :func:`analyze_command`'s command; for a plan built in code (``record``'s
    ``plan`` ``null``), which no ``--plan`` names, call ``nudgecli.analyze`` with it again from
    Python; where nothing records the plan (a ``stats.json`` of an older nudge), the command names
    none and the advice says to add the one the table was analysed with."""
    if record is not None and "plan" in record and record["plan"] is None:
        arguments = [repr(str(table)), "plan=PLAN"]
        if folder.resolve() != analysis_folder(table.resolve()):
            arguments += [f"out={str(folder)!r}", "force=True"]
        if record.get("questionnaires"):
            arguments.append(f"questionnaires={os.path.normpath(folder / record['questionnaires'])!r}")
        arguments += ["drop_duplicates=True"] if drop_duplicates else []
        return (f"the plan it was analysed with was built in code, which no --plan names: analyse it again "
                f"from Python with that plan as PLAN, `nudgecli.analyze({', '.join(arguments)})`,")
    command = analyze_command(table, folder, drop_duplicates, record)
    if record is None or "plan" not in record:
        return (f"run `{command}` again (adding the --plan it was analysed with unless that was "
                f"{resolve_plan(None)}: {folder / STATS_JSON}, of an older nudge, does not record it)")
    return f"run `{command}` again"


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
                    f"({then}; {rows_now}; its SHA-256 differs); "
                    f"{analyze_again(table, stats_path.parent, repeated, record)} before plotting")


__all__ = ["TABLE_READ_KEY", "analysed_inputs", "analyze_again", "analyze_command", "check_table_is_analysed",
           "plan_seen_from_here", "recorded_table_read", "table_read_record"]
