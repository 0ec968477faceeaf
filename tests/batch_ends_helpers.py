"""Helpers of the tests of a batch interrupted at its start or its end (a batch of each kind, an
uninterrupted one's tables to compare with)."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

from cli_helpers import nudge

SWEEP = ('experiment = "smoke"\nreplications = 2\nseed = 3\nset = ["study.participants=2"]\n'
         '[parameters]\n"disambiguation.window" = [3, 5]\n')


def command(kind: str, folder: Path) -> tuple[str, ...]:
    if kind == "sweep":
        sweep_file = folder.parent / "small-sweep.toml"
        sweep_file.write_text(SWEEP, encoding="utf-8")
        return ("sweep", str(sweep_file))
    if kind == "power":
        return ("power", "smoke", "--participants", "2,3", "-R", "2", "--seed", "9")
    return ("replicate", "smoke", "-R", "2", "--participants", "2", "--seed", "9")


def tables(folder: Path) -> dict[str, bytes]:
    """The batch's tables and its record of parts (its figures: their names)."""
    found = {p.name: p.read_bytes() for p in sorted(folder.glob("*.csv"))}
    found["checksums.sha256"] = (folder / "checksums.sha256").read_bytes()
    found.update({f"figures/{p.name}": b"" for p in sorted((folder / "figures").glob("*.png"))})
    return found


def status(folder: Path) -> str:
    return json.loads((folder / "batch.json").read_text(encoding="utf-8"))["status"]


REFERENCE: dict[str, dict[str, bytes]] = {}
#: An uninterrupted batch's kept inputs, by kind and name.
INPUTS: dict[str, dict[str, bytes]] = {}


def reference(kind: str, tmp_path: Path) -> dict[str, bytes]:
    """An uninterrupted batch's tables (one per kind for the module)."""
    if kind not in REFERENCE:
        folder = tmp_path / f"reference-{kind}"
        done = nudge(*command(kind, folder), "--out", folder)
        assert done.exit_code == 0, done.output
        assert status(folder) == "complete"
        REFERENCE[kind] = tables(folder)
        INPUTS[kind] = {p.name: p.read_bytes() for p in folder.glob("*.toml")}
    return REFERENCE[kind]


def resume_command(output: str) -> list[str]:
    line = next(line for line in output.splitlines() if "resume with: " in line)
    words = shlex.split(line.split("resume with: ", 1)[1])
    assert words[0] == "nudge", line
    return words[1:]


