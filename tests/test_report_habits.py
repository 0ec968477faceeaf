"""`nudge habits` (report/habits.py): HABITS.md's operating habits on hand-built logs with known
answers, the vectorised measurement against a plain loop over a simulated run, the packaged
reference against HABITS.md's table, and bad input."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.cli import main
from nudgecli.errors import DataError
from nudgecli.reference import packaged_reference, people_ranges
from nudgecli.report.habit_cells import DEADBAND, HARD, NEUTRAL, SOFT, run_folder_cells
from nudgecli.report.habits import habits_of, measure_habits
from nudgecli.run_folder_record import file_sha256

HABITS_MD = Path(__file__).resolve().parents[2] / "shared" / "data" / "ciaa-task" / "HABITS.md"
HEADER = "t,trial,label,x,y,theta,mode_switch,layout\n"


def cells_of(kinds: list[int], moving: list[bool] | None = None, switch: list[int] = (),
             at_waypoint: list[int] = ()) -> pd.DataFrame:
    """One trial's cell table from its kinds (moving, switch and at-waypoint cells by index)."""
    n = len(kinds)
    flags = {"switch": np.isin(np.arange(n), switch), "at_waypoint": np.isin(np.arange(n), at_waypoint)}
    return pd.DataFrame({"participant": 0, "trial": 0, "kind": kinds,
                         "moving": moving if moving is not None else [False] * n, **flags,
                         "waypoints_known": True})


def values(events: pd.DataFrame, habit: str) -> list[float]:
    return events.loc[events["habit"] == habit, "value"].tolist()


def write_log(tmp_path: Path, body: str, name: str = "log.csv") -> Path:
    path = tmp_path / name
    path.write_text(HEADER + body)
    return path


# --- known answers -------------------------------------------------------------------------------


@pytest.mark.parametrize("start", [0.0, 100.0, 1.89])
def test_a_first_command_at_exactly_2_3_s_of_a_real_log(tmp_path: Path, start: float) -> None:
    # in binary floating point 102.3 - 100.0 is 2.2999999999999972 and 4.19 - 1.89 is
    # 2.3000000000000007, past the cell read at 23 * 0.1 = 2.3000000000000003
    rows = [(0.0, "Zero Band"), (1.0, "Soft-Hard Puff Deadband"), (1.1, "Zero Band"), (2.3, "Soft Puff"),
            (3.0, "input stopped")]  # the deadband is not a command
    log = write_log(tmp_path, "".join(f"{start + t:.2f},1,{label},22.5,5,0,0,6\n" for t, label in rows))
    events = habits_of(log).events
    assert values(events, "first_command_latency") == [2.3]


def test_a_blow_with_a_known_gap() -> None:
    kinds = [NEUTRAL] * 10 + [SOFT] * 5 + [NEUTRAL] * 6 + [DEADBAND, SOFT, SOFT] + [NEUTRAL] * 3
    events = measure_habits(cells_of(kinds))
    assert values(events, "pause_between_blows") == [0.6]
    assert values(events, "soft_blow") == [0.5, 0.3]  # the deadband cell belongs to the second blow
    assert values(events, "share_pauses_over_1s") == [0.0]


@pytest.mark.parametrize(("rate_hz", "gap_cells", "blows"), [
    (10.0, 2, 1),  # 0.2 s: merged
    (10.0, 3, 2),  # 0.3 s: split
    (20.0, 5, 1),  # exactly 0.25 s: merged
    (20.0, 6, 2),  # 0.3 s: split
])
def test_the_merge_rule_at_0_25_s(rate_hz: float, gap_cells: int, blows: int) -> None:
    kinds = [SOFT] * 4 + [NEUTRAL] * gap_cells + [HARD] * 2 + [NEUTRAL]
    events = measure_habits(cells_of(kinds), rate_hz=rate_hz)
    assert len(values(events, "soft_blow")) + len(values(events, "hard_blow_whole")) == blows
    assert len(values(events, "pause_between_blows")) == blows - 1


def test_a_neutral_gap_at_the_trial_start_or_end_is_never_merged() -> None:
    kinds = [NEUTRAL, SOFT, SOFT, NEUTRAL]
    cells = pd.concat([cells_of(kinds), cells_of(kinds).assign(trial=1)], ignore_index=True)
    events = measure_habits(cells)
    assert values(events, "soft_blow") == [0.2, 0.2]  # not one blow across the trials
    assert values(events, "pause_between_blows") == []  # pauses are within a trial
    assert values(events, "first_command_latency") == [0.1, 0.1]


def test_hard_blow_whole_and_time_in_the_hard_band() -> None:
    kinds = [NEUTRAL, DEADBAND, HARD, HARD, DEADBAND, NEUTRAL, HARD, NEUTRAL, NEUTRAL, NEUTRAL, SOFT, NEUTRAL]
    events = measure_habits(cells_of(kinds))
    assert values(events, "hard_blow_whole") == [0.6]  # one neutral cell inside: merged
    assert values(events, "hard_band_per_excursion") == [0.2, 0.1]
    assert values(events, "soft_blow") == [0.1]


def test_a_stop_at_a_waypoint_then_a_switch_1_s_later_in_a_real_log(tmp_path: Path) -> None:
    """Layout 6's first leg runs from (22.5, 5) to its waypoint (15, 5)."""
    log = write_log(tmp_path, "0.0,1,Zero Band,22.5,5,0,,6\n"
                              "1.0,1,Soft Sip,22.5,5,0,,6\n"
                              "1.5,1,Soft Sip,15.0,5,0,,6\n"  # arrives: cell 1.4-1.5 moves
                              "1.7,1,Zero Band,15.0,5,0,,6\n"  # held on 0.2 s after the stop
                              "2.45,1,Hard Puff,15.0,5,0,y,6\n"  # the switch, seen in the cell read at 2.5:
                              "2.7,1,input stopped,15.0,5,0,,6\n"  # 1.0 s after the stop
                              "3.6,1,Soft Puff,15.0,5,0,,6\n"
                              "3.8,1,Soft Puff,15.0,5.3,0,,6\n"  # moves again: cell 3.7-3.8
                              "4.0,1,Zero Band,15.0,5.3,0,,6\n")
    events = habits_of(log).events
    assert values(events, "reaction_stop_to_switch") == [1.0]
    assert values(events, "reaction_switch_to_motion") == [1.2]
    # 0.2 + 0.2: cells 3.8 and 3.9 after the last moving one, 3.7
    assert values(events, "hold_on_per_trial") == [0.4]
    assert values(events, "hold_on_per_stop") == [0.2, 0.2]  # one per soft blow that held on
    assert values(events, "hard_blow_whole") == [0.2]
    assert values(events, "pause_between_blows") == [0.8, 0.9]


def test_a_stop_away_from_a_waypoint_or_followed_by_motion_is_no_stop_to_switch_reaction() -> None:
    moving = [False, True, True, False, False, True, False, False, False]
    kinds = [NEUTRAL, SOFT, SOFT, SOFT, NEUTRAL, SOFT, NEUTRAL, HARD, NEUTRAL]
    # the first run ends at a waypoint but motion comes before the switch; the second run ends
    # away from a waypoint
    events = measure_habits(cells_of(kinds, moving, switch=[7], at_waypoint=[2]))
    assert values(events, "reaction_stop_to_switch") == []
    events = measure_habits(cells_of(kinds, moving, switch=[7], at_waypoint=[2, 5]))
    assert values(events, "reaction_stop_to_switch") == [0.1]


def test_a_second_switch_before_the_motion_voids_the_first_reaction() -> None:
    moving = [False] * 8 + [True, False]
    kinds = [NEUTRAL, HARD, NEUTRAL, NEUTRAL, NEUTRAL, HARD, NEUTRAL, NEUTRAL, SOFT, NEUTRAL]
    events = measure_habits(cells_of(kinds, moving, switch=[1, 5]))
    assert values(events, "reaction_switch_to_motion") == [0.3]


@pytest.mark.parametrize(("gap_cells", "over_1s"), [(10, 0.0), (11, 1.0)])
def test_a_pause_of_exactly_1_s_is_not_over_1_s(gap_cells: int, over_1s: float) -> None:
    events = measure_habits(cells_of([SOFT, SOFT] + [NEUTRAL] * gap_cells + [SOFT, NEUTRAL]))
    assert values(events, "pause_between_blows") == [gap_cells / 10]
    assert values(events, "share_pauses_over_1s") == [over_1s]
    assert values(events, "share_pauses_over_2s") == [0.0]


def test_a_switch_in_the_cell_where_motion_resumes_is_not_before_the_motion() -> None:
    # switch -> motion: the switch at cell 4 comes with the motion, so the one at cell 1 is
    # answered by the motion 0.3 s later (nothing strictly between them)
    moving = [False] * 4 + [True, False]
    kinds = [NEUTRAL, HARD, NEUTRAL, NEUTRAL, HARD, NEUTRAL]
    events = measure_habits(cells_of(kinds, moving, switch=[1, 4]))
    assert values(events, "reaction_switch_to_motion") == [0.3]
    # stop -> switch: a stop at a waypoint, then a switch in the cell the robot moves again, is
    # no reaction to the stop
    moving = [False, True, True, False, False, True, False]
    kinds = [NEUTRAL, SOFT, SOFT, NEUTRAL, NEUTRAL, HARD, NEUTRAL]
    assert values(measure_habits(cells_of(kinds, moving, switch=[5], at_waypoint=[2])),
                  "reaction_stop_to_switch") == []
    assert values(measure_habits(cells_of(kinds, moving, switch=[4], at_waypoint=[2])),
                  "reaction_stop_to_switch") == [0.1]


@pytest.mark.parametrize(("moving_cell", "back_to", "expected"), [
    (None, 0, [0.5]),  # x -> y, then straight back y -> x 0.5 s later
    (4, 0, []),  # the robot moved between: not undone
    (None, 2, []),  # y -> theta: on, not back
])
def test_an_undone_switch(moving_cell: int | None, back_to: int, expected: list[float]) -> None:
    moving = [i == moving_cell for i in range(10)]
    kinds = [NEUTRAL, HARD, NEUTRAL, NEUTRAL, SOFT, NEUTRAL, HARD, NEUTRAL, NEUTRAL, NEUTRAL]
    cells = cells_of(kinds, moving, switch=[1, 6])  # no motion at all in two cases: nothing to react to
    cells["switch_from"] = [-1, 0, -1, -1, -1, -1, 1, -1, -1, -1]
    cells["switch_to"] = [-1, 1, -1, -1, -1, -1, back_to, -1, -1, -1]
    assert values(measure_habits(cells), "undone_switch") == expected


def test_an_undone_switch_in_a_real_log_starts_from_the_layouts_start_mode(tmp_path: Path) -> None:
    """Layout 6 starts in mode theta: theta -> y, then back to theta 0.8 s later; then y and x
    (where they went unknown for the last), so no more undone switches."""
    log = write_log(tmp_path, "0.0,1,Zero Band,22.5,5,0,,6\n"
                              "1.0,1,Hard Puff,22.5,5,0,y,6\n"
                              "1.2,1,Zero Band,22.5,5,0,,6\n"
                              "1.8,1,Hard Sip,22.5,5,0,theta,6\n"
                              "2.0,1,Zero Band,22.5,5,0,,6\n"
                              "2.5,1,Hard Puff,22.5,5,0,x,6\n"
                              "2.7,1,Zero Band,22.5,5,0,,6\n"
                              "3.5,1,Hard Sip,22.5,5,0,1,6\n"
                              "4.0,1,Zero Band,22.5,5,0,,6\n")
    assert values(habits_of(log).events, "undone_switch") == [0.8]


# --- the vectorised measurement against a plain loop over a simulated run -----------------------------


def loop_habits(cells: pd.DataFrame, dt: float = 0.1) -> dict[str, list[float]]:
    """HABITS.md's definitions, one trial and one cell at a time."""
    out: dict[str, list[float]] = {}
    for _, trial in cells.groupby(["participant", "trial"], sort=False):
        kind, moving = trial["kind"].tolist(), trial["moving"].tolist()
        switch, at = trial["switch"].tolist(), trial["at_waypoint"].tolist()
        n = len(kind)
        first = next((i for i in range(n) if kind[i] in (SOFT, HARD)), None)
        if first is not None:
            out.setdefault("first_command_latency", []).append(first * dt)
        blows: list[list[int]] = []
        i = 0
        while i < n:
            if kind[i] == NEUTRAL:
                i += 1
                continue
            j = i
            while j < n and kind[j] != NEUTRAL:
                j += 1
            gap = j
            while gap < n and kind[gap] == NEUTRAL:
                gap += 1
            if blows and blows[-1][1] == -1:
                blows[-1][1] = j
            else:
                blows.append([i, j])
            if gap < n and gap - j <= 2:
                blows[-1][1] = -1  # continues after the gap
            i = gap
        hold = []
        for k, (s, e) in enumerate(blows):
            hard = any(kind[c] == HARD for c in range(s, e))
            moved = [c for c in range(s, e) if moving[c]]
            out.setdefault("hard_blow_whole" if hard else "soft_blow", []).append((e - s) * dt)
            if k:
                out.setdefault("pause_between_blows", []).append((s - blows[k - 1][1]) * dt)
            if not hard and moved:
                hold.append((e - 1 - moved[-1]) * dt)
            if not hard and not moved:
                out.setdefault("soft_blow_never_moving", []).append((e - s) * dt)
        if hold:
            out.setdefault("hold_on_per_trial", []).append(sum(hold))
        out.setdefault("hold_on_per_stop", []).extend(h for h in hold if h > 0)
        for c in range(n):
            if kind[c] == HARD and (c == 0 or kind[c - 1] != HARD):
                e = c
                while e < n and kind[e] == HARD:
                    e += 1
                out.setdefault("hard_band_per_excursion", []).append((e - c) * dt)
            if moving[c] and (c + 1 == n or not moving[c + 1]) and at[c]:
                nxt = next((d for d in range(c + 1, n) if switch[d] or moving[d]), None)
                if nxt is not None and switch[nxt] and not moving[nxt]:
                    out.setdefault("reaction_stop_to_switch", []).append((nxt - c - 1) * dt)
            if switch[c]:
                back = next((d for d in range(c + 1, n) if switch[d]), None)
                if back is not None and trial["switch_from"].iloc[c] >= 0 and \
                        trial["switch_to"].iloc[back] == trial["switch_from"].iloc[c] and \
                        not any(moving[d] for d in range(c + 1, back)):
                    out.setdefault("undone_switch", []).append((back - c) * dt)
                starts = [d for d in range(c + 1, n) if moving[d] and not moving[d - 1]]
                if starts and not any(switch[d] for d in range(c + 1, starts[0])):
                    out.setdefault("reaction_switch_to_motion", []).append((starts[0] - c) * dt)
    return out


@pytest.fixture(scope="module")
def ciaa_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("habits") / "ciaa"
    result = CliRunner().invoke(main, ["simulate", "ciaa-teleop", "--participants", "2", "--seed", "3",
                                       "--out", str(out)])
    assert result.exit_code == 0, result.output
    return out


def test_the_measurement_equals_a_plain_loop_on_a_simulated_run(ciaa_run: Path) -> None:
    cells, rate = run_folder_cells(ciaa_run)
    assert rate == 10.0
    events = measure_habits(cells, rate)
    expected = loop_habits(cells)
    for habit, loop_values in expected.items():
        got = sorted(values(events, habit))
        np.testing.assert_allclose(got, sorted(loop_values), atol=1e-6, err_msg=habit)
    # the run has each kind of event
    assert {"reaction_stop_to_switch", "reaction_switch_to_motion", "hold_on_per_trial", "hold_on_per_stop",
            "undone_switch"} <= set(expected)


def test_moving_cells_and_waypoint_stops_of_a_run_are_read_from_its_poses(ciaa_run: Path) -> None:
    cells, _ = run_folder_cells(ciaa_run)
    steps = pd.read_parquet(ciaa_run / "steps").sort_values(["participant", "trial", "step"])
    same = (steps[["participant", "trial"]].shift(-1) == steps[["participant", "trial"]]).all(axis=1)
    changed = (steps[["x", "y", "theta"]].shift(-1) != steps[["x", "y", "theta"]]).any(axis=1)
    np.testing.assert_array_equal(cells["moving"].to_numpy()[same.to_numpy()], changed[same].to_numpy())
    # a waypoint stop: the location (cell_x) or the turn flag (cell_y) changed during the run
    assert cells["at_waypoint"][cells["moving"]].mean() < 0.5


def test_a_grid_world_run_has_no_waypoint_stops_to_react_to(tmp_path: Path) -> None:
    """The grid world has no waypoints: a motion run that reaches another cell (a hard blow's soft
    onset, the autonomy's motion) is no stop at a waypoint, so stop -> switch is not measured and
    not printed, as for a real log without its layout."""
    out = tmp_path / "smoke"
    result = CliRunner().invoke(main, ["simulate", "smoke", "--participants", "2", "--seed", "11",
                                       "--out", str(out)])
    assert result.exit_code == 0, result.output
    cells, rate = run_folder_cells(out)
    assert not cells["at_waypoint"].any() and not cells["waypoints_known"].any()
    habits = set(measure_habits(cells, rate)["habit"])
    assert "reaction_stop_to_switch" not in habits and "reaction_switch_to_motion" in habits
    printed = CliRunner().invoke(main, ["habits", str(out)])
    assert printed.exit_code == 0, printed.output
    assert "robot stops at a waypoint" not in printed.output and "stop>switch" not in printed.output


def test_the_cli_prints_table_json_and_csv_with_the_reference(ciaa_run: Path) -> None:
    runner = CliRunner()
    table = runner.invoke(main, ["habits", str(ciaa_run), "--compare", "ciaa-people"])
    assert table.exit_code == 0, table.output
    assert "first-command latency" in table.output and "ciaa-people" in table.output
    data = json.loads(runner.invoke(main, ["habits", str(ciaa_run), "--format", "json",
                                           "--compare", "ciaa-people"]).output)
    result = habits_of(ciaa_run)
    pooled = result.pooled.set_index("habit")
    assert data["habits"]["pause_between_blows"]["pooled"]["median"] == pytest.approx(
        float(np.median(values(result.events, "pause_between_blows"))))
    compared = {row["habit"]: row for row in data["compare"]["habits"]}
    lo, hi = people_ranges()["first_command_latency"]
    median = pooled.loc["first_command_latency", "median"]
    assert compared["first_command_latency"]["inside"] == bool(lo <= median <= hi)
    own = result.people.loc[result.people["habit"] == "first_command_latency", "median"]
    share = ((own >= lo) & (own <= hi)).mean()
    assert compared["first_command_latency"]["people_inside"] == pytest.approx(share)
    csv = runner.invoke(main, ["habits", str(ciaa_run), "--format", "csv", "--by", "trial"]).output
    frame = pd.read_csv(pd.io.common.StringIO(csv))
    assert set(frame["scope"]) == {"pooled", "trial"}
    assert frame.loc[frame["scope"] == "trial", ["participant", "trial"]].drop_duplicates().shape[0] == 24


def test_its_own_json_is_a_reference(ciaa_run: Path, tmp_path: Path) -> None:
    runner = CliRunner()
    own = tmp_path / "own.json"
    own.write_text(runner.invoke(main, ["habits", str(ciaa_run), "--format", "json"]).output)
    data = json.loads(runner.invoke(main, ["habits", str(ciaa_run), "--format", "json",
                                           "--compare", str(own)]).output)
    assert all(row["inside"] for row in data["compare"]["habits"])
    assert all(row["people_inside"] == 1.0 for row in data["compare"]["habits"])


# --- the packaged reference -----------------------------------------------------------------------


def markdown_tables(text: str) -> list[list[list[str]]]:
    """Each ``|``-table of a markdown text: its rows (header first, the ``---`` row dropped) as cells."""
    tables: list[list[list[str]]] = []
    inside = False
    for line in text.splitlines():
        if not line.startswith("|"):
            inside = False
            continue
        if not inside:
            tables.append([])
            inside = True
        if "---" not in line:
            tables[-1].append([c.strip() for c in line.strip().strip("|").split("|")])
    return tables


@pytest.mark.skipif(not HABITS_MD.is_file(), reason="HABITS.md (../shared/data/ciaa-task) is absent")
def test_the_packaged_reference_is_habits_md_tables() -> None:
    tables = markdown_tables(HABITS_MD.read_text())
    assert len(tables) == 2  # the operating habits, then inside a soft blow
    numbers = re.compile(r"-?\d+\.\d+")
    table = {}
    for cells in tables[0][1:] + tables[1][1:]:  # each table's header first
        table[cells[0]] = ([float(v) for v in numbers.findall(cells[2])],
                           [float(v) for v in numbers.findall(cells[3])])
    reference = packaged_reference("ciaa-people")["habits"]
    assert len(reference) == 12 + 5 and len(table) == 12 + 3
    checked = 0
    for entry in reference.values():
        if "row" in entry:  # one outcome of "what follows a deadband run": "<outcome>: 80 %"
            pooled_text = next(c[2] for c in tables[1] if c[0] == entry["row"])
            shares = {k.strip(): v for k, v in re.findall(r"([^:;]+): (\d+) %", pooled_text)}
            assert entry["pooled"] == {"median": int(shares[entry["outcome"]]) / 100}, entry["label"]
            assert entry["people"] is None
            checked += 1
            continue
        pooled, people = table[entry["label"]]
        expected = [entry["pooled"][k] for k in ("median", "q25", "q75") if k in entry["pooled"]]
        assert pooled == expected, entry["label"]
        # the deadband share's people cell also gives their median: "0.045 - 0.21 (median 0.073)"
        assert people == entry["people"] + ([entry["people_median"]] if "people_median" in entry else []), \
            entry["label"]
        checked += 1
    assert checked == 17
    follows = next(c[2] for c in tables[1] if c[0].startswith("what follows"))
    assert sum(int(v) for v in re.findall(r"(\d+) %", follows)) == 100
    stated = packaged_reference("ciaa-people")["stated"]["hold_on_per_stop"]
    assert stated["text"] in HABITS_MD.read_text().replace("\n  ", " ")


# --- bad input: one Error line naming the file and the row, exit 1, nothing written ------------------


def run_cli(tmp_path: Path, source: Path) -> tuple[int, str, str]:
    before = sorted(tmp_path.rglob("*"))
    result = CliRunner().invoke(main, ["habits", str(source)])
    assert sorted(tmp_path.rglob("*")) == before  # nothing written
    return result.exit_code, result.stdout, result.stderr


@pytest.mark.parametrize(("body", "header", "expected"), [
    ("0.0,1,Zero Band,0,0,0,0\n", "trial,label,x,y,theta,mode_switch\n", "no t (or time) column"),
    ("0.0,1,0,0,0,0\n", "t,trial,x,y,theta,mode_switch\n", "no label column"),
    ("0.0,1,Zero Band,0,0,0,0\n0.1,1,Soft Blow,0,0,0,0\n0.2,1,,0,0,0,0\n", None,
     "row 3: unknown label 'Soft Blow'"),
    ("0.0,1,Zero Band,0,0,0,0\n0.5,1,Soft Puff,0,0,0,0\n0.4,1,Zero Band,0,0,0,0\n", None,
     "row 4: time 0.4 s comes before the previous row's 0.5 s"),
    ("0.0,1,Zero Band,0,0,0,0\n1.0,1,Zero Band,0,0,0,0\n5.0,2,Soft Puff,0,0,0,0\n", None,
     "rows 4-4: trial '2'"),
    ("0.0,1,Zero Band,0,0,0,0\nsoon,1,Soft Puff,0,0,0,0\n", None, "row 3: t 'soon' is not a number"),
])
def test_a_bad_log_is_one_error_line(tmp_path: Path, body: str, header: str | None, expected: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text((header or "t,trial,label,x,y,theta,mode_switch\n") + body)
    code, out, err = run_cli(tmp_path, path)
    assert code == 1 and out == ""
    assert err.startswith(f"Error: {path}") and expected in err, err
    assert len(err.strip().splitlines()) == 1


def test_a_folder_that_is_not_a_run_folder(tmp_path: Path) -> None:
    folder = tmp_path / "notes"
    folder.mkdir()
    (folder / "readme.txt").write_text("hello")
    code, out, err = run_cli(tmp_path, folder)
    assert code == 1 and out == "" and err.startswith(f"Error: {folder}: not a run folder")


def test_a_run_with_an_empty_trial(ciaa_run: Path, tmp_path: Path) -> None:
    import shutil

    copy = tmp_path / "run"
    shutil.copytree(ciaa_run, copy)
    part = copy / "steps" / "part-0001.parquet"
    steps = pd.read_parquet(part)
    steps[steps["trial"] != 4].to_parquet(part, index=False)
    # recorded so (as a run whose trial left no steps would be), not a part changed afterwards
    manifest_path = copy / "manifest.json"
    manifest = json.loads(manifest_path.read_text())
    manifest["checksums"]["1"]["steps"] = file_sha256(part)
    manifest_path.write_text(json.dumps(manifest))
    code, out, err = run_cli(tmp_path, copy)
    assert code == 1 and out == ""
    assert "trial 4 of participant 1 has no steps" in err and str(copy / "steps") in err


def test_an_unknown_reference(ciaa_run: Path) -> None:
    result = CliRunner().invoke(main, ["habits", str(ciaa_run), "--compare", "ciaa-robots"])
    assert result.exit_code == 1 and "neither a packaged reference" in result.stderr


# --- the habits panel of `nudge plot-population` ---------------------------------------------------


def test_drawn_habits_are_the_parameters_plus_their_offsets() -> None:
    from nudgecli.config import load_experiment
    from nudgecli.sim.real_population import simulated_habits
    from nudgecli.sim.study import study_participant

    config = load_experiment("ciaa-teleop")
    habits = simulated_habits(config, 3, 11).set_index(["participant", "habit"])["value"]
    person = study_participant(config, 11, 2)
    assert habits[(2, "first_command_latency")] == pytest.approx(person.planning_s, abs=1e-6)
    assert habits[(2, "reaction_stop_to_switch")] == pytest.approx(person.event_reaction_s + 0.1, abs=1e-6)
    assert habits[(2, "reaction_switch_to_motion")] == pytest.approx(person.event_reaction_s + 0.1, abs=1e-6)
    assert habits[(2, "hard_band_per_excursion")] == pytest.approx(person.hard_peak_s, abs=1e-6)
    assert habits[(2, "hold_on_per_stop")] == pytest.approx(person.hold_on_s, abs=1e-6)


def test_the_habits_panel_draws_each_person_beside_the_real_range() -> None:
    from matplotlib.collections import PathCollection
    from matplotlib.patches import Rectangle

    from nudgecli.report.population_figure import HABIT_TITLES, build_population_figure, habits_panel

    habits = pd.DataFrame([{"participant": p, "habit": h, "value": 0.5 + 0.1 * p}
                           for p in range(4) for h in HABIT_TITLES])
    ax = habits_panel(habits)
    dots = [c for c in ax.collections if isinstance(c, PathCollection)]
    assert len(dots) == len(HABIT_TITLES) and all(len(c.get_offsets()) == 4 for c in dots)
    np.testing.assert_allclose(sorted(dots[1].get_offsets()[:, 1]), [0.5, 0.6, 0.7, 0.8])
    bars = [p for p in ax.patches if isinstance(p, Rectangle)]
    spans = [(b.get_y(), b.get_y() + b.get_height()) for b in bars]
    ranges = people_ranges()
    np.testing.assert_allclose(spans, [ranges[h] for h in HABIT_TITLES])
    diagonals = pd.DataFrame([{"participant": 0, "stream": s, "label": label, "diagonal": 0.9}
                              for s in ("fixed_rate", "event_driven")
                              for label in ("Hard Puff", "Hard Sip", "Soft Puff", "Soft Sip")])
    assert len(build_population_figure(diagonals).axes) == 2
    assert len(build_population_figure(diagonals, habits=habits).axes) == 3


def test_the_summaries_and_the_comparison_of_known_events() -> None:
    from nudgecli.report.habits import summarise_habits

    pauses = {"a": [0.4, 1.2, 0.6], "b": [2.5, 0.3]}
    events = pd.DataFrame([{"participant": p, "trial": 0, "habit": habit, "value": value}
                           for p, values_of in pauses.items() for v in values_of
                           for habit, value in (("pause_between_blows", v),
                                                ("share_pauses_over_1s", float(v > 1)),
                                                ("share_pauses_over_2s", float(v > 2)))])
    reference = {"name": "made-up", "habits": {
        "pause_between_blows": {"pooled": {"median": 0.6}, "people": [0.5, 1.0]},
        "share_pauses_over_1s": {"pooled": {"median": 0.2}, "people": [0.5, 0.6]}}}
    result = summarise_habits(events, "made-up events", reference=reference)
    pooled = result.pooled.set_index("habit")
    assert pooled.loc["pause_between_blows", "median"] == pytest.approx(0.6)
    assert pooled.loc["pause_between_blows", ["q25", "q75"]].tolist() == pytest.approx([0.4, 1.2])
    assert pooled.loc["share_pauses_over_1s", "median"] == pytest.approx(2 / 5)  # a share, not a median
    assert pooled.loc["share_pauses_over_2s", "median"] == pytest.approx(1 / 5)
    people = result.people.set_index(["participant", "habit"])["median"]
    assert people[("a", "share_pauses_over_1s")] == pytest.approx(1 / 3)
    assert people[("b", "pause_between_blows")] == pytest.approx(1.4)
    spread = pooled.loc["pause_between_blows", ["people_min", "people_max"]].tolist()
    assert spread == pytest.approx([0.6, 1.4])
    compared = result.comparison().set_index("habit")
    assert bool(compared.loc["pause_between_blows", "inside"]) is True
    assert compared.loc["pause_between_blows", "people_inside"] == pytest.approx(0.5)  # 0.6 in, 1.4 out
    assert bool(compared.loc["share_pauses_over_1s", "inside"]) is False  # 0.4 below 0.5
    assert compared.loc["share_pauses_over_1s", "people_inside"] == pytest.approx(0.5)  # 0.33 out, 0.5 in


@settings(max_examples=50, deadline=None)
@given(st.lists(st.sampled_from(["Soft Puff", " Soft Sip ", "Hard Puff", "Hard Sip", "", None,
                                 "Puff Deadband", "Soft Blow", 3]), max_size=25),
       st.sampled_from(["object", "str"]))
def test_label_kinds_read_each_label_as_the_elementwise_rule(labels, dtype):
    from nudgecli.report.habit_cells import LABEL_KINDS, label_kinds

    if dtype == "str":
        labels = [None if label is None else str(label) for label in labels]
    series = pd.Series(labels, dtype=dtype)
    text = series.fillna("").astype(str).str.strip()  # the rule, label by label
    expected = text.map(LABEL_KINDS)
    if expected.isna().any():
        row = int(np.flatnonzero(expected.isna().to_numpy())[0])
        with pytest.raises(DataError, match=re.escape(f"row {row}: unknown label {text.iloc[row]!r}")):
            label_kinds(series, lambda r: f"row {r}")
    else:
        np.testing.assert_array_equal(label_kinds(series, "log"), expected.to_numpy(dtype=np.int8))


@pytest.mark.parametrize("at_once", [1, 2, 16])
def test_a_runs_cells_read_a_few_participants_at_a_time_are_the_whole_logs(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, at_once: int) -> None:
    from nudgecli.config import load_experiment
    from nudgecli.report import habit_cells
    from nudgecli.runs.study import run_study
    from nudgecli.store import RunFolder

    monkeypatch.setattr(habit_cells, "_PARTICIPANTS_AT_ONCE", at_once)
    run = RunFolder(run_study(load_experiment("smoke"), tmp_path / "run", participants=3).path)
    steps = run.read_table("steps", habit_cells._HABIT_STEP_COLUMNS)
    whole = habit_cells._trial_cells(run, steps, run.read_table("trials", habit_cells._TRIAL_COLUMNS), None)
    cells, _ = run_folder_cells(run.path)
    assert sorted(set(cells["participant"])) == [0, 1, 2]
    pd.testing.assert_frame_equal(cells, whole)
