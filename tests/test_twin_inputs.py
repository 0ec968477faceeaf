"""What `nudge habits` and `nudge fit-people` make of the files a researcher gives them: a log whose
participant column is blank in places (refused, naming the row) or everywhere (the file's name),
an edited habits table's impossible values (one `Error:` line each), and a people, habits or
calibration source given where another is wanted (a message naming the command that reads it).
Each test was seen failing on the code before its fix."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line, write_csv_rows

from nudgecli.report.habit_logs import read_log_cells

PILOTS = Path(__file__).resolve().parents[1] / "experiments" / "pilots"


def pilot_rows(trials: int = 2) -> list[dict[str, str]]:
    """pilot-1.csv's rows of its first ``trials`` trials (a small log, read fast)."""
    with (PILOTS / "pilot-1.csv").open(newline="") as file:
        return [row for row in csv.DictReader(file) if int(row["trial"]) < trials]



# --- a log's participant column ------------------------------------------------------------------


def test_a_blank_participant_cell_among_named_ones_is_refused(tmp_path: Path) -> None:
    # before: the trial's rows became a second participant '' (fit-people wrote two people)
    rows = [{**row, "participant": "" if row["trial"] == "1" else row["participant"]} for row in pilot_rows()]
    first_blank = next(i for i, row in enumerate(rows) if row["trial"] == "1") + 2
    log = write_csv_rows(tmp_path / "blank.csv", rows)
    result = nudge("fit-people", log, "--out", tmp_path / "people.csv")
    assert result.exit_code == 1, result.output
    assert one_error_line(result.output) == (
        f"Error: {log}, row {first_blank}: participant is blank, where other rows name one ('pilot-1'); give "
        "every row its participant, or leave the column out for a log of one person (named after the file)")
    assert not (tmp_path / "people.csv").exists()


def test_an_all_blank_participant_column_is_the_files_name(tmp_path: Path) -> None:
    # before: participant '' (the docstring promises the file's name, as without the column)
    log = write_csv_rows(tmp_path / "anna.csv", [{**row, "participant": " "} for row in pilot_rows()])
    assert set(read_log_cells(log)["participant"]) == {"anna"}


# --- an edited habits table's impossible values --------------------------------------------------

HABITS_TABLE = """scope,participant,habit,n,median,q25,q75,people_min,people_max
pooled,,hold_on_per_stop,73,0.2,0.1,0.3,0.2,0.2
participant,pilot-2,hold_on_per_stop,73,0.2,0.1,0.3,,
participant,pilot-2,reaction_stop_to_switch,49,1.4,1.1,1.7,,
participant,pilot-2,deadband_share_soft_blows,2698,0.161601,,,,
"""


def edited_table(tmp_path: Path, habit: str, column: str, value: str) -> Path:
    """:data:`HABITS_TABLE` with ``column`` of pilot-2's ``habit`` row set to ``value``."""
    header, *rows = [line.split(",") for line in HABITS_TABLE.splitlines()]
    for row in rows:
        if row[0] == "participant" and row[2] == habit:
            row[header.index(column)] = value
    path = tmp_path / "habits.csv"
    path.write_text("\n".join(",".join(row) for row in [header, *rows]) + "\n")
    return path


def test_the_unedited_habits_table_is_fitted(tmp_path: Path) -> None:
    result = nudge("fit-people", edited_table(tmp_path, "", "n", ""), "--out", tmp_path / "people.csv")
    assert result.exit_code == 0, result.output
    with (tmp_path / "people.csv").open(newline="") as file:
        person = next(csv.DictReader(file))
    assert (person["hold_on_s"], person["deadband_share"]) == ("0.2", "0.161601")


@pytest.mark.parametrize(("habit", "column", "value", "problem"), [
    # before: a share of 7.3 (a percent) or inf was silently left to the population's draw
    ("deadband_share_soft_blows", "median", "7.3",
     "the median 7.3 is above 1, and a share is 0-1 (a percent? 7.3 / 100 is 0.073); "
     "give the share as a fraction"),
    ("deadband_share_soft_blows", "median", "inf", "the median inf is infinite; give the measured share"),
    ("hold_on_per_stop", "median", "inf", "the median inf is infinite; give the measured seconds"),
    # before: quartiles the wrong way round silently fell back to the population's spread
    ("reaction_stop_to_switch", "q25", "1.9", "q25 1.9 is above q75 1.7; give the lower quartile in q25 and "
     "the upper in q75"),
    ("reaction_stop_to_switch", "q75", "-inf", "the q75 -inf is infinite; give the measured seconds"),
    # before: n of -3, nan or 2.5 was accepted
    *[("hold_on_per_stop", "n", n, f"n {n!r} is not a number of events; give the whole number (0 or more) "
       "`nudge habits --by participant --format csv` writes") for n in ("-3", "nan", "2.5")],
])
def test_an_impossible_habits_table_value_is_one_error_line(
        tmp_path: Path, habit: str, column: str, value: str, problem: str) -> None:
    table = edited_table(tmp_path, habit, column, value)
    result = nudge("fit-people", table, "--out", tmp_path / "people.csv")
    assert result.exit_code == 1, result.output
    assert one_error_line(result.output) == f"Error: {table}: participant 'pilot-2': {habit}: {problem}"
    assert not (tmp_path / "people.csv").exists()


# --- a source given where another is wanted ------------------------------------------------------


@pytest.mark.parametrize("kind", ["log", "habits table"])
def test_a_log_or_habits_table_given_as_people_names_fit_people(tmp_path: Path, kind: str) -> None:
    # before: "column 't' (or 'scope') is not a people file's", and the columns a people file has
    source = write_csv_rows(tmp_path / "pilot.csv", pilot_rows()) if kind == "log" else \
        edited_table(tmp_path, "", "n", "")
    first = "t, trial, label, x, y, theta, ..." if kind == "log" else \
        "scope, participant, habit, n, median, q25, ..."
    result = nudge("simulate", "smoke", "--participants", "1", "--people", source, "--out", tmp_path / "run")
    assert result.exit_code == 1, result.output
    assert one_error_line(result.output) == (
        f"Error: {source}: not a people file (its columns are {first}; a people file has person, source, "
        "participant, the parameters and from_population); if it is a real log or a habits table, make a "
        f"people file of its participants with `nudge fit-people {source} --out people.csv`, then give "
        "--people people.csv")
    assert not (tmp_path / "run").exists()


def test_a_calibration_session_given_to_fit_people_is_named(tmp_path: Path) -> None:
    # before: "not a run folder (no manifest.json, steps/ or trials/) ... or a CSV log"
    session = tmp_path / "andrew"
    (session / "p_phm_given_phi").mkdir(parents=True)
    result = nudge("fit-people", session, "--out", tmp_path / "people.csv")
    assert result.exit_code == 1, result.output
    assert one_error_line(result.output) == (
        f"Error: {session}: a calibration session (prompted blows: a person's physiology, not the habits of "
        "operating the robot); operating habits are measured on a run folder or a real log (CSV); a "
        "simulation takes a p(phi_m | phi_i) session's physiology as population.physiology_logs (`nudge "
        f"simulate paper --set \"population.physiology_logs=['{session}']\"`), and `nudge fit {session}` "
        "fits its interface model")


def test_a_batch_folder_given_to_fit_people_is_named(tmp_path: Path) -> None:
    # before: "not a run folder"; a batch's tasks/ hold per-trial metrics, no step logs to measure
    batch = tmp_path / "batch"
    (batch / "tasks").mkdir(parents=True)
    (batch / "batch.json").write_text("{}")
    (batch / "experiment.toml").write_text("")
    result = nudge("fit-people", batch, "--out", tmp_path / "people.csv")
    assert result.exit_code == 1, result.output
    assert one_error_line(result.output) == (
        f"Error: {batch}: a batch folder (nudge replicate, power or sweep), whose tasks/ keep each study's "
        "per-trial metrics and no step logs; operating habits are measured on a run folder or a real log "
        f"(CSV): simulate one study of its experiment (`nudge simulate {batch / 'experiment.toml'} --out "
        "RUN`) and give RUN")
