"""``nudge presets``, ``nudge bench`` and ``nudge validate`` (the paper's validation of D(s))."""

from __future__ import annotations

import os
from pathlib import Path

import click

import nudgecli
from nudgecli import command_defaults as defaults
from nudgecli.commands.common import FORCE_HELP, comma_integers, echo_json, info, progress_bar

# --- presets -------------------------------------------------------------------------------

@click.command("presets")
def presets_command() -> None:
    """List the shipped experiments and analysis plans."""
    from nudgecli.api.presets import PRESET_KINDS, presets

    table = presets()
    # one column for both headings, as wide as the longest name (custom-policy is 13 letters)
    width = max((len(name) for name in table["name"]), default=0)
    for kind, title in PRESET_KINDS.items():
        click.echo(f"{title}:")
        for row in table[table["kind"] == kind].itertuples(index=False):
            click.echo(f"  {row.name:<{width}} {row.description}")


# --- bench ---------------------------------------------------------------------------------


@click.command("bench")
@click.option("--format", "output_format", type=click.Choice(["table", "json"]), default="table",
              show_default=True, help="What to print on stdout.")
@click.option("--only", type=click.Choice(["model", "study", "scale", "pipeline", "analyze", "all"]),
              default="all",
              show_default=True,
              help="Which figures: the model's (a few seconds), the study's (about 10-15 s: plan, trials, "
                   "the paper-scale study with 2 workers in a subprocess), both (all); only when asked: "
                   "the scale figures (about a minute on 2 cores: batches on 1..cores workers and on a "
                   "local dask cluster, with parallel efficiency and serial fraction), pipeline "
                   "(`replicate paper -R 4` and `-R 20` end to end against the trial loop's own speed: "
                   "pipeline efficiency and trials an hour; then `power paper --participants "
                   "6,9,12,18,24 -R 50`; about three and a half minutes) or analyze "
                   "(`nudge analyze` of a 3.5 M-row table in a subprocess, about a minute).")
@click.option("--scale-participants", type=click.IntRange(min=2), default=defaults.BENCH_SCALE_PARTICIPANTS,
              show_default=True,
              help="Scale figures: participants of the one-study workload (paper preset).")
@click.option("--scale-studies", type=click.IntRange(min=2), default=defaults.BENCH_SCALE_STUDIES,
              show_default=True,
              help="Scale figures: studies of the many-studies workload (smoke preset).")
@click.option("--scale-workers", metavar="N,N,...", default=None,
              help="Scale figures: the worker counts to time, e.g. 1,2,4,8,16 (1 is always timed: every "
                   "efficiency is against it) [default: every count from 1 to the cores].")
@click.option("--repeats", type=click.IntRange(min=1), default=defaults.BENCH_REPEATS, show_default=True,
              help="Batches of each fast measurement (the best is reported).")
@click.option("--baseline-repeats", type=click.IntRange(min=1), default=defaults.BENCH_BASELINE_REPEATS,
              show_default=True,
              help="Runs of each per-sample Monte-Carlo baseline, about 1 s each (the best is reported).")
@click.option("--study-repeats", type=click.IntRange(min=1), default=defaults.BENCH_STUDY_REPEATS,
              show_default=True,
              help="Runs of the study plan build and of one participant's trials, about 1 s each "
                   "(the best is reported).")
def bench_command(output_format: str, only: str, scale_participants: int, scale_studies: int,
                  scale_workers: str | None, repeats: int, baseline_repeats: int, study_repeats: int) -> None:
    """Performance figures of the model and the study, each against a baseline measured in the same run."""
    from nudgecli.bench import BenchOptions, format_table, run_bench, select_figures
    from nudgecli.bench.common import uncompiled_modules_warning

    warning = uncompiled_modules_warning(Path(nudgecli.__file__).parent, os.environ)
    if warning is not None:
        info(warning)
    options = BenchOptions(repeats=repeats, baseline_repeats=baseline_repeats, study_repeats=study_repeats,
                           scale_participants=scale_participants, scale_studies=scale_studies)
    if only != "scale":  # the scale options time only the scale figures: refused, not ignored
        source = click.get_current_context().get_parameter_source
        scale_options = ("scale_workers", "scale_participants", "scale_studies")
        given = [f"--{name.replace('_', '-')}" for name in scale_options
                 if source(name) is click.core.ParameterSource.COMMANDLINE]
        if given:
            raise click.UsageError(f"{given[0]} times the scale figures: add --only scale")
    counts = None if scale_workers is None else comma_integers(scale_workers, "--scale-workers", "1,2,4,8,16")
    rows = run_bench(options, figures=select_figures(only, counts), progress=info)
    if output_format == "json":
        echo_json(rows)
    else:
        click.echo(format_table(rows))


# --- validate ------------------------------------------------------------------------------


def _validation_readings() -> list[str]:
    """The names of the validation's readings (for ``--reading``'s choices)."""
    from nudgecli.api.validation import reading_names

    return reading_names()


@click.command("validate")
@click.option("--simulations", type=int, default=defaults.VALIDATION_SIMULATIONS, show_default=True,
              help="Random worlds (each queries every state off the goals once).")
@click.option("--min-goals", type=int, default=defaults.VALIDATION_MIN_GOALS,
              show_default=True, help="Fewest goals |G| (at least 2).")
@click.option("--max-goals", type=int, default=defaults.VALIDATION_MAX_GOALS, show_default=True,
              help="Most goals |G|; |G| steps cyclically from --min-goals to --max-goals.")
@click.option("--states", type=int, default=None,
              help="|S| = 2 modes x W x H cells of the two-mode world; not for --reading three-mode, "
                   f"whose world is the study's [default: {defaults.VALIDATION_STATES}, a 10 x 10 grid].")
@click.option("--seed", type=int, default=defaults.VALIDATION_SEED, show_default=True,
              help="Master seed of the whole validation.")
@click.option("--belief-concentration", type=float, default=None,
              help="Query beliefs are Dirichlet(c): 1 spreads them evenly, large c makes them near uniform; "
                   "not for --reading two-goal, whose beliefs are split between two goals "
                   f"[default: {defaults.VALIDATION_BELIEF_CONCENTRATION:g}].")
@click.option("--mc-queries", type=int, default=None,
              help="Queries of the Monte-Carlo convergence study (0 skips it; --all-readings skips it, "
                   "and a value given beside it is said unused) "
                   f"[default: {defaults.VALIDATION_MC_QUERIES}].")
@click.option("--reading", type=click.Choice(list(_validation_readings())),
              default=defaults.VALIDATION_READING,
              show_default=True,
              help="Which reading of the paper's validation paragraph (docs/findings.md describes each).")
@click.option("--all-readings", is_flag=True,
              help="Run every reading on the same worlds and print one row per reading, by |G|.")
@click.option("--out", "out", type=click.Path(file_okay=False, path_type=str), default=None,
              help="Folder for validation.json, validation.csv (per query) and validation.png/.pdf "
                   "(readings.json with --all-readings).")
@click.option("--format", "output_format", type=click.Choice(["table", "json"]), default="table",
              show_default=True, help="What to print on stdout.")
@click.option("--yes", is_flag=True,
              help="Run more queries than the size limit allows (docs/reliability.md).")
@click.option("--force", is_flag=True, help=FORCE_HELP)
def validate_command(simulations: int, min_goals: int, max_goals: int, states: int | None, seed: int,
                     belief_concentration: float | None, mc_queries: int | None, reading: str,
                     all_readings: bool, out: str | None, output_format: str, yes: bool, force: bool) -> None:
    """The paper's simulation-based validation of D(s): its argmax vs a one-step ground truth."""
    import time

    from nudgecli.api.validation import READINGS_EXCLUDE, validate

    if all_readings and reading != defaults.VALIDATION_READING:
        raise click.UsageError(READINGS_EXCLUDE)  # a usage error here (exit 2), a NudgeError in the API
    start = time.perf_counter()
    bar, update = progress_bar("validating", unit="simulation")
    try:
        result = validate(simulations=simulations, min_goals=min_goals, max_goals=max_goals, states=states,
                          seed=seed, belief_concentration=belief_concentration, mc_queries=mc_queries,
                          reading=reading, all_readings=all_readings, out=out, force=force, yes=yes,
                          progress=update, log=info)
    finally:
        bar.close()
    runs = len(result.results)
    info(f"validation: {simulations * runs} simulations in {time.perf_counter() - start:.1f} s")
    if output_format == "json":
        echo_json(result.to_json())
    else:
        click.echo(result.text())
    if out is not None:
        info(str(out))


#: The commands of this module, registered on ``nudge`` by :mod:`nudgecli.cli`.
COMMANDS = (presets_command, bench_command, validate_command)
