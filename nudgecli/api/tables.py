"""``nudgecli.habits`` and ``nudgecli.compare``: operating habits of a run or log, and simulated
people beside real people, as tidy frames with the text the commands print.

The work is :func:`nudgecli.report.habits.habits_of`'s and
:func:`nudgecli.report.compare.compare_sources`'s (``nudge habits`` and ``nudge compare`` call
them through this module).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nudgecli import command_defaults as defaults
from nudgecli.api.run import Run
from nudgecli.errors import ConfigError, shell_words

if TYPE_CHECKING:
    import pandas as pd

    from nudgecli.report.compare import Comparison
    from nudgecli.report.habits import HabitsResult
    from nudgecli.report.plans import AnalysisPlan


def _path_of(source: object, name: str = "source") -> str:
    """``source``'s path as text (:func:`nudgecli.api.arguments.source_path`): a DataFrame or any
    other non-path is refused naming the argument ``name``."""
    from nudgecli.api import arguments

    return arguments.source_path(name, source)


@dataclass(frozen=True)
class Habits:
    """The operating habits of one source (HABITS.md's definitions, 10 Hz cells).

    Attributes
    ----------
    result
        :class:`nudgecli.report.habits.HabitsResult`: ``events``, ``pooled``, ``units``, ``people``.
    """

    result: HabitsResult

    @property
    def pooled(self) -> pd.DataFrame:
        """One row per habit over every event: ``habit, n, median, q25, q75, people_min, people_max,
        participants``."""
        return self.result.pooled

    @property
    def units(self) -> pd.DataFrame:
        """One row per participant (or trial, ``by="trial"``) and habit: ``n, median, q25, q75``."""
        return self.result.units

    @property
    def events(self) -> pd.DataFrame:
        """One row per habit event (a blow, a reaction, an undone switch, ...)."""
        return self.result.events

    def comparison(self) -> pd.DataFrame:
        """Per habit the reference has: the measured median and range beside the reference's (empty
        without ``compare=``)."""
        return self.result.comparison()

    def to_json(self) -> dict[str, Any]:
        """The document of ``nudge habits --format json``."""
        return self.result.to_json()

    def text(self) -> str:
        """The table ``nudge habits`` prints."""
        from nudgecli.report.habits import format_habits

        return format_habits(self.result)

    def csv(self) -> str:
        """The CSV ``nudge habits --format csv`` prints."""
        from nudgecli.report.habits import habits_csv

        return habits_csv(self.result)


def habits(source: Run | str | Path, *, by: str = "participant", compare: str | None = None) -> Habits:
    """The operating habits of a run or a real log, as ``nudge habits`` measures them.

    Parameters
    ----------
    source
        A :class:`Run`, a run folder, or a real log's CSV (t, trial, label, x, y, theta, mode_switch).
    by
        ``participant`` or ``trial``: the units of :attr:`Habits.units`.
    compare
        A reference beside them: ``ciaa-people`` (the ten real users of HABITS.md) or a JSON file
        of ``nudge habits --format json``'s shape.

    Raises
    ------
    NudgeError
        An unreadable source or reference, nothing to measure, a bad ``by``.
    """
    from nudgecli.api import arguments
    from nudgecli.report.habits import habits_of

    by = arguments.text("by", by)
    reference = arguments.path("compare", compare, optional=True)
    if by not in ("participant", "trial"):
        raise ConfigError(f"--by {by!r}: choose participant or trial")
    return Habits(habits_of(_path_of(source), by=by, compare=None if reference is None else str(reference)))


@dataclass(frozen=True)
class ComparisonResult:
    """What :func:`compare` computed, the notes it made and the files it wrote.

    Attributes
    ----------
    comparison
        :class:`nudgecli.report.compare.Comparison`.
    notes
        What was left out (a condition one source holds alone, duplicates dropped), a line each.
    files
        The files written (with ``out``).
    """

    comparison: Comparison
    notes: list[str] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)

    @property
    def table(self) -> pd.DataFrame:
        """One row per metric and condition: medians, quartiles, ranges, KS and Wasserstein
        distances with their cluster-bootstrap intervals."""
        return self.comparison.table

    @property
    def medians(self) -> pd.DataFrame:
        """Per-participant medians of both sources, one row per source, participant, condition, metric."""
        return self.comparison.medians

    def to_json(self) -> dict[str, object]:
        """The document of ``nudge compare --format json`` (and ``compare.json``)."""
        return self.comparison.to_json()

    def text(self) -> str:
        """The table ``nudge compare`` prints."""
        from nudgecli.report.compare_text import format_comparison

        return format_comparison(self.comparison)


def parse_matches(matches: Sequence[str]) -> dict[str, str]:
    """``("none=no assistance", ...)`` -> ``{"none": "no assistance"}``, the labels as written (a
    table's label may end in a space, and ``--match 'control=Control '`` must pair it).

    Raises
    ------
    ConfigError
        A text that is not ``SIMULATED=REAL``, or a simulated condition matched with two real ones
        (naming both ``--match``; the same pairing given twice is one pairing).
    """
    from nudgecli.api import arguments

    mapping: dict[str, str] = {}
    for text in arguments.texts("matches", matches) or ():
        simulated, sep, real = text.partition("=")
        if not sep or not simulated.strip() or not real.strip():
            raise ConfigError(f"--match {text!r}: expected SIMULATED=REAL, e.g. --match none='no assistance'")
        if mapping.get(simulated, real) != real:  # else the last --match would silently win
            given = shell_words(["--match", f"{simulated}={mapping[simulated]}", "--match", text])
            raise ConfigError(f"{given}: the simulated condition {simulated!r} is matched twice, with "
                              f"{mapping[simulated]!r} and {real!r}; keep the --match you mean")
        mapping[simulated] = real
    return mapping


def compare(simulated: Run | str | Path, real: str | Path, *, plan: str | Path | AnalysisPlan | None = None,
            metrics: Sequence[str] | None = None, match: Mapping[str, str] | Sequence[str] | None = None,
            resamples: int = defaults.COMPARE_RESAMPLES, level: float = defaults.COMPARE_LEVEL,
            seed: int = defaults.COMPARE_SEED, drop_duplicates: bool = False, out: str | Path | None = None,
            formats: str | Sequence[str] = ("png", "pdf"), force: bool = False,
            log: Callable[[str], None] | None = None) -> ComparisonResult:
    """Simulated people beside real people, metric by metric, as ``nudge compare`` does.

    Parameters
    ----------
    simulated
        A :class:`Run`, a run folder or a metrics table.
    real
        A metrics table of real trials (CSV/Parquet).
    plan
        The metric definitions and filters (default the simulated run's plan, else ``paper``).
    metrics
        Only these metrics (default every metric both hold; an empty list is refused).
    match
        Simulated condition -> the real table's name for it: a mapping, or ``SIMULATED=REAL`` texts.
    resamples, level, seed
        The cluster bootstrap of the distances (0 resamples: no intervals; else at least
        :data:`nudgecli.report.plans.MIN_RESAMPLES`, as in a plan).
    drop_duplicates
        Keep the first of repeated trial rows instead of refusing them.
    out, formats, force
        Write ``compare.csv``, ``participant_medians.csv``, ``compare.json`` and the figure into
        ``out`` (checked before the bootstrap; ``force``: into a folder that is not empty).
    log
        Called with the ``Note:`` line of each of :attr:`ComparisonResult.notes`, as ``nudge compare``
        writes them on stderr; default silent.

    Raises
    ------
    NudgeError
        ``nudge compare``'s errors, before anything is written.
    """
    from nudgecli.api import arguments
    from nudgecli.api.analysis import log_notes
    from nudgecli.report.compare import CompareOptions, compare_sources, write_comparison
    from nudgecli.report.plans import MIN_RESAMPLES, check_resamples

    simulated, real = _path_of(simulated, "simulated"), arguments.path("real", real)
    metrics = arguments.texts("metrics", metrics, optional=True, empty=False)
    resamples = arguments.whole_number("resamples", resamples, minimum=0)
    level = arguments.real_number("level", level)
    seed = arguments.seed(seed)
    drop_duplicates = arguments.switch("drop_duplicates", drop_duplicates)
    force, log = arguments.switch("force", force), arguments.callback("log", log)
    out = arguments.out_folder(out)
    chosen_formats = arguments.formats(formats)
    check_resamples(resamples or None, "--resamples", MIN_RESAMPLES)  # 0 asks for no intervals
    if not 0.5 < level < 1.0:
        raise ConfigError(f"--level must be between 0.5 and 1 (both excluded), got {level}")
    condition_map = dict(match) if isinstance(match, Mapping) \
        else parse_matches(arguments.texts("match", match, optional=True) or ())  # named as compare's
    made = out is not None and not Path(out).exists()
    try:
        if out is not None:  # before the bootstrap, which takes a while
            _check_out(out, force, chosen_formats)
        notes: list[str] = []
        result = compare_sources(simulated, real, plan=plan,
                                 metrics=list(metrics) if metrics else None, condition_map=condition_map,
                                 options=CompareOptions(resamples=resamples, level=level, seed=seed),
                                 drop_duplicates=drop_duplicates, notes=notes)
        notes += self_comparison_notes(simulated, real, result.trials, result.metrics)
        files: list[Path] = []
        if out is not None:
            from nudgecli.report.compare_figure import plot_comparison

            # the tables are renamed into place only once the figure is written too
            files = write_comparison(result, out, partial(plot_comparison, result.trials, result.table,
                                                          result.medians, out, chosen_formats))
    except BaseException:
        if made and out is not None and Path(out).is_dir() and not any(Path(out).iterdir()):
            Path(out).rmdir()  # made by the write check only: a refused comparison leaves nothing
        raise
    log_notes(notes, log)
    return ComparisonResult(result, notes, files)


def self_comparison_notes(simulated: str | Path, real: str | Path, trials: Mapping[str, pd.DataFrame],
                          metrics: Sequence[str]) -> list[str]:
    """A note when ``compare`` sets a table beside itself: both sources the same file, or the same
    trials (a copy, or a run and its own ``metrics.csv``). Every distance is then 0, which is a
    legitimate sanity check but no comparison with real people, so it is said, not refused.

    Parameters
    ----------
    simulated, real
        The two sources as given.
    trials
        The compared trials, ``{"simulated": ..., "real": ...}`` (after filters and ``--match``).
    metrics
        The compared metric columns.
    """
    if Path(simulated).resolve() == Path(real).resolve():
        return [f"{simulated} and {real} are the same file: the table is compared with itself, so every "
                "distance is 0; give the real people's metrics table as REAL"]
    if _same_trials(trials["simulated"], trials["real"], metrics):
        return [f"{simulated} and {real} hold the same trials: the table is compared with itself, so every "
                "distance is 0; give the real people's metrics table as REAL"]
    return []


def _same_trials(first: pd.DataFrame, second: pd.DataFrame, metrics: Sequence[str]) -> bool:
    """Whether two trial tables hold the same participants, conditions and metric values (in the
    same order within each participant and condition; floats to a relative 1e-9, which a table
    written to CSV and read back keeps)."""
    import numpy as np  # here, as pandas is: the CLI imports this module

    keys = ["participant", "condition"]
    columns = [*keys, *metrics]
    if len(first) != len(second) or any(c not in t.columns for t in (first, second) for c in columns):
        return False
    first, second = (t.sort_values(keys, kind="mergesort")[columns].reset_index(drop=True)
                     for t in (first, second))
    if not all((first[k].astype(str) == second[k].astype(str)).all() for k in keys):
        return False
    try:
        values = [t[list(metrics)].to_numpy(dtype=float) for t in (first, second)]
    except (TypeError, ValueError):
        return False
    return bool(np.allclose(values[0], values[1], rtol=1e-9, atol=0.0, equal_nan=True))


def _check_out(out: str | Path, force: bool, formats: Sequence[str]) -> None:
    from nudgecli.outputs import check_not_an_input, check_output_folder
    from nudgecli.report.compare import COMPARISON_FILES
    from nudgecli.report.compare_figure import FIGURE_STEM
    from nudgecli.store import check_writable

    check_output_folder(out, force=force)
    check_writable(out)
    for name in (*COMPARISON_FILES, *(f"{FIGURE_STEM}.{suffix}" for suffix in formats)):
        check_not_an_input(Path(out) / name)
