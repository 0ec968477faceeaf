"""A CSV table whose rows have fewer fields than its header (a last line cut off in a copy, a row
that lost cells) or more (a separator at the end of each line, which pandas would read as a row
label and shift every cell one column) is refused with one line naming the file and the line, by
every command that reads a real table from CSV; complete rows with empty cells, blank lines and
other delimiters are read as before."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nudgecli.cli import main
from nudgecli.csv_rows import refuse_uneven_rows
from nudgecli.errors import DataError
from nudgecli.report.questionnaires import read_questionnaires
from nudgecli.report.tables import read_csv_labels, read_metrics_table

DATA = Path(__file__).parent / "data"
TABLE = DATA / "metrics_two_conditions.csv"
WIDTH = 7  # the fields of TABLE's header


def cut_copy(path: Path, fragment: str = "1,disambig") -> Path:
    """TABLE without its last line, then ``fragment`` in its place with no line end (a cut copy)."""
    lines = TABLE.read_text(encoding="utf-8").splitlines(keepends=True)
    path.write_text("".join(lines[:-1]) + fragment, encoding="utf-8")
    return path


def one_error_line(args: list[str]) -> str:
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1, result.output
    assert result.stderr.startswith("Error: ") and result.stderr.count("\n") == 1, result.stderr
    return result.stderr


def test_analyze_refuses_a_cut_last_line_and_keeps_the_analysis_there(tmp_path: Path) -> None:
    source = tmp_path / "study.csv"
    source.write_bytes(TABLE.read_bytes())
    assert CliRunner().invoke(main, ["analyze", str(source)]).exit_code == 0
    analysed = {p.name: p.read_bytes() for p in (tmp_path / "study-analysis").iterdir()}
    cut_copy(source)
    n_lines = len(TABLE.read_text(encoding="utf-8").splitlines())
    message = one_error_line(["analyze", str(source)])
    assert f"{source}: line {n_lines} has 2 of {WIDTH} fields; the file looks cut off" in message
    assert {p.name: p.read_bytes() for p in (tmp_path / "study-analysis").iterdir()} == analysed


def test_compare_and_plot_refuse_a_cut_table(tmp_path: Path) -> None:
    cut = cut_copy(tmp_path / "real.csv")
    message = one_error_line(["compare", str(TABLE), str(cut), "--resamples", "0"])
    assert "real.csv: line 49 has 2 of 7 fields" in message
    with pytest.raises(DataError, match="line 49 has 2 of 7 fields"):
        read_metrics_table(cut)


def test_a_short_row_inside_the_table_is_refused_with_a_count(tmp_path: Path) -> None:
    lines = TABLE.read_text(encoding="utf-8").splitlines()
    lines[4] = "1,disambiguation,0,3,2"  # line 5 lost its last two cells
    source = tmp_path / "study.csv"
    source.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(DataError, match=r"line 5 has 5 of 7 fields; the file looks cut off or a row lost "
                                        r"cells"):  # not the last line: more than a cut end
        read_metrics_table(source)
    lines[9] = "1,disambiguation,1,0"  # line 10 its last three
    source.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(DataError, match=r"line 5 has 5 of 7 fields \(and 1 more line\(s\) like it\); .*"
                                        r"an empty cell still needs its separator"):
        read_metrics_table(source)


def test_complete_rows_with_empty_cells_blank_lines_and_quoted_line_breaks_are_read(tmp_path: Path) -> None:
    text = ("participant,condition,note,success\n"
            "\n"
            "1,a,,\n"  # empty cells written out: complete
            "   \n"  # white space only: skipped by pandas, so here
            '2,b,"two\nlines",\n'  # a line break inside quotes is one row
            "3,a,x,True\n")
    source = tmp_path / "t.csv"
    source.write_text(text, encoding="utf-8")
    table = read_csv_labels(source)
    assert list(table["participant"]) == [1, 2, 3] and table["success"].isna().sum() == 2
    source.write_text(text + "4,b\n", encoding="utf-8")
    with pytest.raises(DataError, match="line 8 has 2 of 4 fields"):  # physical lines, quotes included
        read_csv_labels(source)


def test_the_sniffed_delimiter_is_the_one_counted(tmp_path: Path) -> None:
    source = tmp_path / "study.csv"
    semicolons = TABLE.read_text(encoding="utf-8").replace(",", ";")
    source.write_text(semicolons + "2;control;3\n", encoding="utf-8")
    with pytest.raises(DataError, match="line 50 has 3 of 7 fields"):
        read_metrics_table(source)


def test_questionnaires_share_the_check(tmp_path: Path) -> None:
    source = tmp_path / "answers.csv"
    text = (DATA / "questionnaires_two_conditions.csv").read_text(encoding="utf-8").rstrip("\n")
    source.write_text(text + "\n7,control\n", encoding="utf-8")
    width = len(text.splitlines()[0].split(","))
    with pytest.raises(DataError, match=f"line {len(text.splitlines()) + 1} has 2 of {width} fields"):
        read_questionnaires(source)


CELL = st.one_of(st.just(""), st.integers(0, 99).map(str), st.sampled_from(["x", "y z", "a,b", 'q"q']))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(rows=st.lists(st.lists(CELL, min_size=4, max_size=4), min_size=1, max_size=8),
       keep=st.integers(1, 3), cut_at=st.integers(0, 8))
def test_a_short_row_is_found_at_its_line_by_a_plain_count(tmp_path: Path, rows: list[list[str]], keep: int,
                                                           cut_at: int) -> None:
    frame = pd.DataFrame(rows, columns=["participant", "condition", "m1", "m2"])
    source = tmp_path / "h.csv"
    frame.to_csv(source, index=False)
    refuse_uneven_rows(source, ",")  # every row written in full: nothing to refuse
    # cut one row to its first `keep` cells; its line by counting the written lines before it
    cut_at = min(cut_at, len(rows) - 1)
    short = pd.DataFrame([r[:keep] for r in rows[cut_at:cut_at + 1]])
    before = frame.iloc[:cut_at].to_csv(index=False)
    after = frame.iloc[cut_at + 1:].to_csv(index=False, header=False)
    source.write_text(before + short.to_csv(index=False, header=False) + after, encoding="utf-8")
    line = (before + short.to_csv(index=False, header=False)).count("\n")
    only_blank = keep == 1 and rows[cut_at][0] == ""  # a lone empty cell is a blank line to pandas
    if only_blank:
        refuse_uneven_rows(source, ",")
        return
    with pytest.raises(DataError, match=f"line {line} has {keep} of 4 fields"):
        refuse_uneven_rows(source, ",")


def long_copy(path: Path, extra: str = ",", rows: slice = slice(1, None)) -> Path:
    """TABLE with ``extra`` added to the end of the data lines ``rows`` (line 1 is the header)."""
    lines = TABLE.read_text(encoding="utf-8").splitlines()
    lines[rows] = [line + extra for line in lines[rows]]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_every_row_one_field_longer_than_the_header_is_refused_not_shifted(tmp_path: Path) -> None:
    # pandas would take `participant` from the first field as the row label and read each
    # condition as a participant, each block as a condition, ...
    source = tmp_path / "study.csv"
    source.write_bytes(TABLE.read_bytes())
    assert CliRunner().invoke(main, ["analyze", str(source)]).exit_code == 0
    analysed = {p.name: p.read_bytes() for p in (tmp_path / "study-analysis").iterdir()}
    long_copy(source, ",1")
    message = one_error_line(["analyze", str(source)])
    expected = f"{source}: line 2 has {WIDTH + 1} fields, the header {WIDTH} (and 47 more line(s) like it)"
    assert expected in message
    assert {p.name: p.read_bytes() for p in (tmp_path / "study-analysis").iterdir()} == analysed
    real = long_copy(tmp_path / "real.csv")
    message = one_error_line(["compare", str(TABLE), str(real), "--resamples", "0"])
    assert f"real.csv: line 2 has {WIDTH + 1} fields, the header {WIDTH}" in message


def test_a_first_column_of_row_numbers_is_no_excuse(tmp_path: Path) -> None:
    # the row labels pandas would take (0, 1, 2, ...) are its default ones: only the widths tell
    source = tmp_path / "numbered.csv"
    source.write_text("participant,condition,completion_time\n0,1,a,3.5\n1,1,b,4.5\n2,2,a,5.5\n",
                      encoding="utf-8")
    with pytest.raises(DataError, match=r"numbered.csv: line 2 has 4 fields, the header 3 \(and 2 more"):
        read_csv_labels(source)


def test_a_long_row_further_down_is_named_by_the_files_own_line(tmp_path: Path) -> None:
    # a quoted line break above it: pandas' parser error counts rows, the file has one line more
    text = ('participant,condition,note,completion_time\n1,a,"two\nlines",3.5\n2,b,x,4.5\n'
            "3,a,y,5.5,9\n4,b,z,6.5\n")
    source = tmp_path / "t.csv"
    source.write_text(text, encoding="utf-8")
    with pytest.raises(DataError, match=r"t.csv: line 5 has 5 fields, the header 4; a row longer than the "
                                        r"header would shift its cells"):
        read_metrics_table(source)


def test_the_first_uneven_line_is_the_one_named(tmp_path: Path) -> None:
    source = long_copy(tmp_path / "study.csv", ",7", slice(10, 11))  # line 11 long
    with source.open("a", encoding="utf-8") as handle:
        handle.write("2,control\n")  # and a cut last line below it
    with pytest.raises(DataError, match="line 11 has 8 fields, the header 7;"):
        read_metrics_table(source)
    source = long_copy(tmp_path / "study.csv", ",7", slice(30, 31))
    lines = source.read_text(encoding="utf-8").splitlines()
    lines[4] = "1,disambiguation"  # a short line 5 above the long line 31
    source.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(DataError, match="line 5 has 2 of 7 fields;"):
        read_metrics_table(source)


def test_a_header_and_rows_of_one_width_with_a_trailing_separator_are_read(tmp_path: Path) -> None:
    source = tmp_path / "t.csv"
    source.write_text("participant,condition,completion_time,\n1,a,3.5,\n2,b,4.5,\n", encoding="utf-8")
    table = read_csv_labels(source)
    assert list(table["participant"]) == [1, 2] and list(table["completion_time"]) == [3.5, 4.5]


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(rows=st.lists(st.lists(CELL, min_size=4, max_size=4), min_size=1, max_size=8),
       extra=st.lists(CELL, min_size=1, max_size=3), long_at=st.integers(0, 8))
def test_a_long_row_is_found_at_its_line_by_a_plain_count(tmp_path: Path, rows: list[list[str]],
                                                          extra: list[str], long_at: int) -> None:
    frame = pd.DataFrame(rows, columns=["participant", "condition", "m1", "m2"])
    long_at = min(long_at, len(rows) - 1)
    before = frame.iloc[:long_at].to_csv(index=False)
    long = pd.DataFrame([rows[long_at] + extra]).to_csv(index=False, header=False)
    after = frame.iloc[long_at + 1:].to_csv(index=False, header=False)
    source = tmp_path / "h.csv"
    source.write_text(before + long + after, encoding="utf-8")
    line = (before + long).count("\n")
    with pytest.raises(DataError, match=f"line {line} has {4 + len(extra)} fields, the header 4"):
        refuse_uneven_rows(source, ",")
