"""How a run folder's ``config.toml`` and its manifest's experiment differ: key by key, and what a
resume or a reader is told of a ``config.toml`` edited, lost or holding another seed; and the
analysis plan a run records for ``nudge analyze``.

A plan preset is recorded by its name (``"plan": "paper"``); a plan file is kept in the folder as an
exact copy (:data:`PLAN_COPY`, its SHA-256 in the manifest's :data:`PLAN_SHA256_KEY`), as a batch
keeps its ``plan.toml``: the file typed may be edited or moved later, and the run's analysis must
stay the one it was simulated for (:meth:`ConfigRecord.keep_plan`, :meth:`ConfigRecord.recorded_plan`).

:class:`ConfigRecord` is a base of :class:`nudgecli.run_folder_record.RunRecord`.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Mapping, MutableMapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import ValidationError

from nudgecli.config import ExperimentConfig, experiment_from_toml
from nudgecli.config_files import format_validation_error
from nudgecli.errors import ConfigError, NudgeError, RunFolderError, WriteError
from nudgecli.run_folder_names import (
    ANALYSIS_FILES,
    CONFIG,
    MANIFEST,
    PLAN_COPY,
    STATS_JSON,
)
from nudgecli.run_folder_state import only_a_start

if TYPE_CHECKING:
    from nudgecli.store import RunFolder

#: The manifest key of the SHA-256 of a run's copy of its plan file (:data:`PLAN_COPY`, which the
#: manifest's ``plan`` names, relative to the run folder).
PLAN_SHA256_KEY = "plan_sha256"


def _flatten(data: Any, prefix: str = "") -> dict[str, Any]:
    """A nested mapping as ``{"section.key": value}`` (lists stay whole)."""
    if not isinstance(data, Mapping):
        return {prefix: data}
    flat: dict[str, Any] = {}
    for key, value in data.items():
        flat.update(_flatten(value, f"{prefix}.{key}" if prefix else str(key)))
    return flat


def _shown(value: Any) -> str:
    """A value as the user wrote it in TOML or on the command line (JSON spelling)."""
    return "(absent)" if value is _ABSENT else json.dumps(value)


_ABSENT = object()
#: The key of an experiment's own seed (the seed of a run without --seed).
_EXPERIMENT_SEED = "experiment.seed"


def experiment_differences(recorded: Mapping[str, Any], current: Mapping[str, Any],
                           source: str = "the manifest") -> list[str]:
    """``key: OLD in the manifest, NEW now`` for every key of two resolved experiments that differs.

    Parameters
    ----------
    recorded
        The experiment the manifest recorded (``manifest["config"]``).
    current
        The experiment now (``ExperimentConfig.model_dump(mode="json")``).
    source
        The file that recorded it, as the differences name it (a batch's ``batch.json``).
    """
    old, new = _flatten(recorded), _flatten(json.loads(json.dumps(current)))
    return [f"{key}: {_shown(old.get(key, _ABSENT))} in {source}, {_shown(new.get(key, _ABSENT))} now"
            for key in sorted(old.keys() | new.keys())
            if old.get(key, _ABSENT) != new.get(key, _ABSENT)]


def kept_run_people(experiment: object, people: Any, log: Callable[[str], None] | None = None) -> Any:
    """The people a simulation of ``experiment`` takes: ``people`` (``--people``) where given; else,
    where ``experiment`` is a run folder's ``config.toml`` (a path) whose manifest records a people
    file, the copy the run keeps (``RUN/people/<name>``), so that simulating a run's ``config.toml``
    gives the run's tables again, ``log`` told so in a ``Note:`` line; else none (the population's
    people).

    Raises
    ------
    RunFolderError
        The run's copy of its people file is gone or was edited since: names it and the fix.
    """
    from nudgecli.sim.people_file import MANIFEST_KEY, copy_path

    if people is not None or not isinstance(experiment, str | Path) or Path(experiment).name != CONFIG:
        return people
    run = Path(experiment).parent
    try:
        recorded = json.loads((run / MANIFEST).read_text(encoding="utf-8")).get(MANIFEST_KEY)
    except (OSError, ValueError, AttributeError):  # no run's manifest there (or not one to read)
        return None
    if not isinstance(recorded, Mapping) or not isinstance(recorded.get("file"), str):
        return None  # simulated with the population's people
    copy = copy_path(run, dict(recorded))
    try:
        kept = not copy_changed(copy, recorded.get("sha256"))
    except OSError:
        kept = False
    if not kept:
        raise RunFolderError(f"{copy}: the run's copy of its people file ({run / MANIFEST} {MANIFEST_KEY!r}) "
                             "is missing or changed since the run kept it, so simulating its config.toml "
                             f"would not give its participants; give the file {recorded['file']} it was "
                             f"simulated with (--people PATH/{recorded['file']}), or other people as "
                             "--people FILE")
    if log is not None:
        log(f"Note: {experiment} is the experiment of the run folder {run}, simulated with --people "
            f"{recorded['file']}: simulating the copy it keeps, --people {copy} (--people FILE chooses "
            "other people)")
    return str(copy)


def copy_changed(copy: Path, recorded: object) -> bool:
    """Whether ``copy``, a file a folder keeps beside the SHA-256 it records of it (``recorded``), changed
    since it was kept: its SHA-256 (:func:`~nudgecli.run_folder_record.file_sha256`) is another.

    Raises
    ------
    OSError
        The copy cannot be read (gone, a folder): each folder names its own copy and fix."""
    from nudgecli.run_folder_record import file_sha256  # the record builds on this module

    return file_sha256(copy) != recorded


def remove_run_analysis(folder: Path) -> None:
    """Remove a run's analysis (``stats.json`` first: an analysis cut short is one without it) and its
    figures: what ``--force`` replaces with the run, and what a resume under another plan analyses
    again (:meth:`ConfigRecord.keep_plan`)."""
    from nudgecli.run_folder_record import remove_run_figures  # the record builds on this module

    for name in (STATS_JSON, *ANALYSIS_FILES):
        (folder / name).unlink(missing_ok=True)
    remove_run_figures(folder)  # drawn under the old analysis (its plan's star rule)


class ConfigRecord:
    """The ``config.toml`` side of a run folder (``path``)."""

    path: Path

    def config_toml_warning(self, config: ExperimentConfig) -> str | None:
        """What a resume that writes ``config`` (the manifest's experiment, with the run's seed) to
        config.toml again says of the one there: it was missing, it held the experiment's own seed
        rather than the run's (written before config.toml recorded the --seed), or it differed;
        ``None`` when it holds ``config`` already."""
        path = self.path / CONFIG
        if not path.is_file():
            return f"{path} was missing; written again from the experiment in the manifest"
        text = path.read_text(encoding="utf-8")
        if text == config.to_toml():
            return None
        try:
            on_disk = experiment_from_toml(text, str(path))
        except (NudgeError, ValueError):
            on_disk = None
        if on_disk is not None and [difference.split(":")[0] for difference in experiment_differences(
                on_disk.model_dump(mode="json"), config.model_dump(mode="json"))] == [_EXPERIMENT_SEED]:
            return (f"{path} held the experiment's own seed ({on_disk.experiment.seed}), not the one the "
                    f"run used ({config.experiment.seed}); rewritten with it")
        return f"{path} differed from the experiment in the manifest; rewritten from it"

    def other_start_error(self, config: ExperimentConfig) -> RunFolderError | None:
        """The refusal of a run of ``config`` into a folder holding only the start of another run (no
        manifest; its ``config.toml`` differs): left by that run killed before its manifest, or by a
        ``--force`` cut short after it removed the manifest of the run it replaced (``config.toml``
        goes last), whose config.toml a resume would simulate again. ``None`` otherwise."""
        path = self.path / CONFIG
        if (self.path / MANIFEST).exists() or not path.is_file() or not only_a_start(self.path) or \
                only_a_start(self.path, config.to_toml()):
            return None
        try:
            differences = experiment_differences(experiment_from_toml(
                path.read_text(encoding="utf-8"), str(path)).model_dump(mode="json"),
                config.model_dump(mode="json"), source=CONFIG)
        except (NudgeError, ValueError):
            differences = []
        shown = f": {'; '.join(differences[:3])}" if differences else ""
        return RunFolderError(f"{self.path}: holds only the start of another run (its {CONFIG} differs"
                              f"{shown}), killed before it wrote its manifest, or a --force that was "
                              "replacing a run there, cut short; nothing of it was simulated: run this "
                              "command with --force (without --resume) to start this run there, or choose "
                              "another --out")

    def _edited_config_hint(self, manifest: Mapping[str, Any]) -> str:
        """``put back ...; `` when the run's ``config.toml`` no longer holds the experiment its
        manifest recorded (edited after the run started), else nothing."""
        path = self.path / CONFIG
        recorded = manifest.get("config")
        if not isinstance(recorded, Mapping) or not path.is_file():
            return ""
        try:
            on_disk = experiment_from_toml(path.read_text(encoding="utf-8"), str(path))
        except (NudgeError, OSError, ValueError):
            return f"{path} no longer holds the run's experiment: put back the manifest's values, then "
        if experiment_differences(recorded, on_disk.model_dump(mode="json")):
            return f"{path} was edited after the run started: put back the manifest's values, then "
        return ""

    def check_plan_not_its_copy(self, plan: str | Path) -> None:
        """Refuse a run into this folder whose plan file (``plan``: ``--plan``) is the run's own copy of
        its plan (:data:`PLAN_COPY`), before the folder is touched: the run writes that copy
        (:meth:`ConfigRecord.keep_plan`), and ``--force`` removes it first; no output replaces a file
        the command read (:func:`nudgecli.outputs.check_not_an_input`, as a batch refuses it).

        Raises
        ------
        WriteError
            ``plan`` is (the same file as) the folder's plan copy: names both and the fix.
        """
        from nudgecli.outputs import check_not_an_input, command_inputs, declare_input

        with command_inputs():  # a preset's name is no file, and is not declared
            declare_input(f"--plan {plan}", plan)
            try:
                check_not_an_input(self.path / PLAN_COPY)
            except WriteError as exc:
                raise WriteError(f"{exc}, or give a copy of the plan kept elsewhere as --plan (a resume "
                                 "without --plan keeps the run's)") from None

    def keep_plan(self, manifest: MutableMapping[str, Any], plan: str | None,
                  config: ExperimentConfig) -> None:
        """Record the analysis plan of a run of ``config`` in ``manifest``: ``plan`` (``--plan``), else the
        default one (:func:`~nudgecli.config_files.resolve_plan`); a preset by its name, a plan file (a
        ``.toml`` path, or a file by that name, as :func:`~nudgecli.config_files.resolve_preset` tells
        them apart) as an exact copy in the folder (:data:`PLAN_COPY`) with its SHA-256. A plan other
        than the one ``manifest`` records removes the folder's analysis first (:func:`remove_run_analysis`):
        the manifest is written later, and the old analysis must never stand under the new plan's name."""
        from nudgecli.config_files import resolve_plan

        plan = resolve_plan(plan, experiment=config.experiment.name, world=config.world.kind)
        given = Path(plan)
        preset = given.suffix != ".toml" and not given.is_file()
        data = None if preset else given.read_bytes()
        recorded = (manifest.get("plan"), manifest.get(PLAN_SHA256_KEY))
        if recorded != ((plan, None) if data is None else (PLAN_COPY, hashlib.sha256(data).hexdigest())):
            # the analysis of the plan recorded so far goes before the new plan is: a resume killed
            # from here on leaves no analysis (analyze redoes it), never one beside another plan's name
            remove_run_analysis(self.path)
        manifest.pop(PLAN_SHA256_KEY, None)
        if data is None:
            manifest["plan"] = plan
            return
        from nudgecli.store import write_bytes_atomic  # the store imports this module

        write_bytes_atomic(self.path / PLAN_COPY, data)
        manifest.update({"plan": PLAN_COPY, PLAN_SHA256_KEY: hashlib.sha256(data).hexdigest()})

    def recorded_plan(self, manifest: Mapping[str, Any]) -> Any:
        """The manifest's ``plan`` as a reader loads it: the path of the run's copy of its plan file,
        checked against the SHA-256 the manifest records (:meth:`keep_plan`); else as recorded (a
        preset's name; a path, of an older nudge; ``None``).

        Raises
        ------
        ConfigError
            The copy is missing or was edited: one line naming it, the manifest's ``plan`` and the
            fix (``--plan`` overrides it).
        """
        recorded = manifest.get("plan")
        if PLAN_SHA256_KEY not in manifest or not isinstance(recorded, str):
            return recorded
        copy = self.path / recorded
        where = f"{self.path / MANIFEST} 'plan'"
        try:
            changed = copy_changed(copy, manifest[PLAN_SHA256_KEY])
        except OSError as exc:
            raise ConfigError(f"{copy}: the run's copy of its analysis plan ({where}) cannot be read "
                              f"({exc.strerror or exc}); put it back from a backup, or give --plan PLAN, "
                              f"which overrides {where}") from None
        if changed:
            raise ConfigError(f"{copy}: changed since the run kept it as the plan of {where} (its "
                              f"SHA-256 differs from the manifest's {PLAN_SHA256_KEY!r}); put it back from a "
                              f"backup, or give --plan PLAN, which overrides {where}")
        return str(copy)


def run_experiment(run: RunFolder) -> ExperimentConfig:
    """The experiment a run was made with, as its manifest records it (a run folder is read only
    through its manifest: an edited ``config.toml`` changes nothing read); a manifest of an older
    nudge, which records none, leaves its ``config.toml``."""
    recorded = run.read_manifest().get("config") if run.is_run() else None
    if not isinstance(recorded, Mapping):
        return run.read_config()
    try:
        return ExperimentConfig.model_validate(recorded)
    except ValidationError as exc:
        where = f"{run.manifest_path} (config)"
        raise RunFolderError(format_validation_error(exc, where, ExperimentConfig, dict(recorded))) from None
