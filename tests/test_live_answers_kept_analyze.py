"""`nudge analyze --questionnaires` of a live folder: answers whose condition contradicts the run's
trials are refused, and a folder without answers yet is named as one."""

from __future__ import annotations

import pandas as pd
from click.testing import CliRunner
from live_helpers import played_folder

from nudgecli.cli import main


def test_an_answer_whose_condition_contradicts_the_run_is_refused(tmp_path):
    out = tmp_path / "run"
    played_folder(out, lambda s: False)
    path = out / "questionnaires.csv"
    answers = pd.read_csv(path)
    right, wrong = answers.at[0, "condition"], answers.at[1, "condition"]
    # the two blocks' conditions swapped: both conditions still answered, each counted wrongly
    answers.loc[[0, 1], "condition"] = [wrong, right]
    answers.to_csv(path, index=False)
    result = CliRunner().invoke(main, ["analyze", str(out), "--questionnaires", str(path)])
    assert result.exit_code != 0
    assert result.output.strip().splitlines()[-1] == (
        f"Error: {path}: row 2 gives participant 1's block 0 the condition {wrong}, but in {out} that "
        f"block's trials are of condition {right}; write {right} in the row's condition (or correct its "
        "participant or block)")


def test_a_live_folder_without_answers_yet_says_so(tmp_path):
    out = tmp_path / "run"
    played_folder(out, lambda s: s.phase == "questionnaire")
    path = out / "questionnaires.csv"
    result = CliRunner().invoke(main, ["analyze", str(out), "--questionnaires", str(path)])
    assert result.exit_code != 0
    assert "no questionnaire of the live study in" in result.output
    assert "has been answered yet" in result.output and "analyse without --questionnaires" in result.output
