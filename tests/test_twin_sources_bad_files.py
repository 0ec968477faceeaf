"""`nudge fit-people` given a file that is no source it reads: a habits table written as JSON, a
file whose delimiter cannot be told (empty, blank lines), a habits table that is not UTF-8. Each is
one `Error:` line naming the file and what to give instead, exit 1, nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

from nudgecli.errors import DataError
from nudgecli.report.twin_sources import table_source

LOG_ROWS = ["t,trial,label,x,y,theta,mode_switch,participant",
            "0.0,1,,0,0,0,0,A", "0.5,1,Soft Puff,0,0,0,0,A", "0.8,1,Soft Puff,1,0,0,0,A",
            "1.2,1,,1,0,0,0,A"]


def refused(tmp_path: Path, source: Path) -> str:
    """The one error line of `nudge fit-people SOURCE`, which must exit 1 with nothing written."""
    before = sorted(tmp_path.rglob("*"))
    result = nudge("fit-people", source, "--out", tmp_path / "people.csv")
    assert result.exit_code == 1 and result.stdout == "", result.output
    assert sorted(tmp_path.rglob("*")) == before
    return one_error_line(result.stderr)


@pytest.mark.parametrize("by", ["participant", "trial"])
def test_a_json_habits_table_is_refused_with_the_csv_to_give(tmp_path: Path, by: str) -> None:
    log = tmp_path / "log.csv"
    log.write_text("\n".join(LOG_ROWS) + "\n")
    written = nudge("habits", log, "--by", by, "--format", "json")
    assert written.exit_code == 0, written.output
    table = tmp_path / "h.json"
    table.write_text(written.stdout)
    line = refused(tmp_path, table)
    for words in (str(table), "JSON", "nudge habits --by participant --format csv"):
        assert words in line, line
    assert "tokenizing" not in line and "column(s)" not in line


def test_a_json_file_with_a_bom_and_leading_blank_lines_is_still_json(tmp_path: Path) -> None:
    table = tmp_path / "h.json"
    table.write_bytes(b"\xef\xbb\xbf\n  \r\n[1, 2]\n")
    assert "JSON" in refused(tmp_path, table)


@pytest.mark.parametrize("text", ["", "\n\n"])
def test_a_file_whose_delimiter_cannot_be_told_is_one_line(tmp_path: Path, text: str) -> None:
    """pandas' delimiter sniffing raises csv.Error on these: still the log reader's one refusal."""
    source = tmp_path / "neither.csv"
    source.write_text(text)
    line = refused(tmp_path, source)
    assert str(source) in line and "not a readable CSV log" in line, line


def test_a_habits_table_not_utf8_says_to_save_it_as_utf8(tmp_path: Path) -> None:
    table = tmp_path / "habits.csv"
    rows = ["scope,participant,habit,n,median,q25,q75", "participant,Zoé,soft_blow,12,0.5,0.4,0.6"]
    table.write_bytes(("\n".join(rows) + "\n").encode("latin-1"))
    with pytest.raises(DataError) as caught:
        table_source(table)
    message = str(caught.value)
    assert message.startswith(f"{table}: not UTF-8 text (byte 0xe9 on line 2"), message
    assert "save it as UTF-8" in message
    assert "save it as UTF-8" in refused(tmp_path, table)
