"""What ``batch.json`` records of the inputs a batch folder keeps (its experiment and plan, a sweep's
sweep file: :data:`~nudgecli.runs.batch_folder.INPUTS_KEY`) when a command writes it.

A new batch records the SHA-256 of the bytes it writes. A resume never writes over a kept input (it
puts back only a lost one, :func:`~nudgecli.runs.batch_folder.prepare_folder`), so the record keeps
the digest of each file the folder holds: the one the batch recorded when it wrote it, or that of
the bytes the resume put back. The resume's own inputs may differ from the kept ones in bytes alone
(a comment added to the experiment file, a sweep file's ``replications`` overridden by an equal
``-R``): recording theirs would describe files the folder does not hold, and the folder's own resume
command (``nudge sweep FOLDER/sweep.toml --resume``) would then be refused as "changed".
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from nudgecli.run_folder_names import BATCH_MANIFEST
from nudgecli.run_folder_record import file_sha256
from nudgecli.runs.batch_folder import INPUTS_KEY, PolicyCopies, read_manifest


def copies_record(folder: Path, copies: PolicyCopies, resumed: bool) -> dict[str, Any]:
    """``batch.json``'s record of the policy copies and kept inputs of the batch in ``folder``
    (:meth:`~nudgecli.runs.batch_folder.PolicyCopies.record`), once its folder is prepared.

    Parameters
    ----------
    folder
        The batch folder, its lock held and its kept inputs in place.
    copies
        What this command keeps of the batch's code and inputs.
    resumed
        Whether the command resumes the batch: each kept input keeps the digest its ``batch.json``
        records, unless the folder's file holds this command's bytes (put back where it was lost).

    Returns
    -------
    dict
        The entries to record beside the batch's description.
    """
    record = copies.record()
    ours = record.get(INPUTS_KEY)
    if not resumed or not ours:
        return record
    old, _ = read_manifest(folder / BATCH_MANIFEST)
    kept = old.get(INPUTS_KEY) if old is not None else None
    if not isinstance(kept, Mapping):  # a batch of an older nudge: its inputs are this command's bytes
        return record
    record[INPUTS_KEY] = {name: _kept_digest(folder / name, digest, kept.get(name))
                          for name, digest in ours.items()}
    return record


def _kept_digest(path: Path, ours: str, recorded: object) -> str:
    """The digest to record of the kept input at ``path``: ``ours`` (this command's bytes) where the
    file holds them or none was recorded, else the ``recorded`` one (the file the batch wrote)."""
    if not isinstance(recorded, str) or (path.is_file() and file_sha256(path) == ours):
        return ours
    return recorded
