"""A run's and a live study's calibration logs are checked by one rule
(:func:`nudgecli.run_folder_calibration.changed_logs`), with each check's own message, and
``read_sessions`` checks a run's logs once for both sessions (one manifest read)."""

from __future__ import annotations

from pathlib import Path

import pytest

import nudgecli.sim.calibration_readers as calibration_readers
from nudgecli.errors import RunFolderError
from nudgecli.live.calibration import CALIBRATION_FILES, check_calibration_files
from nudgecli.run_folder_calibration import LIVE_CALIBRATION_FILES, changed_logs, log_digests

LOGS = Path("calibration") / "participant-0000"
ALL_LOGS = {"mapping_prompts.csv", "mapping_responses.csv", "distortion_prompts.csv", "distortion_stream.csv"}


def _recorded(folder: Path) -> dict[str, str]:
    """Two logs written into ``folder``, and their record (name -> SHA-256)."""
    folder.mkdir(parents=True, exist_ok=True)
    for name in ("mapping_prompts.csv", "mapping_responses.csv"):
        (folder / name).write_text("t,command\n0.0,up\n", encoding="utf-8")
    return log_digests(sorted(folder.iterdir()))


def test_changed_logs_names_each_missing_or_changed_log_in_the_record_s_order(tmp_path: Path) -> None:
    recorded = _recorded(tmp_path)
    assert changed_logs(tmp_path, recorded) == []
    (tmp_path / "mapping_prompts.csv").unlink()
    (tmp_path / "mapping_responses.csv").write_text("edited\n", encoding="utf-8")
    missing, changed = ("mapping_prompts.csv", True), ("mapping_responses.csv", False)
    assert changed_logs(tmp_path, recorded) == [missing, changed]


def test_a_live_study_s_record_is_read_under_the_one_key() -> None:
    assert CALIBRATION_FILES is LIVE_CALIBRATION_FILES


@pytest.mark.parametrize(("damage", "words"), [
    ("unlink", "mapping_prompts.csv: is missing, but the manifest records it as participant P7's "
               "calibration"),
    ("edit", "mapping_prompts.csv: changed since it was written (its SHA-256 differs from the one in the "
             "manifest), but the manifest records it as participant P7's calibration"),
])
def test_a_live_resume_refuses_a_log_missing_or_changed_as_before(tmp_path: Path, damage: str,
                                                                    words: str) -> None:
    entry = {CALIBRATION_FILES: _recorded(tmp_path), "participant_id": "P7"}
    check_calibration_files(tmp_path, 7, entry)  # as recorded: nothing to say
    log = tmp_path / "mapping_prompts.csv"
    log.unlink() if damage == "unlink" else log.write_text("edited\n", encoding="utf-8")
    with pytest.raises(RunFolderError) as refused:
        check_calibration_files(tmp_path, 7, entry)
    assert str(refused.value) == f"{tmp_path}/{words}; restore it from a backup (a person's calibration " \
                                 "cannot be recorded again as it was)"


def test_read_sessions_checks_a_run_s_logs_once_for_both_sessions(analysed_smoke_run: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    checked: list[set[str]] = []
    check = calibration_readers.check_calibration_logs

    def counted(folder: str | Path, names: tuple[str, ...] | None = None) -> None:
        checked.append(set(names or ()))
        check(folder, names)

    monkeypatch.setattr(calibration_readers, "check_calibration_logs", counted)
    mapping, distortion = calibration_readers.read_sessions(analysed_smoke_run / LOGS)
    assert mapping is not None and distortion is not None
    assert checked == [ALL_LOGS]  # was: two checks, each parsing the manifest
    calibration_readers.read_distortion_session(analysed_smoke_run / LOGS)  # alone: checks its own
    assert checked[1:] == [{"distortion_prompts.csv", "distortion_stream.csv"}]
