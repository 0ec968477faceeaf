"""Every user file nudge reads as CSV outside the metrics tables (a calibration log, a real habit
log, a habits table for ``fit-people``) refuses a row with fewer or more fields than its header,
with one ``Error:`` line naming the file and the line, as the metrics tables do
(:mod:`nudgecli.csv_rows`). Each reader misread a cut-off last line without a word before: a
calibration prompt without its command was a clearing row, a log sample without its
``mode_switch`` was a sample without a switch, a habits row without ``q75`` had no upper quartile.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from cli_helpers import nudge, stderr_error_line

from nudgecli.errors import DataError
from nudgecli.sim.calibration_readers import read_sessions

SHARED_CALIBRATION = Path(__file__).resolve().parents[2] / "shared" / "data" / "calibration"
STUDY_HEADER = "rosbagTimestamp,header,seq,stamp,secs,nsecs,frame_id,command"


def study_mapping_session(folder: Path) -> Path:
    """A p(phi_i | a) session in the study's export format: two images, each shown, answered
    and cleared; returns its prompts file."""
    session = folder / "p_phi_given_a"
    session.mkdir(parents=True)
    prompts = [(1.0, '"""left"""'), (3.0, "''"), (4.0, '"""up"""'), (6.0, "''")]
    responses = [(2.0, '"""4"""'), (5.0, '"""3"""')]
    for name, rows in (("_action_prompt.csv", prompts), ("_user_response.csv", responses)):
        lines = [STUDY_HEADER] + [f"{t},,{i + 1},,{1000 + int(t)},0,'',{command}"
                                  for i, (t, command) in enumerate(rows)]
        (session / name).write_text("\n".join(lines) + "\n", encoding="utf-8")
    return session / "_action_prompt.csv"


def cut_last_line(path: Path, fields: int) -> None:
    """``path`` with its last line cut to its first ``fields`` fields (no line end: a cut copy)."""
    lines = path.read_text(encoding="utf-8").splitlines()
    path.write_text("\n".join([*lines[:-1], ",".join(lines[-1].split(",")[:fields])]), encoding="utf-8")


def test_a_calibration_prompt_cut_before_its_command_is_refused(tmp_path: Path) -> None:
    prompts = study_mapping_session(tmp_path)
    mapping, _ = read_sessions(tmp_path)
    assert mapping is not None and mapping.prompt_commands == ("left", "", "up", "")
    cut_last_line(prompts, 7)  # the clearing row lost its command: it read as '' all the same
    with pytest.raises(DataError, match=r"_action_prompt.csv: line 5 has 7 of 8 fields; the file looks "
                                        r"cut off: complete that line or remove it$"):
        read_sessions(tmp_path)


def test_nudge_fit_refuses_a_cut_log_in_one_line_and_keeps_the_profile(tmp_path: Path) -> None:
    prompts = study_mapping_session(tmp_path / "p1")
    profile = tmp_path / "p1.profile.json"
    assert nudge("fit", tmp_path / "p1", "--out", profile).exit_code == 0
    before = profile.read_bytes()
    cut_last_line(prompts, 5)
    line = stderr_error_line(nudge("fit", tmp_path / "p1", "--out", profile, "--force"))
    assert f"{prompts}: line 5 has 5 of 8 fields" in line
    assert profile.read_bytes() == before


@pytest.mark.skipif(not SHARED_CALIBRATION.is_dir(), reason="the pilot logs are not beside the repository")
def test_a_real_pilot_log_cut_off_is_refused(tmp_path: Path) -> None:
    folder = tmp_path / "andrewtest"
    shutil.copytree(SHARED_CALIBRATION / "andrewtest", folder)
    stream = folder / "p_phm_given_phi" / "_joy_sip_puff.csv"
    n_lines = len(stream.read_text(encoding="utf-8").splitlines())
    cut_last_line(stream, 8)  # the buttons, which nothing reads, lost: still a cut file
    with pytest.raises(DataError, match=f"_joy_sip_puff.csv: line {n_lines} has 8 of 9 fields"):
        read_sessions(folder)
    shutil.copy(SHARED_CALIBRATION / "andrewtest" / "p_phm_given_phi" / "_joy_sip_puff.csv", stream)
    read_sessions(folder)  # the whole log reads as before


LOG = ("t,trial,label,x,y,theta,mode_switch\n"
       "0.0,1,Zero Band,0,0,0,0\n0.5,1,Soft Puff,0,0,0,0\n0.8,1,Soft Puff,1,0,0,0\n"
       "1.2,1,Zero Band,1,0,0,y\n2.0,1,Soft Sip,1,0,0,0\n2.4,1,Zero Band,1,1,0,0\n")


def test_a_habit_log_cut_before_its_switch_is_refused(tmp_path: Path) -> None:
    log = tmp_path / "log.csv"
    log.write_text(LOG + "3.0,1,input stopped,1,1,0,0\n", encoding="utf-8")
    assert nudge("habits", log).exit_code == 0
    log.write_text(LOG + "3.0,1,Zero Band,1,1,0", encoding="utf-8")  # its switch (or not) lost
    line = stderr_error_line(nudge("habits", log))
    assert line == (f"Error: {log}: line 8 has 6 of 7 fields; the file looks cut off: complete that line "
                    "or remove it")


def test_a_habit_log_with_a_field_more_in_every_row_is_refused(tmp_path: Path) -> None:
    # a separator at the end of each row: pandas would read `t` from the trial column, and so on
    log = tmp_path / "log.csv"
    header, *rows = LOG.replace(",", ";").splitlines()
    log.write_text("\n".join([header, *(row + ";" for row in rows)]) + "\n", encoding="utf-8")
    line = stderr_error_line(nudge("habits", log))
    assert f"{log}: line 2 has 8 fields, the header 7 (and 5 more line(s) like it)" in line


HABITS_TABLE = ("scope,participant,habit,n,median,q25,q75\n"
                "participant,P1,first_command_latency,12,2.0,1.8,2.2\n"
                "participant,P1,soft_blow,12,0.8,0.6,1.0\n")


def test_a_habits_table_cut_before_its_upper_quartile_is_refused(tmp_path: Path) -> None:
    table = tmp_path / "habits.csv"
    table.write_text(HABITS_TABLE + "participant,P1,planning,12,2.0,1.8", encoding="utf-8")
    line = stderr_error_line(nudge("fit-people", table, "--out", tmp_path / "people.csv"))
    assert line == (f"Error: {table}: line 4 has 6 of 7 fields; the file looks cut off: complete that "
                    "line or remove it")
    assert not (tmp_path / "people.csv").exists()
    tabs = HABITS_TABLE.replace(",", "\t")  # the fields counted by the delimiter pandas sniffed
    table.write_text(tabs + "participant\tP1\tplanning\t12\t2.0\t1.8", encoding="utf-8")
    assert "line 4 has 6 of 7 fields" in stderr_error_line(nudge("fit-people", table, "--out",
                                                                 tmp_path / "people.csv"))
    table.write_text(tabs, encoding="utf-8")
    assert nudge("fit-people", table, "--out", tmp_path / "people.csv").exit_code == 0


def test_a_log_pandas_cannot_parse_is_named_in_one_line(tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    # pandas' tokenizer messages end in a line break, which made the refusal two lines
    import pandas as pd

    from nudgecli.report import habit_logs

    log = tmp_path / "log.csv"
    log.write_text("t,x\n0,1\n")

    def unparsable(*args: object, **kwargs: object) -> None:
        raise pd.errors.ParserError("Error tokenizing data. C error: Expected 2 fields in line 3, saw 3\n")

    monkeypatch.setattr(habit_logs.pd, "read_csv", unparsable)
    with pytest.raises(DataError) as refused:
        habit_logs._read_log_frame(log)
    assert str(refused.value) == (f"{log}: not a readable CSV log (Error tokenizing data. C error: "
                                  "Expected 2 fields in line 3, saw 3)")
