"""Commands that read runs and tables: ``analyze``, ``plot``, ``plot-population``, ``habits`` and
``compare``."""

from __future__ import annotations

import click

from nudgecli import command_defaults as defaults
from nudgecli.commands.common import FORCE_HELP, SET_HELP, echo_json, info, progress_bar

# --- analyze -------------------------------------------------------------------------------


@click.command("analyze")
@click.argument("source", type=click.Path(path_type=str))
@click.option("--plan", "plan", default=None, metavar="PLAN",
              help="Analysis plan: a preset (`nudge presets` lists them) or a TOML file [default: the "
                   "plan recorded in the run folder, else the plan named like the run's experiment, else "
                   "its world's (ciaa-teleop for the CIAA world), else paper].")
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
@click.option("--seed", type=int, default=None,
              help="Bootstrap seed [default: the plan's].")
@click.option("--bootstrap", "bootstrap", type=int, default=None, metavar="N",
              help="Bootstrap resamples of the intervals, at least 100 as in a plan [default: the plan's].")
@click.option("--drop-duplicates", is_flag=True,
              help="Keep the first of repeated trial rows of a table instead of refusing them.")
@click.option("--force", is_flag=True, help=FORCE_HELP)
def analyze_command(source: str, plan: str | None, out: str | None, output_format: str,
                    metric_names: tuple[str, ...], questionnaires: str | None, seed: int | None,
                    bootstrap: int | None, drop_duplicates: bool, reference: str | None, force: bool) -> None:
    """Metrics and statistics of a run folder or a metrics table (CSV/Parquet, one row per trial)."""
    from nudgecli import api

    bar, update = progress_bar("analysing", unit="metric")
    try:
        result = api.analyze(source, plan=plan, out=out, metrics=list(metric_names) or None,
                             questionnaires=questionnaires, seed=seed, bootstrap=bootstrap,
                             drop_duplicates=drop_duplicates, progress=update, reference=reference,
                             force=force, log=info)
    finally:
        bar.close()
    if output_format == "json":
        echo_json(result.stats)
    elif output_format == "csv":
        click.echo(result.csv(), nl=False)
    else:
        click.echo(result.table(reference))
    info(str(result.path))


# --- plot ----------------------------------------------------------------------------------

@click.command("plot", short_help="Draw the figures of an analysed run or metrics table.")
@click.argument("run", type=click.Path(path_type=str))
@click.option("--plan", metavar="PLAN", default=None,
              help="Analyse RUN with this plan first (writes metrics.csv and stats.json; the analysis "
                   "replaced is put back if the plot then fails), then plot "
                   "[default: plot the existing analysis, with the star rule and item labels of the plan "
                   "its stats.json names (an analysis written away from its run, or under another plan), "
                   "else the plan recorded in the run folder, else the plan named like the run's experiment, "
                   "else its world's (ciaa-teleop for the CIAA world), else paper].")
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
    from nudgecli import api

    written = api.save_figures(run, plan=plan, out=out, formats=formats, trial=trial, reference=reference,
                               force=force, log=info)
    for path in written:
        click.echo(str(path))


# --- plot-population -----------------------------------------------------------------------


@click.command("plot-population", short_help="Simulated participants' calibrations beside real people's.")
@click.argument("experiment")
@click.option("--participants", type=click.IntRange(min=1), default=defaults.POPULATION_PARTICIPANTS,
              show_default=True, help="Simulated participants to calibrate.")
@click.option("--seed", type=int, default=None,
              help="Master seed [default: the experiment's].")
@click.option("--out", type=click.Path(file_okay=False, path_type=str), default=".", show_default=True,
              help="Folder for population.csv, population_habits.csv, coverage.txt (the table printed) and "
                   "the figure population.<format>; one holding other files needs --force.")
@click.option("--force", is_flag=True, help="Write into an --out that holds other files.")
@click.option("--formats", default="png,pdf", show_default=True, help="Figure formats: png, pdf, svg.")
@click.option("--format", "output_format", type=click.Choice(["table", "json", "csv"]), default="table",
              show_default=True, help="What to print on stdout: the coverage table.")
@click.option("--yes", is_flag=True,
              help="Calibrate more participants than the size limit allows (docs/reliability.md).")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=SET_HELP)
def plot_population_command(experiment: str, participants: int, seed: int | None, out: str, force: bool,
                            formats: str, output_format: str, yes: bool, overrides: tuple[str, ...]) -> None:
    """Calibrate EXPERIMENT's simulated participants and draw their fitted p(phi_m | phi_i) diagonals
    beside the real people's (pilots: fixed 10 Hz stream; sibling study: event-driven stream), and
    their drawn timing habits beside the ten real users' ranges (HABITS.md)."""
    from nudgecli.api.population import plot_population

    made = plot_population(experiment, participants=participants, seed=seed, out=out, force=force,
                           formats=formats, yes=yes, overrides=overrides)
    table = made.coverage
    if output_format == "json":
        echo_json(table.to_dict(orient="records"))
    elif output_format == "csv":
        click.echo(table.to_csv(index=False), nl=False)
    else:
        click.echo(made.coverage_text(), nl=False)
    for path in made.files:
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
    study) or a real log (CSV: t, trial, label, x, y, theta, mode_switch; participant, layout and turn
    optional: turn = human or autonomy marks an assisted study's turns), read in 10 Hz cells as
    HABITS.md defines them, the person's turns only."""
    from nudgecli import api

    result = api.habits(source, by=by, compare=compare)
    if output_format == "json":
        echo_json(result.to_json())
    elif output_format == "csv":
        click.echo(result.csv(), nl=False)
    else:
        click.echo(result.text())


# --- compare -------------------------------------------------------------------------------


@click.command("compare", short_help="Simulated people beside real people, metric by metric.")
@click.argument("simulated", type=click.Path(path_type=str))
@click.argument("real", type=click.Path(path_type=str))
@click.option("--plan", metavar="PLAN", default=None,
              help="Analysis plan: the metric definitions of a run folder and the filters of both sources "
                   "[default: the plan the simulated run records or is named like, else its world's, "
                   "else paper].")
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
              help="Cluster-bootstrap resamples of the distances, at least 100 as in a plan "
                   "(0: no intervals).")
@click.option("--level", type=click.FloatRange(0.5, 1.0, min_open=True, max_open=True),
              default=defaults.COMPARE_LEVEL,
              show_default=True, help="Level of the bootstrap intervals.")
@click.option("--seed", type=int, default=defaults.COMPARE_SEED, show_default=True,
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
    from nudgecli import api

    result = api.compare(simulated, real, plan=plan, metrics=list(metric_names) or None, match=matches,
                         resamples=resamples, level=level, seed=seed, drop_duplicates=drop_duplicates,
                         out=out, formats=formats, force=force, log=info)
    if output_format == "json":
        echo_json(result.to_json())
    elif output_format == "csv":
        click.echo(result.table.to_csv(index=False), nl=False)
    else:
        click.echo(result.text())
    for path in result.files:
        info(str(path))


#: The commands of this module, registered on ``nudge`` by :mod:`nudgecli.cli`.
COMMANDS = (analyze_command, plot_command, plot_population_command, habits_command, compare_command)
