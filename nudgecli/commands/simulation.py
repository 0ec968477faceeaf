"""Commands that simulate or run a study: ``fit``, ``simulate``, ``run`` (simulate, analyse and
plot) and ``study`` (a person in the loop)."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

from nudgecli import command_defaults as defaults
from nudgecli.commands.common import INTERRUPT_HINT, PEOPLE_HELP, SET_HELP, YES_HELP, info, progress_bar

# --- fit -----------------------------------------------------------------------------------

@click.command("fit")
@click.argument("calibration_dir", type=click.Path(file_okay=False))
@click.option("--out", "out", type=click.Path(dir_okay=False), default=None,
              help="Profile JSON to write [default: ./<folder name>.profile.json].")
@click.option("--force", is_flag=True, help="Replace the profile --out names if it exists.")
@click.option("--variant", default=defaults.AUTO_VARIANT, show_default=True,
              type=click.Choice([defaults.AUTO_VARIANT, defaults.PILOT_VARIANT, defaults.CIAA_VARIANT]),
              help="Log format of the p(phi_m | phi_i) stream: pilot (fixed 10 Hz, neutral label 'None'), "
                   "ciaa (the sibling study's event-driven stream, neutral label 'Zero Band'), or auto "
                   "(detect from the neutral label, else from the message timing).")
def fit_command(calibration_dir: str, out: str | None, force: bool, variant: str) -> None:
    """Fit p(phi_i | a) and p(phi_m | phi_i) from one participant's calibration logs.

    CALIBRATION_DIR holds p_phi_given_a/ and/or p_phm_given_phi/ (the study's export; the sibling
    study's <id>_p_ui_given_a/ and <id>_p_um_given_ui/ too) or the tidy files of a simulated
    session. A missing session falls back to the default table.
    """

    from nudgecli.api.fitting import fit

    folder = Path(calibration_dir)
    target = Path(out) if out is not None else Path.cwd() / f"{folder.resolve().name}.profile.json"
    result = fit(folder, out=target, force=force, variant=variant)
    for warning in result.warnings:
        info(f"Warning: {warning}")
    click.echo(result.summary)
    info(str(target))


def _interrupt_hint(target: Path, people: str | None,
                    resume_commands: Callable[[str | None, str | None], list[str]]) -> Callable[[], str]:
    """What to say after Ctrl-C of a simulation into ``target``: the commands that resume it
    (``resume_commands`` of the ``--people`` they name: the copy the folder keeps where it has
    been written, else ``people`` as typed; and of the experiment the run's folder keeps in place
    of the one typed, :meth:`~nudgecli.run_folder_record.RunRecord.resume_experiment`)."""

    def hint() -> str:
        from nudgecli.api.resuming import people_to_resume
        from nudgecli.errors import NudgeError
        from nudgecli.store import RunFolder

        run = RunFolder(target)
        if run.is_run():
            done = len(run.completed_participants())
            try:  # a run of its own policies: its config.toml, which imports the copies
                kept = run.resume_experiment(run.read_manifest())
            except NudgeError:
                kept = None
            commands = resume_commands(people_to_resume(target, people), kept)
            return f"{target} keeps its {done} finished participant(s); resume with: {_offered(commands)}"
        if target.is_dir() and any(target.iterdir()):  # its start is written: a plain rerun is refused
            commands = resume_commands(people_to_resume(target, people), None)
            return (f"nothing was simulated yet; {target} holds the run's start: continue with: "
                    f"{_offered(commands)}")
        return "nothing was simulated yet; run the command again"

    return hint


def _offered(commands: list[str]) -> str:
    """The resume commands a Ctrl-C hint offers: the first (``nudge simulate``), then each other one
    (``nudge run``'s, which analyses and plots too) as an alternative."""
    return commands[0] + "".join(f" (or, to analyse and plot too: {c})" for c in commands[1:])


def _simulate(experiment: str, out: str | None, seed: int | None, participants: int | None, workers: int,
              scheduler: str | None, resume: bool, force: bool, overrides: tuple[str, ...],
              plan: str | None = None, command: str = "simulate", confirm: bool = False,
              people: str | None = None) -> Any:

    from click.core import ParameterSource

    from nudgecli import api
    from nudgecli.commands.scheduler_choice import chosen_scheduler
    from nudgecli.run_folder_config import kept_run_people
    from nudgecli.store import default_run_dir, simulate_resume_command

    ctx = click.get_current_context()
    # the resume command names the --scheduler typed; one from DASK_SCHEDULER_ADDRESS is there again for
    # it (as the batch commands' resume commands do), and --workers still wins over it
    typed = scheduler if ctx.get_parameter_source("scheduler") is ParameterSource.COMMANDLINE else None
    # and the --workers typed, 1 too: with the variable set for the rerun, it would run on its scheduler
    typed_workers = workers if ctx.get_parameter_source("workers") is ParameterSource.COMMANDLINE else None
    scheduler = chosen_scheduler(ctx, scheduler)  # --workers wins over the variable
    config = api.experiment_config(experiment, overrides, out=out)  # out's own files checked as kept
    people = kept_run_people(experiment, people, info)  # a run's config.toml: the people file it keeps
    target = Path(out) if out else default_run_dir(config.experiment.name)
    if command == "run" and plan is None:  # the plan `run` analyses with, refused before simulating
        from nudgecli.api.run_plan import check_run_plan

        check_run_plan(config, target if resume else None)

    def resume_commands(people_named: str | None, kept: str | None = None) -> list[str]:
        named, sets = (kept, ()) if kept else (experiment, overrides)  # the kept one holds the --set values
        commands = [simulate_resume_command(named, target, seed, participants, typed_workers, sets,
                                            confirm=confirm, people=people_named, scheduler=typed)]
        if command != "simulate":
            commands.append(simulate_resume_command(named, target, seed, participants, typed_workers, sets,
                                                    command, confirm, people_named, plan, scheduler=typed))
        return commands

    ctx.meta[INTERRUPT_HINT] = _interrupt_hint(target, people, resume_commands)
    bar, update = progress_bar("simulating")
    try:
        return api.simulate(config, out=target, seed=seed, participants=participants, workers=workers,
                            scheduler=scheduler, resume=resume, force=force, progress=update, plan=plan,
                            confirm=confirm, people=people, log=info)
    except BaseException:
        if not out and target.is_dir() and not any(target.iterdir()):
            target.rmdir()  # the default folder made for this run, still empty: leave nothing behind
        raise
    finally:
        bar.close()


def _print_study_summary(run: Any) -> None:
    click.echo(run.report())


#: ``--scheduler`` of ``nudge simulate`` and ``nudge run``: where their simulation runs.
_scheduler_option = click.option(
    "--scheduler", envvar="DASK_SCHEDULER_ADDRESS",
    help="dask.distributed scheduler address (or DASK_SCHEDULER_ADDRESS, unless --workers is given); needs "
         "nudgecli[cluster].")


@click.command("simulate")
@click.argument("experiment")
@click.option("--out", type=click.Path(file_okay=False),
              help="Run folder [default: results/<experiment>-<UTC time>].")
@click.option("--seed", type=int, help="Master seed [default: the experiment's].")
@click.option("--participants", type=int, help="Number of participants [default: the experiment's].")
@click.option("--workers", type=int, default=1, show_default=True, help="Local worker processes.")
@_scheduler_option
@click.option("--resume", is_flag=True, help="Finish an interrupted run in --out (same experiment and seed).")
@click.option("--force", is_flag=True, help="Replace a run that already is in --out.")
@click.option("--yes", is_flag=True, help=YES_HELP)
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=SET_HELP)
@click.option("--people", metavar="PEOPLE.csv", default=None, help=PEOPLE_HELP)
def simulate_command(experiment: str, out: str | None, seed: int | None, participants: int | None,
                     workers: int, scheduler: str | None, resume: bool, force: bool, yes: bool,
                     overrides: tuple[str, ...], people: str | None) -> None:
    """Simulate a study: EXPERIMENT is a preset (`nudge presets` lists them) or a TOML file."""
    run = _simulate(experiment, out, seed, participants, workers, scheduler, resume, force, overrides,
                    confirm=yes, people=people)
    _print_study_summary(run)
    click.echo(f"Run folder: {run.path}", err=True)
    click.echo(str(run.path))


# --- run -----------------------------------------------------------------------------------

@click.command("run")
@click.argument("experiment", default="paper")
@click.option("--out", type=click.Path(file_okay=False),
              help="Run folder [default: results/<experiment>-<UTC time>].")
@click.option("--seed", type=int, help="Master seed [default: the experiment's].")
@click.option("--participants", type=int, help="Number of participants [default: the experiment's].")
@click.option("--workers", type=int, default=1, show_default=True, help="Local worker processes.")
@_scheduler_option
@click.option("--plan", metavar="PLAN", default=None,
              help="Analysis plan [default: the plan named like the experiment, else its world's, else "
                   "paper].")
@click.option("--resume", is_flag=True, help="Finish an interrupted run in --out.")
@click.option("--force", is_flag=True, help="Replace a run that already is in --out.")
@click.option("--yes", is_flag=True, help=YES_HELP)
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=SET_HELP)
@click.option("--people", metavar="PEOPLE.csv", default=None, help=PEOPLE_HELP)
def run_command(experiment: str, out: str | None, seed: int | None, participants: int | None, workers: int,
                scheduler: str | None, plan: str | None, resume: bool, force: bool, yes: bool,
                overrides: tuple[str, ...], people: str | None) -> None:
    """Simulate, analyse and plot in one go: EXPERIMENT defaults to the paper preset."""
    from nudgecli import api
    from nudgecli.run_folder_names import FIGURES_DIR, STATS_JSON, SUMMARY_MD

    if plan is not None and Path(plan).suffix.lower() == ".toml":
        plan = str(Path(plan).resolve())
    run = _simulate(experiment, out, seed, participants, workers, scheduler, resume, force, overrides,
                    plan=plan, command="run", confirm=yes, people=people)
    _print_study_summary(run)
    result, written = api.analyze_and_plot(run, plan=plan, log=info)  # its notes too, as Note: lines
    click.echo("")
    click.echo(result.table())
    click.echo("")
    click.echo(f"Statistics: {run.path / STATS_JSON}, {run.path / SUMMARY_MD}")
    click.echo(f"Figures:    {len(written)} files in {run.path / FIGURES_DIR}")
    click.echo(str(run.path))


# --- study (a person in the loop) ---------------------------------------------------------


@click.command("study")
@click.argument("experiment")
@click.option("--participant", "participant_id", required=True, metavar="ID",
              help="Participant ID ending in their number, e.g. P01 (the number seeds their schedule).")
@click.option("--port", type=click.IntRange(1, 65535), default=defaults.STUDY_PORT, show_default=True,
              help="Port on 127.0.0.1.")
@click.option("--out", type=click.Path(file_okay=False),
              help="Run folder, shared by the participants of one study "
                   "[default: results/<experiment>-live].")
@click.option("--condition-order", metavar="A,B,...",
              help="The order of the conditions' blocks, e.g. control,disambiguation: any order the "
                   "experiment's [study] counterbalancing design assigns, another participant's included "
                   "[default: the order it assigns this participant's number].")
@click.option("--seed", type=int, help="Master seed [default: the experiment's].")
@click.option("--resume", is_flag=True, help="Continue this participant's session at their next trial.")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=SET_HELP)
def study_command(experiment: str, participant_id: str, port: int, out: str | None,
                  condition_order: str | None, seed: int | None, resume: bool,
                  overrides: tuple[str, ...]) -> None:
    """Run one participant's session in a browser page served on 127.0.0.1 (needs nudgecli[study])."""
    from nudgecli.live.app import run_live_study

    session = run_live_study(experiment, participant_id, port=port, out=out, condition_order=condition_order,
                             seed=seed, resume=resume, overrides=overrides, announce=click.echo, log=info)
    if session.phase != "done":
        sys.exit(130)  # interrupted (Ctrl-C) before the participant finished


#: The commands of this module, registered on ``nudge`` by :mod:`nudgecli.cli`.
COMMANDS = (fit_command, simulate_command, run_command, study_command)
