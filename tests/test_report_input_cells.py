"""Cells of a metrics or questionnaire table that were refused for the wrong reason, or not
refused with a line (nudgecli.report.tables, nudgecli.report.questionnaires):

- an empty ``condition`` (or ``participant``) of a questionnaire response is refused naming the
  file and the row, as a trial's is (was: a ``TypeError`` traceback, or a stranger ``'nan'``);
- a metric column mixing true/false with numbers is refused naming the first number, not a valid
  ``True`` as "not numeric";
- an integer beyond int64 is a number wherever it sits (was: refused in the first row, with no row
  named, and accepted after a decimal).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.errors import DataError
from nudgecli.report.questionnaires import check_run_conditions, questionnaire_scores
from nudgecli.report.tables import read_metrics_table, validate_metrics_table

TRIALS = ("participant,condition,trial,completion_time\n1,a,1,10\n1,a,2,11\n1,b,1,12\n1,b,2,14\n"
          "2,a,1,9\n2,a,2,10\n2,b,1,15\n2,b,2,13\n")


def _refused(args: list[str]) -> str:
    """The one ``Error:`` line ``nudge`` refuses ``args`` with."""
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1, result.output
    assert result.stderr.startswith("Error: ") and result.stderr.count("\n") == 1, result.stderr
    return result.stderr.strip()


@pytest.mark.parametrize(("answers", "column"), [
    ("participant,condition,likert_Q3\n1,a,5\n1,,4\n2,a,6\n2,b,3\n", "condition"),
    ("participant,condition,likert_Q3\n1,a,5\n,b,4\n2,a,6\n2,b,3\n", "participant"),
])
def test_an_empty_id_of_a_questionnaire_response_is_refused_naming_the_row(tmp_path: Path, answers: str,
                                                                           column: str) -> None:
    (tmp_path / "t.csv").write_text(TRIALS)
    (tmp_path / "q.csv").write_text(answers)
    out = tmp_path / "out"
    line = _refused(["analyze", str(tmp_path / "t.csv"), "--questionnaires", str(tmp_path / "q.csv"),
                     "--out", str(out)])
    assert line == (f"Error: {tmp_path / 'q.csv'}: column {column!r} is empty in row 3; fill it in or "
                    "remove the row")
    assert not out.exists()


def test_an_empty_condition_is_refused_before_a_run_s_conditions_are_compared() -> None:
    answers = pd.DataFrame({"participant": [1, 1], "block": [1, 2], "condition": ["a", None],
                            "likert_q3": [5, 4]})
    trials = pd.DataFrame({"participant": [1, 1], "block": [1, 2], "condition": ["a", "b"]})
    with pytest.raises(DataError, match=r"^q.csv: column 'condition' is empty in row 3; fill it in"):
        check_run_conditions(answers, trials, "q.csv", "run")  # was: "gives ... the condition nan"
    with pytest.raises(DataError, match=r"^q.csv: column 'condition' is empty in row 3"):
        questionnaire_scores(answers, "q.csv")


def _table(metric: list[object]) -> pd.DataFrame:
    return pd.DataFrame({"participant": [1, 1, 2, 2], "condition": ["a", "b", "a", "b"], "m": metric},
                        dtype=object)


def test_a_column_mixing_true_false_with_numbers_is_named_as_such() -> None:
    with pytest.raises(DataError, match=r"^t.csv: metric column 'm' mixes true/false with numbers \(row 3 "
                                        r"holds '1'\); write it all as true/false or all as numbers"):
        validate_metrics_table(_table(["True", "1", "False", "0"]), "t.csv")
    # a cell that is neither is still the one named
    with pytest.raises(DataError, match=r"'m' is not numeric \(row 4 holds 'yes'"):
        validate_metrics_table(_table(["True", "1", "yes", "0"]), "t.csv")
    # each format alone is a metric, as before
    assert validate_metrics_table(_table(["True", "False", "False", None]), "t.csv") == ["m"]
    assert validate_metrics_table(_table([1, 0, 1, 0]).astype({"m": int}), "t.csv") == ["m"]


@pytest.mark.parametrize("row", [1, 2])
@pytest.mark.parametrize("decimal", [False, True])
def test_an_integer_beyond_int64_is_a_number_wherever_it_sits(tmp_path: Path, row: int,
                                                               decimal: bool) -> None:
    lines = TRIALS.splitlines()
    lines[row] = lines[row].rsplit(",", 1)[0] + ",99999999999999999999999"
    if decimal:  # pandas read a decimal after it as text, before it as floats
        lines[3 - row] = lines[3 - row].rsplit(",", 1)[0] + ",11.5"
    (tmp_path / "t.csv").write_text("\n".join(lines) + "\n")
    table = read_metrics_table(tmp_path / "t.csv")
    assert validate_metrics_table(table, "t.csv") == ["completion_time"]
    assert table["completion_time"].dtype == float and table["completion_time"].iloc[row - 1] == 1e23
