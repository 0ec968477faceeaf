"""A run's simulated calibration logs (``calibration/participant-NNNN/``, the tidy files ``nudge fit``
and a ``population.physiology_logs`` recording read) in its manifest: where they live, the SHA-256
of each log as the run wrote it (:data:`CALIBRATION_CHECKSUMS`, as the parts' are under
``checksums``), and their verification wherever they are read (:func:`check_calibration_logs`): an
edited or truncated log is refused in one line, as a damaged part is. A run written before the logs
were recorded (no :data:`CALIBRATION_CHECKSUMS`) reads as before: its logs are not checked."""

from __future__ import annotations

import os
import re
from collections.abc import Collection, Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nudgecli.errors import RunFolderError
from nudgecli.run_folder_names import CALIBRATION_DIR
from nudgecli.run_folder_record import RunRecord, file_sha256

if TYPE_CHECKING:
    from nudgecli.sim.calibration_io import DistortionSession, MappingSession

#: The manifest's record of the logs: participant -> log file name -> SHA-256 (hex).
CALIBRATION_CHECKSUMS = "calibration_checksums"
#: A live study's record of a participant's logs, in its ``live`` entry: log file name -> SHA-256
#: (hex), written by :mod:`nudgecli.live.records` and checked here and on resume.
LIVE_CALIBRATION_FILES = "calibration_files"
_PARTICIPANT_FOLDER = re.compile(r"participant-(\d{4,})")


def calibration_dir(run: Path, participant: int) -> Path:
    """Where participant ``participant``'s simulated calibration logs go in the run folder ``run``."""
    return run / CALIBRATION_DIR / f"participant-{participant:04d}"


def write_calibration_logs(run: Path, manifest: dict[str, Any], participant: int,
                           sessions: tuple[MappingSession | None, DistortionSession | None]) -> None:
    """Write ``participant``'s simulated calibration ``sessions`` into the run folder ``run`` (the tidy
    format, :func:`~nudgecli.sim.calibration_io.write_sessions`) and record in ``manifest`` the SHA-256
    of each log, replacing what it recorded of them before (a participant simulated again)."""
    from nudgecli.sim.calibration_io import write_sessions  # numpy and pandas: with a run's logs only

    logs = write_sessions(calibration_dir(run, participant), *sessions)
    manifest.setdefault(CALIBRATION_CHECKSUMS, {})[str(participant)] = log_digests(logs)


def log_digests(logs: Iterable[Path]) -> dict[str, str]:
    """What a manifest records of calibration ``logs`` just written: file name -> SHA-256 (hex), a
    simulated run's (:data:`CALIBRATION_CHECKSUMS`) and a ``nudge study`` participant's alike."""
    return {path.name: file_sha256(path) for path in logs}


def recorded_calibration_logs(record: RunRecord, manifest: Mapping[str, Any],
                              participant: int) -> dict[str, str] | None:
    """Log file name -> SHA-256 that ``manifest`` records of ``participant``'s calibration logs (a
    ``nudge study`` folder's, in the participant's ``live`` entry); ``None`` where it records none
    (a run of an older nudge, a participant without logs): those are not checked.

    Raises
    ------
    RunFolderError
        The record is not of that shape (a damaged or edited manifest).
    """
    if manifest.get("executor") == "live":
        entry = (manifest.get("live") or {}).get(str(participant))
        recorded = entry.get(LIVE_CALIBRATION_FILES) if isinstance(entry, Mapping) else None
    else:
        by_participant = manifest.get(CALIBRATION_CHECKSUMS)
        recorded = by_participant.get(str(participant)) if isinstance(by_participant, Mapping) else \
            by_participant  # a damaged record (not an object) is named below
    if recorded is None:
        return None
    if isinstance(recorded, Mapping) and all(isinstance(v, str) for v in recorded.values()):
        return {str(name): digest for name, digest in recorded.items()}
    raise RunFolderError(f"{record.manifest_path}: '{CALIBRATION_CHECKSUMS}' is damaged (expected "
                         "participant -> log file name -> SHA-256); restore the manifest, or simulate the "
                         "run again with --force")


def changed_calibration_logs(record: RunRecord, manifest: Mapping[str, Any], participant: int,
                             names: Collection[str] | None = None) -> list[str]:
    """``participant``'s calibration logs the manifest records (of ``names``; ``None``: all) that are
    missing or changed since written, each as ``calibration/participant-NNNN/NAME (missing)`` or
    ``(changed since written)``."""
    folder = calibration_dir(record.path, participant)
    recorded = {name: digest for name, digest in
                (recorded_calibration_logs(record, manifest, participant) or {}).items()
                if names is None or name in names}
    return [f"{(folder / name).relative_to(record.path).as_posix()} "
            f"({'missing' if missing else 'changed since written'})"
            for name, missing in changed_logs(folder, recorded)]


def changed_logs(folder: Path, recorded: Mapping[str, Any]) -> list[tuple[str, bool]]:
    """The logs of ``recorded`` (log file name -> SHA-256 the manifest records) in ``folder`` that are
    missing or changed since written, in the record's order: (name, whether missing) each; a
    simulated run's (:func:`changed_calibration_logs`) and a ``nudge study`` participant's on resume
    (:func:`nudgecli.live.calibration.check_calibration_files`)."""
    changed = []
    for name, digest in recorded.items():
        path = folder / str(name)
        if not path.is_file():
            changed.append((str(name), True))
        elif file_sha256(path) != digest:
            changed.append((str(name), False))
    return changed


def check_calibration_logs(folder: str | Path, names: Collection[str] | None = None) -> None:
    """Refuse to read a run's calibration logs (``folder``: a run folder's
    ``calibration/participant-NNNN``; ``names``: the logs about to be read, ``None``: all) that are
    missing or changed since the run wrote them, as its manifest records them; any other folder (a
    person's recording, a run of an older nudge) is left to its reader.

    Raises
    ------
    RunFolderError
        Names the log and what restores it, in one line.
    """
    where = Path(os.path.abspath(folder))  # "." or "..": named by the folder they are
    match = _PARTICIPANT_FOLDER.fullmatch(where.name)
    record = RunRecord(where.parent.parent)
    if match is None or where.parent.name != CALIBRATION_DIR or not record.is_run():
        return
    manifest = record.read_manifest()
    changed = changed_calibration_logs(record, manifest, int(match.group(1)), names)
    if not changed:
        return
    log, why = changed[0].split(" (", 1)
    live = manifest.get("executor") == "live"
    missing = why.startswith("missing")
    fix = record.restore_from_backup([log]) if live else \
        record.part_fix(manifest, record.path / log, "restore" if missing else "restore it")
    if missing:
        raise RunFolderError(f"{record.path} is incomplete: {log} (missing); {fix}")
    raise RunFolderError(f"{record.path}: {log} changed since it was written (its SHA-256 differs from the "
                         f"one in the manifest); {fix}")
