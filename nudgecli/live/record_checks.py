"""What a resume checks of a participant's records before it continues their session.

A person's trial or answer cannot be asked again, so a record that does not match the manifest
is refused, naming the file, with the advice to restore it from a backup: a part whose SHA-256
differs from the one the manifest recorded (``checksums``, the key and format of ``nudge
simulate``), a part missing while the manifest lists trials in it, a part without rows of a trial
the manifest lists as completed, an unreadable part, and a ``questionnaires.csv`` missing (or
without the participant's row) while the manifest lists the block as answered.

A checkpoint records the SHA-256 of the parts it is about to rename into place in the
participant's entry (:data:`WRITING`) before it renames them, so a crash between the renames and
the manifest's update (the running trial's rows on disk, not yet listed) is told apart from an
edit: such a part is taken, without the unlisted trial's rows, and written again (any part holding
rows of a trial the manifest does not list is: the readers of the folder refuse one).
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from nudgecli.errors import RunFolderError
from nudgecli.live.questionnaire import RESTORE_ANSWERS, answered_blocks
from nudgecli.parquet_reader import read_parquet
from nudgecli.run_folder_names import QUESTIONNAIRES_CSV
from nudgecli.run_folder_record import part_name

#: The participant's entry's record of the parts a checkpoint is renaming into place:
#: ``{"trial": t, "trials": SHA-256, "steps": SHA-256}``.
WRITING = "writing_parts"
#: The manifest's record of each part's SHA-256 (participant -> kind -> hex), as ``nudge simulate``'s.
CHECKSUMS = "checksums"
#: The parts a checkpoint rewrites after each trial.
TRIAL_PARTS = ("trials", "steps")
RESTORE = "restore it from a backup (a person's trial cannot be run again)"


def recorded_sums(manifest: Mapping[str, Any], participant: int) -> dict[str, str]:
    """The SHA-256 the manifest records of the participant's parts (kind -> hex; empty: none)."""
    sums = (manifest.get(CHECKSUMS) or {}).get(str(participant))
    return {str(k): str(v) for k, v in sums.items()} if isinstance(sums, Mapping) else {}


@dataclass(frozen=True)
class TrialPart:
    """A participant's trials or steps part as the manifest's checks see it
    (:func:`trial_parts`): the resume's (:func:`check_trial_parts`) and a reader's
    (:meth:`~nudgecli.run_folder_live.LiveRecord.check_live_trials`)."""

    kind: str
    path: Path
    #: ``kind/part-NNNN.parquet``, as a message names it.
    name: str
    #: Its SHA-256 (``None``: no such file).
    digest: str | None
    #: The SHA-256 the manifest records of it (``None``: none yet).
    recorded: str | None
    #: Its rows (``None``: missing, or unreadable: :attr:`error` says why).
    frame: pd.DataFrame | None
    error: str
    #: The trials it holds that the manifest does not list, and those listed that it holds no rows of.
    extra: list[int]
    lacking: list[int]


def trial_parts(folder: Path, manifest: Mapping[str, Any], participant: int, entry: Mapping[str, Any],
                columns: list[str] | None = None) -> Iterator[TrialPart]:
    """The participant's parts (:data:`TRIAL_PARTS`, in order), each read once (hashed, then its
    ``columns`` read; ``None``: all), beside the trials their manifest ``entry`` lists as completed."""
    listed = {int(trial) for trial in entry.get("completed_trials") or []}
    sums = recorded_sums(manifest, participant)
    for kind in TRIAL_PARTS:
        path = folder / kind / part_name(participant)
        name, recorded = f"{kind}/{path.name}", sums.get(kind)
        if not path.is_file():
            yield TrialPart(kind, path, name, None, recorded, None, "", [], [])
            continue
        data = path.read_bytes()
        frame: pd.DataFrame | None = None
        trials: set[int] = set()
        error = ""
        try:
            frame = read_parquet(data, columns)
            trials = set(frame["trial"].astype(int).tolist())
        except Exception as exc:  # pyarrow raises several types for broken files; no trial column
            frame, error = None, str(exc)
        yield TrialPart(kind, path, name, hashlib.sha256(data).hexdigest(), recorded, frame, error,
                        sorted(trials - listed), sorted(listed - trials))


class CheckedParts:
    """The participant's trials and steps of their completed trials, checked against the manifest;
    ``rewrite``: the parts on disk that hold rows of a trial a crash left unlisted (write again)."""

    def __init__(self) -> None:
        self.tables: dict[str, pd.DataFrame | None] = {kind: None for kind in TRIAL_PARTS}
        self.rewrite: list[str] = []


def check_trial_parts(folder: Path, manifest: Mapping[str, Any], participant: int,
                      entry: Mapping[str, Any]) -> CheckedParts:
    """The participant's parts, checked (see the module docstring).

    Raises
    ------
    RunFolderError
        A part changed, missing, unreadable, or without rows of a completed trial.
    """
    who = f"participant {entry.get('participant_id', participant)}"
    completed = [int(trial) for trial in entry.get("completed_trials") or []]
    writing = entry.get(WRITING) or {}
    checked = CheckedParts()
    for part in trial_parts(folder, manifest, participant, entry):
        name = part.name
        if part.digest is None:
            if completed:
                raise RunFolderError(f"{folder}: {name} is missing, but the manifest records "
                                     f"{len(completed)} trial(s) of {who} in it; {RESTORE}")
            continue
        if part.recorded is not None and part.digest not in (part.recorded, writing.get(part.kind)):
            raise RunFolderError(f"{folder}: {name} changed since it was written (its SHA-256 differs from "
                                 f"the one in the manifest); {RESTORE}")
        if part.frame is None:
            raise RunFolderError(f"{folder}: {name} is not a readable part of a live session "
                                 f"({part.error[:120]}); {RESTORE}")
        if lacking := part.lacking:
            raise RunFolderError(f"{folder}: {name} holds no rows of trial(s) "
                                 f"{', '.join(map(str, lacking))}, which the manifest lists as completed by "
                                 f"{who}; {RESTORE}")
        if part.extra:
            # a crash after the rename (on the first trial too, whose part has no SHA-256 recorded yet):
            # written again without the unlisted trial, so the part holds exactly the trials listed
            checked.rewrite.append(part.kind)
        checked.tables[part.kind] = part.frame[part.frame["trial"].isin(completed)].reset_index(drop=True)
    return checked


def check_answered_blocks(folder: Path, participant: int, entry: Mapping[str, Any]) -> None:
    """Refuse a ``questionnaires.csv`` that is missing, or lacks a row of the participant, for a
    block the manifest lists as answered (rows matched by
    :func:`~nudgecli.live.questionnaire.answered_blocks`, as every reader of the file matches them).

    Raises
    ------
    RunFolderError, DataError
        Naming the file and the blocks.
    """
    blocks = sorted(int(block) for block in entry.get("questionnaire_blocks") or [])
    path = folder / QUESTIONNAIRES_CSV
    if not blocks:
        return
    who = f"participant {entry.get('participant_id', participant)}"
    if not path.is_file():
        raise RunFolderError(f"{path} is missing, but the manifest records the answers of {who} to "
                             f"block(s) {', '.join(map(str, blocks))} in it; {RESTORE_ANSWERS}")
    # matched as the analysis matches labels (a block read back as 0.0 beside a blank cell is block 0)
    found = answered_blocks(path, participant, blocks)
    if lacking := [block for block in blocks if block not in found]:
        raise RunFolderError(f"{path} holds no answers of {who} to block(s) {', '.join(map(str, lacking))}, "
                             f"which the manifest records as answered; {RESTORE_ANSWERS}")
