"""Whether what a batch folder keeps agrees with what its ``batch.json`` records, before a resume
trusts either: the experiment and plan it keeps (their SHA-256 in ``batch.json``'s ``inputs``), and
``batch.json``'s own plan against the kept plan whose SHA-256 it records. A TOML file a run or batch
folder keeps is checked so as it is read only by the command whose output folder it is
(:func:`reading_as_folder`): another command reads it as any file, to start a new folder.

:func:`nudgecli.runs.batch_folder.prepare_folder` calls these; they read and never write.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path
from typing import Any

from nudgecli.errors import ConfigError, DataError, RunFolderError
from nudgecli.run_folder_names import BATCH_MANIFEST
from nudgecli.run_folder_record import file_sha256
from nudgecli.runs.batch_folder import (  # noqa: F401 - EXPERIMENT_COPY named in docs
    EXPERIMENT_COPY,
    INPUTS_KEY,
    PLAN_COPY,
    read_manifest,
)
from nudgecli.sim.policy_files import check_copies_placeable


def check_kept_inputs(folder: Path, recorded: object, inputs: Mapping[str, bytes]) -> None:
    """Refuse to resume the batch in ``folder`` where the experiment or plan it keeps
    (:data:`EXPERIMENT_COPY`, :data:`PLAN_COPY`) is not as it wrote them: a file whose SHA-256
    differs from the one ``batch.json`` records (``recorded``, its :data:`INPUTS_KEY` entry), unless
    only its comments or layout changed (the batch's ``inputs`` now are the recorded bytes, and the
    file reads as the same TOML: a note of the person's own); or, where it records none (a batch of
    an older nudge), a file of the person's own with other bytes than the batch's
    (:func:`~nudgecli.sim.policy_files.check_copies_placeable`). Checked before the settings are
    compared: an edited copy may be what the resume read. A missing one is no fault (the resume
    writes it again).

    Raises
    ------
    RunFolderError
        The first such file: names it, what is wrong and the fix.
    """
    from nudgecli.config_files import read_toml, toml_of_bytes

    def same_settings(kept: Path, now: bytes | None, digest: object) -> bool:
        try:
            return now is not None and hashlib.sha256(now).hexdigest() == digest and \
                read_toml(kept) == toml_of_bytes(now, kept)
        except ConfigError:  # unreadable, not TOML: not the batch's
            return False

    recorded_sums = {str(k): v for k, v in recorded.items()} if isinstance(recorded, Mapping) else {}
    for name, digest in sorted(recorded_sums.items()):
        kept = folder / name
        if kept.is_file() and file_sha256(kept) != digest and \
                not same_settings(kept, inputs.get(name), digest):
            raise RunFolderError(changed_input_message(kept))
    check_copies_placeable(inputs, folder, recorded, "batch", "input")


def changed_input_message(kept: Path) -> str:
    """Why the batch's kept input ``kept`` (its experiment, plan or sweep file) is not resumed with:
    it changed since the batch wrote it; and the fix."""
    return (f"{kept}: changed since the batch wrote it (its SHA-256 differs from the one {BATCH_MANIFEST} "
            f"records in {INPUTS_KEY!r}), so the batch would not resume with what made its results; delete "
            "it and resume with the command that started the batch (it writes the file again), or put it "
            "back from a backup")


#: The output folder of the command reading (:func:`reading_as_folder`), resolved; ``None`` outside one.
_OWN_FOLDER: ContextVar[Path | None] = ContextVar("own_folder", default=None)


@contextmanager
def reading_as_folder(out: str | Path | None) -> Iterator[None]:
    """Within it, a TOML file of the folder ``out`` (the command's ``--out``: the run or batch it
    resumes or replaces) is read as that folder's kept input, checked against its record
    (:func:`read_as_own`); a file of another folder, read to start a new one, as any file."""
    token = _OWN_FOLDER.set(None if out is None else Path(out).resolve())
    try:
        yield
    finally:
        _OWN_FOLDER.reset(token)


def read_as_own(path: Path) -> bool:
    """Whether ``path`` is read as a file its folder keeps: the folder is the reading command's own
    (:func:`reading_as_folder`)."""
    own = _OWN_FOLDER.get()
    return own is not None and path.parent.resolve() == own


def own_copy_refusal(path: Path) -> DataError | None:
    """:func:`~nudgecli.sim.policy_files.changed_copy_error` of the experiment file ``path`` where it
    is read as its folder's own (:func:`read_as_own`); ``None`` for another folder's, which a new run
    or batch takes as it is now (it imports the policy code it finds and keeps its own copies)."""
    from nudgecli.sim.policy_files import changed_copy_error

    return changed_copy_error(path) if read_as_own(path) else None


def kept_input_changed(path: Path) -> str | None:
    """:func:`changed_input_message` where ``path`` is an input a batch keeps (its folder's
    ``batch.json`` records its SHA-256 in :data:`INPUTS_KEY`) and its bytes are not those; else
    ``None`` (no batch there, a batch.json unreadable: its own refusal says so)."""
    document, _ = read_manifest(path.parent / BATCH_MANIFEST)
    recorded = document.get(INPUTS_KEY) if document is not None else None
    digest = recorded.get(path.name) if isinstance(recorded, Mapping) else None
    if not isinstance(digest, str):
        return None
    try:
        changed = file_sha256(path) != digest
    except OSError:
        return None
    return changed_input_message(path) if changed else None


def check_plan_not_edited(folder: Path, old: Mapping[str, Any], inputs: Mapping[str, bytes],
                          differences: list[str]) -> None:
    """Refuse a resume of the batch in ``folder`` (``old``: its ``batch.json``) refused for
    ``differences`` of its plan where the plan now is the one whose SHA-256 ``batch.json`` records
    (``inputs``: this command's, whose :data:`PLAN_COPY` is the plan as the batch keeps it): the
    plan ``batch.json`` describes was edited, and the advised resume would be refused again.

    Raises
    ------
    RunFolderError
        Names ``batch.json`` as edited, and the fix (restore it, or ``--force``).
    """
    recorded = old.get(INPUTS_KEY)
    digest = recorded.get(PLAN_COPY) if isinstance(recorded, Mapping) else None
    plan = inputs.get(PLAN_COPY)
    edited = [difference for difference in differences if difference.split(":")[0].split(".")[0] == "plan"]
    if not edited or plan is None or hashlib.sha256(plan).hexdigest() != digest:
        return
    shown = "; ".join(edited[:3]).replace(" now", f" in {PLAN_COPY}")
    raise RunFolderError(f"{folder / BATCH_MANIFEST}: its plan differs from the plan whose SHA-256 it "
                         f"records in {INPUTS_KEY!r}, which the folder keeps as {PLAN_COPY} ({shown}), so "
                         f"{BATCH_MANIFEST} was edited; put it back from a copy, or start the batch again "
                         "with --force (its tasks are computed again)")
