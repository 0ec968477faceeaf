"""NASA-TLX and Likert scores on hand cases, and the validation of questionnaire tables."""

from __future__ import annotations

import itertools
import math

import pandas as pd
import pytest

from nudgecli.errors import DataError
from nudgecli.report.questionnaires import TLX_SUBSCALES, questionnaire_scores, read_questionnaires

RATINGS = {"mental": 80, "physical": 20, "temporal": 50, "performance": 30, "effort": 60, "frustration": 10}
WINS = {"mental": 5, "physical": 0, "temporal": 3, "performance": 2, "effort": 4, "frustration": 1}
RAW = 250 / 6                                     # (80 + 20 + 50 + 30 + 60 + 10) / 6
WEIGHTED = (80 * 5 + 0 + 50 * 3 + 30 * 2 + 60 * 4 + 10 * 1) / 15   # 860 / 15


def _row(**extra: object) -> dict[str, object]:
    return {"participant": 1, "condition": "control", "block": 0,
            **{f"tlx_{s}": v for s, v in RATINGS.items()}, **extra}


def _pairs_for(wins: dict[str, int]) -> dict[str, str]:
    """The 15 pairwise winners that give ``wins`` (the subscale with more wins beats the other)."""
    order = sorted(TLX_SUBSCALES, key=lambda s: -wins[s])
    return {f"tlx_pair_{i}": (a if order.index(a) < order.index(b) else b)
            for i, (a, b) in enumerate(itertools.combinations(TLX_SUBSCALES, 2), start=1)}


def test_raw_and_weighted_tlx_from_weights() -> None:
    table = pd.DataFrame([_row(**{f"tlx_weight_{s}": w for s, w in WINS.items()})])
    scores = questionnaire_scores(table)
    assert scores.loc[0, "tlx_raw"] == pytest.approx(RAW)
    assert scores.loc[0, "tlx_weighted"] == pytest.approx(WEIGHTED)


def test_weighted_tlx_from_pairwise_winners() -> None:
    pairs = {k: v.capitalize() + (" Demand" if v == "mental" else "") for k, v in _pairs_for(WINS).items()}
    scores = questionnaire_scores(pd.DataFrame([_row(**pairs)]))
    assert scores.loc[0, "tlx_weighted"] == pytest.approx(WEIGHTED)
    assert scores.loc[0, "tlx_raw"] == pytest.approx(RAW)


def test_likert_items_and_missing_answers() -> None:
    table = pd.DataFrame([_row(likert_q3=7, likert_q4=1), _row(block=1, likert_q3=None, likert_q4=4)])
    table.loc[1, [f"tlx_{s}" for s in TLX_SUBSCALES]] = None  # no TLX answered: all six or none
    scores = questionnaire_scores(table)
    assert list(scores.columns) == ["participant", "condition", "block", "tlx_raw", "likert_q3", "likert_q4"]
    assert scores["likert_q3"].tolist()[0] == 7 and math.isnan(scores.loc[1, "likert_q3"])
    assert math.isnan(scores.loc[1, "tlx_raw"])


@pytest.mark.parametrize(("change", "message"), [
    ({"tlx_mental": 120}, "'tlx_mental' must hold values from 0 to 100"),
    ({"tlx_mental": "high"}, "'tlx_mental' must be numeric"),
    ({"likert_q3": 8}, "'likert_q3' must hold integers from 1 to 7"),
    ({"likert_q3": 2.5}, "'likert_q3' must hold integers"),
    ({**{f"tlx_weight_{s}": w for s, w in WINS.items()}, "tlx_weight_mental": 4}, "sum to 14"),
    ({**_pairs_for(WINS), "tlx_pair_3": "boredom"}, "name the winning subscale"),
    ({**_pairs_for(WINS), **{f"tlx_pair_{i}": "mental" for i in range(1, 16)}}, "each subscale is in only 5"),
    # six wins, one more than the pairs a subscale is in (the other nine answers are possible)
    ({f"tlx_pair_{i + 1}": s for i, s in enumerate(["mental"] * 6 + ["physical"] * 5 + ["temporal"] * 4)},
     "'mental' wins 6 of the 15"),
    ({**_pairs_for(WINS), **{f"tlx_weight_{s}": w for s, w in WINS.items()}}, "keep one of the two"),
])
def test_invalid_values_are_refused(change: dict[str, object], message: str) -> None:
    with pytest.raises(DataError, match=message):
        questionnaire_scores(pd.DataFrame([_row(**change)]), source="q.csv")


def test_invalid_tables_are_refused() -> None:
    with pytest.raises(DataError, match="missing column\\(s\\) tlx_frustration"):
        questionnaire_scores(pd.DataFrame([_row()]).drop(columns="tlx_frustration"))
    with pytest.raises(DataError, match="no 'condition' column"):
        questionnaire_scores(pd.DataFrame([_row()]).drop(columns="condition"))
    with pytest.raises(DataError, match="missing tlx_pair_15"):
        questionnaire_scores(pd.DataFrame([_row(**_pairs_for(WINS))]).drop(columns="tlx_pair_15"))
    with pytest.raises(DataError, match="holds no scores"):
        questionnaire_scores(pd.DataFrame({"participant": [1], "condition": ["a"]}))
    with pytest.raises(DataError, match="has no rows"):
        questionnaire_scores(pd.DataFrame(columns=["participant", "condition"]))


def test_read_questionnaires_refuses_missing_and_empty_files(tmp_path) -> None:
    with pytest.raises(DataError, match="does not exist"):
        read_questionnaires(tmp_path / "nope.csv")
    (tmp_path / "empty.csv").write_text("")
    with pytest.raises(DataError, match="is empty"):
        read_questionnaires(tmp_path / "empty.csv")


def test_a_repeated_or_conflicting_response_is_refused_naming_both_rows() -> None:
    other = _row(participant=2)
    repeated = pd.DataFrame([_row(likert_q3=5), other, _row(likert_q3=5)])
    with pytest.raises(DataError, match=r"rows 2 and 4 are both participant 1's response for condition "
                                        r"control, block 0, with the same answers twice"):
        questionnaire_scores(repeated, "q.csv")
    conflicting = pd.DataFrame([_row(likert_q3=5), other, _row(likert_q3=2)])
    with pytest.raises(DataError, match=r"rows 2 and 4 .* different answers \(conflicting"):
        questionnaire_scores(conflicting, "q.csv")
    # one label in a mixed column ("1" and 1) is one person; another spelling (" 1") is another
    # label, as the tables read it (report/tables.py), and check_respondents judges it
    mixed = pd.DataFrame([_row(), {**_row(), "participant": "1"}])
    with pytest.raises(DataError, match="rows 2 and 3"):
        questionnaire_scores(mixed)
    assert len(questionnaire_scores(pd.DataFrame([_row(), {**_row(), "participant": " 1"}]))) == 2
    # one response per block is fine, and so is the same block number of another condition
    fine = pd.DataFrame([_row(), _row(block=1), _row(condition="disambiguation")])
    assert len(questionnaire_scores(fine)) == 3


def test_respondents_outside_the_run_are_named() -> None:
    from nudgecli.report.questionnaires import check_respondents

    scores = questionnaire_scores(pd.DataFrame([_row(participant=p) for p in (1, 2, 9, 12)]))
    with pytest.raises(DataError, match=r"q.csv: respondent\(s\) 9, 12 are not participants of RUN"):
        check_respondents(scores, pd.Series([1, 1, 2, 3]), "q.csv", "RUN")
    check_respondents(scores, pd.Series([1.0, 2, 9, 12, 40]), "q.csv", "RUN")  # everyone is known


def test_analyze_refuses_questionnaires_of_people_not_in_the_table(tmp_path) -> None:
    from pathlib import Path

    from nudgecli.report.analysis import analyze

    data = Path(__file__).parent / "data"
    table = pd.read_csv(data / "questionnaires_two_conditions.csv")
    table.loc[len(table)] = {**table.iloc[0].to_dict(), "participant": 77}
    table.to_csv(tmp_path / "q.csv", index=False)
    with pytest.raises(DataError, match=r"respondent.* 77 are not participants of"):
        analyze(data / "metrics_two_conditions.csv", out=tmp_path / "a", questionnaires=tmp_path / "q.csv")


def _unblocked(**extra: object) -> dict[str, object]:
    """A response row of a table without a ``block`` column (one response per condition)."""
    return {k: v for k, v in _row(**extra).items() if k != "block"}


def test_without_a_block_column_a_repeated_response_is_refused_naming_both_rows() -> None:
    # the QA case: participant 0 answered for "control" twice; counted twice it made n = 3 of 2 people
    table = pd.DataFrame([_unblocked(participant=0, condition="disambiguation"), _unblocked(participant=0),
                          _unblocked(participant=1, condition="disambiguation"), _unblocked(participant=1),
                          _unblocked(participant=0)])
    with pytest.raises(DataError) as caught:
        questionnaire_scores(table, "q.csv")
    message = str(caught.value)
    assert message.startswith("q.csv: rows 3 and 6 are both participant 0's response for condition control, "
                              "with the same answers twice")
    assert "or add a block column" in message and "\n" not in message  # the fix names both ways
    conflicting = table.copy()
    conflicting.loc[4, "tlx_mental"] = 5
    with pytest.raises(DataError, match=r"rows 3 and 6 .* different answers \(conflicting"):
        questionnaire_scores(conflicting, "q.csv")
    # one response per participant and condition is what such a table holds
    assert len(questionnaire_scores(table.iloc[:4], "q.csv")) == 4


@pytest.mark.parametrize(("column", "suggestion"), [
    ("tlx_mentl", "tlx_mental"), ("tlx_weight_efort", "tlx_weight_effort"), ("TLX_Mentl", "tlx_mental"),
    ("tlx_overall_score", None),
])
def test_an_unknown_tlx_column_is_refused_with_a_suggestion(column: str, suggestion: str | None) -> None:
    extra: dict[str, object] = {column: 5}
    if column.startswith("tlx_weight_"):  # beside a complete set of weights
        extra |= {f"tlx_weight_{s}": w for s, w in WINS.items()}
    with pytest.raises(DataError) as caught:
        questionnaire_scores(pd.DataFrame([_row(**extra)]), "q.csv")
    message = str(caught.value)
    assert message.startswith(f"q.csv: unknown NASA-TLX column {column!r}")
    if suggestion is not None:
        assert f"(did you mean {suggestion!r}?)" in message
    else:
        assert "did you mean" not in message
    assert "rename it or remove it" in message


def test_range_errors_print_plain_numbers() -> None:
    with pytest.raises(DataError) as caught:
        questionnaire_scores(pd.DataFrame([_row(), _row(block=1, tlx_mental=150)]), "q.csv")
    assert str(caught.value).endswith("row 3 holds 150")
    with pytest.raises(DataError) as caught:
        questionnaire_scores(pd.DataFrame([_row(likert_q3=2.5)]), "q.csv")
    assert str(caught.value).endswith("row 2 holds 2.5")
    weights = {f"tlx_weight_{s}": w for s, w in WINS.items()}
    with pytest.raises(DataError) as caught:
        questionnaire_scores(pd.DataFrame([_row(**{**weights, "tlx_weight_mental": 7})]), "q.csv")
    assert str(caught.value).endswith("row 2 holds 7")
