"""A CSV table whose rows have fewer fields than its header (a last line cut off in a copy, a row
that lost cells) is refused with one line naming the file and the line, by every command that
reads a real table from CSV; complete rows with empty cells, blank lines and other delimiters
are read as before."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nudgecli.cli import main
from nudgecli.errors import DataError
from nudgecli.report.questionnaires import read_questionnaires
from nudgecli.report.tables import read_csv_labels, read_metrics_table, refuse_short_rows

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
    refuse_short_rows(source, ",")  # every row written in full: nothing to refuse
    # cut one row to its first `keep` cells; its line by counting the written lines before it
    cut_at = min(cut_at, len(rows) - 1)
    short = pd.DataFrame([r[:keep] for r in rows[cut_at:cut_at + 1]])
    before = frame.iloc[:cut_at].to_csv(index=False)
    after = frame.iloc[cut_at + 1:].to_csv(index=False, header=False)
    source.write_text(before + short.to_csv(index=False, header=False) + after, encoding="utf-8")
    line = (before + short.to_csv(index=False, header=False)).count("\n")
    only_blank = keep == 1 and rows[cut_at][0] == ""  # a lone empty cell is a blank line to pandas
    if only_blank:
        refuse_short_rows(source, ",")
        return
    with pytest.raises(DataError, match=f"line {line} has {keep} of 4 fields"):
        refuse_short_rows(source, ",")
