"""Questionnaires taken on trust no more, through the command line: a response given twice, or a
misspelt NASA-TLX column, is refused with one ``Error:`` line and the analysis already there is
left as it was.

Each test was seen failing with its fix removed."""

from __future__ import annotations

import shutil
from pathlib import Path

import pandas as pd
import pytest
from cli_helpers import one_error_line
from click.testing import CliRunner, Result

from nudgecli.cli import main

DATA = Path(__file__).parent / "data"
TABLE = DATA / "metrics_two_conditions.csv"
ANSWERS = DATA / "questionnaires_two_conditions.csv"


def invoke(*args: str) -> Result:
    return CliRunner().invoke(main, list(args))


def files_of(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (the lock aside) by its name, with its bytes."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and p.name != ".nudge.lock"}


@pytest.fixture
def analysed(tmp_path: Path) -> Path:
    """A copy of the two-condition table, analysed with its (valid) answers; returns the table."""
    table = tmp_path / "study.csv"
    shutil.copy(TABLE, table)
    result = invoke("analyze", str(table), "--questionnaires", str(ANSWERS), "--bootstrap", "50")
    assert result.exit_code == 0, result.output
    return table


def _bad_answers(tmp_path: Path, kind: str) -> Path:
    answers = pd.read_csv(ANSWERS)
    if kind == "repeated":  # the three blocks' answers without the block column: each pair thrice
        answers = answers.drop(columns="block")
    else:  # a misspelt subscale beside the six real ones
        answers["tlx_mentl"] = answers["tlx_mental"]
    path = tmp_path / f"{kind}.csv"
    answers.to_csv(path, index=False)
    return path


@pytest.mark.parametrize(("kind", "expected"), [
    ("repeated", "repeated.csv: rows 2 and 3 are both participant 1's response for condition disambiguation, "
                 "with different answers (conflicting responses); keep one row per participant and "
                 "condition, or add a block column"),
    ("misspelt", "misspelt.csv: unknown NASA-TLX column 'tlx_mentl' (did you mean 'tlx_mental'?); "
                 "rename it or remove it"),
])
def test_bad_answers_are_one_error_line_and_the_analysis_is_kept(analysed: Path, tmp_path: Path, kind: str,
                                                                 expected: str) -> None:
    folder = tmp_path / "study-analysis"
    before = files_of(folder)
    result = invoke("analyze", str(analysed), "--questionnaires", str(_bad_answers(tmp_path, kind)),
                    "--bootstrap", "50")
    assert result.exit_code == 1
    assert one_error_line(result.output).startswith(f"Error: {tmp_path / expected}")
    assert files_of(folder) == before
