"""``nudge habits FILE.json``: one Error line saying what habits reads and what the JSON is for
(``--compare``), or, for a run folder's own JSON, the folder to give instead."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.errors import DataError
from nudgecli.report.habits import source_cells

#: A habits JSON --compare reads (the shape `nudge habits --format json` writes), as written and after
#: blank lines; JSON texts it does not read (a BOM too) are not advised for it (tests/test_tools_mends.py).
REFERENCE = {"source": "pilot.csv", "kind": "log",
             "habits": {"soft_blow": {"pooled": {"median": 1.4}, "people": [0.6, 3.4]}}}
JSON_TEXTS = {
    "habits": json.dumps(REFERENCE, indent=2),
    "blank lines": "\n\n  " + json.dumps(REFERENCE) + "\n",
}


@pytest.mark.parametrize("text", JSON_TEXTS.values(), ids=JSON_TEXTS.keys())
def test_habits_of_a_json_file_says_what_it_reads_and_where_the_json_goes(tmp_path: Path, text: str) -> None:
    source = tmp_path / "h.json"
    source.write_text(text, encoding="utf-8")
    result = CliRunner().invoke(main, ["habits", str(source)])
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"Error: {source}: a JSON file; ")
    message = lines[0]
    assert "a run folder or a real log's CSV" in message  # what habits reads
    assert f"--compare {source}" in message               # where a habits JSON goes
    assert "header holds" not in message                  # not the CSV log's column message


def test_the_json_of_a_run_folder_points_to_the_folder(tmp_path: Path) -> None:
    run = tmp_path / "run"
    run.mkdir()
    manifest = run / "manifest.json"
    manifest.write_text('{"files": {}}', encoding="utf-8")
    with pytest.raises(DataError, match=f"give the run folder itself: nudge habits {run}"):
        source_cells(manifest)


def test_a_csv_log_named_json_is_still_read_as_a_log(tmp_path: Path) -> None:
    # the content decides, as for fit-people: a CSV saved under a .json name is a log's message
    source = tmp_path / "log.json"
    source.write_text("t,trial,label\n0,1,None\n", encoding="utf-8")
    with pytest.raises(DataError, match="no x, y, theta, mode_switch column"):
        source_cells(source)
