"""Questionnaires taken on trust no more, through the command line: a response given twice, or a
misspelt NASA-TLX column, is refused with one ``Error:`` line and the analysis already there is
left as it was; ``plot`` draws only the questionnaire scores its analysis wrote (``stats.json``
records their SHA-256), and refuses scores that are stale, edited or gone.

Each test was seen failing with its fix removed."""

from __future__ import annotations

import hashlib
import json
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
    result = invoke("analyze", str(table), "--questionnaires", str(ANSWERS), "--bootstrap", "100")
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
                    "--bootstrap", "100")
    assert result.exit_code == 1
    assert one_error_line(result.output).startswith(f"Error: {tmp_path / expected}")
    assert files_of(folder) == before


# --- plot draws the scores of the analysis it plots, or refuses ---------------------------------------

def _plot(folder: Path) -> Result:
    return invoke("plot", str(folder), "--formats", "png")


def test_plot_draws_the_scores_the_analysis_wrote(analysed: Path, tmp_path: Path) -> None:
    folder = tmp_path / "study-analysis"
    stats = json.loads((folder / "stats.json").read_text(encoding="utf-8"))
    written = (folder / "questionnaire_scores.csv").read_bytes()
    # the record is the SHA-256 of the file's bytes, and its rows
    expected = {"algorithm": "sha256", "rows": len(pd.read_csv(ANSWERS)),
                "digest": hashlib.sha256(written).hexdigest()}
    assert stats["questionnaire_scores_checksum"] == expected
    result = _plot(folder)
    assert result.exit_code == 0, result.output
    assert (folder / "figures" / "questionnaires.png").is_file()


def test_an_analysis_without_questionnaires_records_no_scores(tmp_path: Path) -> None:
    table = tmp_path / "study.csv"
    shutil.copy(TABLE, table)
    assert invoke("analyze", str(table), "--bootstrap", "100").exit_code == 0
    stats = json.loads((tmp_path / "study-analysis" / "stats.json").read_text(encoding="utf-8"))
    assert "questionnaire_scores_checksum" not in stats


def _edit_a_score(folder: Path) -> None:
    scores = (folder / "questionnaire_scores.csv").read_text(encoding="utf-8").splitlines()
    cells = scores[1].split(",")
    cells[scores[0].split(",").index("tlx_raw")] = "99"  # a hand edit of one response's raw TLX
    edited = "\n".join([scores[0], ",".join(cells), *scores[2:]]) + "\n"
    (folder / "questionnaire_scores.csv").write_text(edited, encoding="utf-8")


@pytest.mark.parametrize(("damage", "expected"), [
    ("stale", "study-analysis/questionnaire_scores.csv is not from the analysis in "),
    ("edited", "study-analysis/questionnaire_scores.csv does not match "),
    ("deleted", "study-analysis/stats.json records questionnaire scores, but "),
])
def test_plot_refuses_scores_the_analysis_did_not_write(analysed: Path, tmp_path: Path, damage: str,
                                                        expected: str) -> None:
    folder = tmp_path / "study-analysis"
    assert _plot(folder).exit_code == 0  # the figures drawn from the analysis with questionnaires
    if damage == "stale":  # analysed again without them (which removes the old scores), then the old
        old_scores = (folder / "questionnaire_scores.csv").read_bytes()  # scores copied back by hand
        assert invoke("analyze", str(analysed), "--bootstrap", "100").exit_code == 0
        assert not (folder / "questionnaire_scores.csv").exists()
        (folder / "questionnaire_scores.csv").write_bytes(old_scores)
    elif damage == "edited":
        _edit_a_score(folder)
    else:
        (folder / "questionnaire_scores.csv").unlink()
    before = files_of(folder)
    result = _plot(folder)
    assert result.exit_code == 1
    line = one_error_line(result.output)
    assert line.startswith(f"Error: {tmp_path / expected}")
    assert "nudge analyze" in line and "--questionnaires" in line  # the fix
    assert files_of(folder) == before  # the figures drawn before are left as they were


@pytest.mark.parametrize("given", ["table", "folder"])
def test_plot_with_a_plan_refuses_an_analysis_with_questionnaires(analysed: Path, tmp_path: Path,
                                                                  given: str) -> None:
    # --plan analyses again without the answers (their file is not recorded): the folder would hold
    # one analysis's metrics beside another's scores; it is refused and left as it was
    folder = tmp_path / "study-analysis"
    before = files_of(folder)
    source = analysed if given == "table" else folder
    result = invoke("plot", str(source), "--plan", "study-code")
    assert result.exit_code == 1
    line = one_error_line(result.output)
    assert f"{folder} holds questionnaire scores (questionnaire_scores.csv)" in line
    assert f"`nudge analyze {analysed} --plan study-code --questionnaires ANSWERS.csv`" in line
    assert files_of(folder) == before
    # analysed again with the plan and the answers, it plots
    result = invoke("analyze", str(analysed), "--plan", "study-code", "--questionnaires", str(ANSWERS),
                    "--bootstrap", "100")
    assert result.exit_code == 0, result.output
    assert invoke("plot", str(folder)).exit_code == 0
