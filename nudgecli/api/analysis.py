"""``nudgecli.analyze``: the metrics and statistics of a run or a metrics table, as tidy frames.

The work is :func:`nudgecli.report.analysis.analyze`'s (what ``nudge analyze`` and ``nudge run``
call through this module); an :class:`Analysis` holds what it computed and where it wrote it.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nudgecli.api.folders import FolderOwner, remove_if_made, temporary_folder
from nudgecli.api.run import ProgressCallback, Run
from nudgecli.errors import DataError, NudgeError

if TYPE_CHECKING:
    import pandas as pd

    from nudgecli.report.analysis import AnalysisResult
    from nudgecli.report.plans import AnalysisPlan

#: The file a metrics DataFrame given to :func:`analyze` is written to, in the analysis folder
#: (Parquet: the values exactly as given), so the analysis can be plotted and read again.
DATAFRAME_TABLE = "metrics.parquet"

#: What an error about a metrics DataFrame's table calls it (the table is a copy the caller never named).
FRAME_NAME = "the metrics DataFrame"

#: What ``summary.md``'s source line says of a DataFrame analysed into a temporary folder (its table
#: there is a copy removed with the :class:`Analysis`, no file the caller could open later).
FRAME_SOURCE = "a DataFrame given to analyze"

#: The columns of :attr:`Analysis.tests`, one row per metric.
TEST_COLUMNS = ("metric", "kruskal_statistic", "kruskal_p", "p_adjust", "participant_test",
                "participant_aggregate", "participant_statistic", "participant_p", "n_participants",
                "participant_note")


class Analysis(FolderOwner):
    """What :func:`analyze` computed: tidy frames, the statistics document and the files written.

    Attributes
    ----------
    path
        The folder of ``stats.json``, ``stats.csv``, ``summary.md`` (and ``metrics.csv``).
    source
        What was analysed: the run folder or table (the table written for a DataFrame; without
        ``out=`` a temporary copy, which :meth:`summary` calls "a DataFrame given to analyze").
    plan
        The analysis plan given (``None``: the source's own, as ``nudge analyze`` chooses it).
    result
        :class:`nudgecli.report.analysis.AnalysisResult`, everything ``nudge analyze`` used.
    """

    def __init__(self, result: AnalysisResult, source: Path, plan: str | Path | AnalysisPlan | None, *,
                 temporary: bool = False, keep_alive: object = None) -> None:
        self._own(result.out, temporary)
        self.result = result
        self.source = source
        self.plan = plan
        self._keep_alive = keep_alive  # a temporary Run whose folder this analysis was written into

    @property
    def metrics(self) -> pd.DataFrame:
        """One row per trial (after the plan's filters): participant, condition and each metric."""
        return self.result.metrics

    @property
    def pairs(self) -> pd.DataFrame:
        """One row per metric and pair of conditions: ``stats.csv``'s columns (medians, Conover p,
        stars, participant-level test, effect size, bootstrap interval of the difference), then
        columns only ``stats.json`` holds besides (``mean_a``, ``mean_b``, ``mean_rank_a``,
        ``mean_rank_b``, ``participant_note``, ``ci_seed``, ``ci_resamples``); :meth:`csv` is
        ``stats.csv`` itself."""
        return self.result.table

    def csv(self) -> str:
        """The text ``stats.csv`` holds (what ``nudge analyze --format csv`` prints): :attr:`pairs`
        with ``stats.csv``'s columns only."""
        from nudgecli.report.stats_document import stats_csv

        return stats_csv(self.result.table)

    @functools.cached_property
    def tests(self) -> pd.DataFrame:
        """One row per metric: the omnibus Kruskal-Wallis test and the participant-level test
        (columns :data:`TEST_COLUMNS`)."""
        import pandas as pd

        rows = []
        for entry in self.result.stats["metrics"]:
            kruskal = entry.get("kruskal") or {}
            participant = entry.get("participant_level") or {}
            rows.append({"metric": entry["metric"], "kruskal_statistic": kruskal.get("statistic"),
                         "kruskal_p": kruskal.get("p"), "p_adjust": entry.get("p_adjust"),
                         "participant_test": participant.get("test"),
                         "participant_aggregate": participant.get("aggregate"),
                         "participant_statistic": participant.get("statistic"),
                         "participant_p": participant.get("p"),
                         "n_participants": participant.get("n_participants"),
                         "participant_note": participant.get("note")})
        return pd.DataFrame(rows, columns=list(TEST_COLUMNS))

    @property
    def stats(self) -> dict[str, Any]:
        """The ``stats.json`` document (NaN as ``None``)."""
        return self.result.stats

    @property
    def conditions(self) -> list[str]:
        """The conditions, in the analysis's order."""
        return list(self.result.stats["conditions"])

    @property
    def notes(self) -> list[str]:
        """What was left out or changed (the metric definitions, duplicates or participants dropped, an
        undefined test), a line each; :func:`analyze` sends each to ``log=`` as :func:`note_line`."""
        return list(self.result.notes)

    @property
    def files(self) -> list[Path]:
        """The files written."""
        return list(self.result.files)

    def summary(self) -> str:
        """The text ``summary.md`` holds."""
        return self.result.summary

    def table(self, reference: str | None = None) -> str:
        """The plain-text table ``nudge analyze`` prints (only ``reference``'s pairs when given).

        Raises
        ------
        ConfigError
            ``reference`` is not one of :attr:`conditions` (as ``analyze(reference=...)`` refuses it).
        """
        from nudgecli.api import arguments
        from nudgecli.report.pair_display import check_reference
        from nudgecli.report.summary import format_table

        check_reference(arguments.text("reference", reference, optional=True), self.conditions)
        return format_table(self.result.table, self.conditions, reference,
                            thresholds=self.result.p_thresholds)

    def __repr__(self) -> str:
        return (f"Analysis({len(self.result.stats['metrics'])} metrics, conditions {self.conditions}, "
                f"{str(self.path)!r})")


def note_line(note: str) -> str:
    """The line ``nudge`` writes on stderr for ``note``, one of a result's notes (``Note: ...``)."""
    return f"Note: {note}"


def log_notes(notes: Iterable[str], log: Callable[[str], None] | None) -> None:
    """Send each of ``notes`` to ``log`` as its :func:`note_line`, the line the command prints: how
    every API function's ``log=`` receives the notes of what it returns; nothing without ``log``."""
    if log is not None:
        for note in notes:
            log(note_line(note))


def analyze(source: Run | str | Path | pd.DataFrame, *, plan: str | Path | AnalysisPlan | None = None,
            metrics: Sequence[str] | None = None, questionnaires: str | Path | None = None,
            bootstrap: int | None = None, out: str | Path | None = None, seed: int | None = None,
            reference: str | None = None, drop_duplicates: bool = False, force: bool = False,
            progress: ProgressCallback | None = None, log: Callable[[str], None] | None = None) -> Analysis:
    """Compute the metrics and statistics of ``source``, as ``nudge analyze`` does.

    Parameters
    ----------
    source
        A :class:`Run`, a run folder, a metrics table's path (CSV/Parquet), or a metrics DataFrame
        (one row per trial: ``participant``, ``condition`` and metric columns).
    plan
        A preset (``paper``, ``study-code``), a TOML file or a loaded plan; default the run's
        recorded plan, else the one named like its experiment, else its world's, else ``paper``.
    metrics, questionnaires
        Only these metrics, in this order (``--metric``; ``None``: all of them, and an empty list is
        refused); a questionnaire CSV analysed alongside.
    bootstrap, seed
        Bootstrap resamples and seed of the intervals; default the plan's (shipped: 2000 and 0).
    out
        The folder written; default as ``nudge analyze``: the run folder, ``<table>-analysis/``
        beside a table, and for a DataFrame a temporary folder removed with the :class:`Analysis`.
    reference
        ``summary.md`` compares every other condition with this one only.
    drop_duplicates
        Keep the first of repeated trial rows of a table instead of refusing them.
    progress, log
        Called with (metrics done, metrics in all), and with the lines ``nudge analyze`` writes on
        stderr: the ``Warning:`` of a stale lock taken over, then a ``Note:`` line per note of
        :attr:`Analysis.notes` (the metric definitions, participants dropped); default silent.
    force
        Write into an ``out`` that holds other files or a run (``--force``), or into a table's
        ``<table>-analysis/`` that holds another table's analysis; without it such a folder is
        refused, as ``nudge analyze`` refuses it.

    Returns
    -------
    Analysis

    Raises
    ------
    NudgeError
        Invalid source, plan, metric, questionnaire table or reference (``nudge``'s ``Error:`` line);
        a folder this call made is removed again, and one given as ``out`` is left as it was
        (a DataFrame's previous table there put back byte for byte).
    """
    from nudgecli.api import arguments
    from nudgecli.outputs import check_output_folder
    from nudgecli.report.analysis import analysis_folder, left_by_a_killed_analysis
    from nudgecli.report.plans import MIN_RESAMPLES, check_resamples

    metrics = arguments.texts("metrics", metrics, optional=True, empty=False)
    questionnaires = arguments.path("questionnaires", questionnaires, optional=True)
    bootstrap = arguments.whole_number("bootstrap", bootstrap, optional=True)  # its bounds: check_resamples
    out = arguments.out_folder(out)
    seed = arguments.seed(seed, optional=True)
    reference = arguments.text("reference", reference, optional=True)
    arguments.switches(drop_duplicates=drop_duplicates, force=force)
    progress, log = arguments.callback("progress", progress), arguments.callback("log", log)
    check_resamples(bootstrap, "--bootstrap", MIN_RESAMPLES)  # the analysis's own bounds, before --out's
    path = source.path if isinstance(source, Run) else source
    if out is not None:  # the source's own folders, or one a killed analysis left, need no --force
        own = [path, analysis_folder(Path(path))] if isinstance(path, str | Path) else []
        check_output_folder(out, force=force, own=own, own_file=left_by_a_killed_analysis(out))
    options: dict[str, Any] = {"plan": plan, "metrics": list(metrics) if metrics is not None else None,
                               "questionnaires": questionnaires, "seed": seed, "bootstrap": bootstrap,
                               "drop_duplicates": drop_duplicates, "progress": progress,
                               "reference": reference, "log": log}
    analysis = _analysis_of(source, out, force, options)
    log_notes(analysis.notes, log)
    return analysis


def _analysis_of(source: Run | str | Path | pd.DataFrame, out: str | Path | None, force: bool,
                 options: dict[str, Any]) -> Analysis:
    """:func:`analyze`'s work once its arguments are checked: ``source`` analysed by its kind."""
    import pandas as pd

    from nudgecli.report.analysis import analyze as analyze_source

    if isinstance(source, pd.DataFrame):
        return _analyze_frame(source, out, options)
    if isinstance(source, Run):
        result = analyze_source(source.path, out=out, **options)
        return Analysis(result, source.path, options["plan"], keep_alive=source if out is None else None)
    if not isinstance(source, str | Path):
        raise DataError(f"analyze: source must be a Run, a run folder, a metrics table or a DataFrame, "
                        f"not {type(source).__name__}")
    return Analysis(analyze_source(source, out=out, force=force, **options), Path(source), options["plan"])


def _analyze_frame(frame: pd.DataFrame, out: str | Path | None, options: dict[str, Any]) -> Analysis:
    """:func:`analyze` of a DataFrame: written as :data:`DATAFRAME_TABLE` into the analysis folder
    (``out`` or a temporary one) and analysed from there; on failure the folder is left as it was
    (a previous analysis's table put back byte for byte)."""
    from pyarrow.lib import ArrowException

    from nudgecli.report.analysis import analyze as analyze_source
    from nudgecli.store import write_bytes_atomic, write_parquet_atomic

    temporary = out is None
    folder = temporary_folder("analysis") if out is None else Path(out)
    made = temporary or not folder.exists()
    table = folder / DATAFRAME_TABLE
    previous = table.read_bytes() if table.is_file() else None  # put back if this analysis fails
    try:
        folder.mkdir(parents=True, exist_ok=True)
        try:
            write_parquet_atomic(table, frame)
        except (ValueError, TypeError, ArrowException) as exc:  # columns Parquet cannot hold
            raise DataError(f"metrics DataFrame: cannot be stored as a table ({exc}); give one row per "
                            "trial with participant, condition and numeric metric columns") from None
        try:
            result = analyze_source(table, out=folder, **options)
        except NudgeError as exc:  # the table is this call's copy of the frame: name what was given
            raise type(exc)(str(exc).replace(str(table), FRAME_NAME)) from None
    except BaseException:
        if made:
            remove_if_made(folder, True)
        elif previous is None:
            table.unlink(missing_ok=True)
        else:
            write_bytes_atomic(table, previous)
        raise
    return Analysis(_frame_named(result, table, temporary), table, options["plan"], temporary=temporary)


def _frame_named(result: AnalysisResult, table: Path, temporary: bool) -> AnalysisResult:
    """``result`` of a DataFrame written to ``table``, saying what was given: its notes name
    :data:`FRAME_NAME`, as its errors do, not the table (a copy the caller never named); and when
    ``temporary`` (a copy removed with the :class:`Analysis`) ``summary.md``'s source is
    :data:`FRAME_SOURCE`, in the text and the file alike, not a file gone later."""
    import dataclasses

    from nudgecli.run_folder_names import SUMMARY_MD
    from nudgecli.store import write_text_atomic

    notes = [note.replace(str(table), FRAME_NAME) for note in result.notes]
    if not temporary:
        return dataclasses.replace(result, notes=notes)
    summary = result.summary.replace(f"`{DATAFRAME_TABLE}`", FRAME_SOURCE, 1)
    write_text_atomic(result.out / SUMMARY_MD, summary)
    return dataclasses.replace(result, notes=notes, summary=summary)
