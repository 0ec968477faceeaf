"""``nudge fit-people``: twins of real people from their logs (a people file for ``--people``)."""

from __future__ import annotations

from pathlib import Path

import click

from nudgecli.commands.common import info


@click.command("fit-people", short_help="Twins of real people: a people file from their logs or habits.")
@click.argument("sources", nargs=-1, required=True, type=click.Path(path_type=str))
@click.option("--out", "out", required=True, type=click.Path(dir_okay=False, path_type=str),
              help="The people file to write (CSV), read by simulate, run, replicate and power --people.")
@click.option("--force", is_flag=True, help="Replace the people file --out names if it exists.")
def fit_people_command(sources: tuple[str, ...], out: str, force: bool) -> None:
    """One simulated person per participant of SOURCE...: a real log (the CSV nudge habits reads), a run
    folder, or a table of `nudge habits --by participant --format csv`. Each timing parameter is set
    from the participant's own habit medians by the documented offsets (docs/people.md); one their
    source lacks is left to the population's draw, and the file's from_population column says so."""
    from nudgecli.api.fitting import fit_people

    people = fit_people(list(sources), out=out, force=force, log=info)
    click.echo(people.text())
    info(f"People file: {Path(out)}")


#: The commands of this module, registered on ``nudge`` by :mod:`nudgecli.cli`.
COMMANDS = (fit_people_command,)
