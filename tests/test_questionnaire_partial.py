"""A questionnaire row answers the six TLX ratings, the 15 pairwise comparisons and the six weights
each all or none: a row that leaves some of them empty is one Error line naming the file, the row
and the empty columns (one blank cell lost the response's TLX scores unseen, and the condition's n
dropped by one); a row that leaves all of them empty is a respondent who skipped that part."""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd
import pytest
from cli_helpers import nudge, stderr_error_line

from nudgecli.errors import DataError
from nudgecli.report.questionnaires import (
    TLX_PAIR_COLUMNS,
    TLX_RATING_COLUMNS,
    questionnaire_scores,
    read_questionnaires,
)

DATA = Path(__file__).parent / "data"
ANSWERS = DATA / "questionnaires_two_conditions.csv"
METRICS = DATA / "metrics_two_conditions.csv"


def _with_blanks(tmp_path: Path, row: int, columns: tuple[str, ...] | list[str]) -> Path:
    """The shipped answers with ``columns`` of data row ``row`` (file row ``row + 2``) left empty."""
    table = pd.read_csv(ANSWERS, dtype=str, keep_default_na=False)
    table.loc[row, list(columns)] = ""
    path = tmp_path / "q.csv"
    table.to_csv(path, index=False)
    return path


@pytest.mark.parametrize(("blank", "named"), [
    (["tlx_mental"], "row 3 answers 5 of the six NASA-TLX ratings but leaves tlx_mental empty"),
    (["tlx_pair_1"], "row 3 answers 14 of the 15 TLX pairwise comparisons but leaves tlx_pair_1 empty"),
])
def test_analyze_refuses_a_row_with_one_blank_tlx_answer(tmp_path: Path, blank: list[str],
                                                         named: str) -> None:
    answers = _with_blanks(tmp_path, 1, blank)
    result = nudge("analyze", METRICS, "--questionnaires", answers, "--out", tmp_path / "o", "--force")
    line = stderr_error_line(result)
    assert str(answers) in line and named in line and "fill in" in line
    assert not (tmp_path / "o" / "questionnaire_scores.csv").exists()


def test_blank_weights_and_a_spaces_only_pair_are_refused() -> None:
    table = read_questionnaires(ANSWERS).head(1).drop(columns=list(TLX_PAIR_COLUMNS))
    weights = {"tlx_weight_mental": 5, "tlx_weight_physical": 4, "tlx_weight_temporal": 3,
               "tlx_weight_performance": 2, "tlx_weight_effort": 1, "tlx_weight_frustration": None}
    with pytest.raises(DataError, match="answers 5 of the six TLX weights but leaves tlx_weight_frustration"):
        questionnaire_scores(table.assign(**weights), "q.csv")
    pairs = read_questionnaires(ANSWERS).head(1).assign(tlx_pair_15="  ")
    with pytest.raises(DataError, match=r"row 2 answers 14 of the 15 .* leaves tlx_pair_15 empty"):
        questionnaire_scores(pairs, "q.csv")


def test_a_row_that_answers_no_tlx_at_all_keeps_its_likert_items() -> None:
    table = read_questionnaires(ANSWERS).head(2)
    table.loc[1, [*TLX_RATING_COLUMNS, *TLX_PAIR_COLUMNS]] = None
    scores = questionnaire_scores(table, "q.csv")
    assert math.isnan(scores.loc[1, "tlx_raw"]) and math.isnan(scores.loc[1, "tlx_weighted"])
    assert scores.loc[1, "likert_q3"] == 5 and not math.isnan(scores.loc[0, "tlx_weighted"])


def test_ratings_without_pairs_keep_the_raw_score() -> None:
    table = read_questionnaires(ANSWERS).head(2)
    table.loc[1, list(TLX_PAIR_COLUMNS)] = None
    scores = questionnaire_scores(table, "q.csv")
    assert not math.isnan(scores.loc[1, "tlx_raw"]) and math.isnan(scores.loc[1, "tlx_weighted"])
