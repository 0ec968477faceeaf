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

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from nudgecli.errors import RunFolderError
from nudgecli.live.questionnaire import read_answers
from nudgecli.parquet_reader import read_parquet
from nudgecli.run_folder_names import QUESTIONNAIRES_CSV
from nudgecli.run_folder_record import file_sha256, part_name

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
    sums, writing = recorded_sums(manifest, participant), entry.get(WRITING) or {}
    checked = CheckedParts()
    for kind in TRIAL_PARTS:
        part = folder / kind / part_name(participant)
        name = f"{kind}/{part.name}"
        if not part.is_file():
            if completed:
                raise RunFolderError(f"{folder}: {name} is missing, but the manifest records "
                                     f"{len(completed)} trial(s) of {who} in it; {RESTORE}")
            continue
        digest = file_sha256(part)
        if kind in sums and digest not in (sums[kind], writing.get(kind)):
            raise RunFolderError(f"{folder}: {name} changed since it was written (its SHA-256 differs from "
                                 f"the one in the manifest); {RESTORE}")
        try:
            frame = read_parquet(part)
            trials = set(frame["trial"].astype(int))
        except Exception as exc:  # pyarrow raises several types for broken files; no trial column
            raise RunFolderError(f"{folder}: {name} is not a readable part of a live session "
                                 f"({str(exc)[:120]}); {RESTORE}") from None
        if lacking := sorted(set(completed) - trials):
            raise RunFolderError(f"{folder}: {name} holds no rows of trial(s) "
                                 f"{', '.join(map(str, lacking))}, which the manifest lists as completed by "
                                 f"{who}; {RESTORE}")
        if trials - set(completed):
            # a crash after the rename (on the first trial too, whose part has no SHA-256 recorded yet):
            # written again without the unlisted trial, so the part holds exactly the trials listed
            checked.rewrite.append(kind)
        checked.tables[kind] = frame[frame["trial"].isin(completed)].reset_index(drop=True)
    return checked


def check_answered_blocks(folder: Path, participant: int, entry: Mapping[str, Any]) -> None:
    """Refuse a ``questionnaires.csv`` that is missing, or lacks a row of the participant, for a
    block the manifest lists as answered.

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
                             f"block(s) {', '.join(map(str, blocks))} in it; {RESTORE}")
    table = read_answers(path)
    rows = {(str(p), str(b)) for p, b in zip(table["participant"], table["block"], strict=True)}
    if lacking := [block for block in blocks if (str(participant), str(block)) not in rows]:
        raise RunFolderError(f"{path} holds no answers of {who} to block(s) {', '.join(map(str, lacking))}, "
                             f"which the manifest records as answered; {RESTORE}")
