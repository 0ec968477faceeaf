"""docs/people.md says which plan ``nudge compare`` takes a simulated run folder's metrics under by
default as the command chooses it (:func:`nudgecli.report.analysis.plan_of_source`): the plan the
run records, else the one named like its experiment, else its world's (it said ``paper`` by
default, and a run of the ``ciaa-teleop`` experiment is compared under ``ciaa-teleop``)."""

from __future__ import annotations

import json
from pathlib import Path

from nudgecli.report.analysis import plan_of_source

PAGE = Path(__file__).resolve().parents[1] / "docs" / "people.md"


def test_the_default_plan_of_compare_is_documented_as_the_command_chooses_it(tmp_path) -> None:
    text = " ".join(PAGE.read_text(encoding="utf-8").split())
    start = text.index("SIMULATED is a run folder")
    paragraph = text[start:text.index("One condition is enough", start)]
    assert "run folder (its metrics are computed with `--plan`, `paper` by default)" not in paragraph
    assert ("by default the plan the run records, else the one named like its experiment, else its "
            "world's: `ciaa-teleop` for a CIAA run, `paper` for the paper's world) or a metrics table "
            "(`paper` by default)") in paragraph
    run = tmp_path / "ciaa"
    run.mkdir()
    (run / "manifest.json").write_text(json.dumps({"experiment": "ciaa-teleop"}))
    assert plan_of_source(run) == "ciaa-teleop"
    renamed = {"experiment": "mine", "config": {"world": {"kind": "ciaa"}}}
    (run / "manifest.json").write_text(json.dumps(renamed))
    assert plan_of_source(run) == "ciaa-teleop"  # its world's
    (run / "manifest.json").write_text(json.dumps({"experiment": "paper", "plan": "study-code"}))
    assert plan_of_source(run) == "study-code"
    table = tmp_path / "t.csv"
    table.write_text("participant,condition,trial,completion_time\n0,a,0,1.0\n")
    assert plan_of_source(table) == "paper"
