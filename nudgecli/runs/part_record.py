"""A batch folder's record of its parts, ``checksums.sha256`` (:class:`PartRecord`): each part's
SHA-256 is appended once the part is in place (the format of ``sha256sum``, so ``sha256sum -c
checksums.sha256`` checks a batch by hand), and the record is written again in path order once the
batch is complete, so a batch run twice writes the same bytes whatever order its tasks finished in.
The batch folder's other rules are in :mod:`nudgecli.runs.batch_folder`.
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

from nudgecli.errors import RunFolderError
from nudgecli.run_folder_record import file_sha256, readable_parquet
from nudgecli.store import json_text, write_bytes_atomic, write_error

#: Where a batch's lines for the user go: the command's stderr, an API caller's ``log=``, or nowhere.
Log = Callable[[str], None] | None

#: The record of the batch's parts: one ``<SHA-256>  <path in the folder>`` line per part written.
PART_RECORD = "checksums.sha256"
_RECORD_LINE = re.compile(r"([0-9a-f]{64})  ([^\n]+)")


class PartRecord:
    """The batch folder's record of its parts (:data:`PART_RECORD`): what ``--resume`` may keep.

    A part is recorded once it is in place, so a part without a line (killed between the two,
    copied in from another batch) or whose bytes no longer give its line's SHA-256 (edited,
    truncated) is not vouched for, and is computed again. A torn last line (a kill while
    appending, or the zeros a power cut can leave) vouches for nothing, and the first line this
    record appends starts on a line of its own. Later lines of a path replace earlier ones.

    Parameters
    ----------
    folder
        The batch folder.
    """

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.path = folder / PART_RECORD
        self.sums: dict[str, str] = {}
        try:
            text = self.path.read_text(encoding="utf-8", errors="replace")
        except FileNotFoundError:
            text = ""
        except OSError as exc:
            raise RunFolderError(f"{self.path}: cannot be read ({exc.strerror or exc}); use --force to "
                                 "start the batch again") from None
        for line in text.splitlines():
            match = _RECORD_LINE.fullmatch(line)
            if match:
                self.sums[match.group(2)] = match.group(1)
        #: what ends a torn last line before the first line appended (it would glue onto it)
        self._line_break = "\n" if text and not text.endswith("\n") else ""
        #: Parts on disk that the record does not vouch for, as they were met (for the warning).
        self.refused: list[str] = []
        #: Parts the record holds that are no longer on disk (deleted since), as they were met.
        self.missing: list[str] = []
        #: The parts of this batch the record vouches for or has written (:meth:`write_in_order`'s lines).
        self.kept: set[str] = set()

    def _name(self, part: Path) -> str:
        return part.relative_to(self.folder).as_posix()

    def vouches(self, part: Path, readable: Callable[[Path], bool] = readable_parquet) -> bool:
        """Whether ``part`` is on disk, readable, and has the SHA-256 the record holds of it."""
        if not part.is_file():
            if self._name(part) in self.sums:  # written by this batch, gone since (not merely unfinished)
                self.missing.append(self._name(part))
            return False
        recorded = self.sums.get(self._name(part))
        if recorded is not None and file_sha256(part) == recorded and readable(part):
            self.kept.add(self._name(part))
            return True
        self.refused.append(self._name(part))
        return False

    def warn_refused(self, log: Log) -> None:
        """Tell ``log`` (the command's stderr, an API caller's ``log=``) which parts are computed
        again: those on disk not vouched for, and those the record holds that are missing (a part
        never written, of an unfinished task, is neither)."""
        def shown(parts: list[str]) -> str:
            return ", ".join(parts[:6]) + (f" and {len(parts) - 6} more" if len(parts) > 6 else "")

        if log is not None and self.refused:
            log(f"Warning: {self.folder}: {shown(self.refused)}: not vouched for by {PART_RECORD} (not as "
                "this batch wrote them); computing them again")
        if log is not None and self.missing:
            log(f"Warning: {self.folder}: {shown(self.missing)}: missing (written by this batch, as "
                f"{PART_RECORD} records, and deleted since); computing them again")

    def write_json(self, part: Path, document: Any) -> None:
        """Write an analysis's part atomically, then record it."""
        self.write(part, json_text(document).encode("utf-8"))

    def write(self, part: Path, data: bytes) -> None:
        """Write ``data`` to ``part`` atomically, then append its line to the record.

        Neither is forced to disk (fsync, a third of the batch process's time per part on some
        file systems): the record vouches for a part only while its bytes give the line's SHA-256,
        so a part or a line that a power cut lost is computed again; a killed process loses
        neither."""
        write_bytes_atomic(part, data, durable=False)
        name = self._name(part)
        self.sums[name] = digest = hashlib.sha256(data).hexdigest()
        self.kept.add(name)
        try:
            with open(self.path, "a", encoding="utf-8") as handle:
                handle.write(f"{self._line_break}{digest}  {name}\n")
            self._line_break = ""
        except OSError as exc:
            raise write_error(self.path, exc) from exc

    def write_in_order(self) -> None:
        """Write the record again from the lines of the batch's parts, each part once, in path order:
        once the batch is complete, the same bytes whatever order its tasks finished in (or a resume
        computed them again in). A line of no part of the batch (a torn last line whose path was cut
        short, as a power cut leaves it; a part of another batch) is left out: ``sha256sum -c
        --strict`` checks the record."""
        kept = sorted((name, digest) for name, digest in self.sums.items() if name in self.kept)
        lines = "".join(f"{digest}  {name}\n" for name, digest in kept)
        write_bytes_atomic(self.path, lines.encode("utf-8"), durable=False)  # (names the path if it fails)
