"""What identifies the recordings an experiment's ``population.physiology_logs`` names: a digest of
the files read from each folder. A run's manifest and a batch's description record them, so that a
resume that would read another recording (a relative path read from another folder, a recording
changed since) is refused instead of mixing two people's physiology in one study."""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from nudgecli.config import ExperimentConfig

#: The record's key (a run's manifest, a batch point's description): each folder's
#: :func:`recording_digest`, in the order the experiment names them; only where it names any.
RECORDINGS_KEY = "physiology_logs"
#: What a difference in the record means, for the line that refuses a resume.
RECORDINGS_DIFFER = ("digests of the files read from each population.physiology_logs folder: a recording "
                     "differs; a relative path is read from the current folder, so resume from the folder "
                     "the {what} was started in")


def recording_digest(folder: str | Path) -> str:
    """What identifies a recording folder's contents: the SHA-256 of the path in it and the SHA-256
    of each file the participant's reader reads there
    (:func:`nudgecli.sim.calibration_readers.distortion_session_files`: the distortion session's
    prompts and stream), in path order (16 hex digits, as a study's key). Another file (notes, a
    ``.DS_Store``, the mapping session) changes nothing simulated, so nothing here."""
    from nudgecli.run_folder_record import file_sha256  # which reads the record at resume
    from nudgecli.sim.calibration_readers import distortion_session_files  # pandas: with a recording only

    root = Path(folder)
    digest = hashlib.sha256()
    for path in sorted(distortion_session_files(root) or ()):
        digest.update(f"{path.relative_to(root).as_posix()}\0{file_sha256(path)}\n".encode())
    return digest.hexdigest()[:16]


def recordings(config: ExperimentConfig) -> dict[str, list[str]]:
    """The :data:`RECORDINGS_KEY` record of ``config``'s recordings (empty without recordings)."""
    logs = config.population.physiology_logs
    return {RECORDINGS_KEY: [recording_digest(folder) for folder in logs]} if logs else {}


def compared(recorded: Mapping[str, Any], now: Mapping[str, Any]) -> dict[str, Any]:
    """``now`` (what a run's manifest or a batch point's description would record now), less its
    :data:`RECORDINGS_KEY` where ``recorded`` (the one on disk) has none: a record made before
    recordings were digested (an older run or batch, a live study) is not compared, for a run and a
    batch alike; one that has it is."""
    return {key: value for key, value in now.items() if key != RECORDINGS_KEY or RECORDINGS_KEY in recorded}
