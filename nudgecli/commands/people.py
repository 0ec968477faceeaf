"""``nudge fit-people``: twins of real people from their logs (a people file for ``--people``)."""

from __future__ import annotations

from pathlib import Path

import click

from nudgecli.commands.common import info


@click.command("fit-people", short_help="Twins of real people: a people file from their logs or habits.")
@click.argument("sources", nargs=-1, required=True, type=click.Path(path_type=str))
@click.option("--out", "out", required=True, type=click.Path(dir_okay=False, path_type=str),
              help="The people file to write (CSV), read by simulate, run, replicate and power --people.")
def fit_people_command(sources: tuple[str, ...], out: str) -> None:
    """One simulated person per participant of SOURCE...: a real log (the CSV nudge habits reads), a run
    folder, or a table of `nudge habits --by participant --format csv`. Each timing parameter is set
    from the participant's own habit medians by the documented offsets (docs/people.md); one their
    source lacks is left to the population's draw, and the file's from_population column says so."""
    from nudgecli.outputs import declare_input
    from nudgecli.report.twin_sources import twins_of_sources
    from nudgecli.sim.people_file import people_csv
    from nudgecli.store import check_writable, write_text_atomic

    declare_input("SOURCE", *sources)  # --out never replaces a source
    target = Path(out)
    check_writable(target.parent if str(target.parent) else Path.cwd())
    twins = twins_of_sources(list(sources))
    write_text_atomic(target, people_csv(twins))
    for person, twin in enumerate(twins):
        drawn = ", ".join(twin.from_population) or "-"
        click.echo(f"person {person}: {twin.source} participant {twin.participant}: "
                   f"{len(twin.parameters)} parameter(s) from their habits; from the population: {drawn}")
    info(f"People file: {target}")


#: The commands of this module, registered on ``nudge`` by :mod:`nudgecli.cli`.
COMMANDS = (fit_people_command,)
