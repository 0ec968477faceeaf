"""``nudgecli.fit`` and ``nudgecli.fit_people``: a participant's calibration profile from their logs,
and twins of real people (a people file) from their logs or habits.

The work is :func:`nudgecli.sim.calibration_profile.fit_calibration_dir`'s and
:func:`nudgecli.report.twin_sources.twins_of_sources`'s; ``nudge fit`` and ``nudge fit-people``
call them through this module and print what it returns.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import pandas as pd

    from nudgecli.api.run import Run
    from nudgecli.sim.calibration_profile import CalibrationProfile


def _check_out_writable(target: Path) -> None:
    """Fail now, before the sources are read, if ``target`` cannot be written, making no folder: a
    missing folder of it is checked at the nearest folder above that exists, and made only when
    ``target`` is written (a failed call leaves nothing behind)."""
    from nudgecli.store import check_writable

    folder = target.absolute().parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    check_writable(folder)


def fit(calibration_dir: str | Path, *, out: str | Path | None = None, force: bool = False,
        variant: str = "auto") -> CalibrationProfile:
    """Fit p(phi_i | a) and p(phi_m | phi_i) from one participant's calibration logs, as ``nudge fit``.

    Parameters
    ----------
    calibration_dir
        The folder of the logs: ``p_phi_given_a/`` and/or ``p_phm_given_phi/`` (the sibling
        study's ``<id>_p_ui_given_a/`` and ``<id>_p_um_given_ui/`` too) or a simulated session's
        tidy files. A missing session falls back to the default table.
    out
        The profile JSON to write; ``None`` writes nothing (``nudge fit``'s default is
        ``./<folder name>.profile.json``).
    force
        Replace an existing ``out``.
    variant
        ``auto``, ``pilot`` or ``ciaa``: the log format of the p(phi_m | phi_i) stream; anything
        else is refused before the logs are read.

    Returns
    -------
    CalibrationProfile
        ``.profile`` (the JSON document), ``.summary`` (the text ``nudge fit`` prints) and
        ``.warnings`` (one line each, what ``nudge fit`` prints as ``Warning:`` lines).

    Raises
    ------
    NudgeError
        An existing ``out`` without ``force``, an ``out`` that is one of the logs, an unwritable
        folder, unreadable logs; checked before anything is written.
    """
    from nudgecli.api import arguments
    from nudgecli.errors import ConfigError
    from nudgecli.outputs import check_output_file, command_inputs, declare_input
    from nudgecli.sim.calibration_io import AUTO_VARIANT, LOG_VARIANTS
    from nudgecli.sim.calibration_profile import fit_calibration_dir, write_profile

    folder = Path(arguments.path("calibration_dir", calibration_dir))
    out = arguments.path("out", out, optional=True)
    force = arguments.switch("force", force)
    variant = arguments.text("variant", variant)
    if variant not in (AUTO_VARIANT, *LOG_VARIANTS):  # else unread where no session uses it
        raise ConfigError(f"variant={variant!r}: choose {', '.join((AUTO_VARIANT, *LOG_VARIANTS))} "
                          "(nudge fit --variant)")
    with command_inputs():  # the logs are this call's inputs only
        if out is not None:
            declare_input("CALIBRATION_DIR", *(folder.rglob("*") if folder.is_dir() else ()))  # never out
            check_output_file(out, force=force)  # a profile fitted before is replaced only with force
            _check_out_writable(Path(out))
        result = fit_calibration_dir(folder, variant)
        if out is not None:
            write_profile(result.profile, Path(out))
    return result


@dataclass(frozen=True)
class FittedPeople:
    """The twins :func:`fit_people` made, with the text ``nudge fit-people`` prints.

    Attributes
    ----------
    table
        ``(P, columns)``: the people file's rows (:data:`nudgecli.sim.people_file.PEOPLE_COLUMNS`):
        ``person``, ``source``, ``participant`` (text), one float column per parameter (NaN where
        the population's draw is used) and ``from_population`` (those parameters' names, ``;``
        between them).
    fitted
        ``(P,)``: how many parameters each person has from their own habits.
    files
        The people file written (with ``out``).
    notes
        ``(P,)``: per person, parameter -> why it is the population's, or how its fit was bounded
        (:attr:`nudgecli.sim.twins.Twin.notes`).
    """

    table: pd.DataFrame
    fitted: tuple[int, ...]
    files: list[Path] = field(default_factory=list)
    notes: tuple[Mapping[str, str], ...] = ()

    def text(self) -> str:
        """The lines ``nudge fit-people`` prints, one a person: its source and participant, how many
        parameters their habits set, and those left to the population's draw."""
        from nudgecli.sim.people_file import LIST_SEPARATOR

        lines = []
        for row, fitted in zip(self.table.to_dict(orient="records"), self.fitted, strict=True):
            drawn = ", ".join(str(row["from_population"]).split(LIST_SEPARATOR)) if row["from_population"] \
                else "-"
            lines.append(f"person {row['person']}: {row['source']} participant {row['participant']}: "
                         f"{fitted} parameter(s) from their habits; from the population: {drawn}")
        return "\n".join(lines)

    def note_lines(self) -> list[str]:
        """One ``Note:`` line per parameter of a person that is the population's or was bounded, and
        why (``nudge fit-people`` prints them on stderr)."""
        from nudgecli.api.analysis import note_line

        return [note_line(f"person {row['person']} ({row['source']} participant {row['participant']}): "
                          f"{parameter}: {note}")
                for row, notes in zip(self.table.to_dict(orient="records"), self.notes, strict=True)
                for parameter, note in notes.items()]


def fit_people(sources: str | Path | Run | Sequence[str | Path | Run], *, out: str | Path | None = None,
               force: bool = False, log: Callable[[str], None] | None = None) -> FittedPeople:
    """One simulated person per participant of ``sources``, as ``nudge fit-people``.

    Each timing parameter is set from the participant's own habit medians by the documented
    offsets (docs/people.md); one their source lacks is left to the population's draw.

    Parameters
    ----------
    sources
        Real logs (the CSV ``nudge habits`` reads), run folders (or :class:`~nudgecli.api.run.Run`),
        or tables of ``nudge habits --by participant --format csv``.
    out
        The people file to write (CSV, read by ``--people``); ``None`` writes nothing.
    force
        Replace an existing ``out``.
    log
        Called with each of :meth:`FittedPeople.note_lines`, as ``nudge fit-people`` writes them on
        stderr; default silent.

    Returns
    -------
    FittedPeople
        ``.table`` (the people file's rows, one a person), ``.fitted`` (per person, how many
        parameters their habits set), ``.files`` and ``.text()`` (what ``nudge fit-people`` prints).

    Raises
    ------
    NudgeError
        An unreadable source, no participants, an existing ``out`` without ``force``, an ``out``
        that is a source; nothing is written.
    """
    import pandas as pd

    from nudgecli.api import arguments
    from nudgecli.outputs import check_output_file, command_inputs, declare_input
    from nudgecli.report.twin_sources import twins_of_sources
    from nudgecli.sim.people_file import LIST_SEPARATOR, PEOPLE_COLUMNS, people_csv
    from nudgecli.sim.twins import TWIN_PARAMETERS
    from nudgecli.store import write_text_atomic

    # one source, or a list of them; anything else (a number, None, a DataFrame) is refused as a path
    listed = sources if isinstance(sources, Sequence) and not isinstance(sources, str) else [sources]
    named: list[str | Path] = [arguments.source_path("sources", source) for source in listed]
    out, force = arguments.path("out", out, optional=True), arguments.switch("force", force)
    log = arguments.callback("log", log)
    target = None if out is None else Path(out)
    with command_inputs():  # the sources are this call's inputs only
        if target is not None:
            declare_input("SOURCE", *named)  # out never replaces a source
            check_output_file(target, force=force)
            _check_out_writable(target)
        twins = twins_of_sources(named)
        if target is not None:
            write_text_atomic(target, people_csv(twins))
    rows = [{"person": person, "source": twin.source, "participant": str(twin.participant),
             **{name: float(twin.parameters.get(name, float("nan"))) for name in TWIN_PARAMETERS},
             "from_population": LIST_SEPARATOR.join(twin.from_population)}
            for person, twin in enumerate(twins)]
    fitted = tuple(sum(name in twin.parameters for name in TWIN_PARAMETERS) for twin in twins)
    people = FittedPeople(pd.DataFrame(rows, columns=list(PEOPLE_COLUMNS)), fitted,
                          [] if target is None else [target], tuple(dict(twin.notes) for twin in twins))
    for line in people.note_lines() if log is not None else []:
        log(line)
    return people
