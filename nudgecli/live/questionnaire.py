"""The questionnaire after each block: NASA-TLX and the study's Likert items, as the page asks them
and as the rows of ``questionnaires.csv`` that ``nudge analyze --questionnaires`` reads
(:mod:`nudgecli.report.questionnaires` owns that format and its ranges)."""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from nudgecli.errors import DataError, did_you_mean
from nudgecli.report.questionnaires import (
    ID_COLUMNS,
    LIKERT_PREFIX,
    LIKERT_RANGE,
    TLX_RANGE,
    TLX_RATING_COLUMNS,
    TLX_SUBSCALES,
    read_questionnaires,
)
from nudgecli.report.tables import label_text
from nudgecli.sim.protocol import TrialSpec

#: The study's post-block Likert items (study-software-notes, post_task_likert_analysis.py).
LIKERT_ITEMS = {
    "q3": "After the assistant's turn, it was able to figure out where I wanted to go much more easily.",
    "q4": "The assistant helped me move the robot towards the desired goal more effectively after its turn.",
    "q7": "The assistant's help let me complete the task more efficiently.",
    "q10": "The assistant's help reduced unwanted mode switches.",
}
#: NASA-TLX questions and the words at the two ends of each scale (0 and 100).
TLX_QUESTIONS = {
    "mental": ("How mentally demanding was the task?", "very low", "very high"),
    "physical": ("How physically demanding was the task?", "very low", "very high"),
    "temporal": ("How hurried or rushed was the pace of the task?", "very low", "very high"),
    "performance": (
        "How successful were you in accomplishing what you were asked to do?",
        "perfect",
        "failure",
    ),
    "effort": (
        "How hard did you have to work to accomplish your level of performance?",
        "very low",
        "very high",
    ),
    "frustration": (
        "How insecure, discouraged, irritated, stressed, and annoyed were you?",
        "very low",
        "very high",
    ),
}


#: The columns of a row of ``questionnaires.csv`` as ``nudge study`` writes it.
ROW_COLUMNS = (*ID_COLUMNS, *TLX_RATING_COLUMNS,
               *(f"{LIKERT_PREFIX}{item}" for item in LIKERT_ITEMS))
#: What to do with a live folder's damaged answers file.
RESTORE_ANSWERS = "restore it from a backup (a person's answers cannot be asked again)"


def read_answers(path: Path) -> pd.DataFrame:
    """A live folder's answers file (``questionnaires.csv``) read as ``nudge analyze --questionnaires``
    reads it (:func:`~nudgecli.report.questionnaires.read_questionnaires`: an empty or cut-off file
    refused), checked to hold the columns ``nudge study`` writes (:data:`ROW_COLUMNS`).

    Raises
    ------
    DataError
        The file cannot be read, or lacks a column (re-saved with another separator, or edited).
    """
    try:
        table = read_questionnaires(path)
    except DataError as exc:
        raise DataError(f"{exc}; it holds the answers nudge study records: {RESTORE_ANSWERS}") from None
    missing = [column for column in ROW_COLUMNS if column not in table.columns]
    if missing:
        header = ",".join(str(column) for column in table.columns)
        raise DataError(f"{path}: not the comma-separated table nudge study writes (no column "
                        f"{', '.join(missing[:3])}{' ...' if len(missing) > 3 else ''}; its header reads "
                        f"{header[:80]!r}): save it again as comma-separated CSV with the columns "
                        f"{','.join(ROW_COLUMNS)}, or {RESTORE_ANSWERS}")
    return table


def merged_answers(old: pd.DataFrame | None, rows: list[dict[str, Any]], source: str | Path) -> pd.DataFrame:
    """``old`` answers (:func:`read_answers` of ``source``; ``None``: none yet) with ``rows`` added,
    sorted by participant and block. A row whose participant and block ``old`` holds already is
    taken once when its answers are the same; with other answers it is refused: a recorded answer
    is never replaced (a person's answers cannot be asked again).

    Raises
    ------
    DataError
        A row's participant and block hold other answers in ``old``, naming both values.
    """
    new = pd.DataFrame(rows)
    if old is not None:
        recorded = {_row_key(p, b): i for i, (p, b) in enumerate(zip(old["participant"], old["block"],
                                                                      strict=True))}
        for row in rows:
            at = recorded.get(_row_key(row["participant"], row["block"]))
            if at is not None:
                _check_same_answers(old.iloc[at], row, at, source)
        keys = {_row_key(row["participant"], row["block"]) for row in rows}
        keep = [_row_key(p, b) not in keys for p, b in zip(old["participant"], old["block"], strict=True)]
        new = pd.concat([old[keep], new], ignore_index=True)
    return new.sort_values(["participant", "block"], key=lambda c: pd.to_numeric(c, errors="coerce"),
                           kind="stable", ignore_index=True)


def _check_same_answers(recorded: pd.Series, row: dict[str, Any], at: int, source: str | Path) -> None:
    """Refuse ``row`` where it differs from the ``recorded`` row ``at`` (0-based) of ``source``."""
    for column in ROW_COLUMNS:
        old, new = recorded.get(column), row.get(column)
        same = label_text(old) == label_text(new) if column in ID_COLUMNS else _number(old) == _number(new)
        if not same:
            raise DataError(
                f"{source}: row {at + 2} already holds participant {row['participant']}'s answers to block "
                f"{row['block']}, with {column} {old} where the new answers give {new}; a recorded answer "
                "is never replaced: keep the row the participant gave and remove the other by hand")


def complete_blocks(schedule: Sequence[TrialSpec], done: Collection[int]) -> list[int]:
    """The blocks of ``schedule`` whose trials are all in ``done`` (their questionnaire is due)."""
    blocks = sorted({spec.block for spec in schedule})
    return [block for block in blocks
            if all(spec.trial in done for spec in schedule if spec.block == block)]


def answered_blocks(path: Path, participant: int, blocks: Collection[int]) -> set[int]:
    """The ``blocks`` whose answers of ``participant`` the answers file ``path`` holds (none: no file),
    its labels matched as the analysis matches them (:func:`_row_key`): a block column read back as
    ``1.0`` (beside a blank cell) holds block 1; ``01`` is a label of its own, as in the analysis."""
    if not path.is_file():
        return set()
    table = read_answers(path)
    rows = {_row_key(p, b) for p, b in zip(table["participant"], table["block"], strict=True)}
    return {block for block in blocks if _row_key(participant, block) in rows}


def _row_key(participant: object, block: object) -> tuple[str, str]:
    """A row's participant and block as text, as every table's labels are matched
    (:func:`~nudgecli.report.tables.label_text`: ``1``, ``1.0`` and ``np.int64(1)`` are ``"1"``)."""
    return label_text(participant), label_text(block)


def answers_line(row: dict[str, Any]) -> str:
    """One block's answers as the CSV line of ``questionnaires.csv`` (:data:`ROW_COLUMNS`)."""
    return str(pd.DataFrame([row], columns=list(ROW_COLUMNS)).to_csv(index=False, header=False)).strip()


def answers_by_hand(path: Path, row: dict[str, Any]) -> str:
    """How to add one block's answers to the answers file ``path`` by hand (the last resort when no
    file could be written): the line to add, or, where ``path`` does not exist yet, both lines to
    create it with (its header first: :func:`read_answers` refuses a file without it)."""
    if path.is_file():
        return f"add this line to {path} by hand: {answers_line(row)}"
    return (f"create {path} by hand with these two lines, the header {','.join(ROW_COLUMNS)} "
            f"and then the answers {answers_line(row)}")


def questionnaire_form() -> dict[str, Any]:
    """What the page shows: the TLX scales (0-100) and the Likert statements (1-7)."""
    return {
        "tlx": [
            {
                "name": column,
                "subscale": subscale,
                "question": TLX_QUESTIONS[subscale][0],
                "low": TLX_QUESTIONS[subscale][1],
                "high": TLX_QUESTIONS[subscale][2],
            }
            for subscale, column in zip(TLX_SUBSCALES, TLX_RATING_COLUMNS, strict=True)
        ],
        "likert": [{"name": f"{LIKERT_PREFIX}{k}", "statement": s} for k, s in LIKERT_ITEMS.items()],
        "tlx_range": list(TLX_RANGE),
        "likert_range": list(LIKERT_RANGE),
    }


def questionnaire_row(answers: dict[str, Any]) -> dict[str, Any] | str:
    """The answers as ``tlx_*`` and ``likert_*`` cells, or a message for the page saying what is missing.

    Every TLX rating must be a number in 0-100 and every Likert answer an integer in 1-7; an answer
    of another name (``likert_q11``, ``tlx_mentl``) is refused, naming it, not dropped.
    """
    known = ROW_COLUMNS[len(ID_COLUMNS):]
    unknown = [str(name) for name in answers if name not in known]
    if unknown:
        return (f"unknown answer(s) {', '.join(repr(name[:40]) for name in unknown[:3])}"
                f"{did_you_mean(unknown[0], known)}; the questionnaire's answers are {', '.join(known)}")
    row: dict[str, Any] = {}
    for subscale, column in zip(TLX_SUBSCALES, TLX_RATING_COLUMNS, strict=True):
        value = _number(answers.get(column))
        if value is None or not TLX_RANGE[0] <= value <= TLX_RANGE[1]:
            return f"rate '{subscale}' from {TLX_RANGE[0]:g} to {TLX_RANGE[1]:g}"
        row[column] = value
    for item in LIKERT_ITEMS:
        column = f"{LIKERT_PREFIX}{item}"
        value = _number(answers.get(column))
        if value is None or value != int(value) or not LIKERT_RANGE[0] <= value <= LIKERT_RANGE[1]:
            return f"answer every statement ({LIKERT_RANGE[0]}-{LIKERT_RANGE[1]})"
        row[column] = int(value)
    return row


def _number(value: Any) -> float | None:
    try:
        number = float(value)
    except (TypeError, ValueError, OverflowError):
        return None
    return number if math.isfinite(number) else None
