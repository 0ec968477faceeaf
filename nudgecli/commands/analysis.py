"""Commands that read runs and tables: ``analyze``, ``plot``, ``plot-population``, ``habits`` and
``compare``."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any

import click

from nudgecli import command_defaults as defaults
from nudgecli.commands.common import FORCE_HELP, SET_HELP, echo_json, info, progress_bar
from nudgecli.errors import NudgeError

# --- analyze -------------------------------------------------------------------------------


@click.command("analyze")
@click.argument("source", type=click.Path(path_type=str))
@click.option("--plan", "plan", default=None, metavar="PLAN",
              help="Analysis plan: a preset (paper, study-code, ciaa-teleop) or a TOML file [default: the "
                   "plan recorded in the run folder, else the plan named like the run's experiment, else "
                   "paper].")
@click.option("--out", "out", type=click.Path(file_okay=False, path_type=str), default=None,
              help="Folder for stats.json, stats.csv, summary.md (and metrics.csv) [default: the run folder, "
                   "or <table>-analysis/ beside the table].")
@click.option("--format", "output_format", type=click.Choice(["table", "json", "csv"]), default="table",
              show_default=True, help="What to print on stdout.")
@click.option("--metric", "metric_names", multiple=True, metavar="NAME",
              help="Analyse only this metric (repeatable).")
@click.option("--reference", metavar="CONDITION", default=None,
              help="summary.md compares every other condition with this one only [default: every pair up "
                   "to three conditions, a compact letter display from four].")
@click.option("--questionnaires", type=click.Path(dir_okay=False, path_type=str), default=None,
              help="Questionnaire CSV (NASA-TLX, Likert) analysed alongside.")
@click.option("--seed", type=click.IntRange(min=0), default=None,
              help="Bootstrap seed [default: the plan's].")
@click.option("--bootstrap", "bootstrap", type=click.IntRange(min=1), default=None, metavar="N",
              help="Bootstrap resamples of the intervals [default: the plan's].")
@click.option("--drop-duplicates", is_flag=True,
              help="Keep the first of repeated trial rows of a table instead of refusing them.")
@click.option("--force", is_flag=True, help=FORCE_HELP)
def analyze_command(source: str, plan: str | None, out: str | None, output_format: str,
                    metric_names: tuple[str, ...], questionnaires: str | None, seed: int | None,
                    bootstrap: int | None, drop_duplicates: bool, reference: str | None, force: bool) -> None:
    """Metrics and statistics of a run folder or a metrics table (CSV/Parquet, one row per trial)."""
    from nudgecli.outputs import check_output_folder
    from nudgecli.report.analysis import analysis_folder, analyze
    from nudgecli.report.plans import check_resamples
    from nudgecli.report.summary import format_table

    check_resamples(bootstrap, "--bootstrap")
    if out is not None:  # the run folder itself, or the table's analysis folder, is the source's own
        check_output_folder(out, force=force, own=[source, analysis_folder(Path(source))])
    bar, update = progress_bar("analysing", unit="metric")
    try:
        result = analyze(source, plan=plan, out=out, metrics=list(metric_names) or None,
                         questionnaires=questionnaires, seed=seed, bootstrap=bootstrap,
                         drop_duplicates=drop_duplicates, progress=update, reference=reference)
    finally:
        bar.close()
    for note in result.notes:
        info(f"Note: {note}")
    if output_format == "json":
        echo_json(result.stats)
    elif output_format == "csv":
        click.echo(result.table.to_csv(index=False), nl=False)
    else:
        click.echo(format_table(result.table, result.stats["conditions"], reference))
    info(str(result.out))


# --- plot ----------------------------------------------------------------------------------

def _plan_of(source: str, plan: str | None) -> str:
    """The plan of ``source`` by :func:`nudgecli.config_files.resolve_plan`: ``plan``, else the plan
    its run folder's manifest records, else the one named like its experiment, else paper."""
    from nudgecli.config_files import resolve_plan
    from nudgecli.store import RunFolder

    manifest: Any = {}
    folder = RunFolder(Path(source))
    if plan is None and Path(source).is_dir() and folder.is_run():
        with contextlib.suppress(NudgeError):  # a damaged manifest: plotting says what is wrong
            manifest = folder.read_manifest()
    if not isinstance(manifest, dict):
        manifest = {}
    return resolve_plan(plan, recorded=manifest.get("plan"), experiment=str(manifest.get("experiment", "")))


@click.command("plot", short_help="Draw the figures of an analysed run or metrics table.")
@click.argument("run", type=click.Path(path_type=str))
@click.option("--plan", metavar="PLAN", default=None,
              help="Analyse RUN with this plan first (writes metrics.csv and stats.json), then plot "
                   "[default: plot the existing analysis, with the star rule and item labels of the plan "
                   "recorded in the run folder, else the plan named like the run's experiment, else paper].")
@click.option("--out", type=click.Path(file_okay=False, path_type=str), default=None,
              help="Folder for the figures [default: figures/ in the run or analysis folder].")
@click.option("--formats", default="png,pdf", show_default=True, help="Comma-separated: png, pdf, svg.")
@click.option("--trial", metavar="PARTICIPANT:TRIAL", default=None,
              help="The trial of Fig. 5 and the trajectory [default: the Disambiguation trial whose "
                   "true-goal belief rose most after a nudge].")
@click.option("--reference", metavar="CONDITION", default=None,
              help="Box plots: brackets only for the pairs of this condition [default: every significant "
                   "pair up to three conditions, a compact letter display from four].")
@click.option("--force", is_flag=True, help=FORCE_HELP)
def plot_command(run: str, plan: str | None, out: str | None, formats: str, trial: str | None,
                 reference: str | None, force: bool) -> None:
    """Draw the figures of RUN: an analysed run folder, a metrics table or the table's analysis folder.

    Fig. 3 and 4 where their metrics are present, one panel per other metric; Fig. 5 and a
    trajectory for a run; questionnaires where analysed. stats.json must match the metrics.
    """
    from nudgecli.locks import run_lock
    from nudgecli.report.plans import load_plan
    from nudgecli.report.plotting import default_out, parse_formats, parse_trial, plot_folder

    chosen, trial_key = parse_formats(formats), parse_trial(trial)
    analysis_plan = load_plan(_plan_of(run, plan))
    if plan is not None:
        from nudgecli.report.analysis import analyze

        analyze(run, plan=analysis_plan, reference=reference)  # takes the locks of what it writes
    # lock only the folder written: the figures' folder given by --out (a read-only RUN is then
    # only read), else the run or analysis folder that holds figures/ (which `analyze` locks)
    written_folder: Path | None = None  # None: not a plottable source; plot_folder says why
    if out is not None:
        written_folder = Path(out)
    elif Path(run).exists():
        with contextlib.suppress(NudgeError):
            written_folder = default_out(run).parent
    made = written_folder is not None and not written_folder.exists()
    try:
        with run_lock(written_folder) if written_folder is not None else contextlib.nullcontext():
            if out is not None:  # under the lock: a folder another command is writing is named so
                _check_figures_folder(run, out, force)
            written = plot_folder(run, out, chosen, trial_key, star_rule=analysis_plan.comparison_options(),
                                  item_labels=analysis_plan.questionnaires.labels, reference=reference)
    except BaseException:
        if made and written_folder is not None and written_folder.is_dir() \
                and not any(written_folder.iterdir()):
            written_folder.rmdir()  # made only to hold the lock: a failed plot leaves nothing behind
        raise
    for path in written:
        click.echo(str(path))


def _check_figures_folder(run: str, out: str, force: bool) -> None:
    """``plot --out``'s folder: new, empty or RUN's own figures folder, unless ``force``
    (:func:`nudgecli.outputs.check_output_folder`)."""
    from nudgecli.outputs import check_output_folder
    from nudgecli.report.plotting import default_out

    own: list[Path] = []
    with contextlib.suppress(NudgeError):  # not a plottable source: plot_folder says why
        own.append(default_out(run))
    check_output_folder(out, force=force, own=own)


# --- plot-population -----------------------------------------------------------------------


@click.command("plot-population", short_help="Simulated participants' calibrations beside real people's.")
@click.argument("experiment")
@click.option("--participants", type=click.IntRange(min=1), default=100, show_default=True,
              help="Simulated participants to calibrate.")
@click.option("--seed", type=int, default=None, help="Master seed [default: the experiment's].")
@click.option("--out", type=click.Path(file_okay=False, path_type=str), default=".", show_default=True,
              help="Folder for population.csv, population_habits.csv and the figure population.<format>.")
@click.option("--formats", default="png,pdf", show_default=True, help="Figure formats: png, pdf, svg.")
@click.option("--format", "output_format", type=click.Choice(["table", "json", "csv"]), default="table",
              show_default=True, help="What to print on stdout: the coverage table.")
@click.option("--yes", is_flag=True,
              help="Calibrate more participants than the size limit allows without asking.")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=SET_HELP)
def plot_population_command(experiment: str, participants: int, seed: int | None, out: str, formats: str,
                            output_format: str, yes: bool, overrides: tuple[str, ...]) -> None:
    """Calibrate EXPERIMENT's simulated participants and draw their fitted p(phi_m | phi_i) diagonals
    beside the real people's (pilots: fixed 10 Hz stream; sibling study: event-driven stream), and
    their drawn timing habits beside the ten real users' ranges (HABITS.md)."""
    from nudgecli.config import load_experiment
    from nudgecli.report.plotting import parse_formats
    from nudgecli.report.population_figure import plot_population
    from nudgecli.runs.size import MAX_CALIBRATIONS_WITHOUT_YES, check_size
    from nudgecli.sim.real_population import coverage_table, simulated_diagonals, simulated_habits
    from nudgecli.store import check_writable, write_text_atomic

    check_size(participants, yes, limit=MAX_CALIBRATIONS_WITHOUT_YES,
               work="calibrate {} simulated participants", fix="fewer --participants")
    chosen = parse_formats(formats)
    config = load_experiment(experiment, overrides)
    check_writable(out)  # before the calibrations, which take a while
    master = config.experiment.seed if seed is None else seed
    diagonals = simulated_diagonals(config, participants, master)
    habits = simulated_habits(config, participants, master)
    table = coverage_table(diagonals)
    if output_format == "json":
        echo_json(table.to_dict(orient="records"))
    elif output_format == "csv":
        click.echo(table.to_csv(index=False), nl=False)
    else:
        click.echo(table.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    folder = Path(out)
    write_text_atomic(folder / "population.csv", diagonals.to_csv(index=False))
    write_text_atomic(folder / "population_habits.csv", habits.to_csv(index=False))
    title = f"{config.experiment.name}: {participants} simulated participants (seed {master})"
    for path in [folder / "population.csv", folder / "population_habits.csv",
                 *plot_population(diagonals, folder, chosen, title, habits)]:
        info(str(path))


# --- habits --------------------------------------------------------------------------------


@click.command("habits", short_help="Operating habits (HABITS.md definitions) of a run or a real log.")
@click.argument("source", type=click.Path(path_type=str))
@click.option("--by", type=click.Choice(["participant", "trial"]), default="participant", show_default=True,
              help="The units listed beside the pooled figures.")
@click.option("--format", "output_format", type=click.Choice(["table", "json", "csv"]), default="table",
              show_default=True, help="What to print on stdout.")
@click.option("--compare", "compare", metavar="FILE|ciaa-people", default=None,
              help="A reference printed beside: ciaa-people (the ten real users of HABITS.md, shipped with "
                   "nudge) or a JSON of the shape of --format json.")
def habits_command(source: str, by: str, output_format: str, compare: str | None) -> None:
    """The operating habits of SOURCE, per participant and pooled: a run folder (nudge simulate, run or
    study) or a real log (CSV: t, trial, label, x, y, theta, mode_switch; participant and layout
    optional), read in 10 Hz cells as HABITS.md defines them."""
    from nudgecli.report.habits import format_habits, habits_csv, habits_of

    result = habits_of(source, by=by, compare=compare)
    if output_format == "json":
        echo_json(result.to_json())
    elif output_format == "csv":
        click.echo(habits_csv(result), nl=False)
    else:
        click.echo(format_habits(result))


# --- compare -------------------------------------------------------------------------------


def _parse_matches(matches: tuple[str, ...]) -> dict[str, str]:
    """``("none=no assistance", ...)`` -> ``{"none": "no assistance"}``, the labels as written (a
    table's label may end in a space, and ``--match 'control=Control '`` must pair it)."""
    from nudgecli.errors import ConfigError

    mapping: dict[str, str] = {}
    for text in matches:
        simulated, sep, real = text.partition("=")
        if not sep or not simulated.strip() or not real.strip():
            raise ConfigError(f"--match {text!r}: expected SIMULATED=REAL, e.g. --match none='no assistance'")
        mapping[simulated] = real
    return mapping


@click.command("compare", short_help="Simulated people beside real people, metric by metric.")
@click.argument("simulated", type=click.Path(path_type=str))
@click.argument("real", type=click.Path(path_type=str))
@click.option("--plan", metavar="PLAN", default=None,
              help="Analysis plan: the metric definitions of a run folder and the filters of both sources "
                   "[default: the plan the simulated run records or is named like, else paper].")
@click.option("--metric", "metric_names", multiple=True, metavar="NAME",
              help="Compare only this metric (repeatable) [default: every metric both hold].")
@click.option("--match", "matches", multiple=True, metavar="SIMULATED=REAL",
              help="Pair a simulated condition with the real table's name for it (repeatable) "
                   "[default: conditions with the same name].")
@click.option("--format", "output_format", type=click.Choice(["table", "json", "csv"]), default="table",
              show_default=True, help="What to print on stdout.")
@click.option("--out", type=click.Path(file_okay=False, path_type=str), default=None,
              help="Folder for compare.csv, participant_medians.csv, compare.json and the figure.")
@click.option("--formats", default="png,pdf", show_default=True,
              help="Figure formats with --out: png, pdf, svg.")
@click.option("--resamples", type=click.IntRange(min=0), default=defaults.COMPARE_RESAMPLES,
              show_default=True,
              help="Cluster-bootstrap resamples of the distances (0: no intervals).")
@click.option("--level", type=click.FloatRange(0.5, 1.0, min_open=True, max_open=True),
              default=defaults.COMPARE_LEVEL,
              show_default=True, help="Level of the bootstrap intervals.")
@click.option("--seed", type=click.IntRange(min=0), default=defaults.COMPARE_SEED, show_default=True,
              help="Bootstrap seed.")
@click.option("--drop-duplicates", is_flag=True,
              help="Keep the first of repeated trial rows of a table instead of refusing them.")
@click.option("--force", is_flag=True, help=FORCE_HELP)
def compare_command(simulated: str, real: str, plan: str | None, metric_names: tuple[str, ...],
                    matches: tuple[str, ...], output_format: str, out: str | None, formats: str,
                    resamples: int, level: float, seed: int, drop_duplicates: bool, force: bool) -> None:
    """Compare SIMULATED (a run folder or metrics table) with REAL (a metrics table of real trials).

    For each metric and condition both hold: per-participant medians side by side, the real
    people's range, pooled medians and quartiles, Kolmogorov-Smirnov and Wasserstein distances
    with cluster-bootstrap intervals.
    """
    from nudgecli.report.compare import CompareOptions, compare_sources, format_comparison, write_comparison
    from nudgecli.report.plans import check_resamples
    from nudgecli.report.plotting import parse_formats

    chosen_formats = parse_formats(formats)
    notes: list[str] = []
    check_resamples(resamples, "--resamples")
    if out is not None:  # before the bootstrap, which takes a while
        from nudgecli.outputs import check_not_an_input, check_output_folder
        from nudgecli.report.compare import COMPARISON_FILES
        from nudgecli.report.compare_figure import FIGURE_STEM
        from nudgecli.store import check_writable

        check_output_folder(out, force=force)
        check_writable(out)
        for name in (*COMPARISON_FILES, *(f"{FIGURE_STEM}.{suffix}" for suffix in chosen_formats)):
            check_not_an_input(Path(out) / name)
    result = compare_sources(simulated, real, plan=plan, metrics=list(metric_names) or None,
                             condition_map=_parse_matches(matches),
                             options=CompareOptions(resamples=resamples, level=level, seed=seed),
                             drop_duplicates=drop_duplicates, notes=notes)
    for note in notes:
        info(f"Note: {note}")
    if output_format == "json":
        echo_json(result.to_json())
    elif output_format == "csv":
        click.echo(result.table.to_csv(index=False), nl=False)
    else:
        click.echo(format_comparison(result))
    if out is not None:
        from nudgecli.report.compare_figure import plot_comparison

        written = write_comparison(result, out)
        written += plot_comparison(result.trials, result.table, result.medians, out, chosen_formats)
        for path in written:
            info(str(path))


#: The commands of this module, registered on ``nudge`` by :mod:`nudgecli.cli`.
COMMANDS = (analyze_command, plot_command, plot_population_command, habits_command, compare_command)
