"""Batch commands: ``replicate``, ``power`` and ``sweep`` (many studies, resumable, on local
workers or a dask cluster)."""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

from nudgecli import command_defaults as defaults
from nudgecli.commands.common import INTERRUPT_HINT, PEOPLE_HELP, SET_HELP, comma_integers, echo_json, info

# --- replicate / power / sweep -------------------------------------------------------------

def _batch_options(func: Any, out_default: str = "results/<experiment>-<command>-<UTC time>") -> Any:
    """The options every batch command shares (executor, output folder, resume, size check);
    ``out_default`` is the folder ``--out`` defaults to, as its help shows it."""
    options = [
        click.option("--out", type=click.Path(file_okay=False),
                     help=f"Batch folder [default: {out_default}]."),
        click.option("--workers", type=int, default=1, show_default=True, help="Local worker processes."),
        click.option("--scheduler", envvar="DASK_SCHEDULER_ADDRESS",
                     help="dask.distributed scheduler address (or DASK_SCHEDULER_ADDRESS, unless --workers "
                          "is given); needs nudgecli[cluster]."),
        click.option("--resume", is_flag=True, help="Finish an interrupted batch in --out (same settings)."),
        click.option("--force", is_flag=True, help="Replace a batch that already is in --out."),
        click.option("--yes", is_flag=True, help="Run a batch above the size limit (docs/batches.md)."),
        click.option("--format", "output_format", type=click.Choice(["table", "json", "csv"]),
                     default="table", show_default=True, help="What to print on stdout."),
    ]
    for option in reversed(options):
        func = option(func)
    return func


def _run_batch_command(label: str, run: Any, out: str | None, default_name: str, output_format: str,
                       **kwargs: Any) -> None:
    from nudgecli.api import progress_line
    from nudgecli.commands.scheduler_choice import chosen_scheduler
    from nudgecli.store import default_run_dir

    ctx = click.get_current_context()
    kwargs["scheduler"] = chosen_scheduler(ctx, kwargs["scheduler"])  # --workers wins over the environment
    target = Path(out) if out else default_run_dir(default_name)
    ctx.meta[INTERRUPT_HINT] = _batch_interrupt_hint(target, ctx)
    # the progress line (rate and ETA) is for a person: where a script reads stdout (json, csv), only on a
    # terminal, as the other commands' progress bars
    progress = progress_line(label) if output_format == "table" or sys.stderr.isatty() else None
    try:
        result = run(out=target, progress=progress, log=info, **kwargs)
    except BaseException:
        if not out and target.is_dir() and not any(target.iterdir()):
            target.rmdir()  # the default folder made for this batch, still empty: leave nothing behind
        raise
    table = result.summary
    if output_format == "json":
        # every value as it is (a p of 3e-14 is not 0.0), through the strict JSON every --format json prints
        echo_json(table.to_dict(orient="records"))
    elif output_format == "csv":
        click.echo(table.to_csv(index=False), nl=False)
    else:
        click.echo(result.text())
    info(f"Batch folder: {result.path} ({result.computed} tasks computed now)")
    if output_format == "table":  # under json/csv stdout is the document alone (the folder is on stderr)
        click.echo(str(result.path))


def rerun_command(ctx: click.Context, target: Path, people: str | None = None) -> str:
    """The command line that resumes the interrupted command of ``ctx`` into ``target``
    (:func:`nudgecli.api.resuming.typed_resume_command`): its arguments and the options given on the
    command line as typed (``--people`` naming ``people`` where given)."""
    from click.core import ParameterSource

    from nudgecli.api.resuming import typed_resume_command

    arguments: list[tuple[str, str]] = []
    options: list[tuple[str, list[str]]] = []
    for param in ctx.command.params:
        name = param.name or ""
        value = people if name == "people" and people is not None else ctx.params.get(name)
        if isinstance(param, click.Argument):
            arguments.append((name, str(value)))
            continue
        if ctx.get_parameter_source(name) is not ParameterSource.COMMANDLINE:
            continue
        flag = max(param.opts, key=len)  # the long name: --replications, not -R
        if getattr(param, "is_flag", False):
            options.append((name, [flag] if value else []))
        elif getattr(param, "multiple", False):
            options.append((name, [word for item in value or () for word in (flag, str(item))]))
        else:
            options.append((name, [flag, str(value)]))
    return typed_resume_command(target, ctx.info_name or ctx.command.name or "", arguments, options)


def _batch_interrupt_hint(target: Path, ctx: click.Context) -> Callable[[], str]:
    """What to say after Ctrl-C of the batch command of ``ctx`` into ``target``: the command that
    resumes it, naming the copy of ``--people`` the folder keeps where it has been written (else
    the file as typed), and on a line of its own the folder to run it from where the experiment
    names a recording by a relative path (:func:`nudgecli.api.resuming.recordings_base`); where the
    folder holds no batch, or only one a ``--force`` was removing (:func:`nudgecli.api.holds_batch`),
    that nothing was computed yet."""

    def hint() -> str:
        from nudgecli.api import holds_batch
        from nudgecli.api.resuming import people_to_resume, recordings_base

        if holds_batch(target):
            command = rerun_command(ctx, target, people_to_resume(target, ctx.params.get("people")))
            base = recordings_base(target)
            where = "" if base is None else (f"\n(run it from {base}: population.physiology_logs names its "
                                             "recordings by paths relative to that folder)")
            return f"{target} keeps its finished tasks; resume with: {command}{where}"
        return "nothing was computed yet; run the command again"

    return hint


def _experiment_name(experiment: str) -> str:
    return Path(experiment).stem if experiment.endswith(".toml") else experiment


@click.command("replicate")
@click.argument("experiment")
@click.option("--replications", "-R", type=int, required=True,
              help="Independent studies (each its own seed).")
@click.option("--seed", type=int, help="Master seed of the replications [default: the experiment's].")
@click.option("--plan", default=None, metavar="PLAN",
              help="Analysis plan of each study [default: the plan named like the experiment, else its "
                   "world's, else paper].")
@click.option("--participants", type=int, help="Participants per study [default: the experiment's].")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=SET_HELP)
@click.option("--people", metavar="PEOPLE.csv", default=None, help=PEOPLE_HELP)
@_batch_options
def replicate_command(experiment: str, replications: int, seed: int | None, plan: str | None,
                      participants: int | None, overrides: tuple[str, ...], people: str | None,
                      out: str | None, workers: int, scheduler: str | None, resume: bool, force: bool,
                      yes: bool, output_format: str) -> None:
    """R independent studies of EXPERIMENT: how often each difference is significant, the pooled effect."""
    from nudgecli.api import replicate

    _run_batch_command("replicate", replicate, out, f"{_experiment_name(experiment)}-replicate",
                       output_format,
                       experiment=experiment, replications=replications, seed=seed, plan=plan,
                       participants=participants, overrides=overrides, workers=workers, scheduler=scheduler,
                       resume=resume, force=force, confirm=yes, people=people)


@click.command("power")
@click.argument("experiment")
@click.option("--participants", "counts", required=True, metavar="N,N,...",
              help="Participant counts, e.g. 6,9,12,18,24.")
@click.option("--replications", "-R", type=int, required=True, help="Studies per count.")
@click.option("--seed", type=int, help="Master seed of the replications [default: the experiment's].")
@click.option("--plan", default=None, metavar="PLAN",
              help="Analysis plan of each study [default: the plan named like the experiment, else its "
                   "world's, else paper].")
@click.option("--target", type=click.FloatRange(0, 1, min_open=True, max_open=True),
              default=defaults.POWER_TARGET, show_default=True,
              help="The power to reach (smallest_n.csv), strictly between 0 and 1.")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=SET_HELP)
@click.option("--people", metavar="PEOPLE.csv", default=None, help=PEOPLE_HELP)
@_batch_options
def power_command(experiment: str, counts: str, replications: int, seed: int | None, plan: str | None,
                  target: float, overrides: tuple[str, ...], people: str | None, out: str | None,
                  workers: int, scheduler: str | None, resume: bool, force: bool, yes: bool,
                  output_format: str) -> None:
    """Power curves: the chance of a significant difference in the paper's direction per participant count."""
    from nudgecli.api import power

    counted = comma_integers(counts, "--participants", "6,9,12,18,24")
    _run_batch_command("power", power, out, f"{_experiment_name(experiment)}-power", output_format,
                       experiment=experiment, participants=counted,
                       replications=replications, seed=seed, plan=plan, overrides=overrides, target=target,
                       workers=workers, scheduler=scheduler, resume=resume, force=force, confirm=yes,
                       people=people)


@click.command("sweep")
@click.argument("sweep_file")
@click.option("--replications", "-R", type=int, help="Studies per design point [default: the file's].")
@click.option("--seed", type=int, help="Master seed of the replications [default: the file's].")
@functools.partial(_batch_options, out_default="results/<sweep file>-sweep-<UTC time>")
def sweep_command(sweep_file: str, replications: int | None, seed: int | None, out: str | None, workers: int,
                  scheduler: str | None, resume: bool, force: bool, yes: bool, output_format: str) -> None:
    """Run a sweep file (grid, Sobol or Morris design over experiment keys); see docs/batches.md
    for the format."""
    from nudgecli.api import sweep

    _run_batch_command("sweep", sweep, out, f"{_experiment_name(sweep_file)}-sweep", output_format,
                       sweep_file=sweep_file, replications=replications, seed=seed, workers=workers,
                       scheduler=scheduler, resume=resume, force=force, confirm=yes)


#: The commands of this module, registered on ``nudge`` by :mod:`nudgecli.cli`.
COMMANDS = (replicate_command, power_command, sweep_command)
