"""Live-study mends: a resume matches the answers file's rows as every reader of it does, the
last-resort advice for answers no file took gives the header when the file does not exist yet, every
bad message gets an error reply and the page keeps its answers until the server has them, and the
message size limit counts bytes."""

from __future__ import annotations

from pathlib import Path

import pytest

from nudgecli.errors import RunFolderError
from nudgecli.live import records
from nudgecli.live.questionnaire import ROW_COLUMNS, read_answers
from nudgecli.live.record_checks import check_answered_blocks

ANSWER_CELLS = [str(50 if column.startswith("tlx") else 4) for column in ROW_COLUMNS[3:]]


def _answers_file(folder: Path, rows: list[tuple[str, str]]) -> Path:
    """``questionnaires.csv`` in ``folder`` with one row per ``(participant, block)`` as written."""
    lines = [",".join(ROW_COLUMNS)]
    lines += [",".join([participant, "control", block, *ANSWER_CELLS]) for participant, block in rows]
    path = folder / "questionnaires.csv"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


# --- a resume finds the answers of a block read back as a float ------------------------------------


@pytest.mark.parametrize("rows", [
    [("8", "0"), ("9", "")],  # a blank block in another row: the block column reads back as floats
    [("8", "0"), ("", "1")],  # a blank participant: the participant column does
])
def test_a_resume_finds_answers_whose_labels_read_back_as_floats(tmp_path: Path, rows) -> None:
    _answers_file(tmp_path, rows)
    check_answered_blocks(tmp_path, 8, {"participant_id": "P08", "questionnaire_blocks": [0]})


def test_answers_missing_from_the_file_are_refused_in_the_answers_words(tmp_path: Path) -> None:
    _answers_file(tmp_path, [("8", "0"), ("9", "")])
    with pytest.raises(RunFolderError) as refused:
        check_answered_blocks(tmp_path, 8, {"participant_id": "P08", "questionnaire_blocks": [0, 1]})
    message = str(refused.value)
    assert "holds no answers of participant P08 to block(s) 1," in message
    assert message.endswith("restore it from a backup (a person's answers cannot be asked again)")


# --- answers no file took: the advice to write them by hand works as given --------------------------


def _advice_followed(folder: Path, monkeypatch) -> Path:
    """The answers of participant 1's block 0 no file takes (the disk full), written into
    ``questionnaires.csv`` exactly as the error's last-resort advice says."""
    def disk_full(path: Path, text: str) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(records, "write_text_atomic", disk_full)
    row = {"participant": 1, "condition": "control", "block": 0,
           **{column: float(cell) if column.startswith("tlx") else int(cell)
              for column, cell in zip(ROW_COLUMNS[3:], ANSWER_CELLS, strict=True)}}
    message = str(records.LiveFolder(folder)._answers_kept(1, row, OSError(28, "No space left on device")))
    path = folder / "questionnaires.csv"
    if "create " in message:
        header, line = message.split("the header ")[1].split(" and then the answers ")
        path.write_text(f"{header}\n{line}\n", encoding="utf-8")
    else:
        with path.open("a", encoding="utf-8") as handle:
            handle.write(message.split("by hand: ")[1] + "\n")
    return path


def test_answers_given_by_hand_create_the_answers_file_that_does_not_exist_yet(tmp_path, monkeypatch):
    path = _advice_followed(tmp_path, monkeypatch)
    table = read_answers(path)
    assert table[["participant", "block", "tlx_mental", "likert_q10"]].values.tolist() == [[1, 0, 50.0, 4]]


def test_answers_given_by_hand_are_one_more_line_of_an_existing_answers_file(tmp_path, monkeypatch):
    _answers_file(tmp_path, [("2", "0")])
    table = read_answers(_advice_followed(tmp_path, monkeypatch))
    assert table[["participant", "block"]].values.tolist() == [[2, 0], [1, 0]]


# --- the message size limit counts bytes -----------------------------------------------------------


def test_the_message_size_limit_counts_utf8_bytes_not_characters() -> None:
    pytest.importorskip("aiohttp", reason="the live server needs aiohttp: pip install '.[study]'")
    from nudgecli.live.messages import MAX_MESSAGE_BYTES
    from nudgecli.live.server import _parse

    euros = '{"type": "ping", "pad": "' + "\u20ac" * 6000 + '"}'  # 6,027 characters, 18,027 bytes
    assert len(euros) < MAX_MESSAGE_BYTES
    assert _parse(euros) == (None, f"message of 18027 bytes; at most {MAX_MESSAGE_BYTES}", True)
    fits = '{"type": "ping", "pad": "' + "\u20ac" * 5000 + '"}'  # 15,027 bytes
    assert _parse(fits) == ({"type": "ping", "pad": "\u20ac" * 5000}, None, False)
