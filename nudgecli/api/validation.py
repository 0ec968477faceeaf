"""``nudgecli.validate``: the paper's simulation-based validation of D(s) (its argmax against a
one-step ground truth), as ``nudge validate`` runs it.

The work is :mod:`nudgecli.sim.validation`'s (settings, readings, runner, output) and
:func:`nudgecli.report.validation_figure.plot_validation`'s; ``nudge validate`` calls it through
this module and prints what it returns.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nudgecli import command_defaults as defaults
from nudgecli.errors import ConfigError

if TYPE_CHECKING:
    import pandas as pd

    from nudgecli.sim.validation.runner import ValidationResult
    from nudgecli.sim.validation.settings import ValidationSettings

#: The message of a reading named beside ``all_readings`` (``nudge validate``'s usage error).
READINGS_EXCLUDE = "--reading and --all-readings exclude each other"


@dataclass(frozen=True)
class Validation:
    """What :func:`validate` computed and the files it wrote.

    Attributes
    ----------
    results
        One :class:`~nudgecli.sim.validation.runner.ValidationResult` per reading run.
    all_readings
        Whether every reading ran (``--all-readings``): the printed table is then one row per reading.
    files
        The files written (with ``out``).
    notes
        What to tell the person beside the results, a line each (an option some readings ignore).
    """

    results: tuple[ValidationResult, ...]
    all_readings: bool
    files: list[Path] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def summary(self) -> dict[str, Any]:
        """The one reading's JSON summary (``validation.json``); with ``all_readings`` the first's."""
        return self.results[0].summary()

    def readings(self) -> list[dict[str, Any]]:
        """One record per reading and |G| (``readings.json``'s rows)."""
        from nudgecli.sim.validation import readings_summary

        return readings_summary(list(self.results))

    def to_json(self) -> dict[str, Any] | list[dict[str, Any]]:
        """The document ``nudge validate --format json`` prints."""
        return self.readings() if self.all_readings else self.summary()

    def text(self) -> str:
        """The table ``nudge validate`` prints."""
        from nudgecli.sim.validation import format_readings, format_summary

        return format_readings(self.readings()) if self.all_readings else format_summary(self.summary())

    @property
    def queries(self) -> pd.DataFrame:
        """``(Q * readings, columns)``: one row per query (``validation.csv``'s columns) and its
        ``reading``."""
        import pandas as pd

        from nudgecli.sim.validation import QUERY_COLUMNS

        return pd.concat([pd.DataFrame({"reading": result.settings.reading,
                                        **{name: result.queries[name] for name in QUERY_COLUMNS}})
                          for result in self.results], ignore_index=True)


def reading_names() -> list[str]:
    """The readings of the paper's validation paragraph, by name (``reading=``'s choices)."""
    from nudgecli.sim.validation.readings import READINGS

    return list(READINGS)


def validate(*, simulations: int = defaults.VALIDATION_SIMULATIONS,
             min_goals: int = defaults.VALIDATION_MIN_GOALS, max_goals: int = defaults.VALIDATION_MAX_GOALS,
             states: int | None = None, seed: int = defaults.VALIDATION_SEED,
             belief_concentration: float | None = None,
             mc_queries: int | None = None, reading: str = defaults.VALIDATION_READING,
             all_readings: bool = False, out: str | Path | None = None, force: bool = False,
             yes: bool = False, progress: Callable[[int, int], None] | None = None,
             log: Callable[[str], None] | None = None) -> Validation:
    """Run the paper's validation of D(s), as ``nudge validate`` does.

    Parameters
    ----------
    simulations
        Random worlds (each queries every state off the goals once).
    min_goals, max_goals
        |G| steps cyclically from ``min_goals`` to ``max_goals``.
    states
        |S| = 2 modes x W x H cells of the two-mode world; ``None``: 200 (a 10 x 10 grid), and not
        given. Given (even as 200), it is refused with the three-mode reading alone, whose world is
        the study's.
    seed
        Master seed of the whole validation.
    belief_concentration
        Query beliefs are Dirichlet(c); ``None``: 1, and not given. Given, it is refused with the
        two-goal reading alone, whose beliefs are split between two goals.
    mc_queries
        Queries of the Monte-Carlo convergence study (0 skips it; a note where fewer ran, or none);
        ``None``: 100, and not given. Given beside ``all_readings``, which skips the study, even as
        100, a note says it is not used.
    reading
        Which reading of the paper's validation paragraph.
    all_readings
        Run every reading on the same worlds (``reading`` must then be left at its default).
    out, force
        Folder for ``validation.json``, ``validation.csv`` and the figure (``readings.json`` with
        ``all_readings``); ``force``: one that is not empty.
    yes
        Run more queries than the size limit allows.
    progress
        ``progress(done, total)`` after each simulation.
    log
        Called with each of :attr:`Validation.notes` as its ``Note:`` line (``nudge validate``'s stderr).

    Raises
    ------
    NudgeError
        ``nudge validate``'s errors (bad settings, over the size limit, an unusable ``out``),
        before anything is written.
    """
    from nudgecli.api import arguments
    from nudgecli.api.analysis import log_notes
    from nudgecli.outputs import check_output_folder
    from nudgecli.runs.size import MAX_QUERIES_WITHOUT_YES, check_size, override_named
    from nudgecli.sim import validation
    from nudgecli.sim.validation.runner import mc_queries_notes

    settings, names, notes = _checked_settings(simulations, min_goals, max_goals, states, seed,
                                               belief_concentration, mc_queries, reading, all_readings)
    arguments.switches(all_readings=all_readings, force=force, yes=yes)
    out, progress = arguments.out_folder(out), arguments.callback("progress", progress)
    log = arguments.callback("log", log)
    with override_named("yes=True"):  # the refusal names this API's parameter (--yes on the command line)
        check_size(simulations * settings.states * len(names), yes, limit=MAX_QUERIES_WITHOUT_YES,
                   work="run {} queries (worlds x states x readings)", fix="fewer --simulations or --states")
    if out is not None:
        check_output_folder(out, force=force)
        validation.prepare_out(out)
    if all_readings:
        results = validation.run_all_readings(settings, names, progress=progress)
    else:
        results = [validation.run_validation(settings, progress=progress)]
        notes += mc_queries_notes(results)  # the worlds held fewer queries than --mc-queries asked
    made = Validation(tuple(results), all_readings, notes=notes)
    if out is not None:
        made.files.extend(_write(made, out))
    log_notes(made.notes, log)
    return made


def _write(made: Validation, out: str | Path) -> list[Path]:
    """Write ``made`` into ``out``: ``readings.json`` of every reading, or one reading's
    ``validation.json``, ``validation.csv`` and figure, the tables renamed into place only once the
    figure is written too."""
    from nudgecli.sim import validation

    if made.all_readings:
        return validation.save_readings(made.results, out)
    from nudgecli.report.validation_figure import plot_validation

    return validation.save_validation(made.results[0], out, partial(plot_validation, made.summary(), out))


def _checked_settings(simulations: int, min_goals: int, max_goals: int, states: int | None, seed: int,
                      belief_concentration: float | None, mc_queries: int | None, reading: str,
                      all_readings: bool) -> tuple[ValidationSettings, list[str], list[str]]:
    """:func:`validate`'s settings checked, the readings to run and the notes on options some of
    them do not use (``None``: an option not given). Before any work."""
    from nudgecli.api import arguments
    from nudgecli.sim import validation
    from nudgecli.sim.validation.runner import all_readings_mc_note

    counts = {name: arguments.whole_number(name, value) for name, value in (
        ("simulations", simulations), ("min_goals", min_goals), ("max_goals", max_goals),
        ("states", defaults.VALIDATION_STATES if states is None else states), ("seed", seed),
        ("mc_queries", defaults.VALIDATION_MC_QUERIES if mc_queries is None else mc_queries))}
    if all_readings and reading != defaults.VALIDATION_READING:
        raise ConfigError(READINGS_EXCLUDE)
    concentration = (defaults.VALIDATION_BELIEF_CONCENTRATION if belief_concentration is None
                     else belief_concentration)
    settings = validation.ValidationSettings(
        **counts, reading=arguments.text("reading", reading),
        belief_concentration=arguments.real_number("belief_concentration", concentration))
    names = list(validation.READINGS) if all_readings else [reading]
    notes = [validation.settings.states_note(None if states is None else settings.states, names),
             validation.settings.concentration_note(
                 None if belief_concentration is None else settings.belief_concentration, names),
             all_readings_mc_note(None if mc_queries is None else settings.mc_queries)
             if all_readings else None]
    for name in names:
        replace(settings, reading=name).check()
    return settings, names, [note for note in notes if note]
