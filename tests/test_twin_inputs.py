"""What `nudge habits` and `nudge fit-people` make of the files a researcher gives them: a log whose
participant column is blank in places (refused, naming the row) or everywhere (the file's name),
an edited habits table's impossible values (one `Error:` line each), and a people, habits or
calibration source given where another is wanted (a message naming the command that reads it).
Each test was seen failing on the code before its fix."""

from __future__ import annotations

import csv
from pathlib import Path

from cli_helpers import nudge, one_error_line

from nudgecli.report.habit_logs import read_log_cells

PILOTS = Path(__file__).resolve().parents[1] / "experiments" / "pilots"


def pilot_rows(trials: int = 2) -> list[dict[str, str]]:
    """pilot-1.csv's rows of its first ``trials`` trials (a small log, read fast)."""
    with (PILOTS / "pilot-1.csv").open(newline="") as file:
        return [row for row in csv.DictReader(file) if int(row["trial"]) < trials]


def write_rows(path: Path, rows: list[dict[str, str]]) -> Path:
    with path.open("w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return path


# --- a log's participant column ------------------------------------------------------------------


def test_a_blank_participant_cell_among_named_ones_is_refused(tmp_path: Path) -> None:
    # before: the trial's rows became a second participant '' (fit-people wrote two people)
    rows = [{**row, "participant": "" if row["trial"] == "1" else row["participant"]} for row in pilot_rows()]
    first_blank = next(i for i, row in enumerate(rows) if row["trial"] == "1") + 2
    log = write_rows(tmp_path / "blank.csv", rows)
    result = nudge("fit-people", log, "--out", tmp_path / "people.csv")
    assert result.exit_code == 1, result.output
    assert one_error_line(result.output) == (
        f"Error: {log}, row {first_blank}: participant is blank, where other rows name one ('pilot-1'); give "
        "every row its participant, or leave the column out for a log of one person (named after the file)")
    assert not (tmp_path / "people.csv").exists()


def test_an_all_blank_participant_column_is_the_files_name(tmp_path: Path) -> None:
    # before: participant '' (the docstring promises the file's name, as without the column)
    log = write_rows(tmp_path / "anna.csv", [{**row, "participant": " "} for row in pilot_rows()])
    assert set(read_log_cells(log)["participant"]) == {"anna"}
