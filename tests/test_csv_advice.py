"""The advice for a CSV file a spreadsheet wrote in its locale's way (not UTF-8, decimal commas),
shared by ``analyze`` and ``habits``, and the messages of ``habits`` on a log's values and people."""

from __future__ import annotations

import shutil
from pathlib import Path

import pandas as pd
import pytest
from cli_helpers import nudge, one_error_line
from hypothesis import given
from hypothesis import strategies as st

from nudgecli.csv_text import decimal_comma_advice, not_utf8_message

TWO_CONDITIONS = Path(__file__).with_name("data") / "metrics_two_conditions.csv"
LOG_HEADER = "t,trial,label,x,y,theta,mode_switch\n"


# --- the decimal-comma advice --------------------------------------------------------------------


@given(st.floats(allow_nan=False, allow_infinity=False, width=32))
def test_a_number_written_with_a_decimal_comma_is_advised_back_to_itself(value):
    written = repr(float(value))
    if "e" in written or "." not in written:
        return  # 1e-05, inf: not how a spreadsheet writes a decimal
    advice = decimal_comma_advice(written.replace(".", ","))
    assert advice == f"a decimal comma? write {written}"
    assert float(advice.rsplit(" ", 1)[1]) == float(value)


@pytest.mark.parametrize("text", ["inf", "-inf", "nan", "abc", "0.5", "1,000,5", "", "1,", ",", "inf,0",
                                  "1_0,5"])
def test_no_decimal_comma_advice_where_a_point_would_not_make_a_number(text):
    # 'inf' was advised "(a decimal comma? write inf)": it is a number to pandas, with no comma
    assert decimal_comma_advice(text) is None
    assert decimal_comma_advice(" 0,5 ") == "a decimal comma? write 0.5"
    assert decimal_comma_advice(",5") == "a decimal comma? write .5"
    assert decimal_comma_advice("-1,5E-03") == "a decimal comma? write -1.5E-03"
    assert decimal_comma_advice("1,5e999") is None  # no finite number either way


# --- not UTF-8 -------------------------------------------------------------------------------------


def test_the_not_utf8_message_names_the_line_and_byte(tmp_path):
    path = tmp_path / "t.csv"
    path.write_bytes("a,b\n1,2\n3,caf\u00e9\n".encode("latin-1"))
    assert not_utf8_message(path) == (
        f"{path}: not UTF-8 text (byte 0xe9 on line 3; a spreadsheet's latin-1 or Windows encoding?); "
        "save it as UTF-8 (a spreadsheet's \"CSV UTF-8\", an editor's encoding UTF-8)")
    # a character that is UTF-8 before it is not the place
    path.write_bytes("a,b\n\u00e9,2\n".encode() + "3,\u00e9\n".encode("cp1252"))
    assert "(byte 0xe9 on line 3;" in not_utf8_message(path)


def test_analyze_of_a_latin1_table_says_to_save_it_as_utf8(tmp_path):
    table = pd.read_csv(TWO_CONDITIONS)
    table["condition"] = table["condition"].replace("control", "contr\u00f4le")
    path = tmp_path / "latin.csv"
    table.to_csv(path, index=False, encoding="latin-1")
    line = one_error_line(nudge("analyze", path).output)
    assert line.startswith(f"Error: {path}: not UTF-8 text (byte 0xf4 on line "), line
    assert line.endswith("save it as UTF-8 (a spreadsheet's \"CSV UTF-8\", an editor's encoding UTF-8)"), line
    assert not (tmp_path / "latin-analysis").exists()


def test_habits_of_a_latin1_log_says_to_save_it_as_utf8(tmp_path):
    path = tmp_path / "log.csv"
    rows = "0,1,Soft Puff,0,0,0,0\n0.1,1,Soft Puff,0,0,0,r\u00f4le\n"
    path.write_bytes((LOG_HEADER + rows).encode("latin-1"))
    line = one_error_line(nudge("habits", path).output)
    assert line.startswith(f"Error: {path}: not UTF-8 text (byte 0xf4 on line 3;"), line


# --- a European table --------------------------------------------------------------------------------


def test_analyze_of_a_table_with_decimal_commas_gives_habits_advice(tmp_path):
    """A table saved with ';' between columns and decimal commas: the column is named, and now why."""
    path = tmp_path / "european.csv"
    pd.read_csv(TWO_CONDITIONS).to_csv(path, sep=";", decimal=",", index=False)
    line = one_error_line(nudge("analyze", path).output)
    assert line == (f"Error: {path}: metric column 'completion_time' is not numeric (row 2 holds '30,9', and "
                    "47 more cell(s); a decimal comma? write 30.9); make it numeric, remove it, or pick the "
                    "metrics with --metric"), line


def test_a_non_number_that_no_comma_explains_gets_no_advice(tmp_path):
    path = Path(shutil.copy(TWO_CONDITIONS, tmp_path / "t.csv"))
    text = path.read_text().splitlines()
    text[1] = text[1].replace("30.9", "fast")
    path.write_text("\n".join(text) + "\n")
    line = one_error_line(nudge("analyze", path).output)
    assert "(row 2 holds 'fast'); make it numeric" in line, line


# --- habits: values and people ------------------------------------------------------------------------


@pytest.mark.parametrize("value", ["inf", "-inf", "Infinity"])
def test_habits_says_an_infinite_pose_is_no_pose(tmp_path, value):
    path = tmp_path / "log.csv"
    path.write_text(LOG_HEADER + f"0,1,Soft Puff,0,0,0,0\n0.1,1,Soft Puff,0.1,0,{value},0\n")
    line = one_error_line(nudge("habits", path).output)
    assert line == (f"Error: {path}, row 3: theta {value!r} is infinite, and infinite values are not times "
                    "or poses; every row needs its time and the robot's pose"), line


def test_habits_keeps_its_decimal_comma_advice(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text(LOG_HEADER.replace(",", ";") + "0;1;Soft Puff;0;0;0;0\n0,1;1;Soft Puff;0,1;0;0;0\n")
    line = one_error_line(nudge("habits", path).output)
    assert line.startswith(f"Error: {path}, row 3: t '0,1' is not a number (a decimal comma? write 0.1);"), \
        line


@pytest.mark.parametrize(("people", "header"), [(["P1"], "1 participant)"),
                                               (["P1", "P2"], "2 participants)")])
def test_habits_counts_its_participants_in_words(tmp_path, people, header):
    rows = [LOG_HEADER.replace("t,", "participant,t,", 1).rstrip("\n")]
    for person in people:
        rows += [f"{person},0,1,Soft Puff,0,0,0,0", f"{person},0.1,1,Soft Puff,0.1,0,0,0",
                 f"{person},0.2,1,None,0.2,0,0,0", f"{person},0.3,1,Hard Sip,0.2,0,0,x",
                 f"{person},0.4,1,None,0.2,0,0,0"]
    path = tmp_path / "log.csv"
    path.write_text("\n".join(rows) + "\n")
    result = nudge("habits", path)
    assert result.exit_code == 0, result.output
    assert result.output.splitlines()[0] == f"Operating habits of {path} (HABITS.md definitions, {header}"
