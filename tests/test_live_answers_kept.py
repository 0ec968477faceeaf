"""A participant's work in a live study is never lost or silently replaced: a finished calibration
part 1 survives a crash in part 2, answers written before a crash count as answered on resume, and a
recorded answer is never replaced by another."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pandas as pd
import pytest
from live_helpers import ANSWERS, DEFAULT_TABLES, TWO_TRIALS, play_session

from nudgecli.errors import DataError, RunFolderError
from nudgecli.live import records
from nudgecli.live.app import build_session
from nudgecli.live.questionnaire import merged_answers


def _calibrate_until(session, phase: str) -> None:
    """Tick the session's calibration on its clock, answering each prompt with key 1, until ``phase``."""
    session.handle({"type": "start"}, 0.0)
    now = 0.0
    while session.phase != phase:
        now += session.settings.dt
        if session.phase == "mapping" and session.mapping_recorder.prompt is not None:
            for down in (True, False):
                session.handle({"type": "key", "key": "1", "down": down}, now)
        session.tick(now)


def test_a_finished_calibration_part_1_is_kept_and_a_resume_starts_at_part_2(tmp_path):
    out = tmp_path / "live"
    session = build_session("paper", "P01", out, overrides=TWO_TRIALS)
    _calibrate_until(session, "distortion")  # part 1 done; then a crash (the session is dropped)
    prompts = session.folder.calibration_dir(1) / "mapping_prompts.csv"
    written = prompts.read_bytes()
    entry = json.loads((out / "manifest.json").read_text())["live"]["1"]
    assert set(entry["calibration_files"]) == {"mapping_prompts.csv", "mapping_responses.csv"}
    assert entry["calibrated"] is False

    resumed = build_session("paper", "P01", out, resume=True, overrides=TWO_TRIALS)
    _calibrate_until(resumed, "ready")  # part 2 only, then the practice
    assert prompts.read_bytes() == written  # part 1 as the participant gave it
    entry = json.loads((out / "manifest.json").read_text())["live"]["1"]
    assert entry["calibrated"] is True and "distortion_stream.csv" in entry["calibration_files"]
    assert resumed.mapping is not None


def test_a_changed_calibration_log_is_refused_on_resume(tmp_path):
    out = tmp_path / "live"
    session = build_session("paper", "P01", out, overrides=TWO_TRIALS)
    _calibrate_until(session, "distortion")
    session.folder.release()
    prompts = session.folder.calibration_dir(1) / "mapping_prompts.csv"
    prompts.write_text(prompts.read_text() + "\n")
    with pytest.raises(RunFolderError, match=r"mapping_prompts\.csv: changed since it was written"):
        build_session("paper", "P01", out, resume=True, overrides=TWO_TRIALS)


def test_answers_written_before_a_crash_count_as_answered_on_resume(tmp_path, monkeypatch):
    out, overrides = tmp_path / "live", TWO_TRIALS + DEFAULT_TABLES
    session = build_session("paper", "P01", out, overrides=overrides)
    play_session(session, lambda s: s.phase == "questionnaire")

    def crash_after_the_csv(self, participant: int) -> None:  # killed before the manifest's update
        raise KeyboardInterrupt

    monkeypatch.setattr(records.LiveFolder, "save", crash_after_the_csv)
    with pytest.raises(KeyboardInterrupt):
        session.handle({"type": "questionnaire", "answers": {**ANSWERS, "tlx_mental": 90}}, 0.0)
    monkeypatch.undo()

    resumed = build_session("paper", "P01", out, resume=True, overrides=overrides)
    resumed.handle({"type": "start"}, 0.0)
    assert resumed.phase == "ready" and resumed.entry["questionnaire_blocks"] == [0]
    recorded = json.loads((out / "manifest.json").read_text())["live"]["1"]["questionnaire_blocks"]
    assert recorded == [0]
    assert pd.read_csv(out / "questionnaires.csv")["tlx_mental"].tolist() == [90.0]


def test_a_recorded_answer_is_never_replaced_by_another(tmp_path):
    path = tmp_path / "questionnaires.csv"
    row = {"participant": 1, "condition": "control", "block": 0, **ANSWERS}
    path.write_text(merged_answers(None, [row], path).to_csv(index=False))
    old = pd.read_csv(path, dtype={"participant": str, "block": str})
    assert len(merged_answers(old, [row], path)) == 1  # the same answers again: one row
    with pytest.raises(DataError, match=r"row 2 already holds participant 1's answers to block 0, with "
                                        r"tlx_mental 35(\.0)? where the new answers give 10"):
        merged_answers(old, [{**row, "tlx_mental": 10}], path)


def test_answers_that_no_file_takes_are_given_as_a_csv_line(tmp_path, monkeypatch):
    out, overrides = tmp_path / "live", TWO_TRIALS + DEFAULT_TABLES
    session = build_session("paper", "P01", out, overrides=overrides)
    play_session(session, lambda s: s.phase == "questionnaire")

    def refuse(path: Path, text: str) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(records, "write_text_atomic", refuse)
    with pytest.raises(Exception, match=r"create .*questionnaires\.csv by hand with these two lines, "
                                        r"the header participant,condition,block,.*,likert_q10 and then "
                                        r"the answers "
                                        r"1,control,0,35\.0,10\.0,40\.0,20\.0,45\.0,30\.0,6,5,4,3$"):
        session.handle({"type": "questionnaire", "answers": ANSWERS}, 0.0)
    assert not os.path.exists(out / "questionnaires.csv")
