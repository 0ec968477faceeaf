"""``nudgecli.plot``: one figure of an analysis as a matplotlib Figure, or one panel into one's own axes;
and :func:`save_figures`, every figure written as files (``nudge plot``).

The drawing is :mod:`nudgecli.report.plotting`'s and :mod:`nudgecli.report.figures`'; the star
rule and item labels are the analysis plan's, chosen as ``nudge plot`` chooses them.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nudgecli.api import arguments
from nudgecli.api.analysis import Analysis, log_notes
from nudgecli.api.run import Run
from nudgecli.errors import ConfigError, NudgeError, did_you_mean, shell_words

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from nudgecli.report.plans import AnalysisPlan

#: The figures of several panels, which cannot be drawn into one axes: ``plot(..., ax=)`` takes a
#: metric's name (one panel) instead.
MULTI_PANEL = ("fig3", "fig4", "metrics", "questionnaires", "measures")


def plan_of(source: str | Path, plan: str | Path | AnalysisPlan | None = None) -> str | Path | AnalysisPlan:
    """The plan whose star rule and labels the figures of ``source`` use: ``plan``, else the one its
    analysis records having used (an analysis written away from its run, or under another plan:
    :func:`nudgecli.report.recorded_plans.analysed_plan`: a plan file as the analysis's copy of it,
    checked), else the one its run folder's manifest
    records, else the one named like its experiment, else ``paper``
    (:func:`nudgecli.config_files.resolve_plan`)."""
    from nudgecli.report.recorded_plans import analysed_plan, plan_of_source

    source = arguments.path("source", source)
    plan = arguments.plan(plan)  # a preset's name, a plan file or a loaded plan
    if plan is not None:
        return plan
    # a run's plan file as its kept copy, checked (an edited one, or one that does not load, refused);
    # a damaged manifest is taken as none: plotting says what is wrong
    return analysed_plan(source) or plan_of_source(source, damaged_manifest=True)


def _folder_of(analysis: Analysis | Run | str | Path) -> Path:
    """The analysed folder or table to draw from."""
    if isinstance(analysis, Analysis | Run):
        return analysis.path
    if isinstance(analysis, str | Path):
        return Path(analysis)
    raise NudgeError(f"plot: give an Analysis, an analysed run folder or a metrics table, not "
                     f"{type(analysis).__name__}")


def plot(analysis: Analysis | Run | str | Path, figure: str = "fig4", *, ax: Axes | None = None,
         trial: str | tuple[int, int] | None = None, reference: str | None = None) -> Figure:
    """Draw one figure of an analysis, as ``nudge plot`` draws it, without writing a file.

    Parameters
    ----------
    analysis
        An :class:`Analysis`, an analysed :class:`Run`, or the path ``nudge plot`` takes (an
        analysed run folder, an analysed metrics table or its analysis folder). An Analysis written
        away from its run (``analyze(run, out=...)``) draws Fig. 5 and the trajectory from the run.
    figure
        ``fig3``, ``fig4`` (the paper's box plots), ``metrics`` (every other metric), ``fig5``,
        ``trajectory``, ``questionnaires`` (where the data allow them; a path-world run:
        ``measures`` and ``trajectory``), or one metric's name: its box-plot panel alone.
    ax
        One matplotlib ``Axes`` of one's own to draw one panel into: a metric's box plot, ``fig5``
        or ``trajectory``; default a new figure. Anything else (a text, an array of axes) is refused.
    trial
        ``(participant, trial)`` or ``"P:T"`` of Fig. 5 and the trajectory (``--trial``); refused
        with any other figure, which it would not change.
    reference
        Brackets only for this condition's pairs (``--reference``).

    Returns
    -------
    Figure
        The new figure, or the figure ``ax`` belongs to.

    Raises
    ------
    NudgeError
        Not analysed, an unknown figure or metric, a figure of several panels with ``ax``, an
        ``ax`` that is not one Axes, a ``trial`` of a figure that is not of one trial, an unknown
        trial or reference (``nudge plot``'s messages).
    """
    from nudgecli.report import figures
    from nudgecli.report.plans import load_plan
    from nudgecli.report.plotting import (
        PlotPlan,
        draw_figures,
        draw_path_figures,
        drawn_metrics,
        metric_figure_groups,
    )

    trial_key = arguments.trial(trial)
    figure = arguments.text("figure", figure)
    ax = arguments.axes(ax)
    reference = arguments.text("reference", reference, optional=True)
    folder = _folder_of(analysis)
    inputs = _inputs_of(analysis, folder, figure, trial_key)
    # the analysis folder's plan, also of an Analysis written away from its run (stats.json says which)
    chosen = load_plan(plan_of(folder, analysis.plan if isinstance(analysis, Analysis) else None))
    conditions = figures.resolve_conditions(inputs.metrics, inputs.stats)
    _check_choices(folder, inputs, conditions, trial_key, reference)
    metrics = drawn_metrics(inputs)
    _check_figure(folder, figure, trial, _figures_of(inputs, metrics), metrics)
    if figure in metrics:
        return _metric_panel(inputs, figure, ax, conditions, chosen, reference)
    plan = PlotPlan(out_dir=folder, trial=trial_key, star_rule=chosen.comparison_options(),
                    item_labels=chosen.questionnaires.labels, reference=reference, definitions=chosen.metrics)
    if ax is not None and figure in ("fig5", "trajectory") and inputs.path_layouts is None:
        return _trial_into(inputs, figure, trial_key, ax)
    if ax is not None:
        raise ConfigError(f"figure {figure!r} has several panels, which one axes cannot hold; to draw into "
                          f"ax give one metric's panel ({', '.join(metrics)}), fig5 or trajectory")
    if figure in ("fig3", "fig4", "metrics"):
        return figures.metrics_figure(inputs.metrics, inputs.stats, metric_figure_groups(metrics)[figure],
                                      seed=plan.seed, star_rule=plan.star_rule, reference=reference,
                                      definitions=plan.definitions)
    drawn = draw_path_figures(inputs, plan) if inputs.path_layouts is not None else draw_figures(inputs, plan)
    if figure not in drawn:  # e.g. fig5 of a run whose layouts give no trajectory
        raise ConfigError(f"figure {figure!r}: this source's data do not give it; choose one of "
                          f"{', '.join(drawn)}")
    return drawn[figure]


def _metric_panel(inputs: Any, metric: str, ax: Axes | None, conditions: Sequence[str], chosen: AnalysisPlan,
                  reference: str | None) -> Figure:
    """One metric's box-plot panel (into ``ax``, else a new figure's), labelled by the metric
    definitions its analysis applied (:func:`~nudgecli.report.figures.boxplots.applied_definitions`)."""
    from nudgecli.report import figures
    from nudgecli.report.style import figure_style

    entry = figures.stats_by_metric(inputs.stats).get(metric)
    definitions = figures.boxplots.applied_definitions(inputs.stats, chosen.metrics)
    with figure_style():
        artists = figures.metric_boxplot(inputs.metrics, metric, entry, ax=ax, conditions=conditions,
                                         star_rule=chosen.comparison_options(), reference=reference,
                                         definitions=definitions)
    return artists.ax.figure  # type: ignore[return-value]  # a Figure: axes_or_new makes no SubFigure


def _inputs_of(analysis: Analysis | Run | str | Path, folder: Path, figure: str,
               trial: tuple[int, int] | None) -> Any:
    """The figure inputs of ``analysis`` (its ``folder``), with the trials and steps of the run
    of an Analysis written away from it."""
    from nudgecli.report.plotting import TRIAL_FIGURES, read_inputs

    run = _run_analysed_elsewhere(analysis)
    if run is not None:
        return _with_run_trials(folder, run, trial)
    inputs = read_inputs(folder, trial)
    if inputs.steps is None and inputs.steps_missing is None and \
            (figure in TRIAL_FIGURES or trial is not None):  # no run's steps: is it a run's analysis?
        _check_not_a_runs_analysis_elsewhere(folder, inputs.stats, figure)
    return inputs


def _run_analysed_elsewhere(analysis: Analysis | Run | str | Path) -> Path | None:
    """The run folder of an :class:`Analysis` written away from it (``analyze(run, out=...)``),
    whose trials and step logs Fig. 5 and the trajectory are drawn from; ``None`` otherwise."""
    from nudgecli.store import is_run_folder

    if not isinstance(analysis, Analysis) or not analysis.source.is_dir() or \
            not is_run_folder(analysis.source) or analysis.source.resolve() == analysis.path.resolve():
        return None
    return analysis.source


def _with_run_trials(folder: Path, run: Path, trial: tuple[int, int] | None) -> Any:
    """The figure inputs of the analysis in ``folder`` with the trials, layouts and steps of the
    ``run`` it analysed (:func:`~nudgecli.report.run_figure_inputs.run_fields`), as ``nudge plot
    RUN`` reads them; a live study grown since its analysis is refused as there."""
    import dataclasses

    from nudgecli.report.analysed_run import check_analysed_trials
    from nudgecli.report.plotting import read_inputs
    from nudgecli.report.run_figure_inputs import run_fields
    from nudgecli.report.stats_verify import check_live_analysis_current
    from nudgecli.run_folder_names import STATS_JSON
    from nudgecli.store import RunFolder

    inputs = read_inputs(folder, trial)
    check_live_analysis_current(inputs.stats, RunFolder(run), str(folder / STATS_JSON))
    fields = run_fields(RunFolder(run), trial)
    check_analysed_trials(inputs.stats, fields.get("trials"), run, folder / STATS_JSON)
    return dataclasses.replace(inputs, **fields)


def _check_not_a_runs_analysis_elsewhere(folder: Path, stats: Mapping[str, Any], figure: str) -> None:
    """Refuse a trial's figure of the folder of a run's analysis written away from the run: the
    folder holds the metrics, not the run's step logs, and names no run to read them from
    (``stats``: its ``stats.json``, as the figure inputs read it).

    Raises
    ------
    ConfigError
        One line saying how to draw it (the :class:`Analysis` ``analyze`` returned, or the run).
    """
    from nudgecli.report.plotting import TRIAL_FIGURES
    from nudgecli.run_folder_names import METRICS_CSV, STATS_JSON

    if not folder.is_dir() or not (folder / STATS_JSON).is_file():
        return
    if stats.get("metrics_table") != METRICS_CSV or "table_read" in stats:
        return  # a metrics table's analysis: plot's own message says it holds no trial's steps
    shown = figure if figure in TRIAL_FIGURES else "fig5"
    raise ConfigError(f"figure {shown!r}: {folder} holds an analysis written away from its run (out=), "
                      "without the run's step logs, and names no run to read them from; draw it from "
                      f"the Analysis that analyze returned (nudgecli.plot(analysis, {shown!r})), or from "
                      f"the run analysed in its own folder (nudgecli.analyze(RUN), then "
                      f"nudgecli.plot(RUN, {shown!r}))")


def _check_figure(folder: Path, figure: str, trial: object, available: Sequence[str],
                  metrics: Sequence[str]) -> None:
    """``figure`` one of ``folder``'s figures or a metric's panel, and ``trial`` given only with a
    figure of one trial: with another it would be ignored, and is refused instead."""
    from nudgecli.report.plotting import TRIAL_FIGURES

    if figure not in available and figure not in metrics:
        choices = [*available, *metrics]
        raise ConfigError(f"figure {figure!r}: not a figure of {folder}; choose one of "
                          f"{', '.join(choices)}{did_you_mean(figure, choices)}")
    if trial is not None and figure not in TRIAL_FIGURES:
        raise ConfigError(f"trial={trial!r}: figure {figure!r} is not of one trial; trial= chooses "
                          f"the trial of {' and '.join(TRIAL_FIGURES)}: leave it out (None) for {figure!r}")


def _figures_of(inputs: Any, metrics: Sequence[str]) -> list[str]:
    """The figures ``nudge plot`` draws of these inputs, by file stem."""
    from nudgecli.report.plotting import TRIAL_FIGURES, metric_figure_groups

    if inputs.path_layouts is not None:
        return ["measures", "trajectory"]
    return [*metric_figure_groups(metrics), *(TRIAL_FIGURES if inputs.steps is not None else ()),
            *(["questionnaires"] if inputs.questionnaires is not None else [])]


def _trial_into(inputs: Any, figure: str, trial: tuple[int, int] | None, ax: Axes) -> Figure:
    """Fig. 5 or the trajectory of ``trial`` (default the one ``nudge plot`` draws) on ``ax``."""
    from nudgecli.report import figures
    from nudgecli.report.plotting import trial_panel
    from nudgecli.report.style import figure_style

    panel = trial_panel(inputs, trial)
    with figure_style():
        if figure == "fig5":
            drawn = figures.belief_trace(panel.steps, panel.true_goal, panel.n_goals, ax=ax,
                                         title=panel.title).ax
        else:
            assert panel.layout is not None  # "trajectory" is offered only where the layouts give it
            drawn = figures.trajectory(panel.steps, panel.layout, ax=ax, title=panel.title).ax
    return drawn.figure  # type: ignore[return-value]  # the caller's axes: their figure


def _check_choices(folder: Path, inputs: Any, conditions: Sequence[str], trial: tuple[int, int] | None,
                   reference: str | None) -> None:
    """``reference`` a condition drawn and ``trial`` a trial of the run (``nudge plot``'s checks)."""
    from nudgecli.report.pair_display import check_reference
    from nudgecli.report.plotting import check_trial

    check_reference(reference, conditions)
    if trial is not None:
        check_trial(folder, inputs.trials, trial, inputs.steps_missing)


def save_figures(source: Analysis | Run | str | Path, *, plan: str | Path | AnalysisPlan | None = None,
                 out: str | Path | None = None, formats: str | Sequence[str] = ("png", "pdf"),
                 trial: str | tuple[int, int] | None = None, reference: str | None = None,
                 force: bool = False, log: Callable[[str], None] | None = None) -> list[Path]:
    """Write every figure of ``source`` in every format, as ``nudge plot`` does; the files written.

    Parameters
    ----------
    source
        An :class:`Analysis`, an analysed :class:`Run`, or ``nudge plot``'s RUN.
    plan
        Analyse ``source`` with this plan first (``--plan``; a table's analysis folder: the table
        its ``stats.json`` names, into that folder), once every other choice is checked, so that
        a refused plot leaves the existing analysis as it was; the analysis it replaced is put
        back if the plot then fails; default: plot the existing analysis with the plan it records.
    out
        The figures' folder; default ``figures/`` in the run or analysis folder.
    formats
        ``png``, ``pdf``, ``svg``: a sequence, or comma-separated as ``--formats`` takes them.
    trial
        ``(participant, trial)`` or ``"P:T"`` (``--trial``), as :func:`plot`'s.
    reference
        As :func:`plot`'s.
    force
        Write into an ``out`` that is not empty.
    log
        Receives the line naming the figures an earlier plot wrote into the folder and this one
        did not, which are removed once all of this plot's are written, and the ``Warning:`` line
        of a stale lock taken over.

    Raises
    ------
    NudgeError
        ``nudge plot``'s errors; a folder made only for the figures is removed again.
    """
    from nudgecli.report.plans import AnalysisPlan, load_plan, plan_argument

    chosen_formats = arguments.formats(formats)
    trial_key = arguments.trial(trial)
    out = arguments.out_folder(out)
    reference = arguments.text("reference", reference, optional=True)
    force = arguments.switch("force", force)
    log = arguments.callback("log", log)
    folder = _folder_of(source)
    analysed_first: contextlib.AbstractContextManager[None] = contextlib.nullcontext()
    if isinstance(source, Analysis) and plan is None:
        plan = source.plan
        analysis_plan = load_plan(plan_of(folder, plan))
    else:
        analysis_plan = load_plan(plan_of(folder, plan))
        if plan is not None:
            shown = plan_argument(analysis_plan) if isinstance(plan, AnalysisPlan) else str(plan)
            analysed_first = _analysed_first(folder, analysis_plan, trial_key, out, force, reference, shown,
                                             log)
    with analysed_first:  # --plan: the analysis it replaced is put back if the plot fails
        return _write_figures(folder, out, chosen_formats, trial_key, analysis_plan, reference, force, log)


def _write_figures(folder: Path, out: str | Path | None, formats: Sequence[str],
                   trial: tuple[int, int] | None, analysis_plan: AnalysisPlan, reference: str | None,
                   force: bool, log: Callable[[str], None] | None) -> list[Path]:
    """:func:`save_figures` once the source is analysed: the figures' folder locked and checked, the
    figures drawn and written; a folder made only for them is removed again if that fails."""
    from nudgecli.locks import run_lock
    from nudgecli.report.plotting import default_out, plot_folder

    # lock only the folder written: the figures' folder given by out (a read-only source is then
    # only read), else the run or analysis folder that holds figures/ (which analyze locks)
    written_folder: Path | None = None  # None: not a plottable source; plot_folder says why
    if out is not None:
        written_folder = Path(out)
    elif folder.exists():
        with contextlib.suppress(NudgeError):
            written_folder = default_out(folder).parent
    made = written_folder is not None and not written_folder.exists()
    try:
        with run_lock(written_folder, log=log) if written_folder is not None else contextlib.nullcontext():
            if out is not None:  # under the lock: a folder another command is writing is named so
                _check_figures_folder(folder, out, force)
            return plot_folder(folder, out, formats, trial,
                               star_rule=analysis_plan.comparison_options(),
                               item_labels=analysis_plan.questionnaires.labels, reference=reference,
                               log=log, definitions=analysis_plan.metrics)
    except BaseException:
        if made and written_folder is not None and written_folder.is_dir() \
                and not any(written_folder.iterdir()):
            written_folder.rmdir()  # made only to hold the lock: a failed plot leaves nothing behind
        raise


@contextlib.contextmanager
def _analysed_first(folder: Path, plan: AnalysisPlan, trial: tuple[int, int] | None, out: str | Path | None,
                    force: bool, reference: str | None, shown_plan: str | None,
                    log: Callable[[str], None] | None = None) -> Iterator[None]:
    """``nudge plot --plan``: analyse the source with ``plan`` after checking what the plot can check
    before (the trial, the figures' folder), so that a plot refused for them rewrites nothing; then
    the block (the plot), with the analysis folder's lock held. If the analysis or the block fails,
    the analysis the folder held is put back as it was
    (:func:`nudgecli.report.analysis_folders.analysis_restored_on_failure`), and a folder made for
    this analysis alone is removed: a failed plot leaves the folder as it was.

    A run folder or a table is analysed as ``nudge analyze`` does (into the run folder, the
    table's ``<table>-analysis/``); a table's analysis folder is the table its ``stats.json``
    names (:func:`nudgecli.report.analysis_folders.analysed_table`), analysed again into that
    folder with the ``--drop-duplicates`` it was analysed with.
    """
    from nudgecli.locks import run_lock
    from nudgecli.report.analysis import analyze as analyze_source
    from nudgecli.report.analysis_folders import analysis_folder, analysis_restored_on_failure
    from nudgecli.store import is_run_folder

    table, drop_duplicates = _table_of_analysis_folder(folder)
    if trial is not None:
        _check_trial_of_run(folder, trial)
    if out is not None:
        _check_figures_folder(folder, out, force)
    _check_no_questionnaires(folder, table, shown_plan)
    written = folder if folder.is_dir() else analysis_folder(folder)
    made = not written.exists()
    try:
        with run_lock(written, log=log), analysis_restored_on_failure(written, run=is_run_folder(written)):
            if table is None:
                analyze_source(folder, plan=plan, reference=reference, log=log)
            else:
                analyze_source(table, plan=plan, out=folder, reference=reference,
                               drop_duplicates=drop_duplicates, log=log)
            yield
    except BaseException:
        if made and written.is_dir() and not any(written.iterdir()):
            written.rmdir()  # made for this analysis alone: a failed plot leaves nothing behind
        raise


def _check_no_questionnaires(folder: Path, table: Path | None, shown_plan: str | None) -> None:
    """Refuse ``--plan`` where the analysis it replaces has questionnaire scores: the analysis
    again would be without them (their answers file is not recorded), and a plot would draw the
    trial metrics of one analysis beside the scores of another. ``shown_plan``: how ``--plan``
    names the plan; ``None`` for a plan built in code, which the advice gives from Python."""
    from nudgecli.report.analysis_folders import analysis_folder
    from nudgecli.run_folder_names import QUESTIONNAIRE_SCORES_CSV

    written = folder if table is not None or folder.is_dir() else analysis_folder(folder)
    if (written / QUESTIONNAIRE_SCORES_CSV).is_file():
        source = table if table is not None else folder
        if shown_plan is None:  # built in code: no --plan names it
            fix = ("the plan was built in code, which no --plan names: analyse it from Python with that plan "
                   f"as PLAN, `nudgecli.analyze({str(source)!r}, plan=PLAN, questionnaires='ANSWERS.csv')`, "
                   f"then `nudgecli.save_figures({str(folder)!r})`")
        else:
            again = shell_words(["nudge", "analyze", str(source), "--plan", shown_plan, "--questionnaires",
                                 "ANSWERS.csv"])
            fix = f"analyse it with `{again}`, then `{shell_words(['nudge', 'plot', str(folder)])}`"
        raise ConfigError(
            f"{written} holds questionnaire scores ({QUESTIONNAIRE_SCORES_CSV}) of an analysis with "
            f"--questionnaires, and plot --plan analyses without them: {fix}")


def _table_of_analysis_folder(folder: Path) -> tuple[Path | None, bool]:
    """The metrics table a table's analysis folder holds the analysis of, and whether it was
    analysed with ``--drop-duplicates``; ``(None, False)`` for anything else (a run folder, a
    table, a folder ``nudge plot`` refuses and names).

    Raises
    ------
    RunFolderError
        The folder's ``stats.json`` names no table that is still there (the table's analysis
        changed its rows and no table beside the folder has the bytes it read).
    DataError
        Its ``table_read`` record is malformed.
    """
    from nudgecli.errors import RunFolderError
    from nudgecli.report.analysis_folders import analysed_table
    from nudgecli.report.plotting import read_stats
    from nudgecli.report.table_read import recorded_table_read
    from nudgecli.run_folder_names import STATS_JSON
    from nudgecli.store import is_run_folder

    stats_path = folder / STATS_JSON
    if not folder.is_dir() or is_run_folder(folder) or not stats_path.is_file():
        return None, False
    record = recorded_table_read(read_stats(stats_path), str(stats_path))
    table = analysed_table(folder)
    if table is None and record is None:  # metrics.csv with nothing naming its table
        raise RunFolderError(f"{folder}: its {STATS_JSON} names no metrics table that --plan could analyse "
                             "again (the analysis of a run written there, or of a table by an older nudge); "
                             "give `nudge plot --plan` the run folder or the metrics table itself")
    if table is None or not table.is_file():
        again = shell_words(["nudge", "analyze", "TABLE", "--plan", "PLAN", "--out", str(folder)])
        raise RunFolderError(f"{folder}: --plan analyses the metrics table its {STATS_JSON} was computed "
                             "from, and that table is not there (moved, or edited since); analyse the "
                             f"table with `{again}`, then plot")
    return table, bool(record is not None and record["drop_duplicates"])


def _check_trial_of_run(folder: Path, trial: tuple[int, int]) -> None:
    """``--trial`` a trial of the run ``folder``; refused for a metrics table or its analysis folder,
    which ``--plan`` analyses again (a run without its step logs, ``analyze`` refuses; anything else:
    ``nudge plot`` says what it is)."""
    from nudgecli.report.plotting import check_trial
    from nudgecli.run_folder_names import STATS_JSON
    from nudgecli.store import RunFolder

    run = RunFolder(folder)
    if folder.is_dir() and run.is_run():
        if run.has_completed_participant():
            check_trial(folder, run.read_trials(), trial)
    elif folder.is_file() or (folder / STATS_JSON).is_file():
        check_trial(folder, None, trial)


def _check_figures_folder(source: Path, out: str | Path, force: bool) -> None:
    """The figures' folder: new, empty or the source's own figures folder, unless ``force``
    (:func:`nudgecli.outputs.check_output_folder`)."""
    from nudgecli.outputs import check_output_folder
    from nudgecli.report.plotting import default_out

    own: list[Path] = []
    with contextlib.suppress(NudgeError):  # not a plottable source: plot_folder says why
        own.append(default_out(source))
    check_output_folder(out, force=force, own=own)


def analyze_and_plot(run: Run | str | Path, *, plan: str | Path | None = None,
                     log: Callable[[str], None] | None = None) -> tuple[Analysis, list[Path]]:
    """Analyse a run into its own folder and write its figures there, under its lock (``nudge run``'s
    second half).

    Parameters
    ----------
    run
        A :class:`Run` or a run folder.
    plan
        The analysis plan (default: the one the run's manifest records, as ``nudge analyze`` takes it:
        a resumed ``nudge run --plan X`` is analysed with X again; else the one named like the run's
        experiment, else ``paper``).
    log
        Receives the line naming the plan chosen, before the analysis, the line naming the figures
        of an earlier plot removed (:func:`save_figures`), the warning of a stale lock taken over and,
        between analysis and plot, a ``Note:`` line per note of the analysis (:attr:`Analysis.notes`),
        as ``nudge run`` prints them.

    Returns
    -------
    tuple[Analysis, list[Path]]
        The analysis and the figure files written.
    """
    from nudgecli.config_files import resolve_plan
    from nudgecli.locks import run_lock
    from nudgecli.report.analysis import analyze as analyze_source
    from nudgecli.report.plans import load_plan
    from nudgecli.report.plotting import plot_folder
    from nudgecli.report.recorded_plans import plan_of_source

    opened = run if isinstance(run, Run) else Run.open(arguments.path("run", run))
    log = arguments.callback("log", log)
    chosen: str | Path = plan_of_source(opened.path) if plan is None else \
        resolve_plan(plan, experiment=opened.experiment, world=opened.config.world.kind)
    if log is not None:
        log(f"analysing with the {chosen!r} plan")
    analysis_plan = load_plan(chosen)
    with run_lock(opened.path, log=log):
        result = analyze_source(opened.path, plan=chosen)
        log_notes(result.notes, log)  # the analysis's, before the plot's lines
        written = plot_folder(opened.path, star_rule=analysis_plan.comparison_options(),
                              item_labels=analysis_plan.questionnaires.labels, log=log,
                              definitions=analysis_plan.metrics)
    return Analysis(result, opened.path, chosen, keep_alive=opened), written
