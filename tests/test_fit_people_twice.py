"""A source given twice to ``nudge fit-people`` (or ``nudgecli.fit_people``) would put its people in
the people file twice, each counted twice in every study of the file: one Error line, nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

import nudgecli
from nudgecli.cli import main

PILOT = Path(__file__).resolve().parents[1] / "experiments" / "pilots" / "pilot-1.csv"


def test_the_same_source_twice_is_one_error_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(PILOT.parent)
    out = tmp_path / "people.csv"
    result = CliRunner().invoke(main, ["fit-people", PILOT.name, str(PILOT), "--out", str(out)])
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert result.exit_code == 1 and errors == [
        f"Error: fit-people: {PILOT} is given twice (as {PILOT.name} too): its people would be in the people "
        "file twice; give each source once"], result.output
    assert not out.exists()
    with pytest.raises(nudgecli.NudgeError, match="is given twice"):
        nudgecli.fit_people([PILOT, PILOT])


def test_different_sources_are_fitted_in_order() -> None:
    other = PILOT.with_name("pilot-2.csv")
    people = nudgecli.fit_people([PILOT, other]).table
    assert list(dict.fromkeys(people["source"])) == [PILOT.name, other.name]
