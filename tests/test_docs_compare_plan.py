"""docs/people.md says which plan ``nudge compare`` takes a simulated run folder's metrics under by
default as the command does (``compare --help``, :func:`nudgecli.report.analysis.plan_of_source`):
the plan the run records or is named like, else ``paper`` (it said ``paper`` by default, and a run
of the ``ciaa-teleop`` experiment is compared under ``ciaa-teleop``)."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.report.analysis import plan_of_source

PAGE = Path(__file__).resolve().parents[1] / "docs" / "people.md"


def test_the_default_plan_of_compare_is_documented_as_the_command_chooses_it(tmp_path) -> None:
    text = " ".join(PAGE.read_text(encoding="utf-8").split())
    start = text.index("SIMULATED is a run folder")
    paragraph = text[start:text.index("One condition is enough", start)]
    assert "`paper` by default" not in paragraph
    assert "by default the plan the run records or is named like" in paragraph
    assert "`ciaa-teleop` for a `ciaa-teleop` run, else `paper`" in paragraph
    help_text = " ".join(CliRunner().invoke(main, ["compare", "--help"]).output.split())
    assert "[default: the plan the simulated run records or is named like, else paper]" in help_text
    run = tmp_path / "ciaa"
    run.mkdir()
    (run / "manifest.json").write_text(json.dumps({"experiment": "ciaa-teleop"}))
    assert plan_of_source(run) == "ciaa-teleop"
