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
in its manifest (a plan file's copy in the run, checked: :mod:`nudgecli.report.recorded_plans`), and
``stats.json`` records the digest of the run's trials (:mod:`nudgecli.report.analysed_run`: ``nudge
plot`` never draws the analysis beside another run's trials). A metrics table is checked before
analysis: duplicate trials (same participant, condition, block and trial) are an error unless
``drop_duplicates``, infinite values are an error naming rows and columns, condition labels that
differ only by case or surrounding spaces are an error with a "did you mean"; a CSV's delimiter is
sniffed (:mod:`nudgecli.report.tables`).

A table is taken under the plan's metric definitions as far as its own columns allow, the rest
being the table's own, said in a note (:mod:`nudgecli.report.table_definitions`). The plan's
filters apply, the values they leave out counted in a note (:mod:`nudgecli.report.plan_filters`),
then the statistics (:mod:`nudgecli.report.stats_document`) and the summary
(:mod:`nudgecli.report.summary`). A run folder's metrics that its conditions make constant by
construction are left out of their tests for those conditions
(:func:`nudgecli.model.conditions.not_applicable_metrics`; :mod:`nudgecli.report.not_applicable`).
Written atomically, holding the folder's lock (:func:`nudgecli.store.run_lock`), to the run folder,
``<table>-analysis/`` beside a table (``study.csv`` gives ``study-analysis/``; one that holds the
analysis of another table, such as ``study.parquet``, is refused without ``force``:
:mod:`nudgecli.report.analysis_folders`), or ``out``: the folder's
:data:`~nudgecli.report.analysis_folders.ANALYSIS_FILES`, ``stats.json`` last (:func:`_write_analysis`).
``metrics.csv`` is written for a run folder, or a table the analysis changed (``stats.json``'s
``metrics_table`` names the table the statistics came from, and its ``table_read`` what was done to
a table's rows, :mod:`nudgecli.report.table_read`);
``questionnaire_scores.csv`` with questionnaires (``questionnaires.csv`` is the answers
``nudge study`` records). No output replaces an input (:func:`nudgecli.outputs.check_not_an_input`).
"""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import pandas as pd

from nudgecli.errors import ConfigError, DataError, RunFolderError
from nudgecli.errors import WriteError as NudgeWriteError
from nudgecli.locks import run_lock
from nudgecli.model.conditions import not_applicable_metrics
from nudgecli.outputs import check_not_an_input
from nudgecli.report.analysed_run import TRIALS_DIGEST_KEY, trials_digest
from nudgecli.report.analysis_folders import (
    analysis_folder,
    check_folder_is_the_tables,
    left_by_a_killed_analysis,
    recover_kept_analysis,
    refuse_linked_analysis,
)
from nudgecli.report.checksum import CHECKSUM_KEY, metrics_checksum
from nudgecli.report.metrics import (
    INPUT_STEP_COLUMNS,
    METRIC_STEP_COLUMNS,
    TRIAL_COLUMNS,
    trial_metrics_by_participant,
)
from nudgecli.report.pair_display import check_reference
from nudgecli.report.plan_filters import apply_plan_filters
from nudgecli.report.plan_metrics import (
    check_filters,
    run_definitions_line,
    select_metrics,
    summary_plan_name,
    table_include_note,
)
from nudgecli.report.plans import (
    MIN_RESAMPLES,
    AnalysisPlan,
    check_plan_conditions,
    check_resamples,
    load_plan,
    plan_argument,
)
from nudgecli.report.questionnaires import (
    SCORES_CHECKSUM_KEY,
    check_respondents,
    questionnaire_scores,
    read_run_questionnaires,
    score_columns,
    scores_checksum,
    scores_csv,
)
from nudgecli.report.recorded_plans import ANALYSIS_PLAN_COPY, kept_plan_file, record_plan, recorded_plan
from nudgecli.report.recorded_plans import plan_of_source as plan_of_source  # its readers import it here
from nudgecli.report.stats import ComparisonOptions, order_conditions
from nudgecli.report.stats_document import compare_conditions, json_ready, stats_csv, stats_table
from nudgecli.report.summary import P_THRESHOLDS, format_summary, plan_p_thresholds
from nudgecli.report.table_definitions import apply_plan_definitions
from nudgecli.report.table_read import TABLE_READ_KEY, analysed_inputs, table_read_record
from nudgecli.report.tables import (
    NON_METRIC_COLUMNS,
    drop_or_refuse_duplicates,
    read_metrics_table,
    validate_metrics_table,
)
from nudgecli.run_folder_names import METRICS_CSV, QUESTIONNAIRE_SCORES_CSV, STATS_CSV, STATS_JSON, SUMMARY_MD
from nudgecli.run_folder_record import CONSTANT_METRICS_KEY, file_sha256
from nudgecli.run_folder_state import start_advice
from nudgecli.store import RunFolder, is_run_folder, write_error, write_text_atomic


@dataclass
class AnalysisResult:
    """What :func:`analyze` computed and where it wrote it.

    Attributes
    ----------
    out, files
        The folder the files went to; the files written.
    metrics
        The per-trial metrics (after the plan's filters).
    stats, table, summary
        The ``stats.json`` document (JSON-ready: NaN as ``None``); ``stats.csv`` (one row per
        metric x pair of conditions); ``summary.md``.
    questionnaires
        The questionnaire scores, if a questionnaire table was given.
    notes
        What was excluded or changed (duplicates dropped, participants left out of a test), a line each.
    p_thresholds
        The plan's star thresholds and Kruskal-Wallis alpha, which a printed p-value must not be
        rounded across (:func:`nudgecli.report.summary.plan_p_thresholds`).
    """

    out: Path
    files: list[Path]
    metrics: pd.DataFrame
    stats: dict[str, Any]
    table: pd.DataFrame
    summary: str
    questionnaires: pd.DataFrame | None = field(default=None)
    notes: list[str] = field(default_factory=list)
    p_thresholds: tuple[float, ...] = P_THRESHOLDS


def read_run(folder: str | Path, notes: list[str] | None = None
             ) -> tuple[pd.DataFrame, Callable[[int], pd.DataFrame | None]]:
    """The trial table of a run folder and its step log one participant at a time (the metrics' columns).

    With a manifest, exactly the parts of the participants it promises are read, each verified
    against the SHA-256 the manifest recorded (:meth:`nudgecli.store.RunFolder.read_table`);
    stray parts and parts without a recorded checksum (an older nudge's run, still read) are
    reported in ``notes``. Without one, a run's folder that lost it is refused, and a folder of
    parts alone is read with a note that nothing vouches for them.

    Returns
    -------
    (pd.DataFrame, callable)
        ``trials`` with :data:`~nudgecli.report.metrics.TRIAL_COLUMNS`, and a participant -> their
        steps with :data:`~nudgecli.report.metrics.METRIC_STEP_COLUMNS` (``None`` without any): in a
        run, their part read when asked (and checked), so one participant's steps are in memory at once.

    Raises
    ------
    RunFolderError
        No trial or step parts yet, or (with a manifest) parts missing or unreadable or the run unfinished.
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
    elif notes is not None and run.lost_manifest_error() is None:  # parts alone: say they are unverified
        notes.append(run.unrecorded_note())
    trials = run.read_table("trials", TRIAL_COLUMNS)
    if trials.empty:  # a live study's resume leaves a session's parts empty before its first trial
        raise RunFolderError(run.no_parts_message("trials", run.manifest_to_read() if run.is_run() else None))
    columns = [*METRIC_STEP_COLUMNS, *INPUT_STEP_COLUMNS]
    if not run.is_run():  # parts put together by hand: any part may hold any participant's steps
        groups = dict(tuple(run.read_table("steps", columns).groupby("participant", sort=False)))
        return trials, groups.get
    participants = [int(p) for p in pd.unique(trials["participant"])]
    if not any(run.part_path("steps", p).is_file() for p in participants):
        run.read_table("steps", columns)  # no step log at all: refused, saying what to run

    def steps_of(participant: int) -> pd.DataFrame | None:
        if not run.part_path("steps", int(participant)).is_file():
            return None
        return run.read_table("steps", columns, participants=[int(participant)])

    return trials, steps_of


def comparison_options(plan: AnalysisPlan, seed: int | None = None,
                       bootstrap: int | None = None) -> ComparisonOptions:
    """A plan's statistics settings ([stats], [bootstrap]); ``seed``, ``bootstrap`` override its."""
    options = plan.comparison_options(seed)
    return options if bootstrap is None else replace(options, bootstrap_resamples=bootstrap)


def analysed_metrics_path(folder: str | Path) -> Path | None:
    """The metrics table an analysis folder's statistics came from: the table ``stats.json``'s
    ``metrics_table`` names (a table analysed as it is is not copied), else its ``metrics.csv``;
    ``None`` when there is neither. The named table comes first: a ``metrics.csv`` an earlier
    analysis wrote (a plan whose filters changed the table) stays in the folder when the next
    analysis takes the table as it is."""
    folder = Path(folder)
    try:
        named = json.loads((folder / STATS_JSON).read_text(encoding="utf-8")).get("metrics_table")
    except (OSError, ValueError, AttributeError):
        named = None
    if isinstance(named, str) and named != METRICS_CSV and (folder / named).is_file():
        return folder / named
    return folder / METRICS_CSV if (folder / METRICS_CSV).is_file() else None


def _load_table(source: Path, drop_duplicates: bool, notes: list[str], min_conditions: int = 1,
                chosen: Sequence[str] | None = None) -> tuple[pd.DataFrame, list[str], int]:
    """A checked metrics table (at least ``min_conditions`` conditions), its metric columns, and
    how many repeated trial rows were dropped (``chosen``: the ``--metric`` names, the only
    columns that must then be numeric)."""
    table = read_metrics_table(source)
    rows_read = len(table)
    first_row = 2 if source.suffix.lower() == ".csv" else 1
    metric_columns = validate_metrics_table(table, str(source), first_row, min_conditions, chosen or None)
    table, _ = drop_or_refuse_duplicates(table, source, first_row, drop_duplicates, notes)
    return table, metric_columns, rows_read - len(table)


def _load_source(source: Path, plan: AnalysisPlan,
                 notes: list[str] | None = None) -> tuple[pd.DataFrame, list[str], str]:
    """The metrics of a run folder, its metric columns and the digest of its trials (``stats.json``'s
    :data:`~nudgecli.report.analysed_run.TRIALS_DIGEST_KEY`; ``notes``: :func:`read_run`'s)."""
    if not source.exists():
        raise DataError(f"{source} does not exist; give a run folder or a metrics table (.csv/.parquet)")
    if source.is_dir():
        if not is_run_folder(source):
            if (advice := start_advice(source)) is not None:  # killed as it wrote config.toml: no marker yet
                raise RunFolderError(advice)
            raise DataError(f"{source} is neither a run folder nor a metrics table: it has no trials/ or "
                            "steps/; give a folder made by `nudge simulate` or a .csv/.parquet table")
        trials, steps_of = read_run(source, notes)
        definitions = plan.metrics
        metrics = trial_metrics_by_participant(
            trials, steps_of, engagement=definitions.engagement, strength=definitions.strength,
            mode_switches=definitions.mode_switches, success=definitions.success,
            completion_time=definitions.completion_time)
        return metrics, list(definitions.include), trials_digest(trials)
    raise AssertionError("_load_source takes run folders; tables go through _load_table")  # pragma: no cover


def load_source(source: Path, plan: AnalysisPlan, min_conditions: int = 1, *, drop_duplicates: bool = False,
                notes: list[str] | None = None,
                metrics: Sequence[str] | None = None) -> tuple[pd.DataFrame, list[str], Path]:
    """The metrics table, its metric columns and the default output folder of a source.

    A run folder's metrics are computed with ``plan``'s definitions; a table is read and checked
    as ``nudge analyze`` checks it (:func:`~nudgecli.report.tables.validate_metrics_table`, at
    least ``min_conditions`` conditions; repeated trial rows refused, or dropped with
    ``drop_duplicates``: :func:`~nudgecli.report.tables.drop_or_refuse_duplicates`). What was left
    out goes to ``notes``. With ``metrics`` (``--metric``) only those of a table's columns must be
    numeric; its other non-numeric columns are left out. A table is taken under ``plan``'s metric
    definitions as far as its columns allow, and what it defines itself is said in ``notes``
    (:func:`~nudgecli.report.table_definitions.apply_plan_definitions`).
    """
    notes = [] if notes is None else notes
    if not source.exists():
        raise DataError(f"{source} does not exist; give a run folder or a metrics table (.csv/.parquet)")
    if source.is_dir():
        return *_load_source(source, plan, notes)[:2], source
    table, metric_columns, _ = _load_table(source, drop_duplicates, notes, min_conditions, metrics)
    defined = apply_plan_definitions(table, plan, metrics or metric_columns)
    notes += [f"{source}: {line}" for line in (defined.line, defined.blanks) if line]
    return defined.table, metric_columns, analysis_folder(source)


def _study_conditions(manifest: dict[str, Any] | None) -> list[str]:
    """The conditions a run's experiment lists (``config.study.conditions`` of its manifest), in order."""
    study = ((manifest or {}).get("config") or {}).get("study") or {}
    listed = study.get("conditions") if isinstance(study, dict) else None
    return [str(c) for c in listed] if isinstance(listed, list | tuple) else []


def _excluded_notes(table: pd.DataFrame) -> list[str]:
    """The participant-level tests' exclusions, one line per distinct note with its metrics
    (``table``: :func:`~nudgecli.report.stats_document.stats_table`'s)."""
    by_note: dict[str, list[str]] = {}
    for row in table.drop_duplicates("metric").to_dict("records"):
        note = row["participant_note"]
        if note:
            by_note.setdefault(note, []).append(row["metric"])
    return [f"participant-level test of {', '.join(names)}: {note}" for note, names in by_note.items()]


def analyze(source: str | Path, plan: str | Path | AnalysisPlan | None = None, out: str | Path | None = None,
            metrics: Sequence[str] | None = None, questionnaires: str | Path | None = None,
            seed: int | None = None, *, bootstrap: int | None = None, drop_duplicates: bool = False,
            progress: Callable[[int, int], None] | None = None, reference: str | None = None,
            not_applicable: Mapping[str, Collection[str]] | None = None,
            force: bool = False, log: Callable[[str], None] | None = None) -> AnalysisResult:
    """Compute the metrics and statistics of a run or a metrics table and write them.

    Parameters
    ----------
    source
        A run folder (``trials/`` and ``steps/`` Parquet parts) or a metrics table (CSV or Parquet,
        one row per trial with ``participant``, ``condition`` and metric columns).
    plan
        An analysis plan: preset name (``paper``, ``study-code``), TOML path, or a plan. Default: the
        plan recorded in a run folder's manifest (recorded there now if missing and the run folder
        is the output folder), else ``paper``.
    out
        Output folder; default the run folder, or ``<table>-analysis/`` beside a table.
    metrics
        Only these metrics (trial metrics or questionnaire scores), in this order; default all
        of the plan's (run folder) or of the table's columns, then every questionnaire score.
    questionnaires
        A questionnaire CSV (:mod:`nudgecli.report.questionnaires`) analysed alongside.
    seed, bootstrap
        Bootstrap seed and resamples; default the plan's.
    drop_duplicates
        Drop repeated trial rows of a metrics table (keeping the first) instead of refusing them.
    progress
        Called with (metrics done, metrics in all) as the statistics proceed.
    reference
        ``summary.md`` shows only this condition's pairs (``--reference``); default every pair up
        to three conditions, a compact letter display from four.
    not_applicable
        Metric -> the conditions it is not applicable to, left out of its tests; default, for a
        run folder, :func:`nudgecli.model.conditions.not_applicable_metrics` of its conditions,
        for a table none (a condition without values is left out either way).
    force
        Write a table's analysis into its ``<table>-analysis/`` even when that folder holds the
        analysis of another table (``study.parquet``'s in ``study-analysis/``), replacing it;
        without it that is refused (:func:`~nudgecli.report.analysis_folders.check_folder_is_the_tables`).
    log
        Gets the warning of a stale lock taken over (:func:`~nudgecli.locks.run_lock`); default silent.

    Returns
    -------
    AnalysisResult

    Raises
    ------
    DataError, RunFolderError, ConfigError
        Invalid source, table, questionnaire table, metric name, plan or reference condition (one clear
        message each); a table's analysis folder that holds another table's analysis.
    LockError, WriteError
        Another command is writing the run folder or the output folder; it cannot be written.
    """
    source = Path(source)
    if not source.exists():
        raise DataError(f"{source} does not exist; give a run folder or a metrics table (.csv/.parquet)")
    check_resamples(bootstrap, "--bootstrap", MIN_RESAMPLES)  # the bounds of a plan's resamples
    out_dir = Path(out) if out is not None else (source if source.is_dir() else analysis_folder(source))
    if out_dir.exists() and not out_dir.is_dir():
        raise DataError(f"--out {out_dir} is a file; give a folder")
    made_out = not out_dir.exists()
    try:
        return _analyze_with_locks(source, plan, out_dir, metrics, questionnaires, seed, bootstrap,
                                   drop_duplicates, progress, reference=reference,
                                   not_applicable=not_applicable, force=force, log=log)
    except BaseException:
        if made_out and out_dir.is_dir() and not any(out_dir.iterdir()):
            out_dir.rmdir()  # made only for this analysis, which failed: leave nothing behind
        raise


def _analyze_with_locks(source: Path, plan: str | Path | AnalysisPlan | None, out_dir: Path,
                        metrics: Sequence[str] | None, questionnaires: str | Path | None, seed: int | None,
                        bootstrap: int | None, drop_duplicates: bool,
                        progress: Callable[[int, int], None] | None, *, reference: str | None = None,
                        not_applicable: Mapping[str, Collection[str]] | None = None,
                        force: bool = False, log: Callable[[str], None] | None = None) -> AnalysisResult:
    """:func:`analyze` with the run folder's and the output folder's locks held."""
    with contextlib.ExitStack() as locks:
        if is_run_folder(source):
            try:
                locks.enter_context(run_lock(source, log=log))
            except NudgeWriteError:
                if out_dir.resolve() == source.resolve():
                    raise
                # a read-only run folder analysed elsewhere: nobody can be writing it
        locks.enter_context(run_lock(out_dir, log=log))
        refuse_linked_analysis(out_dir)  # before anything there is written, or put back
        recover_kept_analysis(out_dir)  # what a killed `nudge plot --plan` kept, before the manifest is read
        if source.is_file() and not force and out_dir.resolve() == analysis_folder(source).resolve():
            check_folder_is_the_tables(source, out_dir)  # under its lock: study.csv's, not study.parquet's
        return _analyze_locked(source, plan, out_dir, metrics, questionnaires, seed, bootstrap,
                               drop_duplicates, progress, reference=reference, not_applicable=not_applicable)
    raise AssertionError("unreachable")  # pragma: no cover - for type checkers


def _analyze_locked(source: Path, plan_arg: str | Path | AnalysisPlan | None, out_dir: Path,
                    metrics: Sequence[str] | None, questionnaires: str | Path | None, seed: int | None,
                    bootstrap: int | None, drop_duplicates: bool,
                    progress: Callable[[int, int], None] | None, *, reference: str | None = None,
                    not_applicable: Mapping[str, Collection[str]] | None = None) -> AnalysisResult:
    """:func:`analyze` once the folders' locks are held."""
    notes: list[str] = []
    run = RunFolder(source) if source.is_dir() else None
    manifest = run.read_manifest() if run is not None and run.is_run() else None
    plan = load_plan(recorded_plan(manifest, run) if plan_arg is None else plan_arg)
    source_record: dict[str, Any] = {}  # the run's trials, or what was done to a table's rows: for plot
    # the source as seen from the output folder: no machine's path in what is written
    source_from_out = Path(os.path.relpath(source.resolve(), out_dir.resolve()))
    if source.is_dir():  # the run's trials recorded: plot never draws them beside another run's
        table, available, digest = _load_source(source, plan, notes)
        changed, source_record = True, {TRIALS_DIGEST_KEY: digest}
    else:
        sha256 = file_sha256(source)  # before reading: a table edited meanwhile is never taken for this one
        table, available, dropped = _load_table(source, drop_duplicates, notes, chosen=metrics)
        changed = dropped > 0
        source_record[TABLE_READ_KEY] = table_read_record(
            sha256, len(table) + dropped, drop_duplicates, dropped, source_from_out,
            *analysed_inputs(out_dir, plan_argument(plan), questionnaires))
    try:  # before anything is recorded: a plan whose conditions are not the data's is refused
        check_plan_conditions(plan, plan.label, table["condition"].astype(str).unique(), str(source))
    except ConfigError as exc:  # the run's recorded plan, no --plan given: the fix `nudge run` gives
        from nudgecli.runs.study import own_plan_advice
        fix = own_plan_advice(table["condition"].astype(str).unique())
        raise exc if plan_arg is not None else ConfigError(f"{exc}; no --plan was given: {fix}") from None
    plan_kept, plan_copy = record_plan(run, manifest, plan, out_dir) if run else kept_plan_file(plan, out_dir)
    source_record.update(plan_kept)  # a run's plan where out_dir hides it; a plan file's copy, kept
    check_filters(plan, available)
    scores, score_names = _read_scores(questionnaires, table, source, manifest, notes)
    selected = select_metrics(metrics, [*available, *score_names], plan)
    trial_selected = [m for m in selected if m in available]
    if plan_arg is not None and not metrics and run is None:  # a table's columns are all its metrics
        notes += [f"{source}: {line}" for line in [table_include_note(plan, trial_selected)] if line]
    score_selected = [m for m in selected if m in score_names]
    definitions_line, blanks_line = (run_definitions_line(plan, trial_selected) if run else None), None
    if not source.is_dir():  # a run's metrics were computed with the plan's definitions already
        defined = apply_plan_definitions(table, plan, trial_selected)
        table, changed, definitions_line = defined.table, changed or defined.changed, defined.line
        blanks_line = defined.blanks
        notes += [f"{source}: {line}" for line in (definitions_line, blanks_line) if line]

    filters = apply_plan_filters(table, plan, trial_selected, changed)
    filtered, changed = filters.table, filters.changed
    notes += [f"{source}: {filters.line}"] if filters.line else []
    conditions = order_conditions(filtered["condition"].cat.categories,
                                  (*plan.conditions, *_study_conditions(manifest)))
    check_reference(reference, conditions)
    if not_applicable is None:  # the one place: as the run recorded it, else the built-ins' table
        recorded = (manifest or {}).get(CONSTANT_METRICS_KEY)
        not_applicable = (not_applicable_metrics(conditions, recorded, success=plan.metrics.success)
                          if source.is_dir() else {})
    options = comparison_options(plan, seed, bootstrap)
    stats = _statistics(filtered, trial_selected, scores, score_selected, conditions, options, progress,
                        not_applicable)
    stats["metrics_table"] = METRICS_CSV if changed else str(source_from_out)
    stats[CHECKSUM_KEY] = metrics_checksum(filtered, trial_selected, plan.filters)
    stats.update(RunFolder.analysed_progress(manifest))  # a live study's trials: plot refuses it outgrown
    if scores is not None:  # plot draws only the scores file this analysis writes
        stats[SCORES_CHECKSUM_KEY] = scores_checksum(scores)
    stats.update(source_record)
    stats = json_ready(stats)
    tidy = stats_table(stats)
    notes += _excluded_notes(tidy)
    summary = format_summary(tidy, stats["conditions"], plan, source_from_out, n_trials=len(filtered),
                             plan_name=summary_plan_name(plan, out_dir),
                             n_participants=filtered["participant"].nunique(), reference=reference,
                             definitions=definitions_line, filters=filters.line, blanks=blanks_line,
                             not_applicable={e["metric"]: e.get("not_applicable_reasons") or {}
                                             for e in stats["metrics"]})

    metrics_columns = [c for c in filtered.columns if c in NON_METRIC_COLUMNS or c in available]
    written = _write_analysis(out_dir, filtered[metrics_columns] if changed else None, stats, tidy, summary,
                              scores, plan_copy, inputs=(source, questionnaires))
    return AnalysisResult(out=out_dir, files=written, metrics=filtered, stats=stats, table=tidy,
                          summary=summary, questionnaires=scores, notes=notes,
                          p_thresholds=plan_p_thresholds(plan))


def _read_scores(questionnaires: str | Path | None, table: pd.DataFrame, source: Path,
                 manifest: Mapping[str, Any] | None,
                 notes: list[str]) -> tuple[pd.DataFrame | None, list[str]]:
    """The questionnaire scores (``None`` without a questionnaire table) and their score columns,
    checked against the trials: conditions among the trials' (fewer, those answered, with a note
    naming the rest; of a live study still under way, as its ``manifest`` says, those answered so
    far), respondents among the participants."""
    if questionnaires is None:
        return None, []
    under_way = RunFolder.study_under_way(manifest)
    read = read_run_questionnaires(questionnaires, source, table, manifest)  # its manifest, read once
    scores = questionnaire_scores(read, str(questionnaires), notes)  # notes the columns it does not read
    score_names = score_columns(scores)
    trial_conditions = set(table["condition"].astype(str))
    score_conditions = set(scores["condition"])
    if not score_conditions <= trial_conditions:  # a label the trials lack: named another way
        raise DataError(f"{questionnaires}: conditions {sorted(score_conditions - trial_conditions)} are "
                        f"not among those of {source} {sorted(trial_conditions)}; name the conditions "
                        "the same way")
    if score_conditions < trial_conditions:  # fewer answered: analysed as far as they go
        unanswered = ', '.join(sorted(trial_conditions - score_conditions))
        notes.append(f"{questionnaires}: no answers yet in condition(s) {unanswered} of the study under way; "
                     "the questionnaires are analysed as far as they got" if under_way else
                     f"{questionnaires}: no answers in condition(s) {unanswered}; the questionnaires "
                     "are analysed in the conditions answered")
    check_respondents(scores, table["participant"], str(questionnaires), str(source))
    return scores, score_names


def _statistics(filtered: pd.DataFrame, trial_selected: Sequence[str], scores: pd.DataFrame | None,
                score_selected: Sequence[str], conditions: Sequence[str], options: ComparisonOptions,
                progress: Callable[[int, int], None] | None,
                not_applicable: Mapping[str, Collection[str]]) -> dict[str, Any]:
    """The ``stats.json`` document of the trial metrics, then of the questionnaire scores, one
    metric at a time so that ``progress`` hears of each (``not_applicable``: metric -> the
    conditions left out of its tests)."""
    total = len(trial_selected) + (len(score_selected) if scores is not None else 0)
    entries = []
    for done, name in enumerate(trial_selected):
        if progress:
            progress(done, total)
        entries += compare_conditions(filtered, [name], conditions, options,
                                      not_applicable=not_applicable)["metrics"]
    stats: dict[str, Any] = {"conditions": list(conditions), "metrics": entries}
    if scores is not None and score_selected:
        stats["metrics"] += compare_conditions(scores, score_selected, conditions, options,  # the
                                               not_applicable=not_applicable,  # trials' participants
                                               roster=filtered)["metrics"]
    if progress:
        progress(total, total)
    return stats


def _write_analysis(out_dir: Path, metrics: pd.DataFrame | None, stats: dict[str, Any], tidy: pd.DataFrame,
                    summary: str, scores: pd.DataFrame | None, plan_copy: str | None = None, *,
                    inputs: Sequence[str | Path | None] = ()) -> list[Path]:
    """Write :data:`~nudgecli.report.analysis_folders.ANALYSIS_FILES` atomically into ``out_dir``
    (``metrics.csv`` when ``metrics`` is given: the table analysed differs from the source;
    ``questionnaire_scores.csv`` with ``scores``; the plan's copy with ``plan_copy``, the plan file's
    text: :func:`~nudgecli.report.recorded_plans.record_plan`) and return them; none when one is an
    input of the command. The old ``stats.json`` goes first, then an earlier analysis's outputs this
    one does not write (unless an input: one of ``inputs``, the source and questionnaires, or a file
    the command declared), the new ``stats.json`` last: a killed analysis leaves none (``nudge plot``
    refuses the folder, naming the command that completes it), never one beside another analysis's
    files. An earlier killed analysis's temporaries are removed."""
    outputs = {METRICS_CSV: None if metrics is None else metrics.to_csv(index=False),
               STATS_CSV: stats_csv(tidy), SUMMARY_MD: summary, ANALYSIS_PLAN_COPY: plan_copy,
               QUESTIONNAIRE_SCORES_CSV: None if scores is None else scores_csv(scores),  # as checksummed
               STATS_JSON: json.dumps(stats, indent=2, allow_nan=False) + "\n"}
    written = [out_dir / name for name, text in outputs.items() if text is not None]
    for path in written:
        check_not_an_input(path)  # all of them first: nothing is replaced when one is an input
    stale = [out_dir / name for name, text in outputs.items() if text is None]  # an earlier analysis's
    stale = [path for path in stale if not _is_input(path, inputs)]
    try:  # the lock is held: no live writer owns a temporary; stats.json before the stale outputs
        for path in [*(p for p in out_dir.glob(".*.tmp") if left_by_a_killed_analysis(out_dir)(p.name)),
                     out_dir / STATS_JSON, *stale]:
            path.unlink(missing_ok=True)
    except OSError as exc:
        raise write_error(out_dir / STATS_JSON, exc) from exc
    for path in written:
        write_text_atomic(path, outputs[path.name] or "")
    return written


def _is_input(path: Path, inputs: Sequence[str | Path | None]) -> bool:
    """Whether ``path`` is one of ``inputs`` or of the command's declared inputs (a table analysed
    from its own folder): an output this analysis does not write is removed only when it is not."""
    for given in (Path(p) for p in inputs if p is not None):
        with contextlib.suppress(OSError):
            if given.is_file() and path.is_file() and os.path.samefile(given, path):
                return True
    try:
        check_not_an_input(path)
    except NudgeWriteError:
        return True
    return False
