"""``nudgecli.replicate``, ``nudgecli.power`` and ``nudgecli.sweep``: many studies as one batch, their
tables as tidy frames.

The work is :mod:`nudgecli.runs.batch_kinds`' (``nudge replicate``, ``power`` and ``sweep`` call
it through this module); a :class:`Batch` holds its batch folder, temporary unless ``out`` is given.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nudgecli import command_defaults as defaults
from nudgecli.api import arguments
from nudgecli.api.folders import FolderOwner, remove_if_made, temporary_folder
from nudgecli.api.run import Overrides, ProgressCallback, override_texts

if TYPE_CHECKING:
    import pandas as pd

    from nudgecli.report.plans import AnalysisPlan
    from nudgecli.runs.batch_kinds import BatchResult


class Batch(FolderOwner):
    """A finished batch: its main table, every table it wrote, its folder.

    Attributes
    ----------
    path
        The batch folder (temporary when the call had no ``out``).
    result
        :class:`nudgecli.runs.batch_kinds.BatchResult`.
    """

    def __init__(self, result: BatchResult, *, temporary: bool) -> None:
        self._own(Path(result.run.path), temporary)
        self.result = result

    @property
    def summary(self) -> pd.DataFrame:
        """The table the command prints: per metric and pair (replicate), per count (power); for a
        sweep, per design point (a grid: ``points``) or the sensitivity indices (Sobol, Morris:
        ``sensitivity``)."""
        return self.result.summary

    @property
    def tables(self) -> dict[str, pd.DataFrame]:
        """Every table written, by file stem (``replications``, ``conditions``, ``power``, ...)."""
        return dict(self.result.tables)

    @property
    def rows(self) -> pd.DataFrame:
        """One row per replication, metric and pair of conditions (``replications.csv``)."""
        return self.result.rows

    @property
    def computed(self) -> int:
        """Tasks computed by this call (a resumed batch's finished ones are not)."""
        return int(self.result.run.computed)

    @property
    def files(self) -> list[Path]:
        """The files written."""
        return list(self.result.files)

    def text(self) -> str:
        """The table the command prints."""
        return self.summary.to_string(index=False, float_format=lambda v: f"{v:.3g}")

    def __repr__(self) -> str:
        return f"Batch({len(self.summary)} rows, {str(self.path)!r})"


def holds_batch(folder: str | Path) -> bool:
    """Whether ``folder`` holds a batch (its manifest): one a resumed command would finish; not one
    a ``--force`` was removing (``batch.json`` marked ``replacing``: any command starts afresh)."""
    from nudgecli.runs.batch_folder import BATCH_MANIFEST, read_manifest, replacing

    manifest = Path(arguments.path("folder", folder)) / BATCH_MANIFEST
    return manifest.is_file() and not replacing(read_manifest(manifest)[0])


def progress_line(label: str) -> ProgressCallback:
    """The progress the batch commands print on stderr: tasks done, rate and ETA (``label: ...``)."""
    from nudgecli.runs.progress import Progress

    return Progress(arguments.text("label", label))


def _run(work: Callable[..., BatchResult], out: str | Path | None, label: str,
         progress: ProgressCallback | None, log: Callable[[str], None] | None, **kwargs: Any) -> Batch:
    """Run one batch kind into ``out`` (or a temporary folder, removed again when it fails), once the
    arguments the kinds share have their Python types (:mod:`nudgecli.api.arguments`)."""
    from nudgecli.runs.dask_cluster import check_scheduler_address, scheduler_named
    from nudgecli.runs.size import override_named

    out = arguments.out_folder(out)
    progress, log = arguments.callback("progress", progress), arguments.callback("log", log)
    kwargs["workers"] = arguments.whole_number("workers", kwargs["workers"])
    kwargs["seed"] = arguments.whole_number("seed", kwargs["seed"], optional=True)
    # a refusal of the scheduler's address names this API's parameter: an empty one (as out=''), one
    # that does not answer, its cluster's
    with scheduler_named("scheduler="):
        kwargs["scheduler"] = check_scheduler_address(arguments.text("scheduler", kwargs["scheduler"],
                                                                     optional=True))
        for name in ("resume", "force", "confirm"):
            arguments.switch(name, kwargs[name])
        if "people" in kwargs:
            kwargs["people"] = arguments.people_file(kwargs["people"])
        temporary = out is None
        target = temporary_folder(label) if out is None else Path(out)
        try:
            with override_named("confirm=True"):  # so does a refusal of the size guard
                result = work(out=target, progress=progress, log=log, **kwargs)
        except BaseException:
            remove_if_made(target, temporary)
            raise
    return Batch(result, temporary=temporary)


def replicate(experiment: str | Path, replications: int, *, seed: int | None = None,
              plan: str | Path | AnalysisPlan | None = None, participants: int | None = None,
              overrides: Overrides | None = None, people: str | Path | None = None,
              out: str | Path | None = None, workers: int = 1, scheduler: str | None = None,
              resume: bool = False, force: bool = False, confirm: bool = False,
              progress: ProgressCallback | None = None, log: Callable[[str], None] | None = None) -> Batch:
    """R independent studies of ``experiment``, each analysed with the plan, as ``nudge replicate``.

    Parameters
    ----------
    experiment
        A preset or an experiment TOML file.
    replications
        Independent studies (each its own seed).
    seed, plan, participants, overrides
        The master seed, the analysis plan, participants per study and ``--set`` overrides.
    people
        A people file whose twins are simulated (``--people``, ``nudge fit-people``).
    out
        The batch folder, kept; ``None``: a temporary one removed with the :class:`Batch`.
    workers, scheduler, resume, force, confirm
        Local workers or a dask scheduler, finish or replace a batch in ``out`` (``resume`` and
        ``force`` together are refused: one keeps the finished work, the other deletes it), run
        above the size limit (``--yes``; the limit's refusal names ``confirm=True``).
    progress, log
        ``progress(done, total)`` over tasks and ``log(line)`` for the batch's size; default silent.

    Returns
    -------
    Batch
        ``summary``: per metric and pair, significance rates, median p and pooled effect.
    """
    from nudgecli.runs.batch_kinds import replicate as replicate_batch

    return _run(replicate_batch, out, "replicate", progress, log, experiment=str(experiment),
                replications=arguments.whole_number("replications", replications), seed=seed,
                plan=arguments.plan(plan), participants=arguments.whole_number("participants", participants,
                                                                               optional=True),
                overrides=override_texts(overrides), workers=workers, scheduler=scheduler, resume=resume,
                force=force, confirm=confirm, people=people)


def power(experiment: str | Path, participants: Sequence[int], replications: int, *, seed: int | None = None,
          plan: str | Path | AnalysisPlan | None = None, target: float = defaults.POWER_TARGET,
          overrides: Overrides | None = None, people: str | Path | None = None,
          out: str | Path | None = None, workers: int = 1, scheduler: str | None = None, resume: bool = False,
          force: bool = False, confirm: bool = False, progress: ProgressCallback | None = None,
          log: Callable[[str], None] | None = None) -> Batch:
    """Power curves over participant counts, as ``nudge power``.

    Parameters
    ----------
    participants
        The participant counts (each at least 2), e.g. ``[6, 9, 12]`` (a list, a tuple or a
        one-dimensional NumPy array of integers).
    target
        The power to reach (``smallest_n``).
    experiment, replications, seed, plan, overrides, people
        As :func:`replicate`'s.
    out, workers, scheduler, resume, force, confirm, progress, log
        As :func:`replicate`'s.

    Returns
    -------
    Batch
        ``summary``: per count, metric and level of test, the power with its Clopper-Pearson interval.
    """
    from nudgecli.runs.batch_kinds import power as power_batch

    return _run(power_batch, out, "power", progress, log, experiment=str(experiment),
                participant_counts=arguments.whole_numbers("participants", participants),
                replications=arguments.whole_number("replications", replications), seed=seed,
                plan=arguments.plan(plan), overrides=override_texts(overrides),
                target=arguments.real_number("target", target),
                workers=workers, scheduler=scheduler, resume=resume, force=force, confirm=confirm,
                people=people)


def sweep(sweep_file: str | Path, *, replications: int | None = None, seed: int | None = None,
          out: str | Path | None = None, workers: int = 1, scheduler: str | None = None, resume: bool = False,
          force: bool = False, confirm: bool = False, progress: ProgressCallback | None = None,
          log: Callable[[str], None] | None = None) -> Batch:
    """Every design point of a sweep file, R replications each, as ``nudge sweep``.

    Parameters
    ----------
    sweep_file
        A sweep TOML (grid, Sobol or Morris design over experiment keys).
    replications, seed
        Override the file's.
    out, workers, scheduler, resume, force, confirm, progress, log
        As :func:`replicate`'s.
    """
    from nudgecli.runs.batch_kinds import sweep as sweep_batch

    return _run(sweep_batch, out, "sweep", progress, log,
                sweep_file=str(arguments.path("sweep_file", sweep_file)),
                replications=arguments.whole_number("replications", replications, optional=True), seed=seed,
                workers=workers, scheduler=scheduler, resume=resume, force=force, confirm=confirm)
