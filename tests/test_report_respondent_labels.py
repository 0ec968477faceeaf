"""Questionnaire respondents follow the tables' one label rule (report/tables.py): a respondent is
the participant whose label, as the tables read it, is the same text. ``07`` answers for ``07``
only, never for ``7``; ``7``, ``"7"`` and ``7.0`` (numbers) are one label."""

from __future__ import annotations

import csv
import io
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.cli import main
from nudgecli.errors import DataError
from nudgecli.report.questionnaires import check_respondents
from nudgecli.report.tables import label_text, read_csv_labels

DATA = Path(__file__).parent / "data"


def respondents(*labels: object) -> pd.DataFrame:
    return pd.DataFrame({"participant": list(labels), "condition": "control"})


@pytest.mark.parametrize("label, participants", [
    (7, [7, 8]), (np.int64(7), [7]), ("7", [7]), (7, ["07", "7"]), ("07", ["07", "7"]), (7.0, [7]),
    (7, np.array([7.0, np.nan])),  # integers beside blanks, as pandas reads them
])
def test_a_respondent_is_the_participant_of_the_same_label(label, participants) -> None:
    check_respondents(respondents(label), pd.Series(participants), "q.csv", "RUN")


@pytest.mark.parametrize("label, participants, shown", [
    ("07", [7, 8], "'07'"), ("7.0", [7], "'7.0'"), (" 7", [7], "' 7'"), (7, ["07", "08"], "7"),
    ("7", ["07"], "7"), ("P7", [7], "'P7'"),
])
def test_another_spelling_of_a_participant_is_not_that_participant(label, participants, shown) -> None:
    with pytest.raises(DataError, match=rf"q.csv: respondent\(s\) {shown} are not participants of RUN"):
        check_respondents(respondents(label), pd.Series(participants), "q.csv", "RUN")


def test_the_refusal_shows_how_the_run_writes_the_participant() -> None:
    with pytest.raises(DataError, match=r"\(labels are matched exactly as written: RUN writes 7, not '07'; "
                                        r"8, not '8.0'\); remove their rows"):
        check_respondents(respondents("07", "8.0", "9"), pd.Series([7, 8, 9]), "q.csv", "RUN")
    with pytest.raises(DataError) as refused:
        check_respondents(respondents("P7"), pd.Series([7]), "q.csv", "RUN")
    assert "matched exactly" not in str(refused.value)  # no number to point at: no hint


SPELLINGS = st.text(alphabet="0123456789+-. Pp", min_size=1, max_size=5)


@settings(max_examples=80, deadline=None)
@given(st.lists(st.one_of(SPELLINGS, st.integers(-(2**63), 2**63 - 1).map(str)), min_size=1, max_size=6))
def test_a_label_read_from_a_csv_is_the_text_written(tmp_path_factory: pytest.TempPathFactory,
                                                     labels: list[str]) -> None:
    """Whatever pandas makes of a column (integers, text), each label comes back as written."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["participant", "condition"])
    writer.writerows([label, "c"] for label in labels)
    path = tmp_path_factory.mktemp("labels") / "q.csv"
    path.write_text(buffer.getvalue())
    assert [label_text(v) for v in read_csv_labels(path)["participant"]] == labels


def test_analyze_refuses_answers_of_07_for_a_table_whose_participant_is_7(tmp_path: Path) -> None:
    """Through the command line: the answers of ``07`` (a text column, as a lab writes it) are not
    given to participant 7 of a table of canonical integers; written ``7``, they are."""
    answers = pd.read_csv(DATA / "questionnaires_two_conditions.csv", dtype=str, keep_default_na=False)
    table = tmp_path / "study.csv"
    shutil.copy(DATA / "metrics_two_conditions.csv", table)
    first = answers["participant"].iloc[0]
    padded = answers.assign(participant=answers["participant"].map(lambda p: f"0{p}" if p == first else p))
    padded.to_csv(tmp_path / "q.csv", index=False)
    args = ["analyze", str(table), "--questionnaires", str(tmp_path / "q.csv"), "--bootstrap", "100"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code != 0 and result.output.count("\n") == 1
    assert f"respondent(s) '0{first}' are not participants of {table}" in result.output
    assert f"writes {first}, not '0{first}'" in result.output and not (tmp_path / "study-analysis").exists()
    answers.to_csv(tmp_path / "q.csv", index=False)
    assert CliRunner().invoke(main, args).exit_code == 0
