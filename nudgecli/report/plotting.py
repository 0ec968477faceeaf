"""``nudge plot``: find what an analysed run or metrics table holds, check it, draw and write its figures.

The drawing is :mod:`nudgecli.report.figures`, the choice of Fig. 5's trial
:mod:`nudgecli.report.trial_selection`; this module reads the inputs, checks that ``stats.json``
was computed from the metrics it is about to draw (:mod:`nudgecli.report.checksum`), decides
which figures the data allow (:func:`draw_figures`) and writes them (:func:`write_figures`).

Sources:

- a run folder analysed with ``nudge analyze``: ``metrics.csv``, ``stats.json``, the trial table,
  the step log and the layouts (Fig. 5 and the trajectory), ``questionnaire_scores.csv`` if its
  analysis wrote it (its SHA-256 in ``stats.json``:
  :func:`~nudgecli.report.questionnaires.read_analysed_scores`);
- an analysed metrics table, given as the table itself or as its analysis folder (the folder
  that holds its ``stats.json`` and ``metrics.csv``): box plots only. The table itself is drawn
  only when it is the one analysed, byte for byte (:mod:`nudgecli.report.table_read`).

The paper's Fig. 3 and Fig. 4 are drawn where all three of their metrics are present; every
other analysed metric of the table gets a panel of its own in ``metrics``. Four or more conditions
are compared by letters, or by the brackets of a reference condition (``--reference``;
:mod:`nudgecli.report.figures.comparison_marks`).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from nudgecli.errors import ConfigError, DataError, RunFolderError, shell_words
from nudgecli.report import figures
from nudgecli.report.analysed_run import check_analysed_trials
from nudgecli.report.analysis import analysed_metrics_path
from nudgecli.report.analysis_folders import analysis_folder, check_analysis_complete, interrupted_analysis
from nudgecli.report.checksum import recorded_checksum, verify_metrics
from nudgecli.report.figure_records import replace_earlier_figures
from nudgecli.report.figures import TrialLayout
from nudgecli.report.figures.output import refuse_linked_figures
from nudgecli.report.metrics import apply_filters
from nudgecli.report.metrics_csv import read_metrics_csv
from nudgecli.report.pair_display import check_reference
from nudgecli.report.plans import MetricDefinitions
from nudgecli.report.questionnaires import read_analysed_scores
from nudgecli.report.run_figure_inputs import layouts_by_trial, representative_trial, run_fields
from nudgecli.report.stats import ComparisonOptions
from nudgecli.report.stats_verify import check_live_analysis_current, verify_p_values
from nudgecli.report.style import condition_display_name
from nudgecli.report.table_read import analyze_again, check_table_is_analysed, recorded_table_read
from nudgecli.report.tables import (
    TABLE_SUFFIXES,
    find_duplicate_trials,
    read_metrics_table,
    validate_metrics_table,
)
from nudgecli.report.trial_selection import choose_figure5_trial
from nudgecli.report.trial_steps import TrialKey
from nudgecli.run_folder_names import FIGURES_DIR, METRICS_CSV, STATS_JSON
from nudgecli.run_folder_state import only_a_start
from nudgecli.store import RunFolder, is_run_folder


def parse_formats(text: str) -> tuple[str, ...]:
    """``"png,pdf"`` -> ``("png", "pdf")``, or a ``ConfigError`` naming the bad format."""
    try:
        return figures.check_formats(text.split(","))
    except ConfigError:
        raise ConfigError(f"--formats {text!r}: choose from {', '.join(figures.SUPPORTED_FORMATS)} "
                          "(comma-separated)") from None


def parse_trial(text: str | None) -> TrialKey | None:
    """``"PARTICIPANT:TRIAL"`` -> ``(participant, trial)``."""
    if text is None:
        return None
    try:
        participant, trial = (int(v) for v in text.split(":"))
    except ValueError:
        raise ConfigError(f"--trial {text!r}: expected PARTICIPANT:TRIAL, e.g. --trial 0:12") from None
    return participant, trial


# --- what is drawn -------------------------------------------------------------------------------


@dataclass(frozen=True)
class FigureInputs:
    """The data the figures are drawn from.

    Attributes
    ----------
    metrics
        One row per trial: ``condition`` and metric columns (checked against ``stats``).
    stats
        The ``stats.json`` document (condition order, brackets, which metrics were analysed).
    trials, steps, layouts
        A run's trials table, step log and ``(participant, trial) -> TrialLayout``; ``None`` for
        a metrics table (no Fig. 5, no trajectory).
    questionnaires
        Questionnaire scores (``tlx_*``, ``likert_*`` columns), or ``None``.
    path_layouts, time_limit_s
        A CIAA path-world run's layouts table (waypoints) and trial time limit; ``None`` otherwise.
    trial
        The trial of Fig. 5 and the trajectory where ``steps`` were read for it alone (its
        participant's steps: :func:`read_inputs`); ``None``: chosen from ``steps``.
    steps_missing
        Why a run has no trial to draw (its step logs are not there), else ``None``.
    """

    metrics: pd.DataFrame
    stats: Mapping[str, Any]
    trials: pd.DataFrame | None = None
    steps: pd.DataFrame | None = None
    layouts: Mapping[TrialKey, TrialLayout] | None = None
    questionnaires: pd.DataFrame | None = None
    path_layouts: pd.DataFrame | None = None
    time_limit_s: float | None = None
    trial: TrialKey | None = None
    steps_missing: str | None = None


#: The figures drawn from a run's step logs: an earlier plot's are kept where the logs are not there.
TRIAL_FIGURES = ("fig5", "trajectory")


@dataclass(frozen=True)
class PlotPlan:
    """How the figures are drawn and where they go.

    Attributes
    ----------
    out_dir
        Folder of the figures.
    formats
        File formats (``png``, ``pdf``, ``svg``).
    trial
        ``(participant, trial)`` of Fig. 5 and the trajectory; default
        :func:`nudgecli.report.trial_selection.choose_figure5_trial`.
    seed
        Jitter seed of the box plots.
    star_rule
        The analysis plan's star rule (for statistics entries without stars).
    item_labels
        Axis labels of questionnaire items (the plan's ``[questionnaires] labels``).
    reference
        The box plots' brackets only for this condition's pairs (``--reference``); ``None``:
        every significant pair up to three conditions, letters from four.
    definitions
        The plan's metric definitions, which the box plots' labels name (``None``: the paper's).
    log
        Receives the line naming an earlier plot's figures removed from ``out_dir``.
    """

    out_dir: Path
    formats: tuple[str, ...] = ("png", "pdf")
    trial: TrialKey | None = None
    seed: int = 0
    star_rule: ComparisonOptions = field(default_factory=ComparisonOptions)
    item_labels: Mapping[str, str] = field(default_factory=dict)
    reference: str | None = None
    log: Callable[[str], None] | None = None
    definitions: MetricDefinitions | None = None


def drawn_metrics(inputs: FigureInputs) -> list[str]:
    """The analysed metrics the table has, in the order of ``stats.json``."""
    names = [str(e.get("metric")) for e in inputs.stats.get("metrics") or []]
    return [m for m in names if m in inputs.metrics.columns]


def metric_figure_groups(metrics: Sequence[str]) -> dict[str, tuple[str, ...]]:
    """``stem -> metrics`` of the box-plot figures: ``fig3``/``fig4`` where all their metrics are
    present, ``metrics`` (one panel each) for every other metric."""
    present = set(metrics)
    groups: dict[str, tuple[str, ...]] = {}
    for stem, names in (("fig3", figures.FIGURE3_METRICS), ("fig4", figures.FIGURE4_METRICS)):
        if set(names) <= present:
            groups[stem] = tuple(names)
    taken = {m for names in groups.values() for m in names}
    rest = tuple(m for m in metrics if m not in taken)
    if rest:
        groups["metrics"] = rest
    return groups


def _trial_title(trials: pd.DataFrame, key: TrialKey) -> str:
    rows = trials.loc[(trials["participant"] == key[0]) & (trials["trial"] == key[1]), "condition"]
    label = f"Participant {key[0]}, trial {key[1]}"
    if rows.empty:
        return label
    # Named as among the run's conditions, so -10 and 10, or offset-10 and offset_10, stay apart.
    return f"{label} ({condition_display_name(str(rows.iloc[0]), trials['condition'].astype(str).unique())})"


@dataclass(frozen=True)
class TrialPanel:
    """What Fig. 5 and the trajectory draw of one trial: its steps, true goal, goal count, layout
    (``None``: no trajectory) and title."""

    steps: pd.DataFrame
    true_goal: int
    n_goals: int | None
    layout: TrialLayout | None
    title: str


def trial_panel(inputs: FigureInputs, trial: TrialKey | None) -> TrialPanel:
    """The trial of Fig. 5 and the trajectory: ``trial``, else
    :func:`~nudgecli.report.trial_selection.choose_figure5_trial`'s, from a run's inputs.

    Raises
    ------
    DataError
        The chosen trial has no steps.
    """
    assert inputs.steps is not None and inputs.trials is not None
    key = trial if trial is not None else inputs.trial if inputs.trial is not None else \
        choose_figure5_trial(inputs.steps, inputs.trials)
    steps = inputs.steps[(inputs.steps["participant"] == key[0]) & (inputs.steps["trial"] == key[1])]
    if steps.empty:
        raise DataError(f"no steps for participant {key[0]}, trial {key[1]}; pick a trial of the run "
                        "(--trial PARTICIPANT:TRIAL)")
    layout = (inputs.layouts or {}).get(key)
    true_goal = layout.true_goal if layout is not None else int(
        inputs.trials.loc[(inputs.trials["participant"] == key[0])
                          & (inputs.trials["trial"] == key[1]), "true_goal"].iloc[0])
    return TrialPanel(steps, true_goal, layout.n_goals if layout is not None else None, layout,
                      _trial_title(inputs.trials, key))


def draw_figures(inputs: FigureInputs, plan: PlotPlan) -> dict[str, Figure]:
    """Every figure the inputs allow, by file stem (no files written).

    Returns
    -------
    dict[str, Figure]
        ``fig3``, ``fig4`` and/or ``metrics``; ``fig5`` and ``trajectory`` when the inputs hold
        a run's steps; ``questionnaires`` when they hold questionnaire scores.

    Raises
    ------
    DataError
        The chosen trial has no steps, or the data are unusable.
    """
    out: dict[str, Figure] = {}
    for stem, names in metric_figure_groups(drawn_metrics(inputs)).items():
        out[stem] = figures.metrics_figure(inputs.metrics, inputs.stats, names, seed=plan.seed,
                                           star_rule=plan.star_rule, reference=plan.reference,
                                           definitions=plan.definitions)
    if inputs.steps is not None and inputs.trials is not None and len(inputs.steps):
        panel = trial_panel(inputs, plan.trial)
        out["fig5"] = figures.figure_5(panel.steps, panel.true_goal, panel.n_goals, title=panel.title)
        if panel.layout is not None:
            out["trajectory"] = figures.trajectory_figure(panel.steps, panel.layout, title=panel.title)
    if inputs.questionnaires is not None:
        tlx, likert = figures.split_questionnaire_scores(inputs.questionnaires)
        if tlx is not None or likert is not None:
            out["questionnaires"] = figures.questionnaire_figure(
                tlx, likert, conditions=figures.resolve_conditions(inputs.metrics, inputs.stats),
                stats=inputs.stats, item_labels=plan.item_labels, star_rule=plan.star_rule)
    return out


def draw_path_figures(inputs: FigureInputs, plan: PlotPlan) -> dict[str, Figure]:
    """The figures of a CIAA path-world run: the measures and one trial's trajectory along the path."""
    from nudgecli.report.path_figures import measures_figure, path_trajectory_figure

    assert inputs.trials is not None and inputs.steps is not None and inputs.path_layouts is not None
    trials, layouts = inputs.trials, inputs.path_layouts
    out = {"measures": measures_figure(inputs.metrics, dict(inputs.stats))}
    key = plan.trial if plan.trial is not None else inputs.trial if inputs.trial is not None else \
        representative_trial(trials)
    row = trials[(trials["participant"] == key[0]) & (trials["trial"] == key[1])].iloc[0]
    layout = layouts[layouts["layout"] == int(row["layout"])].iloc[0]
    steps = inputs.steps[(inputs.steps["participant"] == key[0]) & (inputs.steps["trial"] == key[1])]
    outcome = "success" if bool(row["success"]) else "failure"
    title = (f"Participant {key[0]}, trial {key[1]} (layout {int(row['layout'])}, {row['condition']}): "
             f"{float(row['duration_s']):.1f} s, {int(row['human_mode_switches'])} mode switches, {outcome}")
    out["trajectory"] = path_trajectory_figure(
        steps, np.asarray(layout["waypoints"], dtype=float).reshape(-1, 2), int(layout["turn_waypoint"]),
        np.asarray(layout["goal_poses"], dtype=float)[:3], time_limit_s=float(inputs.time_limit_s or 50.0),
        title=title)
    return out


def write_figures(inputs: FigureInputs, plan: PlotPlan) -> list[Path]:
    """Draw every figure (:func:`draw_figures`, or :func:`draw_path_figures` for a path-world run)
    and write each in every format at once (:func:`~nudgecli.report.figures.output.save_figures`);
    return the files. Then an earlier plot's figures there that this one did not write are removed
    (:mod:`nudgecli.report.figure_records`), but the :data:`TRIAL_FIGURES` of a run without step logs."""
    formats = figures.check_formats(plan.formats)
    refuse_linked_figures(plan.out_dir)  # before an earlier plot's temporaries there are removed
    drawn = draw_path_figures(inputs, plan) if inputs.path_layouts is not None else draw_figures(inputs, plan)
    keep = (TRIAL_FIGURES, inputs.steps_missing) if inputs.steps_missing else ((), "")
    return replace_earlier_figures(plan.out_dir, list(drawn), formats, lambda **how: figures.save_figures(
        drawn, plan.out_dir, formats, **how), plan.log, keep)


# --- reading a source ----------------------------------------------------------------------------


def read_stats(path: Path) -> dict[str, Any]:
    """``stats.json`` as a dict, or a :class:`DataError` (unreadable, invalid JSON, wrong shape)."""
    try:
        stats = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise DataError(f"{path}: not valid JSON ({exc.msg} at line {exc.lineno}, column {exc.colno}); "
                        "run `nudge analyze` on the source again") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: cannot be read ({exc}); run `nudge analyze` on the source again") from None
    if not isinstance(stats, dict) or not isinstance(stats.get("metrics"), list):
        raise DataError(f"{path}: not a statistics file of `nudge analyze` (no `metrics` list); "
                        "run `nudge analyze` on the source again")
    return stats


def check_trial(source: str | Path, trials: pd.DataFrame | None, trial: TrialKey,
                steps_missing: str | None = None) -> None:
    """``trial`` is a (participant, trial) of ``trials`` (a run's trial table), else ``--trial``'s error.

    Raises
    ------
    ConfigError
        No such trial: one line naming the run's participants and trials; none at all (``trials``
        ``None``): one line naming why (``steps_missing``, else a metrics table's analysis).
    """
    if trials is None:
        why = steps_missing or f"{source}: the analysis of a metrics table holds no trial's steps"
        raise ConfigError(f"--trial {trial[0]}:{trial[1]}: {why}, so no trial's Fig. 5 or trajectory can be "
                          "drawn; plot without --trial")
    known = set(zip(trials["participant"], trials["trial"], strict=True))
    if tuple(trial) not in known:
        # the participants as they exist (a live study's are numbered from their IDs: 1, 2, 7, 12) and
        # the trials of the one asked for, where it exists
        participants = {int(p) for p, _ in known}
        held = _spans(int(t) for p, t in known if int(p) == trial[0] or trial[0] not in participants)
        shown = f"participant {trial[0]}'s trials {held}" if trial[0] in participants else \
            f"participants {_spans(participants)}, trials {held}"
        raise ConfigError(f"--trial {trial[0]}:{trial[1]}: no such trial in {source} ({shown})")


def _spans(numbers: Iterable[int]) -> str:
    """Whole numbers as their runs, in order: ``0-2``, ``1-2, 7, 12``."""
    runs: list[list[int]] = []
    for number in sorted(set(numbers)):
        if runs and number == runs[-1][-1] + 1:
            runs[-1].append(number)
        else:
            runs.append([number])
    return ", ".join(f"{run[0]}-{run[-1]}" if len(run) > 1 else str(run[0]) for run in runs)


def analysis_folder_of_table(table: Path) -> Path:
    """The folder holding a table's ``stats.json``: ``<stem>-analysis/`` beside it, else its own folder.

    Raises
    ------
    RunFolderError
        Neither holds a ``stats.json``.
    """
    for folder in (analysis_folder(table), table.parent):
        if (folder / STATS_JSON).is_file():
            return folder
    check_analysis_complete(analysis_folder(table), table)  # one cut short: the command that completes it
    raise RunFolderError(f"{table}: not analysed yet (no {STATS_JSON} beside it); "
                         f"run `{shell_words(['nudge', 'analyze', str(table)])}` first")


def _read_table(path: Path, stats: Mapping[str, Any]) -> pd.DataFrame:
    """A metrics table an analysis named, read and checked as ``nudge analyze`` reads one: only the
    metrics its ``stats`` holds must be numeric (a text column left out by ``--metric`` is ignored)."""
    table = read_metrics_table(path)
    entries = stats.get("metrics") or []
    analysed = [str(entry.get("metric")) for entry in entries if isinstance(entry, Mapping)]
    validate_metrics_table(table, str(path), chosen=analysed)
    return table


def _table_as_analysed(path: Path, folder: Path, stats: Mapping[str, Any],
                       stats_path: Path) -> tuple[pd.DataFrame, Path]:
    """The rows the analysis in ``folder`` analysed of the metrics table ``path`` (before the
    plan's filters) and the file they were read from.

    The table must be the one analysed, byte for byte (:mod:`nudgecli.report.table_read`); the
    rows are then the analysis's own: its ``metrics.csv`` where it changed the table (dropped
    repeated trial rows, filtered values), else the table; no rule of the analysis is applied a
    second time here. The analysis's own ``metrics.csv`` given as the table is read as it is (the
    checksum vouches for it). A ``stats.json`` of an older nudge records nothing of the table: it
    is read as it is (the checksum decides) unless it holds repeated trial rows, which that
    analysis may or may not have dropped.

    Raises
    ------
    DataError
        The table is not the one analysed, or (an older analysis) holds repeated trial rows.
    RunFolderError
        The analysis changed the table and its ``metrics.csv`` is gone.
    """
    own_copy = folder / METRICS_CSV
    if own_copy.is_file() and path.resolve() == own_copy.resolve():
        return read_metrics_csv(path), path
    record = recorded_table_read(stats, str(stats_path))
    if record is None:
        table = _read_table(path, stats)
        if find_duplicate_trials(table)[1].any():
            raise DataError(f"{path} holds repeated trial rows and {stats_path} (written by an older nudge) "
                            f"does not record whether its analysis dropped them; "
                            f"{analyze_again(path, folder, drop_duplicates=True)} before plotting")
        return table, path
    check_table_is_analysed(path, record, stats_path)
    if stats.get("metrics_table") != METRICS_CSV:  # analysed as it is: these very bytes
        return _read_table(path, stats), path
    if not own_copy.is_file():
        again = analyze_again(path, folder, record["drop_duplicates"], record)
        raise RunFolderError(f"{own_copy} is gone: it held the rows of {path} that {stats_path} was "
                             f"computed from; {again} before plotting")
    return read_metrics_csv(own_copy), own_copy


def read_inputs(source: str | Path, trial: TrialKey | None = None) -> FigureInputs:
    """The figure inputs of a source, with ``stats.json`` checked against the metrics.

    Of a run, only the steps of the trial Fig. 5 and the trajectory show are kept: the steps of
    its participant (the whole step log of 300 paper participants was 2.4 GB in memory). The
    trial is ``trial``, else the one the default rule chooses from the columns it reads
    (:data:`~nudgecli.report.run_figure_inputs.FIGURE5_CHOICE_COLUMNS`; the path world's
    :func:`representative_trial` from the trials table).

    Parameters
    ----------
    source
        An analysed run folder, an analysed metrics table (CSV/Parquet), or its analysis folder.
    trial
        ``(participant, trial)`` of Fig. 5 and the trajectory; ``None``: the default rule's.

    Raises
    ------
    RunFolderError
        Not a run folder, a table or an analysis folder, or not analysed yet.
    DataError
        Invalid ``stats.json``, statistics computed from other metrics than those present, p-values
        edited, or questionnaire scores the analysis did not write (stale, edited or gone).
    """
    path = Path(source)
    if path.is_file():
        if path.suffix.lower() not in TABLE_SUFFIXES:
            raise RunFolderError(f"{path}: a file, not a folder, and not a metrics table (.csv/.parquet); "
                                 "give a run folder made by `nudge simulate`, a metrics table or its "
                                 "analysis folder")
        folder = analysis_folder_of_table(path)
        stats_path = folder / STATS_JSON
        stats = read_stats(stats_path)
        table, metrics_file = _table_as_analysed(path, folder, stats, stats_path)
        metrics_name = str(metrics_file)
    else:
        folder = path
        run = RunFolder(folder)
        if not folder.is_dir():
            raise RunFolderError(f"{folder}: no such folder or table; give a run folder made by "
                                 "`nudge simulate`, a metrics table or its analysis folder")
        if interrupted_analysis(folder):  # stats.json removed first and written last: one cut short
            run.check_complete() if run.is_run() else None  # a damaged run: the command that restores it
            check_analysis_complete(folder, folder if is_run_folder(folder) else None)
        # an analysis folder holds metrics.csv, or its stats.json names the table it analysed
        metrics_path = analysed_metrics_path(folder)
        if metrics_path is None and not run.is_run():
            if only_a_start(folder):  # killed before its manifest: the command that starts it again
                raise RunFolderError(run.no_parts_message("trials", None))
            raise RunFolderError(f"{folder}: not a run folder (no manifest.json) and no {METRICS_CSV}; "
                                 "run `nudge simulate` and `nudge analyze` first, or give a metrics table")
        analyze_command = shell_words(["nudge", "analyze", str(folder)])  # quoted: pasted as it is
        if metrics_path is None or not (folder / STATS_JSON).is_file():
            run.check_complete() if run.is_run() else None  # incomplete: the command that restores it
            raise RunFolderError(f"{folder}: no metrics yet; run `{analyze_command}` first")
        stats_path = folder / STATS_JSON
        stats = read_stats(stats_path)
        check_live_analysis_current(stats, run, str(stats_path))  # never a study outgrown since
        analysis_copy = metrics_path.name == METRICS_CSV
        again = analyze_command if run.is_run() else None  # a run's metrics: analyze writes them
        table = read_metrics_csv(metrics_path, again) if analysis_copy else _read_table(metrics_path, stats)
        metrics_name = str(metrics_path)
    record = recorded_checksum(stats, str(stats_path))
    table = apply_filters(table, record.get("filters") or {})
    verify_metrics(stats, table, str(stats_path), metrics_name)
    # the scores this analysis wrote, or a refusal: never a stale or edited file's
    questionnaires = read_analysed_scores(folder, stats, str(stats_path))
    verify_p_values(stats, (table, questionnaires), str(stats_path))  # what the brackets draw
    fields = run_fields(RunFolder(folder), trial)
    check_analysed_trials(stats, fields.get("trials"), folder, stats_path)  # never another run's statistics
    return FigureInputs(metrics=table, stats=stats, questionnaires=questionnaires, **fields)


def default_out(source: str | Path) -> Path:
    """Where the figures of a source go by default: ``figures/`` in its (analysis) folder."""
    path = Path(source)
    folder = analysis_folder_of_table(path) if path.is_file() else path
    return folder / FIGURES_DIR


def plot_folder(source: str | Path, out: str | Path | None = None, formats: Sequence[str] = ("png", "pdf"),
                trial: TrialKey | None = None, *, star_rule: ComparisonOptions | None = None,
                item_labels: Mapping[str, str] | None = None, reference: str | None = None,
                log: Callable[[str], None] | None = None,
                definitions: MetricDefinitions | None = None) -> list[Path]:
    """Draw and write every figure a source's data allow; return the files written.

    Parameters
    ----------
    source
        A run folder analysed with ``nudge analyze``, an analysed metrics table, or its
        analysis folder (box plots only).
    out
        Where the figures go [default: ``figures/`` in the run or analysis folder].
    formats
        File formats.
    trial
        ``(participant, trial)`` for Fig. 5 and the trajectory [default: chosen by
        :func:`nudgecli.report.trial_selection.choose_figure5_trial`].
    star_rule
        The plan's star rule (for statistics entries without stars) [default: the paper's].
    item_labels
        Questionnaire item labels (the plan's ``[questionnaires] labels``).
    reference
        Compare the box plots' conditions with this one only (``--reference``).
    log
        Receives the line naming an earlier plot's figures removed (:func:`write_figures`).
    definitions
        The plan's metric definitions (the box plots' labels) [default: the paper's].

    Raises
    ------
    ConfigError
        ``reference`` is not a condition of the analysis (one line naming them).
    """
    inputs = read_inputs(source, trial)
    check_reference(reference, figures.resolve_conditions(inputs.metrics, inputs.stats))
    if trial is not None:
        check_trial(source, inputs.trials, trial, inputs.steps_missing)
    plan = PlotPlan(out_dir=Path(out) if out is not None else default_out(source), formats=tuple(formats),
                    trial=trial, star_rule=star_rule or ComparisonOptions(),
                    item_labels=dict(item_labels or {}), reference=reference, log=log,
                    definitions=definitions)
    return write_figures(inputs, plan)


__all__ = ["TRIAL_FIGURES", "FigureInputs", "PlotPlan", "TrialPanel", "check_trial", "draw_figures",
           "drawn_metrics", "layouts_by_trial", "metric_figure_groups", "parse_formats", "parse_trial",
           "plot_folder", "read_inputs", "read_stats", "trial_panel", "write_figures"]
