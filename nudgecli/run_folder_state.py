"""How a run folder stands after its writer stopped: only the start of a run (killed before its
manifest), or a run whose manifest says running (still running, or killed: whether a live process
holds its lock). Read by :class:`nudgecli.run_folder_record.RunRecord` and
:class:`nudgecli.store.RunFolder`."""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from nudgecli import __version__
from nudgecli.errors import RunFolderError, shell_words
from nudgecli.run_folder_names import (
    CALIBRATION_DIR,
    CONFIG,
    FIGURES_DIR,
    LAYOUTS,
    LOCK,
    MANIFEST,
    PART_KINDS,
    PARTICIPANTS,
    PEOPLE_DIR,
    PLAN_COPY,
)

#: The folders a run makes before its manifest, and ``--force`` empties: empty, part of a start.
_EMPTIED = (*PART_KINDS, CALIBRATION_DIR)

#: The executor a run's manifest and a batch's ``batch.json`` record for work done on a dask
#: scheduler (:func:`nudgecli.runs.study.executor_name`), never its address: a folder shipped with
#: a paper carries no machine's address.
DASK_EXECUTOR = "dask"
#: What a command that resumes such work names for its scheduler, which the person fills in.
SCHEDULER_PLACEHOLDER = "ADDRESS"


def resume_scheduler(manifest: Mapping[str, Any] | None) -> str | None:
    """The ``--scheduler`` value of a command that resumes the run or batch of ``manifest`` (its
    ``manifest.json`` or ``batch.json``): :data:`SCHEDULER_PLACEHOLDER` where its last run was on a
    dask scheduler (a resume without ``--scheduler`` would run on local workers), else ``None``
    (local workers, or a manifest of a nudge that recorded no executor)."""
    on_dask = manifest is not None and manifest.get("executor") == DASK_EXECUTOR
    return SCHEDULER_PLACEHOLDER if on_dask else None


def only_a_start(folder: Path, config_text: str | None = None) -> bool:
    """Whether ``folder`` holds only the start of a run (of the one whose config.toml is
    ``config_text``; ``None``: any), left by a run killed before it wrote its manifest: its
    config.toml, perhaps its layouts and its plan file's copy, temporaries, and empty part and
    calibration folders (a ``--force`` killed after clearing the old run leaves those); never a
    folder holding a file of the person's own. A run killed as it wrote its config.toml leaves
    only that file's temporary (beside its lock and those empty folders): a start of any run."""
    config_path = folder / CONFIG
    if config_path.is_file():
        if config_text is not None and config_path.read_text(encoding="utf-8") != config_text:
            return False
        kept: tuple[str, ...] = (CONFIG, LAYOUTS, LOCK, PEOPLE_DIR, PLAN_COPY)
    elif any(folder.glob(f".{CONFIG}.*.tmp")):  # killed as it wrote config.toml: that run's start
        kept = (LOCK,)
    else:
        return False
    return all(p.name in kept or p.name.endswith(".tmp")
               or (p.name in _EMPTIED and p.is_dir() and not any(p.iterdir())) for p in folder.iterdir())


def start_advice(folder: Path) -> str | None:
    """What a reader of a folder holding only the start of a run (:func:`only_a_start`) is told, else
    ``None``: the ``nudge simulate CONFIG --out FOLDER --resume`` that starts it again, and the
    ``nudge run ... --plan PLAN --resume`` of a run started with ``--plan`` (a start records no plan:
    the simulate one records the default); a ``--force`` cut short leaves such a start too, its
    config.toml perhaps the replaced run's, which that resume would simulate again."""
    if not only_a_start(folder):
        return None
    from nudgecli.store import simulate_resume_command  # store builds on this module

    experiment = str(folder / CONFIG) if (folder / CONFIG).is_file() else "EXPERIMENT"
    run = simulate_resume_command(experiment, folder, command="run", plan="PLAN")
    return (f"{folder} holds only the start of a run killed before it wrote its manifest (a start records "
            f"no analysis plan); start it again with `{simulate_resume_command(experiment, folder)}`, or "
            f"`{run}` for a run started with --plan PLAN; if a --force that was replacing a run there was "
            f"cut short ({CONFIG} may still be the replaced run's), run that same --force command instead")


def run_state(folder: Path, manifest: Mapping[str, Any]) -> str:
    """How an unfinished run stands, for a message: ``is running`` while another live process
    holds its lock (:func:`nudgecli.locks.run_lock`), ``was interrupted`` where its manifest says
    running but none does (it was killed), else ``is <status>``."""
    state = str(manifest.get("status", "not finished"))
    if state != "running":
        return f"is {state}"
    from nudgecli.locks import held_by_another_process  # locks builds on store, which builds on this module

    # this command's own lock (it reads the run) is no other writer's
    return "is running" if held_by_another_process(folder) else "was interrupted"


def reader_state(folder: Path, manifest: Mapping[str, Any]) -> str:
    """:func:`run_state` for a command that reads the run (``habits``, ``compare``, ``fit-people``):
    a run another process is writing now is refused in the words of its lock (the ``--resume`` an
    unfinished run is told would be refused, "in use by"), the others stand as :func:`run_state` says.

    Raises
    ------
    RunFolderError
        The run is running: who writes it, and to wait for it to finish.
    """
    state = run_state(folder, manifest)
    if state == "is running":
        from nudgecli.locks import describe_holder, read_holder  # locks builds on store, which builds on this

        holder = describe_holder(read_holder(folder / LOCK))
        raise RunFolderError(f"{folder}: the run is running, in use by {holder}; wait for it to finish")
    return state


def other_version(manifest: Mapping[str, Any]) -> str | None:
    """The nudgecli version the manifest records when it is not this one (``""``: it records none),
    else ``None``. This nudge refuses to resume such a run (its settings differ: ``resume_differences``
    of :class:`~nudgecli.run_folder_record.RunRecord`), so no advice offers that resume."""
    versions = manifest.get("versions")
    recorded = versions.get("nudgecli") if isinstance(versions, Mapping) else None
    return None if recorded == __version__ else str(recorded or "")


def version_difference(manifest: Mapping[str, Any]) -> str | None:
    """``nudgecli version: OLD in the manifest, NEW now`` where :func:`other_version` finds one."""
    if (old := other_version(manifest)) is None:
        return None
    return f"nudgecli version: {old or '(absent)'} in the manifest, {__version__} now"


def rerun_command(folder: Path, manifest: Mapping[str, Any] | None, resume: str | None = None) -> str:
    """The ``nudge simulate ... --force`` that simulates the run in ``folder`` again with this nudge,
    replacing it: its ``--resume`` command ``resume`` with ``--force`` in place of ``--resume`` (the
    same options: its people file too), else its experiment (its config.toml where there is one),
    seed and participants."""
    from nudgecli.store import forced_command  # store builds on this module

    if resume is not None and (forced := forced_command(resume)) is not None:
        return forced
    manifest = manifest or {}
    experiment = str(folder / CONFIG) if (folder / CONFIG).is_file() else \
        str(manifest.get("experiment") or "EXPERIMENT")
    words = ["nudge", "simulate", experiment, "--out", str(folder)]
    for flag, key in (("--seed", "seed"), ("--participants", "participants")):
        words += [flag, str(manifest[key])] if manifest.get(key) is not None else []
    words += ["--scheduler", scheduler] if (scheduler := resume_scheduler(manifest)) else []
    return shell_words([*words, "--force"])


def simulate_again(folder: Path, manifest: Mapping[str, Any] | None, resume: str | None = None) -> str:
    """The advice to simulate the run in ``folder`` again with this nudge (:func:`rerun_command`)."""
    return f"simulate the run again with this version of nudge: `{rerun_command(folder, manifest, resume)}`"


def repair_advice(folder: Path, manifest: Mapping[str, Any], resume: str, verb: str) -> str:
    """What repairs or finishes the run in ``folder``: ``VERB with `RESUME``` (``resume``: its
    ``--resume`` command), or, where the run was made by another nudgecli version (whose resume this
    one refuses), both versions, the install that resumes it, and the simulation again that works."""
    old = other_version(manifest)
    if old is None:
        return f"{verb} with `{resume}`"
    if not old:
        return (f"the manifest records no nudgecli version (this is {__version__}, which resumes only its "
                f"own runs); {simulate_again(folder, manifest, resume)}")
    return (f"the run was made by nudgecli {old} (this is {__version__}, which resumes only its own runs): "
            f"to {verb if ' ' in verb else f'{verb} it'}, install nudgecli=={old} and run `{resume}`, or "
            f"{simulate_again(folder, manifest, resume)}")


#: What a run writes in its folder: a link in their place is refused (:func:`refuse_links`). The
#: other folder kinds name theirs where they are written: a batch's
#: (:data:`nudgecli.runs.batch_folder.BATCH_OWN`), a ``nudge study`` folder's
#: (:data:`nudgecli.run_folder_live.LIVE_OWN`), an analysis's
#: (:data:`nudgecli.report.analysis_folders.ANALYSIS_FILES`) and a plot's ``figures/``.
RUN_OWN = (*_EMPTIED, PEOPLE_DIR, FIGURES_DIR, MANIFEST, CONFIG, PARTICIPANTS, LAYOUTS)


def refuse_linked_out(folder: Path) -> None:
    """Refuse an ``--out`` that is itself a symbolic link (to a folder elsewhere), before a run or a
    batch writes anything (its lock) through it. A run given by a link to ``analyze`` or ``plot`` is
    the person's choice of folder: only the files and folders inside are checked
    (:func:`refuse_links`).

    Raises
    ------
    RunFolderError
        Names the link, where it points and the real folder to give."""
    if folder.is_symlink():
        raise RunFolderError(f"{folder} is a symbolic link (to {os.readlink(folder)}); nudge never writes "
                             f"through a link, into another folder: give the real folder, {folder.resolve()}")


def refuse_links(folder: Path, names: Iterable[str] = RUN_OWN) -> None:
    """Refuse where a folder or file a command writes in ``folder`` (``names``: a run's by default,
    ``trials/``, ``manifest.json``, ...) is a symbolic link: writing, resuming or ``--force``
    replacing it would follow the link into another folder (another run's parts). Never followed,
    never replaced: the person says which.

    Raises
    ------
    RunFolderError
        Names the link and where it points."""
    for name in names:
        path = folder / name
        if path.is_symlink():
            raise RunFolderError(f"{path} is a symbolic link (to {os.readlink(path)}); nudge never writes "
                                 "through a link, into another folder: replace the link with a folder "
                                 "(or file) of its own, or choose another --out")
