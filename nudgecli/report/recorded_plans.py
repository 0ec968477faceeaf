"""The analysis plan a run folder records for ``nudge analyze`` without ``--plan``: read, checked
and recorded.

A run records its plan in its manifest's ``plan``: a preset's name, or (a plan file) the run's own
copy of it, checked against the SHA-256 the manifest records
(:meth:`~nudgecli.run_folder_config.ConfigRecord.recorded_plan`); a manifest of an older nudge may
name a plan file by its path. A recorded plan that does not load is refused in one line naming the
manifest's ``plan`` and ``--plan``, which overrides it (:func:`recorded_plan`).

An analysis says which plan made it where a reader of its folder would not find that plan anyway:
the analysis of a run written away from it (``--out D``) or under another plan than the run's
records it in ``stats.json``'s :data:`ANALYSIS_PLAN_KEY` (:func:`record_plan`), a table's analysis
in its ``table_read`` record; ``nudge plot`` draws with it (:func:`analysed_plan`). A run's own
analysis under its recorded plan records nothing (``results/paper/stats.json`` as it was). A preset
is recorded by its name; a plan file as the analysis's exact copy of it
(:data:`~nudgecli.run_folder_names.ANALYSIS_PLAN_COPY`, written with the analysis, its SHA-256 in
:data:`ANALYSIS_PLAN_SHA256_KEY`), as a run keeps its plan: the file given may be moved or edited
later, and the analysis folder may be copied elsewhere; plot refuses a copy gone or edited.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from nudgecli.config_files import resolve_plan, world_kind_of
from nudgecli.errors import ConfigError, NudgeError, shell_words
from nudgecli.report.analysis_folders import analysis_folder
from nudgecli.report.plans import AnalysisPlan, load_plan, plan_argument
from nudgecli.report.table_read import TABLE_READ_KEY, analyze_again, plan_seen_from_here, recorded_table_read
from nudgecli.run_folder_config import copy_changed
from nudgecli.run_folder_names import ANALYSIS_PLAN_COPY, MANIFEST, STATS_JSON
from nudgecli.store import RunFolder, is_run_folder

#: The key of ``stats.json`` naming the plan of a run's analysis that its folder would not give
#: (:func:`record_plan`): a preset's name, or the analysis's copy of its file
#: (:data:`~nudgecli.run_folder_names.ANALYSIS_PLAN_COPY`, as seen from the analysis folder).
ANALYSIS_PLAN_KEY = "plan"
#: The key of ``stats.json`` holding the SHA-256 of the analysis's copy of its plan file.
ANALYSIS_PLAN_SHA256_KEY = "plan_sha256"


def plan_of_source(source: str | Path, *, damaged_manifest: bool = False) -> str:
    """The plan a source is analysed with when none is given (:func:`recorded_plan` of its
    manifest: a run folder's recorded plan or its experiment's; ``paper`` for a table).

    ``damaged_manifest``: a manifest that cannot be read is taken as none (a figure's plan, where
    drawing says what is wrong), not refused."""
    path = Path(source)
    run = RunFolder(path) if path.is_dir() else None
    manifest = None
    if run is not None and run.is_run():
        try:
            manifest = run.read_manifest()
        except NudgeError:
            if not damaged_manifest:
                raise
    return recorded_plan(manifest, run)


def recorded_plan(manifest: Mapping[str, Any] | None, run: RunFolder | None = None) -> str:
    """The plan of a run analysed without ``--plan``: the one its manifest records (a plan file's
    copy in the run folder ``run``, checked:
    :meth:`~nudgecli.run_folder_config.ConfigRecord.recorded_plan`),
    else the plan named like its experiment; ``paper`` for a table.

    Raises
    ------
    ConfigError
        The recorded plan does not load (a copy edited or lost, a file moved, a name no preset has):
        one line naming the manifest's ``plan`` and ``--plan``, which overrides it."""
    known = manifest or {}
    recorded = run.recorded_plan(known) if run is not None else known.get("plan")
    plan = resolve_plan(None, recorded=recorded, experiment=str(known.get("experiment", "")),
                        world=world_kind_of(known))
    if run is None or not recorded:  # the experiment's plan: a preset that loads
        return plan
    try:
        load_plan(plan)
    except ConfigError as exc:
        where = f"{run.path / MANIFEST} 'plan'"
        raise ConfigError(f"{where} = {json.dumps(known.get('plan'))}: {exc}; correct it there, or give "
                          f"--plan PLAN, which overrides {where}") from None
    return plan


def record_plan(run: RunFolder | None, manifest: dict[str, Any] | None, plan: AnalysisPlan,
                out_dir: Path) -> tuple[dict[str, Any], str | None]:
    """Record the plan in a finished run's manifest that has none, for the next analysis: only where
    this analysis writes anyway (the run folder as its output folder), and not a plan built in code,
    which no ``--plan`` names (:func:`~nudgecli.report.plans.plan_argument`).

    Returns
    -------
    tuple
        What ``stats.json`` records of the plan, and the text of the plan file for the analysis to
        keep beside it (:data:`~nudgecli.run_folder_names.ANALYSIS_PLAN_COPY`) or ``None``. ``{}``
        where :func:`plan_of_source` of ``out_dir`` gives ``plan`` anyway (a run analysed in its own
        folder under its recorded plan); else :data:`ANALYSIS_PLAN_KEY`: a preset's name (``None``:
        built in code), or, for a plan file, the copy's name with its SHA-256
        (:data:`ANALYSIS_PLAN_SHA256_KEY`), for ``nudge plot OUT`` (:func:`analysed_plan`).
    """
    named = plan_argument(plan)
    if run is not None and manifest is not None and "participants" in manifest and named is not None and \
            "plan" not in manifest and out_dir.resolve() == run.path.resolve():
        manifest["plan"] = named
        run.write_manifest(manifest)
    found = None
    with contextlib.suppress(NudgeError):  # a folder whose own plan does not load: say which this was
        found = load_plan(plan_of_source(out_dir, damaged_manifest=True))
    if found == plan:
        return {}, None
    digest, text = kept_plan_file(plan, out_dir, named)
    return {ANALYSIS_PLAN_KEY: ANALYSIS_PLAN_COPY if digest else named, **digest}, text


def kept_plan_file(plan: AnalysisPlan, out_dir: Path | None = None,
                   named: str | None = None) -> tuple[dict[str, Any], str | None]:
    """What ``stats.json`` records of the analysis's copy of ``plan``'s file
    (:data:`ANALYSIS_PLAN_SHA256_KEY`: its SHA-256) and the copy's text, for a plan read from a file
    (``named``: :func:`~nudgecli.report.plans.plan_argument`, taken when not given); ``({}, None)``
    for a preset or a plan built in code. A table's analysis keeps one too, its ``table_read``
    naming the file it was given (the ``--plan`` of the command that analyses it again). The text
    is ``None`` where the file is the copy in ``out_dir`` itself: its bytes are the copy's already
    (an analysis again under its own kept copy), never rewritten from itself."""
    named = plan_argument(plan) if named is None else named
    if named is None or plan.file is None:  # a preset's name, or none (built in code)
        return {}, None
    # the file as read now (plan_argument has just found it holds this plan): the copy plot reads
    data = Path(named).read_bytes()
    digest = {ANALYSIS_PLAN_SHA256_KEY: hashlib.sha256(data).hexdigest()}
    copy = None if out_dir is None else out_dir / ANALYSIS_PLAN_COPY
    with contextlib.suppress(OSError):
        if copy is not None and copy.is_file() and os.path.samefile(named, copy):
            return digest, None
    return digest, data.decode("utf-8")


def _kept_plan_copy(folder: Path, stats: Mapping[str, Any]) -> str:
    """The analysis's copy of its plan file in ``folder``, checked against the SHA-256 its
    ``stats.json`` (``stats``) records.

    Raises
    ------
    ConfigError
        The copy is missing or was edited: one line naming it, ``stats.json``'s ``plan`` (a table's
        analysis: its ``table_read``'s) and the ``nudge analyze`` command that analyses again."""
    copy = folder / ANALYSIS_PLAN_COPY
    try:
        changed = copy_changed(copy, stats[ANALYSIS_PLAN_SHA256_KEY])
        what = "changed since the analysis kept it (its SHA-256 differs from " \
               f"{STATS_JSON}'s {ANALYSIS_PLAN_SHA256_KEY!r})"
    except OSError as exc:
        changed, what = True, f"cannot be read ({exc.strerror or exc})"
    if not changed:
        return str(copy)
    read = recorded_table_read(stats, str(folder / STATS_JSON))
    where = f"{folder / STATS_JSON} {ANALYSIS_PLAN_KEY!r}" if read is None else \
        f"{folder / STATS_JSON} {TABLE_READ_KEY!r} {ANALYSIS_PLAN_KEY!r}"
    if read is not None and isinstance(read.get("table"), str):  # a table's: the command it was given
        again = analyze_again(Path(os.path.normpath(folder / read["table"])), folder, read["drop_duplicates"],
                              read)
    else:
        own = is_run_folder(folder)  # a run analysed in its own folder under another plan than its own
        words = ["nudge", "analyze", str(folder) if own else "RUN", "--plan", "PLAN"]
        words += [] if own else ["--out", str(folder), "--force"]
        again = (f"analyse again with `{shell_words(words)}` (PLAN: the plan file"
                 f"{'' if own else ', RUN: the run analysed there'})")
    raise ConfigError(f"{copy}: the analysis's copy of its plan file ({where}) {what}, so its figures "
                      f"would not be drawn under the plan its statistics were computed with; {again} before "
                      "plotting")


def analysed_plan(source: str | Path) -> str | None:
    """The plan the analysis of ``source`` records (a run folder or an analysis folder holding
    ``stats.json``, or a metrics table, whose analysis is its ``<table>-analysis/``): its
    :data:`ANALYSIS_PLAN_KEY`, else its ``table_read`` record's plan, as ``--plan`` names it from
    here (a plan file: the analysis's copy, checked); ``None`` where it records none or one built in
    code (:func:`plan_of_source` then), or its ``stats.json`` does not read (drawing says what is
    wrong).

    Raises
    ------
    ConfigError
        The analysis's copy of its plan file is missing or was edited (:func:`_kept_plan_copy`)."""
    path = Path(source)
    folder = path if path.is_dir() else analysis_folder(path)
    try:
        stats = json.loads((folder / STATS_JSON).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(stats, Mapping):
        return None
    if ANALYSIS_PLAN_SHA256_KEY in stats:  # a plan file, kept as the analysis's own copy
        return _kept_plan_copy(folder, stats)
    table_read = stats.get(TABLE_READ_KEY)
    plan = stats.get(ANALYSIS_PLAN_KEY, table_read.get("plan") if isinstance(table_read, Mapping) else None)
    return plan_seen_from_here(folder, plan) if isinstance(plan, str) and plan else None


__all__ = ["ANALYSIS_PLAN_KEY", "ANALYSIS_PLAN_SHA256_KEY", "analysed_plan", "kept_plan_file",
           "plan_of_source", "record_plan", "recorded_plan"]
