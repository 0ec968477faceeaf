"""Each reader of a researcher's file that is not UTF-8 (a spreadsheet's latin-1 "CSV", an é in a
label) says where the first such byte is and to save the file as UTF-8: the one wording of
:func:`nudgecli.csv_text.not_utf8_message`, not the decoder's position within a block."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

from nudgecli.errors import DataError
from nudgecli.report.questionnaires import read_questionnaires
from nudgecli.sim.calibration_readers import read_mapping_session
from nudgecli.sim.people_file import read_people


def latin1(path: Path, lines: list[str]) -> Path:
    """``lines`` written to ``path`` in latin-1 (as a European spreadsheet saves "CSV")."""
    path.write_bytes(("\n".join(lines) + "\n").encode("latin-1"))
    return path


def expect_utf8_advice(read: Callable[[], object], path: Path, line: int) -> None:
    """``read()`` refuses with the shared not-UTF-8 line, naming ``path`` and the é's line."""
    with pytest.raises(DataError) as caught:
        read()
    message = str(caught.value)
    assert message.startswith(f"{path}: not UTF-8 text (byte 0xe9 on line {line};"), message
    assert message.endswith("save it as UTF-8 (a spreadsheet's \"CSV UTF-8\", an editor's encoding UTF-8)")
    assert "\n" not in message and "codec" not in message


def test_a_questionnaire_file_not_utf8(tmp_path: Path) -> None:
    path = latin1(tmp_path / "q.csv", ["participant,condition,tlx_mental", "1,control,50",
                                       "2,assisté,40"])
    expect_utf8_advice(lambda: read_questionnaires(path), path, 3)


def test_a_calibration_log_not_utf8(tmp_path: Path) -> None:
    prompts = latin1(tmp_path / "mapping_prompts.csv", ["t,command", "0.5,Soft Puff", "2.0,Hard Sip é"])
    (tmp_path / "mapping_responses.csv").write_text("t,key\n1.0,a\n")
    expect_utf8_advice(lambda: read_mapping_session(tmp_path), prompts, 3)


def test_a_people_file_not_utf8(tmp_path: Path) -> None:
    path = latin1(tmp_path / "people.csv", ["person,source,participant,planning_s", "0,log.csv,Zoé,2.5"])
    expect_utf8_advice(lambda: read_people(path), path, 2)
    result = nudge("simulate", "smoke", "--participants", "1", "--people", path, "--out", tmp_path / "run")
    assert result.exit_code == 1 and not (tmp_path / "run").exists()
    assert "save it as UTF-8" in one_error_line(result.stderr)
