"""The hand-written people file of the people-copy tests, and the folder it is typed from."""

from __future__ import annotations

from pathlib import Path

import pytest

#: Two twins whose parsed values do not give these bytes back (a BOM, CRLF line ends, a value
#: written as "3.0"): only the file's own bytes pass the people check, and a copy made from the
#: twins rather than the bytes differs from it.
PEOPLE_BYTES = ("\ufeffperson,source,participant,planning_s,from_population\r\n"
                "0,by hand,slow,3.0,\r\n1,by hand,quick,1.0,\r\n").encode("utf-8")


def people_typed_here(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str) -> Path:
    """A folder ``a`` holding the people file ``name``, made the current directory."""
    here = tmp_path / "a"
    here.mkdir()
    (here / name).write_bytes(PEOPLE_BYTES)
    monkeypatch.chdir(here)
    return here
