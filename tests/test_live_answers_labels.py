"""A live folder's answers file is matched by participant and block as the analysis matches every
table's labels (report.tables.label_text): a block column read back as ``1.0`` beside a blank cell
holds block 1, and ``01`` is a label of its own."""

from __future__ import annotations

from pathlib import Path

import pytest

from nudgecli.errors import DataError
from nudgecli.live.questionnaire import ROW_COLUMNS, answered_blocks, merged_answers, read_answers

ANSWERS = {column: 50 if column.startswith("tlx") else 4 for column in ROW_COLUMNS[3:]}


def _answers_file(path: Path, rows: list[tuple[str, str]]) -> Path:
    """``questionnaires.csv`` with one row of ``ANSWERS`` per ``(participant, block)``, as written."""
    lines = [",".join(ROW_COLUMNS)]
    lines += [",".join([participant, "cond", block, *(str(v) for v in ANSWERS.values())])
              for participant, block in rows]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_a_block_read_back_as_a_float_is_that_block(tmp_path: Path) -> None:
    path = _answers_file(tmp_path / "questionnaires.csv", [("1", "1"), ("2", "")])  # the blank: float64
    assert read_answers(path)["block"].tolist()[0] == 1.0
    assert answered_blocks(path, 1, [0, 1, 2]) == {1}


def test_a_block_written_01_is_not_block_1_as_in_the_analysis(tmp_path: Path) -> None:
    path = _answers_file(tmp_path / "questionnaires.csv", [("1", "01")])
    assert answered_blocks(path, 1, [1]) == set()


def test_a_row_recorded_under_a_float_block_is_taken_once_and_never_replaced(tmp_path: Path) -> None:
    path = _answers_file(tmp_path / "questionnaires.csv", [("1", "1"), ("2", "")])
    old = read_answers(path)
    same = {"participant": 1, "condition": "cond", "block": 1, **ANSWERS}
    assert len(merged_answers(old, [same], path)) == 2
    with pytest.raises(DataError, match="already holds participant 1's answers to block 1"):
        merged_answers(old, [{**same, "tlx_mental": 90}], path)
