"""What a command that resumes an interrupted run or batch folder names: the ``--people`` file,
and a batch's own experiment and plan files.

A run or batch made with ``--people`` keeps an exact copy of the file in its folder
(``people/<name>``, :func:`nudgecli.sim.people_file.keep_copy`); the command that resumes it names
that copy by the folder's path as given, so it works from wherever that path does, not only from
the folder the file's own path was typed in. The rule is
:func:`nudgecli.sim.people_file.resume_people`'s; this module reads what the folder records.
"""

from __future__ import annotations

import json
from pathlib import Path


def _recorded_people(folder: Path) -> object:
    """The people file a run's (``manifest.json``) or a batch's (``batch.json``, under ``batch``:
    :func:`nudgecli.runs.batch_folder.recorded_people`) manifest records; ``None`` where neither is
    there or readable yet (anything else as read)."""
    from nudgecli.run_folder_names import MANIFEST
    from nudgecli.runs.batch_folder import recorded_people
    from nudgecli.sim.people_file import MANIFEST_KEY

    try:
        document = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):  # absent, or half-written by the process interrupted: a batch's?
        return recorded_people(folder)[1]
    return document.get(MANIFEST_KEY) if isinstance(document, dict) else None


def people_to_resume(folder: str | Path, typed: str | None) -> str | None:
    """The ``--people`` of the command that resumes ``folder``, a run or batch folder.

    Parameters
    ----------
    folder
        The folder as the user gave it (``--out``).
    typed
        ``--people`` as the user typed it; ``None`` without one.

    Returns
    -------
    str or None
        The copy the folder keeps (``FOLDER/people/<name>``) where it has been written, else
        ``typed`` (the command was interrupted before the copy was written).
    """
    from nudgecli.sim.people_file import resume_people

    if typed is None:
        return None
    return resume_people(folder, _recorded_people(Path(folder)), typed)


def inputs_to_resume(folder: str | Path) -> dict[str, str]:
    """The experiment and plan files the command that resumes batch ``folder`` names in place of
    the ones typed, or a sweep's sweep file, where the folder keeps them
    (:func:`nudgecli.runs.batch_folder.kept_inputs`): they import the batch's own policy copies, so
    the command works from any folder.

    Returns
    -------
    dict[str, str]
        ``{"experiment": path, "plan": path}`` (a replicate or power batch) or ``{"sweep_file":
        path}`` (a sweep) for those kept (paths by ``folder`` as given); empty where none is.
    """
    from nudgecli.runs.batch_folder import kept_inputs

    return {name: str(path) for name, path in kept_inputs(Path(folder)).items()}


def recordings_base(folder: str | Path) -> str | None:
    """The folder the command that resumes batch ``folder`` must run from: the current one, where
    the experiment the batch keeps names a ``population.physiology_logs`` recording by a relative
    path (read from the current folder; from elsewhere the resume is refused, or would take another
    recording: :data:`nudgecli.recording_digests.RECORDINGS_KEY`); ``None`` where it names none so."""
    import tomllib

    from nudgecli.runs.batch_folder import kept_inputs

    kept = kept_inputs(Path(folder)).get("experiment")
    try:
        population = tomllib.loads(kept.read_text(encoding="utf-8")).get("population") if kept else None
    except (OSError, ValueError):
        return None
    logs = population.get("physiology_logs") if isinstance(population, dict) else None
    relative = isinstance(logs, list) and any(not Path(str(log)).is_absolute() for log in logs)
    return str(Path.cwd()) if relative else None


__all__ = ["inputs_to_resume", "people_to_resume", "recordings_base"]
