"""A questionnaire's column names are matched in any case (``TLX_Mental``, ``Likert_Q3``,
``Participant``, as a spreadsheet or survey export may write them); two columns whose names differ
only in case are one Error line naming both."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.errors import DataError
from nudgecli.report.questionnaires import TLX_SUBSCALES, questionnaire_scores, read_questionnaires

DATA = Path(__file__).parent / "data"
ANSWERS = DATA / "questionnaires_two_conditions.csv"
METRICS = DATA / "metrics_two_conditions.csv"


def capitalised(name: str) -> str:
    """``tlx_mental`` -> ``TLX_Mental``, ``likert_q3`` -> ``Likert_Q3``, ``participant`` ->
    ``Participant``: a survey export's spelling."""
    head, _, rest = name.partition("_")
    head = "TLX" if head == "tlx" else head.capitalize()
    return "_".join([head, *(part.capitalize() for part in rest.split("_"))]) if rest else head


def test_capitalised_columns_score_as_the_lower_case_ones() -> None:
    table = read_questionnaires(ANSWERS)
    expected = questionnaire_scores(table, "q.csv")
    shouted = table.rename(columns=capitalised)
    assert "TLX_Mental" in shouted.columns and "Likert_Q3" in shouted.columns
    assert "Participant" in shouted.columns and "TLX_Pair_1" in shouted.columns
    pd.testing.assert_frame_equal(questionnaire_scores(shouted, "q.csv"), expected)


def test_an_upper_case_likert_item_is_scored_not_dropped() -> None:
    # the items alone: before, 'LIKERT_Q3' was not seen, and the table 'held no scores'
    table = pd.DataFrame({"participant": [1, 2], "condition": ["a", "a"], "LIKERT_Q3": [4, 6]})
    scores = questionnaire_scores(table, "q.csv")
    assert scores["likert_q3"].tolist() == [4.0, 6.0]


@pytest.mark.parametrize(("first", "second"), [
    ("tlx_mental", "TLX_Mental"), ("likert_q3", "Likert_Q3"), ("participant", "PARTICIPANT"),
])
def test_two_columns_differing_only_in_case_are_named_in_one_line(first: str, second: str) -> None:
    row: dict[str, object] = {"participant": 1, "condition": "a", "likert_q3": 4,
                              **{f"tlx_{s}": 50 for s in TLX_SUBSCALES}}
    row[second] = row[first]
    with pytest.raises(DataError) as caught:
        questionnaire_scores(pd.DataFrame([row]), "q.csv")
    message = str(caught.value)
    assert "\n" not in message and message.startswith("q.csv: ")
    assert f"{first!r} and {second!r}" in message and "differ only in case" in message


def test_an_unknown_capitalised_tlx_column_is_named_as_written() -> None:
    row = {"participant": 1, "condition": "a", **{f"tlx_{s}": 50 for s in TLX_SUBSCALES}, "TLX_Mentl": 5}
    expected = r"unknown NASA-TLX column 'TLX_Mentl' \(did you mean 'tlx_mental'\?\)"
    with pytest.raises(DataError, match=expected):
        questionnaire_scores(pd.DataFrame([row]), "q.csv")


def test_analyze_reads_a_capitalised_questionnaire(tmp_path: Path) -> None:
    shouted = tmp_path / "answers.csv"
    read_questionnaires(ANSWERS).rename(columns=capitalised).to_csv(shouted, index=False)
    runner = CliRunner()
    plain = runner.invoke(main, ["analyze", str(METRICS), "--questionnaires", str(ANSWERS),
                                 "--out", str(tmp_path / "plain")])
    assert plain.exit_code == 0, plain.output
    result = runner.invoke(main, ["analyze", str(METRICS), "--questionnaires", str(shouted),
                                  "--out", str(tmp_path / "shouted")])
    assert result.exit_code == 0, result.output
    name = "questionnaire_scores.csv"
    assert (tmp_path / "shouted" / name).read_bytes() == (tmp_path / "plain" / name).read_bytes()


def test_a_column_written_twice_is_refused_not_scored_as_a_second_item(tmp_path: Path) -> None:
    # pandas reads the second 'likert_q3' as 'likert_q3.1', which was scored as an item of its own
    source = tmp_path / "answers.csv"
    source.write_text("participant,condition,likert_q3,likert_q3\n1,a,4,5\n2,a,3,6\n", encoding="utf-8")
    with pytest.raises(DataError, match=r"more than one column of one name: 'likert_q3' \(columns 3 and 4\)"):
        read_questionnaires(source)
    source.write_text("\nparticipant,condition,likert_q3\n1,a,4\n", encoding="utf-8")  # a blank first line
    assert list(read_questionnaires(source).columns) == ["participant", "condition", "likert_q3"]
