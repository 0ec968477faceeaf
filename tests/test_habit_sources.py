"""Where `nudge habits` and `fit-people` read their sources from: a real log's layouts checked against
its poses (a trial runs on the layout whose path its poses follow), a run folder read through its
manifest, a run at another rate measured in HABITS.md's 10 Hz cells, and one format for the shares
of a `--compare` reference. Each test was seen failing on the code before its fix."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_helpers import one_error_line, write_csv_rows
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.report.habit_cells import habit_rate_cells, run_folder_cells
from nudgecli.report.habits import HABITS, habits_of

PILOT = Path(__file__).resolve().parents[1] / "experiments" / "pilots" / "pilot-1.csv"


def invoke(*args: str):
    return CliRunner().invoke(main, [*args])


def pilot_rows() -> list[dict[str, str]]:
    with PILOT.open(newline="") as file:
        return list(csv.DictReader(file))



# --- a real log's layouts ------------------------------------------------------------------------


def test_a_log_whose_trials_start_elsewhere_than_their_layout_is_refused(tmp_path: Path) -> None:
    # before: every trial labelled layout 0 was measured with layout 0's waypoints (its stop -> switch
    # row 39 0.70 where the log's own layouts give 50 0.80), no error
    rows = [{**row, "layout": "0"} for row in pilot_rows()]
    log = write_csv_rows(tmp_path / "l0.csv", rows)
    for command in (["habits", str(log)], ["fit-people", str(log), "--out", str(tmp_path / "p.csv")]):
        result = invoke(*command)
        assert result.exit_code == 1, result.output
        line = one_error_line(result.output)
        assert line == (f"Error: {log}, row 2, column layout: trial '0' of participant 'pilot-1' starts at "
                        "(7.5, 15.0), but layout 0 starts at (22.5, 5); give each row the CIAA task's trial "
                        "index of the layout its trial ran on, or leave the layout column out"), line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["l0.csv"]


def test_a_log_row_off_its_layouts_path_is_refused(tmp_path: Path) -> None:
    rows = pilot_rows()
    assert (rows[3]["x"], rows[3]["y"], rows[3]["layout"]) == ("7.5", "15.0", "34")
    rows[3]["x"] = "7.65"  # 0.15 units off the first leg (x = 7.5), past the world's 0.1 snap
    line = one_error_line(invoke("habits", str(write_csv_rows(tmp_path / "off.csv", rows))).output)
    assert line.startswith(f"Error: {tmp_path / 'off.csv'}, row 5, column layout: (7.65, 15.0) of trial '0' "
                           "of participant 'pilot-1' is not on layout 34's path ((7.5, 15), (7.5, 10), "
                           "(15, 10), (15, 5), (22.5, 5); within 0.1 units on each axis)"), line


@pytest.mark.parametrize("shift", [0.0, 0.039, 0.0999])
def test_a_log_on_its_layouts_path_within_the_snap_is_measured(tmp_path: Path, shift: float) -> None:
    rows = pilot_rows()
    rows[3]["x"] = f"{7.5 + shift:g}"  # the study's logged overshoot is 0.039 units
    result = invoke("habits", str(write_csv_rows(tmp_path / "on.csv", rows)), "--format", "csv")
    assert result.exit_code == 0, result.output


# --- a run folder is read through its manifest ------------------------------------------------------


@pytest.fixture(scope="module")
def ciaa_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One participant's `ciaa-teleop` run (12 trials)."""
    out = tmp_path_factory.mktemp("runs") / "r1"
    made = invoke("simulate", "ciaa-teleop", "--participants", "1", "--out", str(out))
    assert made.exit_code == 0, made.output
    return out


def test_a_run_folders_edited_config_toml_changes_no_habit_and_no_fit(tmp_path: Path, ciaa_run: Path) -> None:
    # before: habits and fit-people read config.toml: its world edited to "grid", the stop -> switch row
    # was dropped without a word and fit-people took the reactions from the population
    edited = tmp_path / "d3"
    shutil.copytree(ciaa_run, edited)
    config = edited / "config.toml"
    config.write_text(config.read_text().replace('kind = "ciaa"', 'kind = "grid"'))
    for folder in (ciaa_run, edited):
        made = invoke("fit-people", str(folder), "--out", str(tmp_path / f"{folder.name}.csv"))
        assert made.exit_code == 0, made.output
        assert "from the population: -" in made.output, made.output
    own, read = (pd.read_csv(tmp_path / f"{name}.csv").drop(columns="source") for name in ("r1", "d3"))
    pd.testing.assert_frame_equal(own, read)
    tables = [invoke("habits", str(folder), "--format", "csv") for folder in (ciaa_run, edited)]
    assert tables[0].exit_code == 0 and "reaction_stop_to_switch" in tables[0].stdout, tables[0].output
    assert tables[1].stdout == tables[0].stdout, tables[1].output


# --- a run at another rate is read in HABITS.md's 10 Hz cells ----------------------------------------


def doubled(cells: pd.DataFrame) -> pd.DataFrame:
    """10 Hz cells as a 20 Hz run would give them: each cell twice, its motion and switch in the
    first half (where the robot then stands, and the mode, are the same after either half)."""
    twice = cells.loc[cells.index.repeat(2)].reset_index(drop=True)
    second = np.arange(len(twice)) % 2 == 1
    twice.loc[second, ["moving", "switch"]] = False
    twice.loc[second, "switch_from"] = twice.loc[second, "switch_to"]
    return twice


def test_cells_of_20_hz_read_in_10_hz_cells_are_those_of_10_hz(ciaa_run: Path) -> None:
    cells, rate = run_folder_cells(ciaa_run)
    assert rate == 10.0
    assert habit_rate_cells(cells, 10.0) is cells
    pd.testing.assert_frame_equal(habit_rate_cells(doubled(cells), 20.0), cells, check_dtype=False)


def test_a_run_at_20_hz_is_measured_in_10_hz_cells(tmp_path: Path) -> None:
    # before: measured in its own 0.05 s cells (a hard-band excursion of 0.05 or 0.15 s) and printed
    # beside the reference's 10 Hz ones with no word
    out = tmp_path / "y5"
    made = invoke("simulate", "ciaa-teleop", "--participants", "1", "--set", "study.rate_hz=20",
                  "--out", str(out))
    assert made.exit_code == 0, made.output
    assert run_folder_cells(out)[1] == 10.0
    events = habits_of(out).events
    durations = events.loc[events["habit"].isin([h.key for h in HABITS if not h.share]), "value"].to_numpy()
    assert durations.size and np.allclose(durations * 10, np.round(durations * 10)), sorted(set(durations))


# --- a reference's shares print as the measured values do ----------------------------------------------


def share_row(output: str) -> str:
    return next(line for line in output.splitlines() if line.startswith("share of pauses > 1 s"))


@pytest.mark.parametrize(("median", "people", "printed"), [
    # a habits JSON's measured values (before: 0.211864 0.049550-0.396907)
    (0.211864, [0.04955, 0.396907], "0.05 0.05-0.05 0.21 0.05-0.40 yes"),
    # written ones keep their own decimals (HABITS.md's 0.045), as ciaa-people's 0.23 0.05-0.65
    (0.23, [0.045, 0.65], "0.05 0.05-0.05 0.230 0.045-0.650 yes"),
    # a measured range rounded onto the median (0.04955 is above 0.04954): the range gets more decimals
    (0.04, [0.03, 0.04954], "0.05 0.05-0.05 0.0400 0.0300-0.0495 no"),
])
def test_a_references_shares_print_at_the_measured_values_decimals(
        tmp_path: Path, median: float, people: list[float], printed: str) -> None:
    reference = tmp_path / "ref.json"
    entry = {"pooled": {"median": median}, "people": people}
    reference.write_text(json.dumps({"name": "ref", "habits": {"share_pauses_over_1s": entry}}))
    result = invoke("habits", str(PILOT), "--compare", str(reference))  # pilot-1's share: 0.0495
    assert result.exit_code == 0, result.output
    row = " ".join(share_row(result.output).split())
    assert " ".join(printed.split()) in row, row


def test_the_packaged_references_shares_print_as_before() -> None:
    row = " ".join(share_row(invoke("habits", str(PILOT), "--compare", "ciaa-people").output).split())
    assert row.endswith("0.0495 0.0495-0.0495 0.23 0.05-0.65 no 0%"), row
