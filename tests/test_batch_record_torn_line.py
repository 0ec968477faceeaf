"""A torn last line of a batch's ``checksums.sha256`` (a power cut) does not survive a resume: the
record is written again from its parts' lines, in path order."""

from __future__ import annotations

from pathlib import Path

from batch_ends_helpers import command, reference, tables
from cli_helpers import nudge


def test_a_torn_last_line_of_the_record_does_not_survive_a_resume(tmp_path: Path) -> None:
    """A power cut's torn last line (its path cut short, so it reads as a line of another path)
    is left out when the resume writes the record again in path order: ``sha256sum -c --strict``
    passes, and the record is an uninterrupted batch's."""
    expected = reference("replicate", tmp_path)
    out = tmp_path / "batch"
    assert nudge(*command("replicate", out), "--out", out).exit_code == 0
    record = out / "checksums.sha256"
    record.write_bytes(record.read_bytes()[:-40])  # truncate -s -40
    resumed = nudge(*command("replicate", out), "--out", out, "--resume")
    assert resumed.exit_code == 0, resumed.output
    for line in record.read_text(encoding="utf-8").splitlines():
        name = line.split("  ", 1)[1]
        assert (out / name).is_file(), f"a malformed line survived: {line}"
    assert tables(out) == expected
