"""The ``nudge`` command line: parse, call one function, print. No model logic here.

stdout carries results (tables, JSON); logs and progress go to stderr. A ``NudgeError``
prints one ``Error: ...`` line and exits 1 (``--debug`` shows the traceback), and so does an
``OSError`` (naming the path and the cause); click usage errors exit 2; Ctrl-C exits 130 and
says how to resume.
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal

import click

from nudgecli import __version__
from nudgecli.errors import NudgeError

#: ``ctx.meta`` key of a callable returning what to tell the user after Ctrl-C (how to resume).
INTERRUPT_HINT = "nudge.interrupt_hint"
#: Exit status after Ctrl-C (128 + SIGINT, as shells report it).
EXIT_INTERRUPTED = 130


def os_error_message(exc: OSError) -> str:
    """One line for an ``OSError``: the path(s) and the cause."""
    cause = exc.strerror or str(exc) or type(exc).__name__
    paths = [str(p) for p in (exc.filename, exc.filename2) if p is not None]
    return f"{' -> '.join(paths)}: {cause}" if paths else cause


class NudgeGroup(click.Group):
    """A click group that turns ``NudgeError`` and ``OSError`` into one ``Error:`` line and exit
    status 1, and Ctrl-C into exit status 130 with a line on how to resume."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except NudgeError as exc:
            if ctx.meta.get("nudge.debug"):
                raise
            click.echo(f"Error: {exc}", err=True)
            ctx.exit(1)
        except OSError as exc:
            if ctx.meta.get("nudge.debug"):
                raise
            click.echo(f"Error: {os_error_message(exc)}", err=True)
            ctx.exit(1)
        except KeyboardInterrupt:
            hint: Callable[[], str] | None = ctx.meta.get(INTERRUPT_HINT)
            message = hint() if hint is not None else "nothing half-written was left; run the command again"
            click.echo(f"\nInterrupted: {message}", err=True)
            ctx.exit(EXIT_INTERRUPTED)


@click.group(cls=NudgeGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="nudge")
@click.option("--debug", is_flag=True, help="Show full tracebacks for errors.")
@click.pass_context
def main(ctx: click.Context, debug: bool) -> None:
    """Simulate and analyse assistive shared-control studies (sip-and-puff intent disambiguation)."""
    ensure_stderr()
    ctx.meta["nudge.debug"] = debug


def ensure_stderr() -> None:
    """Give the process a stderr when it was started without one (``2>&-``).

    Without it, logs and progress have nowhere to go (Python sets ``sys.stderr`` to None and the
    first progress line raises), and worse, the next file opened would get descriptor 2, so a
    library or worker writing to "stderr" would write into that file. Descriptor 2 becomes
    ``/dev/null`` instead: the command works and says nothing on stderr.
    """
    try:
        os.fstat(2)
    except OSError:
        devnull = os.open(os.devnull, os.O_WRONLY)
        if devnull != 2:
            os.dup2(devnull, 2)
            os.close(devnull)
    if sys.stderr is None:
        sys.stderr = open(2, "w", buffering=1, errors="backslashreplace", closefd=False)  # noqa: SIM115


def echo_json(data: Any) -> None:
    """Print ``data`` as JSON on stdout (the only output of ``--format json``)."""
    click.echo(json.dumps(data, indent=2, sort_keys=False, default=_json_default))


def _json_default(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    if hasattr(value, "item"):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def info(message: str) -> None:
    """A log line on stderr."""
    click.echo(message, err=True)


# --- presets -------------------------------------------------------------------------------

@main.command("presets")
def presets_command() -> None:
    """List the shipped experiments and analysis plans."""
    from nudgecli.config_files import list_presets, read_toml

    kinds: tuple[tuple[Literal["experiments", "analysis"], str], ...] = (
        ("experiments", "Experiments"), ("analysis", "Analysis plans"))
    for kind, title in kinds:
        click.echo(f"{title}:")
        for name, path in list_presets(kind).items():
            data = read_toml(path)
            # experiments describe themselves in [experiment], plans at the top level
            text = data.get("experiment", {}).get("description", "") if kind == "experiments" \
                else data.get("description", "")
            click.echo(f"  {name:<12} {text}")

# --- bench ---------------------------------------------------------------------------------


@main.command("bench")
@click.option("--format", "output_format", type=click.Choice(["table", "json"]), default="table",
              show_default=True, help="What to print on stdout.")
@click.option("--only", type=click.Choice(["model", "study", "scale", "analyze", "all"]), default="all",
              show_default=True,
              help="Which figures: the model's (a few seconds), the study's (about 10-15 s: plan, trials, "
                   "the paper-scale study with 2 workers in a subprocess), both (all); only when asked: "
                   "the scale figures (about a minute on 2 cores: batches on 1..cores workers and on a "
                   "local dask cluster, with parallel efficiency and serial fraction) or analyze "
                   "(`nudge analyze` of a 3.5 M-row table in a subprocess, about a minute).")
@click.option("--scale-participants", type=click.IntRange(min=2), default=16, show_default=True,
              help="Scale figures: participants of the one-study workload (paper preset).")
@click.option("--scale-studies", type=click.IntRange(min=2), default=24, show_default=True,
              help="Scale figures: studies of the many-studies workload (smoke preset).")
@click.option("--repeats", type=click.IntRange(min=1), default=7, show_default=True,
              help="Batches of each fast measurement (the best is reported).")
@click.option("--baseline-repeats", type=click.IntRange(min=1), default=3, show_default=True,
              help="Runs of each per-sample Monte-Carlo baseline, about 1 s each (the best is reported).")
@click.option("--study-repeats", type=click.IntRange(min=1), default=3, show_default=True,
              help="Runs of the study plan build and of one participant's trials, about 1 s each "
                   "(the best is reported).")
def bench_command(output_format: str, only: str, scale_participants: int, scale_studies: int, repeats: int,
                  baseline_repeats: int, study_repeats: int) -> None:
    """Performance figures of the model and the study, each against a baseline measured in the same run."""
    from nudgecli.bench import BenchOptions, format_table, run_bench, select_figures

    options = BenchOptions(repeats=repeats, baseline_repeats=baseline_repeats, study_repeats=study_repeats,
                           scale_participants=scale_participants, scale_studies=scale_studies)
    rows = run_bench(options, figures=select_figures(only), progress=info)
    if output_format == "json":
        echo_json(rows)
    else:
        click.echo(format_table(rows))

# --- fit -----------------------------------------------------------------------------------

@main.command("fit")
@click.argument("calibration_dir", type=click.Path(file_okay=False))
@click.option("--out", "out", type=click.Path(dir_okay=False), default=None,
              help="Profile JSON to write [default: ./<folder name>.profile.json].")
@click.option("--variant", type=click.Choice(["auto", "pilot", "ciaa"]), default="auto", show_default=True,
              help="Log format of the p(phi_m | phi_i) stream: pilot (fixed 10 Hz, neutral label 'None'), "
                   "ciaa (the sibling study's event-driven stream, neutral label 'Zero Band'), or auto "
                   "(detect from the neutral label, else from the message timing).")
def fit_command(calibration_dir: str, out: str | None, variant: str) -> None:
    """Fit p(phi_i | a) and p(phi_m | phi_i) from one participant's calibration logs.

    CALIBRATION_DIR holds p_phi_given_a/ and/or p_phm_given_phi/ (the study's export; the sibling
    study's <id>_p_ui_given_a/ and <id>_p_um_given_ui/ too) or the tidy files of a simulated
    session. A missing session falls back to the default table.
    """

    from nudgecli.sim.calibration_profile import fit_calibration_dir, write_profile
    from nudgecli.store import check_writable

    folder = Path(calibration_dir)
    target = Path(out) if out is not None else Path.cwd() / f"{folder.resolve().name}.profile.json"
    check_writable(target.parent)
    result = fit_calibration_dir(folder, variant)
    for warning in result.warnings:
        info(f"Warning: {warning}")
    write_profile(result.profile, target)
    click.echo(result.summary)
    info(str(target))


# --- simulate / run ------------------------------------------------------------------------

_SET_HELP = "Override one experiment field, e.g. --set disambiguation.window=5 (repeatable)."
_YES_HELP = "Simulate more trials than the size limit allows without asking (see the README)."


def _progress_bar(label: str, unit: str = "trial") -> tuple[Any, Any]:
    """A tqdm bar on stderr (off when stderr is not a terminal) and its update callback."""
    from tqdm import tqdm

    bar = tqdm(total=0, desc=label, unit=unit, file=sys.stderr, disable=None, leave=False)

    def update(done: int, total: int) -> None:
        bar.total = total
        bar.n = done
        bar.refresh()

    return bar, update


def _interrupt_hint(target: Path, commands: list[str]) -> Callable[[], str]:
    """What to say after Ctrl-C of a simulation into ``target``."""

    def hint() -> str:
        from nudgecli.store import RunFolder

        run = RunFolder(target)
        if run.is_run():
            done = len(run.completed_participants())
            alternatives = "".join(f" (or, to analyse and plot too: {c})" for c in commands[1:])
            return (f"{target} keeps its {done} finished participant(s); resume with: "
                    f"{commands[0]}{alternatives}")
        return "nothing was simulated yet; run the command again"

    return hint


def _simulate(experiment: str, out: str | None, seed: int | None, participants: int | None, workers: int,
              scheduler: str | None, resume: bool, force: bool, overrides: tuple[str, ...],
              plan: str | None = None, command: str = "simulate", confirm: bool = False) -> Any:

    from nudgecli.config import load_experiment
    from nudgecli.runs.study import run_study
    from nudgecli.store import default_run_dir, simulate_resume_command

    config = load_experiment(experiment, overrides)
    target = Path(out) if out else default_run_dir(config.experiment.name)
    commands = [simulate_resume_command(experiment, target, seed, participants, workers, overrides,
                                        confirm=confirm)]
    if command != "simulate":
        commands.append(simulate_resume_command(experiment, target, seed, participants, workers, overrides,
                                                command, confirm))
    click.get_current_context().meta[INTERRUPT_HINT] = _interrupt_hint(target, commands)
    bar, update = _progress_bar("simulating")
    try:
        return run_study(config, target, seed=seed, participants=participants, workers=workers,
                         scheduler=scheduler, resume=resume, force=force, progress=update, plan=plan,
                         confirm=confirm)
    except BaseException:
        if not out and target.is_dir() and not any(target.iterdir()):
            target.rmdir()  # the default folder made for this run, still empty: leave nothing behind
        raise
    finally:
        bar.close()


def _print_study_summary(run: Any) -> None:
    from nudgecli.runs.study import success_by_condition

    table = success_by_condition(run.trials)
    click.echo(f"{len(run.trials)} trials, {run.participants} participants "
               f"({'resumed, ' if run.mode == 'resume' else ''}{len(run.computed)} simulated now)")
    click.echo(table.to_string(float_format=lambda v: f"{v:.3f}"))


@main.command("simulate")
@click.argument("experiment")
@click.option("--out", type=click.Path(file_okay=False),
              help="Run folder [default: results/<experiment>-<UTC time>].")
@click.option("--seed", type=int, help="Master seed [default: the experiment's].")
@click.option("--participants", type=int, help="Number of participants [default: the experiment's].")
@click.option("--workers", type=int, default=1, show_default=True, help="Local worker processes.")
@click.option("--scheduler", envvar="DASK_SCHEDULER_ADDRESS",
              help="dask.distributed scheduler address (or DASK_SCHEDULER_ADDRESS); needs nudgecli[cluster].")
@click.option("--resume", is_flag=True, help="Finish an interrupted run in --out (same experiment and seed).")
@click.option("--force", is_flag=True, help="Replace a run that already is in --out.")
@click.option("--yes", is_flag=True, help=_YES_HELP)
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=_SET_HELP)
def simulate_command(experiment: str, out: str | None, seed: int | None, participants: int | None,
                     workers: int, scheduler: str | None, resume: bool, force: bool, yes: bool,
                     overrides: tuple[str, ...]) -> None:
    """Simulate a study: EXPERIMENT is a preset (paper, study-code, smoke) or a TOML file."""
    run = _simulate(experiment, out, seed, participants, workers, scheduler, resume, force, overrides,
                    confirm=yes)
    _print_study_summary(run)
    click.echo(f"Run folder: {run.path}", err=True)
    click.echo(str(run.path))

# --- analyze -------------------------------------------------------------------------------


@main.command("analyze")
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
@click.option("--questionnaires", type=click.Path(dir_okay=False, path_type=str), default=None,
              help="Questionnaire CSV (NASA-TLX, Likert) analysed alongside.")
@click.option("--seed", type=click.IntRange(min=0), default=None,
              help="Bootstrap seed [default: the plan's].")
@click.option("--bootstrap", "bootstrap", type=click.IntRange(min=1), default=None, metavar="N",
              help="Bootstrap resamples of the intervals [default: the plan's].")
@click.option("--drop-duplicates", is_flag=True,
              help="Keep the first of repeated trial rows of a table instead of refusing them.")
def analyze_command(source: str, plan: str | None, out: str | None, output_format: str,
                    metric_names: tuple[str, ...], questionnaires: str | None, seed: int | None,
                    bootstrap: int | None, drop_duplicates: bool) -> None:
    """Metrics and statistics of a run folder or a metrics table (CSV/Parquet, one row per trial)."""
    from nudgecli.report.analysis import analyze, format_table
    from nudgecli.report.plans import check_resamples

    check_resamples(bootstrap, "--bootstrap")
    bar, update = _progress_bar("analysing", unit="metric")
    try:
        result = analyze(source, plan=plan, out=out, metrics=list(metric_names) or None,
                         questionnaires=questionnaires, seed=seed, bootstrap=bootstrap,
                         drop_duplicates=drop_duplicates, progress=update)
    finally:
        bar.close()
    for note in result.notes:
        info(f"Note: {note}")
    if output_format == "json":
        echo_json(result.stats)
    elif output_format == "csv":
        click.echo(result.table.to_csv(index=False), nl=False)
    else:
        click.echo(format_table(result.table, result.stats["conditions"]))
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


@main.command("plot", short_help="Draw the figures of an analysed run or metrics table.")
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
def plot_command(run: str, plan: str | None, out: str | None, formats: str, trial: str | None) -> None:
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

        analyze(run, plan=analysis_plan)  # takes the locks of what it writes
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
            written = plot_folder(run, out, chosen, trial_key, star_rule=analysis_plan.comparison_options(),
                                  item_labels=analysis_plan.questionnaires.labels)
    except BaseException:
        if made and written_folder is not None and written_folder.is_dir() \
                and not any(written_folder.iterdir()):
            written_folder.rmdir()  # made only to hold the lock: a failed plot leaves nothing behind
        raise
    for path in written:
        click.echo(str(path))


# --- run -----------------------------------------------------------------------------------

@main.command("run")
@click.argument("experiment", default="paper")
@click.option("--out", type=click.Path(file_okay=False),
              help="Run folder [default: results/<experiment>-<UTC time>].")
@click.option("--seed", type=int, help="Master seed [default: the experiment's].")
@click.option("--participants", type=int, help="Number of participants [default: the experiment's].")
@click.option("--workers", type=int, default=1, show_default=True, help="Local worker processes.")
@click.option("--plan", metavar="PLAN", default=None,
              help="Analysis plan [default: the plan named like the experiment, else paper].")
@click.option("--resume", is_flag=True, help="Finish an interrupted run in --out.")
@click.option("--force", is_flag=True, help="Replace a run that already is in --out.")
@click.option("--yes", is_flag=True, help=_YES_HELP)
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=_SET_HELP)
def run_command(experiment: str, out: str | None, seed: int | None, participants: int | None, workers: int,
                plan: str | None, resume: bool, force: bool, yes: bool, overrides: tuple[str, ...]) -> None:
    """Simulate, analyse and plot in one go: EXPERIMENT defaults to the paper preset."""
    from nudgecli.config_files import resolve_plan
    from nudgecli.locks import run_lock
    from nudgecli.report.analysis import analyze, format_table
    from nudgecli.report.plans import load_plan
    from nudgecli.report.plotting import plot_folder
    from nudgecli.run_folder_names import FIGURES_DIR, STATS_JSON, SUMMARY_MD

    if plan is not None and Path(plan).suffix.lower() == ".toml":
        plan = str(Path(plan).resolve())
    run = _simulate(experiment, out, seed, participants, workers, None, resume, force, overrides,
                    plan=plan, command="run", confirm=yes)
    _print_study_summary(run)
    chosen_plan = resolve_plan(plan, experiment=run.experiment)
    info(f"analysing with the {chosen_plan!r} plan")
    analysis_plan = load_plan(chosen_plan)
    with run_lock(run.path):
        result = analyze(run.path, plan=chosen_plan)
        for note in result.notes:
            info(f"Note: {note}")
        click.echo("")
        click.echo(format_table(result.table, result.stats["conditions"]))
        written = plot_folder(run.path, star_rule=analysis_plan.comparison_options(),
                              item_labels=analysis_plan.questionnaires.labels)
    click.echo("")
    click.echo(f"Statistics: {run.path / STATS_JSON}, {run.path / SUMMARY_MD}")
    click.echo(f"Figures:    {len(written)} files in {run.path / FIGURES_DIR}")
    click.echo(str(run.path))


# --- plot-population -----------------------------------------------------------------------


@main.command("plot-population", short_help="Simulated participants' calibrations beside real people's.")
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
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=_SET_HELP)
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


@main.command("habits", short_help="Operating habits (HABITS.md definitions) of a run or a real log.")
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
    """``("none=no assistance", ...)`` -> ``{"none": "no assistance"}``."""
    from nudgecli.errors import ConfigError

    mapping: dict[str, str] = {}
    for text in matches:
        simulated, sep, real = text.partition("=")
        if not sep or not simulated.strip() or not real.strip():
            raise ConfigError(f"--match {text!r}: expected SIMULATED=REAL, e.g. --match none='no assistance'")
        mapping[simulated.strip()] = real.strip()
    return mapping


@main.command("compare", short_help="Simulated people beside real people, metric by metric.")
@click.argument("simulated", type=click.Path(path_type=str))
@click.argument("real", type=click.Path(path_type=str))
@click.option("--plan", metavar="PLAN", default="paper", show_default=True,
              help="Analysis plan: the metric definitions of a run folder and the filters of both sources.")
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
@click.option("--resamples", type=click.IntRange(min=0), default=2000, show_default=True,
              help="Cluster-bootstrap resamples of the distances (0: no intervals).")
@click.option("--level", type=click.FloatRange(0.5, 1.0, min_open=True, max_open=True), default=0.95,
              show_default=True, help="Level of the bootstrap intervals.")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Bootstrap seed.")
@click.option("--drop-duplicates", is_flag=True,
              help="Keep the first of repeated trial rows of a table instead of refusing them.")
def compare_command(simulated: str, real: str, plan: str, metric_names: tuple[str, ...],
                    matches: tuple[str, ...], output_format: str, out: str | None, formats: str,
                    resamples: int, level: float, seed: int, drop_duplicates: bool) -> None:
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
    if out is not None:
        from nudgecli.store import check_writable

        check_writable(out)  # before the bootstrap, which takes a while
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


# --- replicate / power / sweep -------------------------------------------------------------

def _batch_options(func: Any) -> Any:
    """The options every batch command shares (executor, output folder, resume, size check)."""
    options = [
        click.option("--out", type=click.Path(file_okay=False),
                     help="Batch folder [default: results/<experiment>-<command>-<UTC time>]."),
        click.option("--workers", type=int, default=1, show_default=True, help="Local worker processes."),
        click.option("--scheduler", envvar="DASK_SCHEDULER_ADDRESS",
                     help="dask.distributed scheduler address (or DASK_SCHEDULER_ADDRESS); needs "
                          "nudgecli[cluster]."),
        click.option("--resume", is_flag=True, help="Finish an interrupted batch in --out (same settings)."),
        click.option("--force", is_flag=True, help="Replace a batch that already is in --out."),
        click.option("--yes", is_flag=True, help="Run a batch above the size limit (see the README)."),
        click.option("--format", "output_format", type=click.Choice(["table", "json", "csv"]),
                     default="table", show_default=True, help="What to print on stdout."),
    ]
    for option in reversed(options):
        func = option(func)
    return func


def _run_batch_command(label: str, run: Any, out: str | None, default_name: str, output_format: str,
                       **kwargs: Any) -> None:
    from nudgecli.runs.executors import Progress
    from nudgecli.store import default_run_dir

    target = Path(out) if out else default_run_dir(default_name)
    ctx = click.get_current_context()
    ctx.meta[INTERRUPT_HINT] = _batch_interrupt_hint(target, rerun_command(ctx, target))
    try:
        result = run(out=target, progress=Progress(label), log=info, **kwargs)
    except BaseException:
        if not out and target.is_dir() and not any(target.iterdir()):
            target.rmdir()  # the default folder made for this batch, still empty: leave nothing behind
        raise
    table = result.summary
    if output_format == "json":
        echo_json(json.loads(table.to_json(orient="records")))
    elif output_format == "csv":
        click.echo(table.to_csv(index=False), nl=False)
    else:
        click.echo(table.to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    info(f"Batch folder: {result.run.path} ({result.run.computed} tasks computed now)")
    if output_format == "table":  # under json/csv stdout is the document alone (the folder is on stderr)
        click.echo(str(result.run.path))


def rerun_command(ctx: click.Context, target: Path) -> str:
    """The command line that resumes the interrupted command of ``ctx`` into ``target``: its
    arguments and the options given on the command line, ``--out target`` and ``--resume``
    (``--force`` dropped: it would delete what was finished)."""
    from click.core import ParameterSource

    from nudgecli.store import resume_command

    arguments: list[str] = []
    options: list[str] = []
    for param in ctx.command.params:
        name = param.name or ""
        value = ctx.params.get(name)
        if isinstance(param, click.Argument):
            arguments.append(str(value))
            continue
        given = ctx.get_parameter_source(name) is ParameterSource.COMMANDLINE
        if name in ("out", "resume", "force") or not given:
            continue
        flag = max(param.opts, key=len)  # the long name: --replications, not -R
        if getattr(param, "is_flag", False):
            options += [flag] if value else []
        elif getattr(param, "multiple", False):
            for item in value or ():
                options += [flag, str(item)]
        else:
            options += [flag, str(value)]
    return resume_command([ctx.info_name or ctx.command.name or "", *arguments, *options], target)


def _batch_interrupt_hint(target: Path, command: str) -> Callable[[], str]:
    """What to say after Ctrl-C of a batch into ``target``."""

    def hint() -> str:
        from nudgecli.runs.batch import BATCH_MANIFEST

        if (target / BATCH_MANIFEST).is_file():
            return f"{target} keeps its finished tasks; resume with: {command}"
        return "nothing was computed yet; run the command again"

    return hint


def _experiment_name(experiment: str) -> str:
    return Path(experiment).stem if experiment.endswith(".toml") else experiment


@main.command("replicate")
@click.argument("experiment")
@click.option("--replications", "-R", type=int, required=True,
              help="Independent studies (each its own seed).")
@click.option("--seed", type=int, help="Master seed of the replications [default: the experiment's].")
@click.option("--plan", default=None, metavar="PLAN",
              help="Analysis plan of each study [default: the plan named like the experiment, else paper].")
@click.option("--participants", type=int, help="Participants per study [default: the experiment's].")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=_SET_HELP)
@_batch_options
def replicate_command(experiment: str, replications: int, seed: int | None, plan: str | None,
                      participants: int | None, overrides: tuple[str, ...], out: str | None, workers: int,
                      scheduler: str | None, resume: bool, force: bool, yes: bool,
                      output_format: str) -> None:
    """R independent studies of EXPERIMENT: how often each difference is significant, the pooled effect."""
    from nudgecli.runs.batch import replicate

    _run_batch_command("replicate", replicate, out, f"{_experiment_name(experiment)}-replicate",
                       output_format,
                       experiment=experiment, replications=replications, seed=seed, plan=plan,
                       participants=participants, overrides=overrides, workers=workers, scheduler=scheduler,
                       resume=resume, force=force, confirm=yes)


def _counts(text: str) -> list[int]:
    try:
        return [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise click.BadParameter(f"{text!r}: give comma-separated integers, e.g. 6,9,12,18,24") from None


@main.command("power")
@click.argument("experiment")
@click.option("--participants", "counts", required=True, metavar="N,N,...",
              help="Participant counts, e.g. 6,9,12,18,24.")
@click.option("--replications", "-R", type=int, required=True, help="Studies per count.")
@click.option("--seed", type=int, help="Master seed of the replications [default: the experiment's].")
@click.option("--plan", default=None, metavar="PLAN",
              help="Analysis plan of each study [default: the plan named like the experiment, else paper].")
@click.option("--target", type=float, default=0.8, show_default=True, help="The power to reach.")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=_SET_HELP)
@_batch_options
def power_command(experiment: str, counts: str, replications: int, seed: int | None, plan: str | None,
                  target: float, overrides: tuple[str, ...], out: str | None, workers: int,
                  scheduler: str | None, resume: bool, force: bool, yes: bool, output_format: str) -> None:
    """Power curves: the chance of a significant difference in the paper's direction per participant count."""
    from nudgecli.runs.batch import power

    _run_batch_command("power", power, out, f"{_experiment_name(experiment)}-power", output_format,
                       experiment=experiment, participant_counts=_counts(counts), replications=replications,
                       seed=seed, plan=plan, overrides=overrides, target=target, workers=workers,
                       scheduler=scheduler, resume=resume, force=force, confirm=yes)


@main.command("sweep")
@click.argument("sweep_file")
@click.option("--replications", "-R", type=int, help="Studies per design point [default: the file's].")
@click.option("--seed", type=int, help="Master seed of the replications [default: the file's].")
@_batch_options
def sweep_command(sweep_file: str, replications: int | None, seed: int | None, out: str | None, workers: int,
                  scheduler: str | None, resume: bool, force: bool, yes: bool, output_format: str) -> None:
    """Run a sweep file (grid, Sobol or Morris design over experiment keys); see the README for the format."""
    from nudgecli.runs.batch import sweep

    _run_batch_command("sweep", sweep, out, f"{_experiment_name(sweep_file)}-sweep", output_format,
                       sweep_file=sweep_file, replications=replications, seed=seed, workers=workers,
                       scheduler=scheduler, resume=resume, force=force, confirm=yes)


# --- validate ------------------------------------------------------------------------------


def _validation_readings() -> list[str]:
    """The names of the validation's readings (for ``--reading``'s choices)."""
    from nudgecli.sim.validation.readings import READINGS

    return list(READINGS)


@main.command("validate")
@click.option("--simulations", type=int, default=100, show_default=True,
              help="Random worlds (each queries every state off the goals once).")
@click.option("--min-goals", type=int, default=3, show_default=True, help="Fewest goals |G| (at least 2).")
@click.option("--max-goals", type=int, default=30, show_default=True,
              help="Most goals |G|; |G| steps cyclically from --min-goals to --max-goals.")
@click.option("--states", type=int, default=200, show_default=True,
              help="|S| = 2 modes x W x H cells of the two-mode world (200: a 10 x 10 grid).")
@click.option("--seed", type=int, default=0, show_default=True, help="Master seed of the whole validation.")
@click.option("--belief-concentration", type=float, default=1.0, show_default=True,
              help="Query beliefs are Dirichlet(c): 1 spreads them evenly, large c makes them near uniform.")
@click.option("--mc-queries", type=int, default=100, show_default=True,
              help="Queries of the Monte-Carlo convergence study (0 skips it).")
@click.option("--reading", type=click.Choice(list(_validation_readings())), default="dirichlet",
              show_default=True, help="Which reading of the paper's validation paragraph (see the README).")
@click.option("--all-readings", is_flag=True,
              help="Run every reading on the same worlds and print one row per reading, by |G|.")
@click.option("--out", "out", type=click.Path(file_okay=False, path_type=str), default=None,
              help="Folder for validation.json, validation.csv (per query) and validation.png/.pdf "
                   "(readings.json with --all-readings).")
@click.option("--format", "output_format", type=click.Choice(["table", "json"]), default="table",
              show_default=True, help="What to print on stdout.")
@click.option("--yes", is_flag=True, help="Run more queries than the size limit allows without asking.")
def validate_command(simulations: int, min_goals: int, max_goals: int, states: int, seed: int,
                     belief_concentration: float, mc_queries: int, reading: str, all_readings: bool,
                     out: str | None, output_format: str, yes: bool) -> None:
    """The paper's simulation-based validation of D(s): its argmax vs a one-step ground truth."""
    import time
    from dataclasses import replace

    from nudgecli.runs.size import MAX_QUERIES_WITHOUT_YES, check_size
    from nudgecli.sim import validation

    if all_readings and reading != "dirichlet":
        raise click.UsageError("--reading and --all-readings exclude each other")
    settings = validation.ValidationSettings(
        simulations=simulations, min_goals=min_goals, max_goals=max_goals, states=states, seed=seed,
        mc_queries=mc_queries, reading=reading, belief_concentration=belief_concentration)
    names = list(validation.READINGS) if all_readings else [reading]
    for name in names:
        replace(settings, reading=name).check()
    check_size(simulations * states * len(names), yes, limit=MAX_QUERIES_WITHOUT_YES,
               work="run {} queries (worlds x states x readings)", fix="fewer --simulations or --states")
    if out is not None:
        validation.prepare_out(out)
    start = time.perf_counter()
    bar, update = _progress_bar("validating", unit="simulation")
    try:
        if all_readings:
            results = validation.run_all_readings(settings, names, progress=update)
        else:
            results = [validation.run_validation(settings, progress=update)]
    finally:
        bar.close()
    info(f"validation: {simulations * len(names)} simulations in {time.perf_counter() - start:.1f} s")
    if all_readings:
        records = validation.readings_summary(results)
        if out is not None:
            validation.save_readings(results, out)
        if output_format == "json":
            echo_json(records)
        else:
            click.echo(validation.format_readings(records))
    else:
        summary = results[0].summary()
        if out is not None:
            from nudgecli.report.validation_figure import plot_validation

            validation.save_validation(results[0], out)
            plot_validation(summary, out)
        if output_format == "json":
            echo_json(summary)
        else:
            click.echo(validation.format_summary(summary))
    if out is not None:
        info(str(out))


# --- study (a person in the loop) ---------------------------------------------------------


@main.command("study")
@click.argument("experiment")
@click.option("--participant", "participant_id", required=True, metavar="ID",
              help="Participant ID ending in their number, e.g. P01 (the number seeds their schedule).")
@click.option("--port", type=click.IntRange(1, 65535), default=8765, show_default=True,
              help="Port on 127.0.0.1.")
@click.option("--out", type=click.Path(file_okay=False),
              help="Run folder, shared by the participants of one study "
                   "[default: results/<experiment>-live].")
@click.option("--condition-order", metavar="A,B",
              help="The order of the conditions' blocks, e.g. control,disambiguation [default: rotates "
                   "with the participant's number, as in the experiment].")
@click.option("--seed", type=int, help="Master seed [default: the experiment's].")
@click.option("--resume", is_flag=True, help="Continue this participant's session at their next trial.")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=_SET_HELP)
def study_command(experiment: str, participant_id: str, port: int, out: str | None,
                  condition_order: str | None, seed: int | None, resume: bool,
                  overrides: tuple[str, ...]) -> None:
    """Run one participant's session in a browser page served on 127.0.0.1 (needs nudgecli[study])."""
    from nudgecli.live.app import run_live_study

    session = run_live_study(experiment, participant_id, port=port, out=out, condition_order=condition_order,
                             seed=seed, resume=resume, overrides=overrides, announce=click.echo, log=info)
    if session.phase != "done":
        sys.exit(130)  # interrupted (Ctrl-C) before the participant finished


def entry_point() -> None:
    """The ``nudge`` program: :data:`main`, and after Ctrl-C a prompt exit.

    After Ctrl-C the run folder is already marked and the resume command printed; what is left
    is the interpreter's shutdown, which joins a process pool's management thread, and that
    thread can wait for ever on a queue whose worker was just stopped (CPython 3.11). So an
    interrupted command leaves at once (``os._exit``, streams flushed first).
    """
    import os

    try:
        main()
    except SystemExit as exc:
        if exc.code == EXIT_INTERRUPTED:
            for stream in (sys.stdout, sys.stderr):
                with contextlib.suppress(Exception):
                    stream.flush()
            os._exit(EXIT_INTERRUPTED)
        raise


if __name__ == "__main__":  # pragma: no cover
    entry_point()
