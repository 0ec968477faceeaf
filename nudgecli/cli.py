"""The ``nudge`` command line: parse, call one function, print. No model logic here.

stdout carries results (tables, JSON); logs and progress go to stderr. A ``NudgeError``
prints one ``Error: ...`` line and exits 1 (``--debug`` shows the traceback); click usage
errors exit 2.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any, Literal

import click

from nudgecli import __version__
from nudgecli.errors import NudgeError


class NudgeGroup(click.Group):
    """A click group that turns ``NudgeError`` into one ``Error:`` line and exit status 1."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except NudgeError as exc:
            if ctx.meta.get("nudge.debug"):
                raise
            click.echo(f"Error: {exc}", err=True)
            ctx.exit(1)


@click.group(cls=NudgeGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="nudge")
@click.option("--debug", is_flag=True, help="Show full tracebacks for errors.")
@click.pass_context
def main(ctx: click.Context, debug: bool) -> None:
    """Simulate and analyse assistive shared-control studies (sip-and-puff intent disambiguation)."""
    ctx.meta["nudge.debug"] = debug


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
    from nudgecli.config import list_presets, read_toml

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
@click.option("--only", type=click.Choice(["model", "study", "all"]), default="all", show_default=True,
              help="Which figures: the model's (a few seconds), the study's (about 10-15 s: plan, trials, "
                   "the paper-scale study with 2 workers in a subprocess) or all.")
@click.option("--repeats", type=click.IntRange(min=1), default=7, show_default=True,
              help="Batches of each fast measurement (the best is reported).")
@click.option("--baseline-repeats", type=click.IntRange(min=1), default=3, show_default=True,
              help="Runs of each per-sample Monte-Carlo baseline, about 1 s each (the best is reported).")
@click.option("--study-repeats", type=click.IntRange(min=1), default=3, show_default=True,
              help="Runs of the study plan build and of one participant's trials, about 1 s each "
                   "(the best is reported).")
def bench_command(output_format: str, only: str, repeats: int, baseline_repeats: int,
                  study_repeats: int) -> None:
    """Performance figures of the model and the study, each against a baseline measured in the same run."""
    from nudgecli.bench import BenchOptions, format_table, run_bench, select_figures

    options = BenchOptions(repeats=repeats, baseline_repeats=baseline_repeats, study_repeats=study_repeats)
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
def fit_command(calibration_dir: str, out: str | None) -> None:
    """Fit p(phi_i | a) and p(phi_m | phi_i) from one participant's calibration logs.

    CALIBRATION_DIR holds p_phi_given_a/ and/or p_phm_given_phi/ (the study's export) or the
    tidy files of a simulated session. A missing session falls back to the default table.
    """

    from nudgecli.sim.calibration import fit_calibration_dir, write_profile

    folder = Path(calibration_dir)
    result = fit_calibration_dir(folder)
    for warning in result.warnings:
        info(f"Warning: {warning}")
    click.echo(result.summary)
    target = Path(out) if out is not None else Path.cwd() / f"{folder.resolve().name}.profile.json"
    write_profile(result.profile, target)
    info(str(target))


# --- simulate / run ------------------------------------------------------------------------

_SET_HELP = "Override one experiment field, e.g. --set disambiguation.window=5 (repeatable)."


def _progress_bar(label: str, unit: str = "trial") -> tuple[Any, Any]:
    """A tqdm bar on stderr (off when stderr is not a terminal) and its update callback."""
    from tqdm import tqdm

    bar = tqdm(total=0, desc=label, unit=unit, file=sys.stderr, disable=None, leave=False)

    def update(done: int, total: int) -> None:
        bar.total = total
        bar.n = done
        bar.refresh()

    return bar, update


def _simulate(experiment: str, out: str | None, seed: int | None, participants: int | None, workers: int,
              scheduler: str | None, resume: bool, force: bool, overrides: tuple[str, ...]) -> Any:

    from nudgecli.config import load_experiment
    from nudgecli.sim.study import run_study
    from nudgecli.store import default_run_dir

    config = load_experiment(experiment, overrides)
    target = Path(out) if out else default_run_dir(config.experiment.name)
    bar, update = _progress_bar("simulating")
    try:
        return run_study(config, target, seed=seed, participants=participants, workers=workers,
                         scheduler=scheduler, resume=resume, force=force, progress=update)
    finally:
        bar.close()


def _print_study_summary(run: Any) -> None:
    from nudgecli.sim.study import success_by_condition

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
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=_SET_HELP)
def simulate_command(experiment: str, out: str | None, seed: int | None, participants: int | None,
                     workers: int, scheduler: str | None, resume: bool, force: bool,
                     overrides: tuple[str, ...]) -> None:
    """Simulate a study: EXPERIMENT is a preset (paper, study-code, smoke) or a TOML file."""
    run = _simulate(experiment, out, seed, participants, workers, scheduler, resume, force, overrides)
    _print_study_summary(run)
    click.echo(f"Run folder: {run.path}", err=True)
    click.echo(str(run.path))

# --- analyze -------------------------------------------------------------------------------


@main.command("analyze")
@click.argument("source", type=click.Path(path_type=str))
@click.option("--plan", "plan", default="paper", show_default=True, metavar="PLAN",
              help="Analysis plan: a preset (paper, study-code) or a TOML file.")
@click.option("--out", "out", type=click.Path(file_okay=False, path_type=str), default=None,
              help="Folder for metrics.csv, stats.json, stats.csv, summary.md [default: the run folder, "
                   "or the table's folder].")
@click.option("--format", "output_format", type=click.Choice(["table", "json", "csv"]), default="table",
              show_default=True, help="What to print on stdout.")
@click.option("--metric", "metric_names", multiple=True, metavar="NAME",
              help="Analyse only this metric (repeatable).")
@click.option("--questionnaires", type=click.Path(dir_okay=False, path_type=str), default=None,
              help="Questionnaire CSV (NASA-TLX, Likert) analysed alongside.")
@click.option("--seed", type=click.IntRange(min=0), default=None,
              help="Bootstrap seed [default: the plan's].")
def analyze_command(source: str, plan: str, out: str | None, output_format: str,
                    metric_names: tuple[str, ...], questionnaires: str | None, seed: int | None) -> None:
    """Metrics and statistics of a run folder or a metrics table (CSV/Parquet, one row per trial)."""
    from nudgecli.report.analysis import analyze, format_table

    result = analyze(source, plan=plan, out=out, metrics=list(metric_names) or None,
                     questionnaires=questionnaires, seed=seed)
    if output_format == "json":
        echo_json(result.stats)
    elif output_format == "csv":
        click.echo(result.table.to_csv(index=False), nl=False)
    else:
        click.echo(format_table(result.stats))
    info(str(result.out))


# --- plot ----------------------------------------------------------------------------------

@main.command("plot", short_help="Draw the paper's figures of an analysed run.")
@click.argument("run", type=click.Path(path_type=str))
@click.option("--plan", metavar="PLAN", default=None,
              help="Analyse RUN with this plan first (writes metrics.csv and stats.json), then plot.")
@click.option("--out", type=click.Path(file_okay=False, path_type=str), default=None,
              help="Folder for the figures [default: RUN/figures].")
@click.option("--formats", default="png,pdf", show_default=True, help="Comma-separated: png, pdf, svg.")
@click.option("--trial", metavar="PARTICIPANT:TRIAL", default=None,
              help="The trial of Fig. 5 and the trajectory [default: the Disambiguation trial whose "
                   "true-goal belief rose most after a nudge].")
def plot_command(run: str, plan: str | None, out: str | None, formats: str, trial: str | None) -> None:
    """Draw the paper's figures (Fig. 3, 4, 5, a trajectory, questionnaires) of an analysed run."""
    from nudgecli.report.plotting import parse_formats, parse_trial, plot_folder

    chosen, trial_key = parse_formats(formats), parse_trial(trial)
    if plan is not None:
        from nudgecli.report.analysis import analyze

        analyze(run, plan=plan)
    for path in plot_folder(run, out, chosen, trial_key):
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
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=_SET_HELP)
def run_command(experiment: str, out: str | None, seed: int | None, participants: int | None, workers: int,
                plan: str | None, resume: bool, force: bool, overrides: tuple[str, ...]) -> None:
    """Simulate, analyse and plot in one go: EXPERIMENT defaults to the paper preset."""
    from nudgecli.config import list_presets
    from nudgecli.report.analysis import analyze, format_table
    from nudgecli.report.plotting import plot_folder

    run = _simulate(experiment, out, seed, participants, workers, None, resume, force, overrides)
    _print_study_summary(run)
    chosen_plan = plan or (run.experiment if run.experiment in list_presets("analysis") else "paper")
    info(f"analysing with the {chosen_plan!r} plan")
    result = analyze(run.path, plan=chosen_plan)
    click.echo("")
    click.echo(format_table(result.stats))
    written = plot_folder(run.path)
    click.echo("")
    click.echo(f"Statistics: {run.path / 'stats.json'}, {run.path / 'summary.md'}")
    click.echo(f"Figures:    {len(written)} files in {run.path / 'figures'}")
    click.echo(str(run.path))


# --- validate ------------------------------------------------------------------------------


@main.command("validate")
@click.option("--simulations", type=int, default=100, show_default=True,
              help="Random worlds (each queries every state off the goals once).")
@click.option("--min-goals", type=int, default=3, show_default=True, help="Fewest goals |G| (at least 2).")
@click.option("--max-goals", type=int, default=30, show_default=True,
              help="Most goals |G|; |G| steps cyclically from --min-goals to --max-goals.")
@click.option("--states", type=int, default=200, show_default=True,
              help="|S| = 2 modes x W x H cells (200: a 10 x 10 grid).")
@click.option("--seed", type=int, default=0, show_default=True, help="Master seed of the whole validation.")
@click.option("--belief-concentration", type=float, default=1.0, show_default=True,
              help="Query beliefs are Dirichlet(c): 1 spreads them evenly, large c makes them near uniform.")
@click.option("--mc-queries", type=int, default=100, show_default=True,
              help="Queries of the Monte-Carlo convergence study (0 skips it).")
@click.option("--out", "out", type=click.Path(file_okay=False, path_type=str), default=None,
              help="Folder for validation.json, validation.csv (per query) and validation.png/.pdf.")
@click.option("--format", "output_format", type=click.Choice(["table", "json"]), default="table",
              show_default=True, help="What to print on stdout.")
def validate_command(simulations: int, min_goals: int, max_goals: int, states: int, seed: int,
                     belief_concentration: float, mc_queries: int, out: str | None,
                     output_format: str) -> None:
    """The paper's simulation-based validation of D(s): its argmax vs a one-step ground truth."""
    import time

    from nudgecli.sim.validation import (
        ValidationSettings,
        format_summary,
        run_validation,
        save_validation,
    )

    settings = ValidationSettings(simulations=simulations, min_goals=min_goals, max_goals=max_goals,
                                  states=states, seed=seed, mc_queries=mc_queries,
                                  belief_concentration=belief_concentration).check()
    start = time.perf_counter()
    bar, update = _progress_bar("validating", unit="simulation")
    try:
        result = run_validation(settings, progress=update)
    finally:
        bar.close()
    info(f"validation: {simulations} simulations in {time.perf_counter() - start:.1f} s")
    summary = result.summary()
    if out is not None:
        from nudgecli.report.validation_figure import plot_validation

        save_validation(result, out)
        plot_validation(summary, out)
    if output_format == "json":
        echo_json(summary)
    else:
        click.echo(format_summary(summary))
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


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
