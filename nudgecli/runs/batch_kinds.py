"""``nudge replicate``, ``power`` and ``sweep``: the three kinds of batch.

Each command builds its :class:`~nudgecli.runs.batch.Batch` (one design point for ``replicate``
and ``power``, the sweep file's points for ``sweep``), runs it with
:func:`~nudgecli.runs.batch.run_batch`, and writes its tables (CSV) and figures into the batch
folder.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nudgecli import command_defaults as defaults
from nudgecli.config import ExperimentConfig
from nudgecli.config_files import resolve_plan
from nudgecli.errors import ConfigError, DataError
from nudgecli.rng import check_seed
from nudgecli.run_folder_config import kept_run_people
from nudgecli.run_folder_names import FIGURES_DIR
from nudgecli.runs.batch import Batch, BatchRun, Point, run_batch, single_point
from nudgecli.runs.batch_folder import (
    BATCH_FIGURES,
    BATCH_MANIFEST,
    BATCH_TABLES,
    SWEEP_COPY,
    check_inputs_kept,
    read_manifest,
    recorded_people,
    sweep_inputs,
)
from nudgecli.runs.batch_resume import with_resume_command
from nudgecli.runs.batch_trust import reading_as_folder
from nudgecli.runs.study import checked_plan, with_participants
from nudgecli.sim.people_file import MANIFEST_KEY as PEOPLE_KEY
from nudgecli.sim.people_file import People, check_same_people, people_of
from nudgecli.sim.policy_registry import checked_policy_specs, run_conditions
from nudgecli.sim.study import left_out_notes
from nudgecli.store import write_text_atomic

if TYPE_CHECKING:  # the statistics, summaries and figures load beside the batch's workers (import_outputs)
    import pandas as pd

    from nudgecli.report.plans import AnalysisPlan
    from nudgecli.runs.sweep import Sweep


@dataclass
class BatchResult:
    """What a command computed and wrote.

    Attributes
    ----------
    run
        The batch run.
    rows
        One row per replication, metric and pair of conditions (``replications.csv``).
    summary
        The command's main table (printed by the CLI).
    tables
        Every table written, by file stem.
    files
        Every file written.
    """

    run: BatchRun
    rows: pd.DataFrame
    summary: pd.DataFrame
    tables: dict[str, pd.DataFrame]
    files: list[Path]


def _declared(stems: Sequence[str], declared: Sequence[str]) -> None:
    """A table or figure not in the batch folder's list would outlive a replacement of its batch."""
    if not set(stems) <= set(declared):
        raise ValueError(f"batch outputs {sorted(set(stems) - set(declared))} are not declared in "
                         "nudgecli.runs.batch_folder (BATCH_TABLES, BATCH_FIGURES)")


def _write_tables(folder: Path, tables: dict[str, pd.DataFrame]) -> list[Path]:
    _declared(list(tables), BATCH_TABLES)
    written = []
    for stem, table in tables.items():
        path = folder / f"{stem}.csv"
        write_text_atomic(path, table.to_csv(index=False))
        written.append(path)
    return written


def _figures(folder: Path, figures: dict[str, Any]) -> list[Path]:
    from nudgecli.report.figures.output import save_figure

    _declared(list(figures), BATCH_FIGURES)
    written: list[Path] = []
    for stem, fig in figures.items():
        written += save_figure(fig, folder / FIGURES_DIR, stem, ("png",))
    return written


def import_outputs() -> None:
    """Import what the commands use after their batch: the replication summaries, the figures and
    matplotlib's PNG renderer (about 2 s on 2 cores, with scipy.stats). It is the batch's
    ``prepare`` (:func:`~nudgecli.runs.batch.run_batch`): on the process pool it runs beside the
    workers, not before they start nor after the last trial."""
    import matplotlib.backends.backend_agg  # noqa: F401  (what savefig loads on its first PNG)

    import nudgecli.report.figures.output
    import nudgecli.report.figures.replication
    import nudgecli.report.replication  # noqa: F401


def _load(experiment: str, overrides: Sequence[str], participants: int | None, kind: str) -> ExperimentConfig:
    """The experiment with its overrides, its own policies made once and checked
    (:func:`~nudgecli.sim.policy_registry.checked_policy_specs`, as ``nudge simulate`` and a sweep
    check them), so a parameter its policy refuses stops the batch before a folder exists; one of a
    single condition is refused too (:func:`check_pairs`)."""
    from nudgecli.config import load_experiment
    from nudgecli.config_files import resolve_preset

    config = with_participants(load_experiment(experiment, tuple(overrides)), participants)
    check_pairs(config, kind, str(resolve_preset(experiment, "experiments")))
    checked_policy_specs(config)
    return config


def check_pairs(config: ExperimentConfig, kind: str, source: str) -> None:
    """Refuse a batch whose studies hold a single condition, before anything is simulated: every
    table of ``replicate``, ``power`` and ``sweep`` is of pairs of conditions (significance rates,
    power, the difference of medians a sweep's points and sensitivity read), and one condition has
    none. The conditions a study runs are :func:`~nudgecli.sim.policy_registry.run_conditions`
    (``world.ciaa_conditions`` in the CIAA world, ``study.conditions`` in the grid).

    Raises
    ------
    ConfigError
        Naming ``source`` (the experiment file), the field, its conditions and the fix.
    """
    conditions = run_conditions(config)
    if len(conditions) >= 2:
        return
    field = "world.ciaa_conditions" if config.world.kind == "ciaa" else "study.conditions"
    listed = ", ".join(f'"{c}"' for c in conditions)
    raise ConfigError(f"{source}: {field} = [{listed}]: each study of experiment {config.experiment.name} "
                      f"holds one condition, so nudge {kind} has no pair of conditions to compare (its "
                      "tables are of pairs); nothing was simulated: give an experiment of two or more "
                      "conditions (e.g. the paper preset's study.conditions = [\"disambiguation\", "
                      "\"control\"]), or use nudge run for one condition's descriptive statistics")


def _people_fields(people: People | str | Path | None, out: str | Path, resume: bool,
                   kind: str) -> tuple[dict[str, Any], People | None]:
    """The people file's record for the batch's description (nothing without one, so a batch of the
    population describes itself as before) and the people; a resumed batch must have the same."""
    chosen = people_of(people)
    described, recorded = recorded_people(Path(out), kind) if resume else (False, None)
    if described:  # a damaged manifest, or a batch of another kind, is the prepare rule's to refuse
        try:
            check_same_people(recorded, chosen, out, Path(out) / BATCH_MANIFEST, f"batch.{PEOPLE_KEY}")
        except DataError as exc:  # named with the command that resumes the batch with its people
            raise DataError(with_resume_command(str(exc), Path(out))) from None
    if chosen is None:
        return {}, None
    return {PEOPLE_KEY: chosen.record()}, chosen


#: The fewest participants a batch analyses a study with: its participant-level test and effect
#: need two (with one, every participant-level column of the tables was NaN).
MIN_BATCH_PARTICIPANTS = 2


def check_participant_counts(counts: Sequence[int], example: str) -> None:
    """Refuse a batch that would analyse a study of fewer than :data:`MIN_BATCH_PARTICIPANTS`
    participants (``power``'s counts, ``replicate``'s study), before anything runs.

    Raises
    ------
    ConfigError
        Naming ``--participants`` and ``example``, what to give instead (``"6,9,12"``: counts).
    """
    if not counts or min(counts) < MIN_BATCH_PARTICIPANTS:
        what = "counts" if "," in example else "a count"
        raise ConfigError(f"--participants: give {what} of at least {MIN_BATCH_PARTICIPANTS} (one "
                          f"participant has no participant-level test), e.g. --participants {example}")


def check_point_participants(loaded: Sweep) -> None:
    """Refuse a sweep with a design point whose studies hold fewer than
    :data:`MIN_BATCH_PARTICIPANTS` participants (from the sweep's ``set``, a swept value or the
    experiment), before anything runs: the rule ``replicate`` and ``power`` apply to their counts.

    Raises
    ------
    ConfigError
        Naming the sweep file, the first such point with its values, and the fix.
    """
    for point in loaded.points:
        count = point.config.study.participants
        if count >= MIN_BATCH_PARTICIPANTS:
            continue
        from nudgecli.runs.sweep import point_words

        shown = point_words(point.parameters)
        raise ConfigError(f"{loaded.source}: design point {point.index} ({shown}) has study.participants = "
                          f"{count}: nudge sweep analyses each point's studies with a participant-level "
                          f"test, which needs at least {MIN_BATCH_PARTICIPANTS} participants; give "
                          f"study.participants of at least {MIN_BATCH_PARTICIPANTS} in the sweep's set or "
                          "its swept values (nothing was simulated)")


def _check(replications: int, seed: int | None) -> None:
    if replications < 1:
        raise ConfigError(f"--replications must be at least 1, got {replications}")
    check_seed(seed)


def replicate(experiment: str, replications: int, out: str | Path, *, seed: int | None = None,
              plan: str | AnalysisPlan | None = None, participants: int | None = None,
              overrides: Sequence[str] = (), people: People | str | Path | None = None,
              **options: Any) -> BatchResult:
    """``nudge replicate``: R independent studies of one experiment, each analysed with the plan.

    Writes ``replications.csv`` (per replication), ``conditions.csv`` (tidy medians per
    condition), ``summary.csv`` (per metric: significance rates, median p, pooled effects) and
    ``figures/forest.png``. ``people``: twins of real people (a people file, ``--people``).
    ``options`` go to :func:`run_batch`.
    """
    _check(replications, seed)
    with reading_as_folder(out):  # out's own kept files checked against its record, another's not
        config = _load(experiment, overrides, participants, "replicate")
    people = kept_run_people(experiment, people, options.get("log"))  # a run's config.toml: its people
    check_participant_counts([config.study.participants], "12")  # as power's: one has no participant test
    chosen = checked_plan(resolve_plan(plan, experiment=config.experiment.name, world=config.world.kind),
                          [config])
    record, chosen_people = _people_fields(people, out, bool(options.get("resume")), "replicate")
    check_inputs_kept(Path(out), [("EXPERIMENT", experiment), ("--plan", plan), ("--people", people)],
                      bool(options.get("force")))
    batch = Batch("replicate", single_point(config, (config.study.participants,)), replications,
                  config.experiment.seed if seed is None else seed, chosen,
                  {"experiment": config.experiment.name, **record}, chosen_people,
                  left_out_notes(config, config.study.participants, chosen_people, study="each replication"))

    def outputs(run: BatchRun) -> BatchResult:
        from nudgecli.report.figures.replication import forest_figure
        from nudgecli.report.replication import condition_values, replication_rows, summarise

        rows = replication_rows(run.graph.entries, run.stats, chosen)
        summarised = summarise(rows)  # the figure reads it with its point column, the table without
        _tell_untested(summarised, options)
        summary = summarised.drop(columns=["point"])
        tables = {"replications": rows.drop(columns=["point"]),
                  "conditions": condition_values(run.graph.entries, run.stats).drop(columns=["point"]),
                  "summary": summary}
        figures = {"forest": forest_figure(rows, summarised)}
        files = _write_tables(run.path, tables) + _figures(run.path, figures)
        return BatchResult(run, rows, summary, tables, files)

    return _result(run_batch(batch, out, prepare=import_outputs, finish=outputs, **options))


def power(experiment: str, participant_counts: Sequence[int], replications: int, out: str | Path, *,
          seed: int | None = None, plan: str | AnalysisPlan | None = None, overrides: Sequence[str] = (),
          target: float = defaults.POWER_TARGET, people: People | str | Path | None = None,
          **options: Any) -> BatchResult:
    """``nudge power``: the power curve of every metric over participant counts.

    Replication ``r`` simulates its largest study once; each count ``n`` analyses its first
    ``n`` participants. Writes ``power.csv`` (per count, metric and level of test, with the
    Clopper-Pearson interval), ``smallest_n.csv`` (of ``target``, which ``batch.json`` records: a
    resume with another is refused), ``replications.csv`` and ``figures/power.png``.
    ``people``: twins of real people (a people file, ``--people``), cycled over the participants.
    """
    _check(replications, seed)
    counts = sorted(set(int(n) for n in participant_counts))
    if len(counts) < len(participant_counts):  # a count given twice was run once, without a word
        twice = next(n for i, n in enumerate(participant_counts) if n in participant_counts[:i])
        raise ConfigError(f"--participants: {twice} is given twice; give each count once, e.g. "
                          "--participants 6,9,12,18,24")
    check_participant_counts(counts, "6,9,12,18,24")
    if not 0 < target < 1:
        raise ConfigError(f"--target must be strictly between 0 and 1 (a power), got {target}")
    with reading_as_folder(out):
        config = _load(experiment, overrides, None, "power")
    people = kept_run_people(experiment, people, options.get("log"))  # a run's config.toml: its people
    with_participants(config, counts[-1])  # the largest study within study.participants' bound
    chosen = checked_plan(resolve_plan(plan, experiment=config.experiment.name, world=config.world.kind),
                          [config])
    record, chosen_people = _people_fields(people, out, bool(options.get("resume")), "power")
    check_inputs_kept(Path(out), [("EXPERIMENT", experiment), ("--plan", plan), ("--people", people)],
                      bool(options.get("force")))
    batch = Batch("power", single_point(config, counts), replications,
                  config.experiment.seed if seed is None else seed, chosen,
                  {"experiment": config.experiment.name, "target": target, **record}, chosen_people,
                  left_out_notes(config, counts[-1], chosen_people, study="the largest study",
                                 fix="a count of {} in --participants"))

    def outputs(run: BatchRun) -> BatchResult:
        from nudgecli.report.figures.replication import power_figure
        from nudgecli.report.replication import power_table, replication_rows, smallest_n

        rows = replication_rows(run.graph.entries, run.stats, chosen)
        curves = power_table(rows)
        _tell_untested(curves, options)
        smallest = smallest_n(curves, target)
        tables = {"power": curves, "smallest_n": smallest, "replications": rows.drop(columns=["point"])}
        files = _write_tables(run.path, tables) + _figures(run.path, {"power": power_figure(curves, target)})
        return BatchResult(run, rows, curves, tables, files)

    return _result(run_batch(batch, out, prepare=import_outputs, finish=outputs, **options))


def sweep(sweep_file: str, out: str | Path, *, replications: int | None = None, seed: int | None = None,
          **options: Any) -> BatchResult:
    """``nudge sweep``: every design point of a sweep file, R replications each with common seeds.

    Writes ``sweep.csv`` (tidy: ``point, replication, seed, <parameters...>, condition, metric,
    value``), ``replications.csv``, ``points.csv`` (per point and metric: the summary of
    :func:`nudgecli.report.replication.summarise` with the parameters), for Sobol and Morris
    designs ``sensitivity.csv``, and the figures ``figures/sweep.png`` (and ``sensitivity.png``).
    """
    from nudgecli.runs.sweep import load_sweep

    with reading_as_folder(out):
        loaded = load_sweep(sweep_file)
    spec = loaded.spec
    for point in loaded.points:
        check_pairs(point.config, "sweep", f"{loaded.source}: experiment {loaded.experiment_file}")
    check_point_participants(loaded)  # as replicate's and power's: one has no participant-level test
    count = spec.replications if replications is None else replications
    _check(count, seed)
    assert spec.plan is not None  # load_sweep applied the plan rule
    chosen = checked_plan(spec.plan, [p.config for p in loaded.points])
    points = tuple(Point(p.index, p.parameters, p.config, (p.config.study.participants,))
                   for p in loaded.points)
    # its experiment and plan as the sweep file names them, a relative path being to its folder
    named = [(f"the sweep file's {field}", written) for field in ("experiment", "plan")
             if isinstance(written := getattr(spec, field), str)]
    beside = [(label, loaded.source.parent / written) for label, written in named]
    check_inputs_kept(Path(out), [("SWEEP_FILE", loaded.source), *named, *beside],
                      bool(options.get("force")))
    described = {"design": spec.design.model_dump(mode="json"), "experiment": _sweep_experiment(out, loaded)}
    batch = Batch("sweep", points, count, spec.seed if seed is None else seed, chosen, described,
                  notes=loaded.notes, inputs=sweep_inputs(spec, loaded.experiment_file))

    def outputs(run: BatchRun) -> BatchResult:
        from nudgecli.report.figures.replication import sensitivity_figure, sweep_figure
        from nudgecli.report.replication import point_outputs, sensitivity

        names = parameter_names(batch)
        rows, tables = _sweep_tables(run, batch, chosen, names)
        _tell_untested(tables["points"], options)
        figures: dict[str, Any] = {"sweep": sweep_figure(rows, names)}
        if loaded.problem is not None and loaded.samples is not None:
            indices = sensitivity(spec.design.method, loaded.problem, loaded.samples, point_outputs(rows),
                                  levels=spec.design.levels, seed=batch.seed)
            tables["sensitivity"] = indices
            if not indices.empty:
                figures["sensitivity"] = sensitivity_figure(indices)
        files = _write_tables(run.path, tables) + _figures(run.path, figures)
        return BatchResult(run, rows, tables.get("sensitivity", tables["points"]), tables, files)

    return _result(run_batch(batch, out, prepare=import_outputs, finish=outputs, **options))


def _sweep_tables(run: BatchRun, batch: Batch, plan: AnalysisPlan,
                  names: list[str]) -> tuple[pd.DataFrame, dict[str, pd.DataFrame]]:
    """A sweep's rows (``replications.csv``) and its tables ``sweep``, ``replications`` and ``points``."""
    from nudgecli.report.replication import condition_values, replication_rows, summarise
    from nudgecli.runs.sweep import parameter_cell

    table = point_table(batch).astype(object)
    for name in names:
        table[name] = table[name].map(parameter_cell)
    rows = replication_rows(run.graph.entries, run.stats, plan, table)
    summary = summarise(rows).merge(table, on="point", how="left")
    tidy = condition_values(run.graph.entries, run.stats, table)
    return rows, {"sweep": tidy, "replications": rows, "points": summary}


def _tell_untested(table: pd.DataFrame, options: dict[str, Any]) -> None:
    """Say, on the batch's ``log`` (the command's stderr), which pairs of conditions ``table``
    (a summary or power table) holds that some replications did not test
    (:func:`nudgecli.report.replication.untested_notes`): their NaN reads "not tested"."""
    from nudgecli.report.replication import untested_notes

    log = options.get("log")
    if log is not None:
        for note in untested_notes(table):
            log(f"Note: {note}")


def _result(run: BatchRun) -> BatchResult:
    """The command's result: what its ``finish`` wrote once the batch's tasks were done
    (:func:`~nudgecli.runs.batch.run_batch` marks the batch complete only after it)."""
    assert isinstance(run.outputs, BatchResult)
    return run.outputs


def _sweep_experiment(out: str | Path, loaded: Sweep) -> str:
    """The experiment a sweep's description names: as its sweep file names it, but for the batch
    folder's own copy (:data:`~nudgecli.runs.batch_folder.SWEEP_COPY`, which names the kept
    ``experiment.toml``) as the sweep file that started the batch named it, which ``batch.json``
    records: a resume from the copy describes the same batch."""
    folder = Path(out)
    old, _ = read_manifest(folder / BATCH_MANIFEST) if loaded.source.resolve() == \
        (folder / SWEEP_COPY).resolve() else (None, None)
    named = old["batch"].get("experiment") if old is not None else None
    return named if isinstance(named, str) else loaded.spec.experiment


def point_table(batch: Batch) -> pd.DataFrame:
    """One row per point: ``point`` and its swept parameters (values as they were given)."""
    import pandas as pd

    return pd.DataFrame([{"point": p.index, **p.parameters} for p in batch.points])


def parameter_names(batch: Batch) -> list[str]:
    """The swept parameters, in the design's order."""
    names: list[str] = []
    for point in batch.points:
        names += [n for n in point.parameters if n not in names]
    return names
