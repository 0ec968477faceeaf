"""A people file (``--people``) given as a researcher may have it: a value out of range names the
range ``[population]`` checks, a folder is said to be one (with the file to give instead), a
spreadsheet's semicolons and decimal commas are read or named as such, and a file with more people
than the study simulates names those left out; so do more ``population.physiology_logs`` than
participants, and a value there that is not a list of folders says what the list takes."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import nudge, stderr_error_line

from nudgecli.errors import DataError
from nudgecli.sim.people_file import read_people

HEADER = "person,source,participant,deadband_share,offset_ramp_samples,from_population\n"


@pytest.mark.parametrize(("row", "words"), [
    ("0,x,A,0.99,1,\n", ["deadband_share: 0.99 is out of its valid range", "0.0 <= deadband_share <= 0.9"]),
    ("0,x,A,0.1,21,\n", ["offset_ramp_samples: 21", "whole number of samples",
                         "0 <= offset_ramp_samples <= 20"]),
])
def test_a_value_out_of_range_names_the_range_population_accepts(tmp_path: Path, row: str,
                                                                 words: list[str]) -> None:
    path = tmp_path / "people.csv"
    path.write_text(HEADER + row)
    with pytest.raises(DataError) as caught:
        read_people(path)
    for word in words:
        assert word in str(caught.value), caught.value


def test_a_folder_given_as_the_people_file_is_named_a_folder_with_the_file_to_give(tmp_path: Path) -> None:
    run = tmp_path / "run"
    run.mkdir()
    (run / "manifest.json").write_text("{}")
    result = nudge("simulate", "smoke", "--people", run, "--out", tmp_path / "out")
    line = stderr_error_line(result)
    assert f"{run}: a run folder, not a people file" in line, line
    assert f"`nudge fit-people {run} --out people.csv`" in line, line  # a command that works as written
    assert not (tmp_path / "out").exists()
    (run / "people").mkdir()
    (run / "people" / "pilots.csv").write_text(HEADER + "0,x,A,0.1,1,\n")
    with pytest.raises(DataError, match=r"give the people file it keeps: --people \S+pilots\.csv$"):
        read_people(run)
    with pytest.raises(DataError, match="a folder, not a people file; give a people file's path"):
        read_people(run / "people")


def test_a_spreadsheets_semicolons_are_read_and_its_decimal_commas_named(tmp_path: Path) -> None:
    commas = tmp_path / "people.csv"
    commas.write_text(HEADER + '0,x,A,0.1,1,\n1,x,B,,2,"deadband_share"\n')
    semicolons = tmp_path / "semicolons.csv"
    semicolons.write_text(HEADER.replace(",", ";") + '0;x;A;0.1;1;\n1;x;B;;2;"deadband_share"\n')
    assert read_people(semicolons).twins == read_people(commas).twins
    semicolons.write_text(HEADER.replace(",", ";") + "0;x;A;0,1;1;\n")
    with pytest.raises(DataError) as caught:
        read_people(semicolons)
    assert str(caught.value) == (f"{semicolons}: person 0 (participant 'A'): deadband_share: '0,1' is not a "
                                 "number (a decimal comma? write 0.1)")


@pytest.mark.parametrize("given", ["string", "file", "missing"])
def test_physiology_logs_say_they_take_a_list_of_folders(tmp_path: Path, given: str) -> None:
    log = tmp_path / "p_phm_given_phi.csv"
    log.write_text("t,label\n")
    value = {"string": f'"{log}"', "file": f'["{log}"]', "missing": f'["{tmp_path / "nope"}"]'}[given]
    result = nudge("simulate", "smoke", "--set", f"population.physiology_logs={value}",
                   "--out", tmp_path / "out")
    line = stderr_error_line(result)
    assert "folders of calibration logs" in line, line
    assert {"string": "should be a list of folders", "file": "a file, not a folder",
            "missing": "which does not exist"}[given] in line, line
    assert "e.g. [0.5, 1.0]" not in line and not (tmp_path / "out").exists()


def _three_people(tmp_path: Path) -> Path:
    path = tmp_path / "people.csv"
    path.write_text(HEADER + "0,x,A,0.1,1,\n1,x,B,0.1,1,\n2,x,C,0.2,0,\n")
    return path


def test_people_no_participant_takes_are_named_in_a_note(tmp_path: Path) -> None:
    people = _three_people(tmp_path)
    result = nudge("simulate", "smoke", "--people", people, "--out", tmp_path / "run")  # 2 participants
    assert result.exit_code == 0, result.output
    note = ("Note: people.csv has 3 people; the study simulates 2, so person 2 (C) is left out; "
            "--participants 3 simulates all")
    assert note in result.stderr.splitlines(), result.stderr
    again = nudge("simulate", "smoke", "--people", people, "--out", tmp_path / "run")
    assert "already holds a run" in stderr_error_line(again)  # a refusal stays one line
    power = nudge("power", "smoke", "--participants", "2", "-R", "1", "--people", people,
                  "--out", tmp_path / "power")
    assert power.exit_code == 0, power.output
    assert ("Note: people.csv has 3 people; the largest study simulates 2, so person 2 (C) is left out; a "
            "count of 3 in --participants simulates all") in power.stderr.splitlines(), power.stderr


def test_the_api_tells_the_note_to_log_and_all_people_taken_need_none(tmp_path: Path) -> None:
    import nudgecli

    people, lines = _three_people(tmp_path), []
    nudgecli.simulate("smoke", participants=1, people=people, out=tmp_path / "one", log=lines.append)
    assert lines == ["Note: people.csv has 3 people; the study simulates 1, so person 1 (B), person 2 (C) "
                     "are left out; --participants 3 simulates all"]
    lines.clear()
    nudgecli.simulate("smoke", participants=3, people=people, out=tmp_path / "all", log=lines.append)
    assert lines == []


def test_physiology_logs_no_participant_takes_are_named_in_a_note() -> None:
    from nudgecli.config import load_experiment
    from nudgecli.sim.study import left_out_notes

    config = load_experiment("smoke", ("population.physiology_logs=['a', 'b', 'c']",))
    assert left_out_notes(config, 2) == (
        "population.physiology_logs lists 3 folders; the study simulates 2, so physiology_logs[2] (c) is "
        "left out; --participants 3 simulates all",)
    assert left_out_notes(config, 3) == ()
