"""`nudge habits` on bad input (issue 38): a log with no input, a time stamp that would make a trial
of millions of cells, a `--compare` reference without a habit nudge measures, and a log separated by
semicolons. Each is one `Error:` line naming the file, the row or field and the fix (or, for the
semicolons, read as the commas would be), through the command line.

Each test was seen failing with its fix removed (a traceback, a KeyError, "no t column")."""

from __future__ import annotations

import io
import json
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_helpers import one_error_line
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.cli import main
from nudgecli.report import habit_logs
from nudgecli.report.habits import HABIT_KEYS

COLUMNS = ("t", "trial", "label", "x", "y", "theta", "mode_switch")
#: One trial: a soft blow that moves the robot, a switch, and a pause (every habit's input but a layout).
ROWS = [(0.0, 1, "Zero Band", 0, 0, 0, 0), (0.5, 1, "Soft Puff", 0, 0, 0, 0),
        (0.8, 1, "Soft Puff", 1, 0, 0, 0), (1.2, 1, "Zero Band", 1, 0, 0, "y"),
        (2.0, 1, "Soft Sip", 1, 0, 0, 0), (2.4, 1, "Zero Band", 1, 1, 0, 0),
        (3.0, 1, "input stopped", 1, 1, 0, 0)]


def write_log(path: Path, rows: list[tuple], delimiter: str = ",",
              columns: tuple[str, ...] = COLUMNS) -> Path:
    path.write_text("\n".join(delimiter.join(str(v) for v in row) for row in [columns, *rows]) + "\n")
    return path


def habits(*args: str):
    return CliRunner().invoke(main, ["habits", *args])


def refused(tmp_path: Path, *args: str) -> str:
    """The one error line of `nudge habits ARGS`, which must exit 1 with nothing on stdout or disk."""
    before = sorted(tmp_path.rglob("*"))
    result = habits(*args)
    assert result.exit_code == 1 and result.stdout == "", result.output
    assert sorted(tmp_path.rglob("*")) == before
    return one_error_line(result.stderr)


# --- a log with no input -----------------------------------------------------------------------


def test_a_log_with_no_input_is_one_error_line(tmp_path: Path) -> None:
    # before: pyarrow's ArrowInvalid (summarising no events), a traceback
    rows = [(0.0, 1, "Zero Band", 0, 0, 0, 0), (1.0, 1, "", 0, 0, 0, 0),
            (0.0, 2, "input stopped", 0, 0, 0, 0), (2.0, 2, "None", 0, 0, 0, 0)]
    log = write_log(tmp_path / "idle.csv", rows)
    for output_format in ("table", "json", "csv"):
        line = refused(tmp_path, str(log), "--format", output_format)
        assert line.startswith(f"Error: {log}: nothing to measure"), line
        assert "30 cells of 2 trials" in line and "no input" in line, line


def test_a_log_of_switches_and_motion_but_no_input_says_so(tmp_path: Path) -> None:
    # the pose changes twice (held: 2 moving cells), then a switch with no motion after it: no reaction
    rows = [(0.0, 1, "", 0, 0, 0, 0), (0.5, 1, "", 1, 0, 0, 0), (1.0, 1, "", 2, 0, 0, 0),
            (1.5, 1, "", 2, 0, 0, "y"), (2.0, 1, "", 2, 0, 0, 0)]
    line = refused(tmp_path, str(write_log(tmp_path / "still.csv", rows)))
    assert "its 20 cells of 1 trial at 10 Hz hold no input" in line, line
    assert "its 1 mode switch(es) and 2 moving cell(s) make no reaction or undone switch" in line, line


# --- a time stamp far out ----------------------------------------------------------------------


@pytest.fixture
def no_cells(monkeypatch: pytest.MonkeyPatch) -> None:
    """Building a trial's cells fails the test: a log past a limit is refused before any is built
    (without the guard, 1e7 s would be 1e8 cells, gigabytes)."""
    def allocate(*args: object) -> None:
        raise AssertionError("cells built before the size was checked")
    monkeypatch.setattr(habit_logs, "_trial_cells", allocate)


@pytest.mark.parametrize(("first", "last"), [(0.0, 1e7), (-1e7, 0.0), (5.0, 5.0 + 3600.1)])
def test_a_trial_longer_than_the_limit_is_refused_before_its_cells_are_built(
        tmp_path: Path, no_cells: None, first: float, last: float) -> None:
    rows = [(0.0, 1, "Soft Puff", 0, 0, 0, 0), (1.0, 1, "Zero Band", 1, 0, 0, 0),
            (first, 2, "Soft Puff", 0, 0, 0, 0), (first + 1.0, 2, "Zero Band", 0, 0, 0, 0),
            (last, 2, "Zero Band", 0, 0, 0, 0)]
    log = write_log(tmp_path / "stamps.csv", rows)
    line = refused(tmp_path, str(log))
    assert line.startswith(f"Error: {log}, row 6: time {last:g} s"), line  # the trial's last row
    assert f"trial '2' of participant 'stamps' from row 4 ({first:g} s)" in line, line
    assert "at most 3600 s (36000 cells at 10 Hz)" in line, line


def test_a_trial_of_exactly_the_limit_is_measured(tmp_path: Path) -> None:
    rows = [(0.0, 1, "Soft Puff", 0, 0, 0, 0), (1.0, 1, "Zero Band", 1, 0, 0, 0),
            (3600.0, 1, "Zero Band", 1, 0, 0, 0)]
    result = habits(str(write_log(tmp_path / "hour.csv", rows)), "--format", "json")
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["habits"]["soft_blow"]["pooled"]["median"] == 1.0


def test_a_log_past_the_cell_limit_is_refused_at_the_trial_that_passes_it(
        tmp_path: Path, no_cells: None, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(habit_logs, "MAX_LOG_CELLS", 80)
    # trials of 4 s: 40 cells each; the first two are exactly the limit, the third passes it
    rows = [(t, trial, "Soft Puff", 0, 0, 0, 0) for trial in (1, 2, 3) for t in (0.0, 4.0)]
    log = write_log(tmp_path / "many.csv", rows)
    line = refused(tmp_path, str(log))
    assert line.startswith(f"Error: {log}, row 7: "), line  # the third trial's last row
    assert "120 cells at 10 Hz up to this row, more than the 80 a log may hold" in line, line


def test_a_log_of_exactly_the_cell_limit_is_measured(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(habit_logs, "MAX_LOG_CELLS", 80)
    rows = [(t, trial, "Soft Puff", 0, 0, 0, 0) for trial in (1, 2) for t in (0.0, 4.0)]
    assert habits(str(write_log(tmp_path / "two.csv", rows))).exit_code == 0


@settings(max_examples=60, deadline=None)
@given(st.lists(st.lists(st.integers(0, 400), min_size=1, max_size=5), min_size=1, max_size=4),
       st.sampled_from([0.0, 1.89, 100.0, 1e5]))
def test_the_cells_counted_before_reading_are_the_cells_read(gaps: list[list[int]], start: float) -> None:
    # the counted cells (which the limits are checked on) against the table read_log_cells builds
    times, trials = [], []
    for trial, steps in enumerate(gaps):
        clock = np.cumsum([0, *steps]) * 0.01 + start  # time stamps every 0.01 s multiple
        times += clock.tolist()
        trials += [trial] * len(clock)
    time, new_trial = np.asarray(times), np.r_[True, np.diff(trials) != 0]
    counted = habit_logs.trial_cell_counts(time, new_trial, 10.0)
    duration = np.asarray([time[np.asarray(trials) == k][-1] - time[np.asarray(trials) == k][0]
                           for k in range(len(gaps))])
    if (duration < 0.1 - 1e-9).any():  # a trial shorter than one cell is refused by name later
        return
    frame = pd.DataFrame({"t": times, "trial": trials, "label": "Zero Band", "x": 0, "y": 0, "theta": 0,
                          "mode_switch": 0})
    cells = _cells_of_frame(frame)
    assert counted.tolist() == cells.groupby("trial", sort=False).size().tolist()


def _cells_of_frame(frame: pd.DataFrame) -> pd.DataFrame:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "log.csv"
        frame.to_csv(path, index=False)
        return habit_logs.read_log_cells(path)


# --- a --compare reference without a known habit --------------------------------------------------


def reference(tmp_path: Path, habits_of_reference: dict) -> Path:
    path = tmp_path / "reference.json"
    path.write_text(json.dumps({"name": "mine", "habits": habits_of_reference}))
    return path


ENTRY = {"pooled": {"median": 0.5}, "people": [0.2, 0.9]}


@pytest.mark.parametrize(("held", "expected"), [
    ({}, "holds no habit"),
    ({"first_cmd_latency": ENTRY}, "habit 'first_cmd_latency' is not one nudge measures (did you mean "
                                   "'first_command_latency'?)"),
    ({"soft_blow": ENTRY, "Soft blow": ENTRY}, "habit 'Soft blow' is not one nudge measures"),
])
def test_a_reference_without_known_habits_is_one_error_line(tmp_path: Path, held: dict,
                                                              expected: str) -> None:
    # before: a KeyError traceback ('habit'), or the unknown habit left out of the comparison unsaid
    log = write_log(tmp_path / "log.csv", ROWS)
    ref = reference(tmp_path, held)
    line = refused(tmp_path, str(log), "--compare", str(ref))
    assert line.startswith(f"Error: {ref}: {expected}"), line
    if held:
        assert ", ".join(HABIT_KEYS) in line


@pytest.mark.parametrize("output_format", ["table", "csv", "json"])
def test_a_reference_whose_habits_the_source_lacks_is_printed_without_a_comparison(
        tmp_path: Path, output_format: str) -> None:
    # the log has no undone switch; the reference has nothing else (before: KeyError 'habit')
    log = write_log(tmp_path / "log.csv", ROWS)
    result = habits(str(log), "--compare", str(reference(tmp_path, {"undone_switch": ENTRY})),
                    "--format", output_format)
    assert result.exit_code == 0, result.output
    if output_format == "json":
        assert json.loads(result.stdout)["compare"] == {"reference": "mine", "habits": []}
    elif output_format == "csv":
        table = pd.read_csv(io.StringIO(result.stdout))
        assert "reference_median" in table.columns and table["reference_median"].isna().all()
    else:
        assert "mine median" in result.stdout and " yes " not in result.stdout


# --- the delimiter -------------------------------------------------------------------------------


@pytest.mark.parametrize("delimiter", [";", "\t", "|"])
def test_a_log_separated_by_semicolons_tabs_or_bars_reads_as_with_commas(tmp_path: Path,
                                                                         delimiter: str) -> None:
    # before: "no t (or time), trial, label, ... column(s)" for a header read as one column
    commas = habits(str(write_log(tmp_path / "log.csv", ROWS)), "--format", "csv")
    other = habits(str(write_log(tmp_path / "log.txt", ROWS, delimiter)), "--format", "csv")
    assert commas.exit_code == 0 and other.exit_code == 0, other.output
    assert other.stdout == commas.stdout and "soft_blow" in other.stdout


def test_a_header_of_no_known_delimiter_says_what_it_found(tmp_path: Path) -> None:
    log = write_log(tmp_path / "colons.csv", ROWS, ":")
    line = refused(tmp_path, str(log))
    assert "no t (or time), trial, label, x, y, theta, mode_switch column(s)" in line, line
    assert "its header holds 1 column, 't:trial:label:x:y:theta:mode_switch'" in line, line
    assert "separated by commas (or ;, tab or |)" in line, line


def test_a_decimal_comma_is_named(tmp_path: Path) -> None:
    rows = [(0.0, 1, "Zero Band", 0, 0, 0, 0), ("0,5", 1, "Soft Puff", 0, 0, 0, 0)]
    line = refused(tmp_path, str(write_log(tmp_path / "comma.csv", rows, ";")))
    assert "row 3: t '0,5' is not a number (a decimal comma? write 0.5)" in line, line


# --- the layout column ---------------------------------------------------------------------------


def with_layouts(layouts: list[str]) -> list[tuple]:
    """ROWS with a layout column: ``layouts[i]`` on row i, the poses moved onto layout 6's path
    (from its start (22.5, 5) to its waypoint (15, 5), then up towards (15, 10))."""
    return [(t, trial, label, 22.5 - 7.5 * x, 5 + 5 * y, theta, switch, layout)
            for (t, trial, label, x, y, theta, switch), layout in zip(ROWS, layouts, strict=True)]


@pytest.mark.parametrize(("changed", "layout", "expected"), [
    (range(7), "2.5", "row 2: layout '2.5' is not a trial index of the CIAA task"),
    ([2], "-1", "row 4: layout '-1' is not a trial index of the CIAA task"),
    ([6], "999", "row 8: layout '999' is not a trial index of the CIAA task"),
    ([3], "", "row 5: layout '' is not a trial index of the CIAA task"),
    ([3, 4], "7", "row 5: layout '7' differs from the '6' of row 2, where trial '1' of participant 'log' "
                  "starts; a trial runs on one layout"),
])
def test_a_layout_that_is_no_index_or_changes_within_a_trial_is_named_by_its_row(
        tmp_path: Path, changed: list[int], layout: str, expected: str) -> None:
    # before: only a trial's first row was checked, and 2.5 read as layout 2 (exit 0)
    layouts = [layout if i in changed else "6" for i in range(len(ROWS))]
    log = write_log(tmp_path / "log.csv", with_layouts(layouts), columns=(*COLUMNS, "layout"))
    line = refused(tmp_path, str(log))
    assert line.startswith(f"Error: {log}, {expected}"), line
    fix = "give each row the CIAA task's trial index (a whole number, 0-35) of the layout its trial runs on"
    assert fix in line, line


def test_a_layout_on_every_row_of_a_trial_is_measured(tmp_path: Path) -> None:
    log = write_log(tmp_path / "log.csv", with_layouts(["6"] * len(ROWS)), columns=(*COLUMNS, "layout"))
    result = habits(str(log), "--format", "csv")
    assert result.exit_code == 0, result.output
