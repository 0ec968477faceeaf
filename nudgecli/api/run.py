"""``nudgecli.simulate``: a simulated study as a :class:`Run` whose tables are DataFrames.

The work is :func:`nudgecli.runs.study.run_study`'s, the one ``nudge simulate`` and ``nudge run``
call through this module; a :class:`Run` reads its run folder's tables when first asked.
"""

from __future__ import annotations

import functools
import numbers
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nudgecli.api.folders import FolderOwner, remove_if_made, temporary_folder
from nudgecli.errors import ConfigError

if TYPE_CHECKING:  # pandas and pydantic load on first use, not with ``import nudgecli``
    import pandas as pd

    from nudgecli.config import ExperimentConfig

#: What ``overrides=`` takes: ``{"disambiguation.window": 5}`` or ``["disambiguation.window=5"]``.
Overrides = Mapping[str, object] | Sequence[str]
#: ``progress(done, total)``: trials (or metrics, tasks) done so far and in all.
ProgressCallback = Callable[[int, int], None]


class Run(FolderOwner):
    """A simulated study: its run folder and its tables, read lazily.

    Attributes
    ----------
    path
        The run folder (a temporary one when :func:`simulate` was given no ``out``).
    config
        The experiment that was simulated.
    mode
        ``new``, ``resume`` or ``replace``: what :func:`simulate` did with the folder.
    computed
        The participants simulated by this call (a resumed run's finished ones are not).
    participant_count
        Participants of the study.
    """

    def __init__(self, path: str | Path, config: ExperimentConfig, *, temporary: bool = False,
                 mode: str = "new", computed: Sequence[int] = (), participant_count: int | None = None,
                 trials: pd.DataFrame | None = None) -> None:
        self._own(Path(path), temporary)
        self.config = config
        self.mode = mode
        self.computed = list(computed)
        self.participant_count = config.study.participants if participant_count is None else participant_count
        if trials is not None:  # the table run_study read back already
            self.__dict__["trials"] = trials

    @classmethod
    def open(cls, path: str | Path) -> Run:
        """The run folder ``path`` (``nudge simulate``'s, a kept :class:`Run`'s); never removed by it.

        An incomplete run (interrupted) opens too, for its :attr:`path` and :meth:`report`; its
        tables are refused until it is finished (``simulate(..., out=path, resume=True)``).

        Raises
        ------
        ConfigError
            ``path`` is not a path (a str or a pathlib.Path), or is empty.
        RunFolderError
            Not a run folder.
        """
        from nudgecli.api import arguments
        from nudgecli.errors import RunFolderError
        from nudgecli.run_folder_config import run_experiment
        from nudgecli.store import RunFolder

        folder = RunFolder(Path(arguments.path("path", path)))
        if not folder.is_run():
            raise RunFolderError(f"{path}: not a run folder (no manifest.json); give a folder made by "
                                 "`nudge simulate`")
        manifest = folder.read_manifest()
        # the experiment as the manifest records it: an edited config.toml changes nothing read
        return cls(path, run_experiment(folder), participant_count=folder.participant_count(manifest),
                   mode="open")

    @property
    def experiment(self) -> str:
        """The experiment's name (``[experiment] name``)."""
        return self.config.experiment.name

    @functools.cached_property
    def trials(self) -> pd.DataFrame:
        """One row per trial, ``(participants x trials, columns)``: condition, success, duration_s, ...

        Of an incomplete run (:meth:`open` of an interrupted one), this and :attr:`steps` and
        :attr:`participants` raise :class:`~nudgecli.errors.RunFolderError`, naming the command
        that finishes it."""
        return self._folder().read_trials()

    @functools.cached_property
    def steps(self) -> pd.DataFrame:
        """The step log, one row per 10 Hz step of every trial (belief, pose, command, ...)."""
        return self._folder().read_steps()

    @functools.cached_property
    def participants(self) -> pd.DataFrame:
        """One row per simulated participant: the person drawn (calibration, habits)."""
        return self._folder().read_table("participants")

    def success(self) -> pd.DataFrame:
        """Trials, success rate, time-outs and median duration per condition (what ``nudge simulate``
        prints), one row per condition, in the order ``nudge analyze`` gives them."""
        from nudgecli.runs.study import success_by_condition

        return success_by_condition(self.trials, self.config.study.conditions)

    def report(self) -> str:
        """The text ``nudge simulate`` prints before the folder: counts and :meth:`success`; of an
        incomplete run (interrupted, parts missing), one line saying so and how to finish it."""
        from nudgecli.errors import RunFolderError

        try:
            trials = self.trials
        except RunFolderError as exc:  # the tables' refusal, the reason and the command that finishes it
            return f"{self.participant_count} participants, not readable: {exc}"
        head = (f"{len(trials)} trials, {self.participant_count} participants "
                f"({'resumed, ' if self.mode == 'resume' else ''}{len(self.computed)} simulated now)")
        return head + "\n" + self.success().to_string(float_format=lambda v: f"{v:.3f}")

    def _folder(self) -> Any:
        """The run folder to read a table of, complete: an interrupted run's tables would hold only
        the participants it finished, so they are refused as ``analyze`` refuses them
        (:meth:`~nudgecli.store.RunFolder.check_complete`, naming the command that finishes it)."""
        from nudgecli.errors import RunFolderError

        if self.closed:
            raise RunFolderError(f"{self.path}: this run was closed and its temporary folder removed; "
                                 "give simulate(out=...) to keep it")
        return self._complete_folder

    @functools.cached_property
    def _complete_folder(self) -> Any:
        """The run folder, checked complete once (the check opens every part: the three tables,
        each cached as read, need it once, as a refusal is not cached and is raised again)."""
        from nudgecli.store import RunFolder

        folder = RunFolder(self.path)
        if folder.is_run():
            folder.check_complete()
        return folder

    def __repr__(self) -> str:
        kept = "temporary" if self.temporary else "kept"
        return f"Run({self.experiment!r}, {self.participant_count} participants, {str(self.path)!r}, {kept})"


def override_texts(overrides: Overrides | None) -> tuple[str, ...]:
    """``overrides`` as ``--set`` texts: a mapping's values written as TOML literals.

    Raises
    ------
    ConfigError
        A value TOML cannot hold (``None``, an object), or overrides given as one string, as bytes
        or as anything else that is neither a mapping nor a list.
    """
    if overrides is None:
        return ()
    if isinstance(overrides, Mapping):
        return tuple(f"{key}={toml_literal(value, key)}" for key, value in overrides.items())
    # a text (or bytes: a sequence of numbers) is no list of texts
    if isinstance(overrides, str | bytes) or not isinstance(overrides, Sequence):
        raise ConfigError(f"overrides={overrides!r}: give a list of KEY=VALUE texts or a mapping, "
                          "e.g. {'disambiguation.window': 5}")
    return tuple(str(text) for text in overrides)


def toml_literal(value: object, key: str = "value") -> str:
    """``value`` as a TOML literal (``5``, ``0.25``, ``true``, ``"tr"``, ``[3, 4]``, ``{a = 1}``):
    NumPy's numbers and booleans as Python's, a mapping as an inline table, a sequence or a NumPy
    array as a list (what ``--set`` takes, written by a notebook), rendered by
    :func:`nudgecli.config_files.toml_value`, the one rendering of a value."""
    from nudgecli.config_files import toml_value  # loads pydantic: on first use

    return toml_value(_toml_ready(value, key))


def _toml_ready(value: object, key: str) -> Any:
    """``value`` as the Python value :func:`~nudgecli.config_files.toml_value` writes (a bool, int,
    float, str, list or dict): NumPy's scalars and arrays converted, and anything TOML cannot hold
    refused naming the ``--set`` key (``key``)."""
    import numpy as np  # its scalars and arrays come from a notebook's own computations

    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real):  # the float itself: NumPy's repr reads np.float64(50.0)
        return float(value)
    if isinstance(value, str):
        return str(value)
    if isinstance(value, Mapping):
        for name in value:
            if not isinstance(name, str):
                raise ConfigError(f"--set {key}: the key {name!r} is not a text; name the fields with texts")
        return {str(name): _toml_ready(item, f"{key}.{name}") for name, item in value.items()}
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, Sequence) and not isinstance(value, bytes):
        return [_toml_ready(item, key) for item in value]
    raise ConfigError(f"--set {key}: {value!r} is not a TOML value; give a number, text, true/false, "
                      "a list or a mapping")


def experiment_config(name_or_path: str | Path, overrides: Overrides | None = None, *,
                      out: str | Path | None = None) -> ExperimentConfig:
    """The experiment ``name_or_path`` (a preset such as ``paper`` or ``smoke``, or a TOML file) with
    ``overrides`` applied, validated: what :func:`simulate` would run. With ``out``, the folder it is
    to run in: a file that folder keeps (its own ``config.toml``, to resume it) is checked against its
    record first (:func:`~nudgecli.runs.batch_trust.reading_as_folder`), as ``simulate`` checks it.

    Raises
    ------
    ConfigError
        An unknown preset, an invalid file or override (the message ``nudge`` prints).
    """
    from nudgecli.api import arguments
    from nudgecli.config import load_experiment
    from nudgecli.runs.batch_trust import reading_as_folder

    with reading_as_folder(arguments.out_folder(out)):
        return load_experiment(str(name_or_path), override_texts(overrides))


def _loaded_experiment(experiment: str | Path | ExperimentConfig, overrides: Overrides | None,
                       options: dict[str, Any], out: str | Path | None = None) -> ExperimentConfig:
    """``simulate``'s experiment: loaded with ``overrides``, or given loaded (then without them). A
    run folder's ``config.toml`` takes the people file the run keeps where ``options`` (``simulate``'s
    :func:`~nudgecli.api.arguments.run_options`) give none: simulated, it gives the run's tables again
    (:func:`~nudgecli.run_folder_config.kept_run_people`, its ``Note:`` told to their ``log``)."""
    from nudgecli.config import ExperimentConfig
    from nudgecli.run_folder_config import kept_run_people

    if not isinstance(experiment, ExperimentConfig):
        config = experiment_config(experiment, overrides, out=out)
        options["people"] = kept_run_people(experiment, options["people"], options["log"])
        return config
    if overrides:
        raise ConfigError("overrides= applies to an experiment given by name or file; give them to "
                          "nudgecli.experiment_config(name, overrides) instead")
    return experiment


def simulate(experiment: str | Path | ExperimentConfig, *, participants: int | None = None,
             seed: int | None = None, workers: int = 1, out: str | Path | None = None,
             overrides: Overrides | None = None, people: str | Path | None = None,
             progress: ProgressCallback | None = None, scheduler: str | None = None, resume: bool = False,
             force: bool = False, plan: str | Path | None = None, confirm: bool = False,
             log: Callable[[str], None] | None = None) -> Run:
    """Simulate a study, as ``nudge simulate`` does.

    Parameters
    ----------
    experiment
        A preset name (``paper``, ``smoke``, ...), an experiment TOML file, or a loaded
        experiment (:func:`experiment_config`). A run's ``config.toml`` given as a file takes the people
        file the run keeps; loaded first, it knows no file: give ``people="RUN/people/NAME.csv"``.
    participants, seed
        Override the experiment's participant count and master seed.
    workers
        Local worker processes (1: in this process).
    out
        The run folder, kept; ``None``: a temporary folder removed when the :class:`Run` is closed,
        leaves its ``with`` block or is garbage-collected.
    overrides
        Experiment fields to change, ``{"disambiguation.window": 5}`` or ``["disambiguation.window=5"]``
        (``--set``); only with an experiment given by name or file.
    people
        A people file (``nudge fit-people``, ``--people``), or the :class:`~nudgecli.api.fitting.FittedPeople`
        of ``fit_people(..., out=...)`` for the file it wrote: participant ``i`` is the twin of person
        ``i mod P``, the rest of their physiology drawn as usual.
    progress
        Called with (trials done, trials in all) as participants finish; default silent.
    log
        Called with the lines ``nudge simulate`` writes on stderr (a ``Note:``); default silent.
    scheduler
        A dask.distributed scheduler's address (overrides ``workers``).
    resume, force
        Finish an interrupted run in ``out``, or replace the run there; giving both is refused
        (they contradict: one keeps the finished work, the other deletes it).
    plan
        The analysis plan recorded in the manifest: a preset's name or a plan file (a ``str`` or a
        ``pathlib.Path``, which the run keeps a copy of); default: the one named like the experiment.
    confirm
        Simulate a study above the size limit (``--yes``).

    Returns
    -------
    Run

    Raises
    ------
    NudgeError
        Invalid experiment, override, count, seed or folder, with the message of ``nudge``'s
        ``Error:`` line; nothing is written then.
    """
    from nudgecli.api import arguments
    from nudgecli.runs.dask_cluster import check_scheduler_address, scheduler_named
    from nudgecli.runs.size import override_named
    from nudgecli.runs.study import run_study

    options = arguments.run_options(workers=workers, seed=seed, scheduler=scheduler, people=people,
                                    progress=progress, resume=resume, force=force, confirm=confirm, log=log)
    # a refusal of the scheduler's address names this API's parameter: an empty one (as out=''), one
    # that does not answer, its cluster's
    with scheduler_named("scheduler="):
        check_scheduler_address(options["scheduler"])
        participants = arguments.whole_number("participants", participants, optional=True)
        out, plan_text = arguments.out_folder(out), arguments.plan(plan, loaded=False)  # a preset or a file
        config = _loaded_experiment(experiment, overrides, options, out)  # out's own files checked as kept
        temporary = out is None
        target = temporary_folder(config.experiment.name) if out is None else Path(out)
        made = temporary or not target.exists()
        try:
            with override_named("confirm=True"):  # so does a refusal of the size guard
                study = run_study(config, target, participants=participants, plan=plan_text, **options)
        except BaseException:
            # a folder this call made is removed whole (a temporary one) or when still empty (--out)
            if temporary or (made and target.is_dir() and not any(target.iterdir())):
                remove_if_made(target, True)
            raise
    return Run(study.path, study.config, temporary=temporary, mode=study.mode, computed=study.computed,
               participant_count=study.participants, trials=study.trials)
