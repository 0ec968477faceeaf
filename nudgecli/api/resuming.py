"""What a command that resumes an interrupted run or batch folder names: the ``--people`` file,
and a batch's own experiment and plan files (:func:`typed_resume_command`).

A run or batch made with ``--people`` keeps an exact copy of the file in its folder
(``people/<name>``, :func:`nudgecli.sim.people_file.keep_copy`); the command that resumes it names
that copy by the folder's path as given, so it works from wherever that path does, not only from
the folder the file's own path was typed in. The rule is
:func:`nudgecli.sim.people_file.resume_people`'s; this module reads what the folder records.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
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


def typed_resume_command(folder: str | Path, command: str, arguments: Sequence[tuple[str, str]],
                         options: Sequence[tuple[str, Sequence[str]]]) -> str:
    """The command that resumes batch ``folder`` from the command as typed, naming the inputs the
    folder keeps in place of those typed (:func:`nudgecli.runs.batch_resume.typed_resume_command`,
    the one builder of the hint after Ctrl-C).

    Parameters
    ----------
    folder
        The folder as the user gave it (``--out``).
    command
        ``replicate``, ``power`` or ``sweep``.
    arguments
        ``(name, value)`` of each argument, in order.
    options
        ``(name, words)`` of each option given on the command line, in order.
    """
    from nudgecli.runs.batch_resume import typed_resume_command as from_typed

    return from_typed(Path(folder), command, arguments, options)


def recordings_base(folder: str | Path) -> str | None:
    """The folder the command that resumes batch ``folder`` must run from: the current one, where
    the experiment the batch keeps names a ``population.physiology_logs`` recording by a relative
    path (read from the current folder; from elsewhere the resume is refused, or would take another
    recording: :data:`nudgecli.recording_digests.RECORDINGS_KEY`); ``None`` where it names none so."""
    from nudgecli.config_files import read_toml
    from nudgecli.errors import ConfigError
    from nudgecli.runs.batch_folder import kept_inputs

    kept = kept_inputs(Path(folder)).get("experiment")
    try:
        population = read_toml(kept).get("population") if kept else None
    except ConfigError:
        return None
    logs = population.get("physiology_logs") if isinstance(population, dict) else None
    relative = isinstance(logs, list) and any(not Path(str(log)).is_absolute() for log in logs)
    return str(Path.cwd()) if relative else None


__all__ = ["people_to_resume", "recordings_base", "typed_resume_command"]
