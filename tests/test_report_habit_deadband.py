"""`nudge habits`' rows inside a soft blow (report/habit_deadband.py, HABITS.md's second table): hand-built
cells and a real log counted by hand, a plain loop over random cell tables, and the comparison with
the packaged reference, whose follow-up shares have no people range."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.cli import main
from nudgecli.reference import packaged_reference
from nudgecli.report.habit_cells import DEADBAND, HARD, NEUTRAL, SOFT
from nudgecli.report.habits import format_habits, habits_of, measure_habits, summarise_habits

N, D, S, H = NEUTRAL, DEADBAND, SOFT, HARD
FOLLOWS = ("deadband_then_soft", "deadband_then_blow_ends", "deadband_then_gap_soft")


def cells_of(trials: list[list[int]], participant: int = 0) -> pd.DataFrame:
    """Cells of one participant's trials from their kinds (no motion, no switch)."""
    frames = [pd.DataFrame({"participant": participant, "trial": k, "kind": kinds, "moving": False,
                            "switch": False, "at_waypoint": False, "waypoints_known": True})
              for k, kinds in enumerate(trials)]
    return pd.concat(frames, ignore_index=True)


def values(events: pd.DataFrame, habit: str) -> list[float]:
    return events.loc[events["habit"] == habit, "value"].tolist()


#: 0 N, 1-2 S, 3-4 D, 5-6 S, 7 D | 8-10 N (three: a split) | 11 S, 12-13 D, 14 N (merged), 15 S |
#: 16-18 N | 19 H, 20 D, 21 S (a hard blow: not counted) | 22 N
HAND = [N, S, S, D, D, S, S, D, N, N, N, S, D, D, N, S, N, N, N, H, D, S, N]


def test_the_deadband_rows_of_a_hand_built_trial() -> None:
    events = measure_habits(cells_of([HAND]))
    # soft blows: cells 1-7 (3 deadband of 7) and 11-15, its merged gap included (2 of 5)
    assert sum(values(events, "deadband_share_soft_blows")) == 5
    assert len(values(events, "deadband_share_soft_blows")) == 12
    # runs: 3-4 then soft; 7, the blow's last cell; 12-13 then the gap at 14. The hard blow's 20: none
    assert values(events, "deadband_run_in_soft_blow") == [0.2, 0.1, 0.2]
    assert values(events, "deadband_then_soft") == [1.0, 0.0, 0.0]
    assert values(events, "deadband_then_blow_ends") == [0.0, 1.0, 0.0]
    assert values(events, "deadband_then_gap_soft") == [0.0, 0.0, 1.0]
    pooled = summarise_habits(events, "hand").pooled.set_index("habit")
    assert math.isclose(pooled.loc["deadband_share_soft_blows", "median"], 5 / 12, abs_tol=1e-6)
    assert pooled.loc["deadband_run_in_soft_blow", "median"] == 0.2
    for habit in FOLLOWS:
        assert math.isclose(pooled.loc[habit, "median"], 1 / 3, abs_tol=1e-6)


def test_a_persons_share_is_summed_over_their_trials_not_averaged() -> None:
    # trial 0: 1 deadband cell of 2; trial 1: 0 of 8 -> 1/10 (the mean of the trials' shares is 1/4)
    events = measure_habits(cells_of([[N, S, D, N], [N] + [S] * 8 + [N]]))
    result = summarise_habits(events, "two trials")
    own = result.people.set_index("habit").loc["deadband_share_soft_blows", "median"]
    assert math.isclose(own, 0.1)
    by_trial = summarise_habits(events, "two trials", by="trial").units
    shares = by_trial[by_trial["habit"] == "deadband_share_soft_blows"]["median"].tolist()
    assert shares == [0.5, 0.0]


def test_a_run_at_a_trials_end_ends_the_blow_and_never_crosses_into_the_next_trial() -> None:
    events = measure_habits(cells_of([[S, D, D], [D, S, N]]))
    assert values(events, "deadband_run_in_soft_blow") == [0.2, 0.1]
    assert values(events, "deadband_then_blow_ends") == [1.0, 0.0]
    assert values(events, "deadband_then_soft") == [0.0, 1.0]


def test_a_real_log_counted_by_hand(tmp_path: Path) -> None:
    # held labels read at 0, 0.1, ...: Soft Sip 0.0-0.3 (cells 0-2), deadband 0.3-0.6 (3-5), Soft Sip
    # 0.6-0.8 (6-7), neutral from 0.8: one soft blow of 8 cells, a 0.3 s run that goes back to soft
    log = tmp_path / "log.csv"
    log.write_text("t,trial,label,x,y,theta,mode_switch\n"
                   "0.0,1,Soft Sip,0,0,0,0\n0.3,1,Soft-Hard Sip Deadband,0,0,0,0\n"
                   "0.6,1,Soft Sip,0,0,0,0\n0.8,1,Zero Band,0,0,0,0\n1.5,1,Zero Band,0,0,0,0\n")
    events = habits_of(log).events
    assert values(events, "deadband_run_in_soft_blow") == [0.3]
    assert values(events, "deadband_then_soft") == [1.0]
    assert math.isclose(np.mean(values(events, "deadband_share_soft_blows")), 3 / 8)


def loop_deadband(kinds: list[list[int]], gap_cells: int = 2) -> dict[str, list[float]]:
    """HABITS.md's deadband rows one trial and one cell at a time."""
    out: dict[str, list[float]] = {key: [] for key in ("share", "run", *FOLLOWS)}
    for kind in kinds:
        n, i, blows = len(kind), 0, []
        while i < n:  # blows: non-neutral runs joined across gaps of at most gap_cells inside the trial
            if kind[i] == N:
                i += 1
                continue
            j = i
            while j < n and kind[j] != N:
                j += 1
            if blows and blows[-1][2]:
                blows[-1][1] = j
                blows[-1][2] = False
            else:
                blows.append([i, j, False])
            k = j
            while k < n and kind[k] == N:
                k += 1
            if k < n and k - j <= gap_cells:
                blows[-1][2] = True
            i = k
        for start, end, _ in blows:
            if any(kind[c] == H for c in range(start, end)):
                continue
            out["share"] += [float(kind[c] == D) for c in range(start, end)]
            c = start
            while c < end:
                if kind[c] != D:
                    c += 1
                    continue
                e = c
                while e < end and kind[e] == D:
                    e += 1
                out["run"].append(round((e - c) * 0.1, 6))
                follow = "deadband_then_blow_ends" if e == end else \
                    "deadband_then_soft" if kind[e] == S else "deadband_then_gap_soft"
                for key in FOLLOWS:
                    out[key].append(float(key == follow))
                c = e
    return out


@settings(max_examples=60, deadline=None)
@given(st.lists(st.lists(st.sampled_from([N, N, D, S, S, H]), min_size=1, max_size=40), min_size=1,
                max_size=4))
def test_the_vectorised_rows_equal_a_plain_loop(kinds: list[list[int]]) -> None:
    events = measure_habits(cells_of(kinds))
    expected = loop_deadband(kinds)
    assert values(events, "deadband_share_soft_blows") == expected["share"]
    assert values(events, "deadband_run_in_soft_blow") == expected["run"]
    for key in FOLLOWS:
        assert values(events, key) == expected[key], key


def test_the_comparison_with_the_reference_and_its_pooled_only_shares(tmp_path: Path) -> None:
    events = measure_habits(pd.concat([cells_of([HAND], 0), cells_of([[S, D, S, S, S, S, S, S]], 1)]))
    reference = packaged_reference("ciaa-people")
    result = summarise_habits(events, "hand", reference=reference)
    table = result.comparison().set_index("habit")
    # people's shares 5/12 and 1/8: the pooled 6/20 lies outside 0.045-0.21, one person of two inside
    share = table.loc["deadband_share_soft_blows"]
    assert math.isclose(share["median"], 0.3) and share["inside"] is False
    assert share["people_inside"] == 0.5
    run = table.loc["deadband_run_in_soft_blow"]
    assert run["inside"] is True and run["people_inside"] == 1.0  # medians 0.2 and 0.1
    # what follows a run has HABITS.md's pooled shares beside it and no people range
    soft = table.loc["deadband_then_soft"]
    assert soft["reference_median"] == 0.8 and soft["inside"] is None and math.isnan(soft["people_inside"])
    text = format_habits(result)
    line = next(row for row in text.splitlines() if row.startswith("deadband run -> soft again"))
    assert line.split()[-4:] == ["0.80", "-", "-", "-"]
    # json and csv through the command line, and a reference file with a null range is read back
    log = tmp_path / "log.csv"
    log.write_text("t,trial,label,x,y,theta,mode_switch\n0.0,1,Soft Sip,0,0,0,0\n"
                   "0.3,1,Soft-Hard Sip Deadband,0,0,0,0\n0.5,1,Soft Sip,0,0,0,0\n0.9,1,Zero Band,0,0,0,0\n")
    runner = CliRunner()
    data = json.loads(runner.invoke(main, ["habits", str(log), "--format", "json", "--compare",
                                           "ciaa-people"]).output)
    assert data["habits"]["deadband_run_in_soft_blow"]["pooled"]["median"] == 0.2
    assert data["habits"]["deadband_then_soft"]["unit"] == "share"
    compared = {row["habit"]: row for row in data["compare"]["habits"]}
    assert compared["deadband_then_soft"]["inside"] is None
    own = tmp_path / "ref.json"
    own.write_text(json.dumps({"name": "mine", "habits": {key: reference["habits"][key] for key in FOLLOWS}}))
    csv = runner.invoke(main, ["habits", str(log), "--format", "csv", "--compare", str(own)])
    assert csv.exit_code == 0, csv.output
    frame = pd.read_csv(pd.io.common.StringIO(csv.output))
    pooled = frame[frame["scope"] == "pooled"].set_index("habit")
    assert pooled.loc["deadband_then_soft", "median"] == 1.0
    assert pooled.loc["deadband_then_soft", "reference_median"] == 0.8


@pytest.mark.parametrize("pilot", ["pilot-1", "pilot-2", "pilot-3"])
def test_a_printed_comparison_reads_as_it_was_decided(pilot: str) -> None:
    # before: pilot-1's share of pauses > 1 s (0.0495) printed 0.05 beside 0.05-0.65 and "no",
    # HABITS.md's 0.045 as 0.04, and the last header cut to people_in
    log = Path(__file__).resolve().parents[1] / "experiments" / "pilots" / f"{pilot}.csv"
    result = CliRunner().invoke(main, ["habits", str(log), "--compare", "ciaa-people"])
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert lines[2].split()[-3:] == ["people", "inside", "people_inside"]
    compared = 0
    for line in lines[3:]:
        fields = line.split()
        if len(fields) < 5 or fields[-2] not in ("yes", "no"):
            continue
        median = float(line[58:78].split()[0])  # the median column, after the habit and n
        low, high = (float(v) for v in fields[-3].split("-"))
        assert (low <= median <= high) == (fields[-2] == "yes"), line
        compared += 1
    assert compared >= 10
    deadband = next(line for line in lines if line.startswith("share of soft-blow time in the deadband"))
    assert "0.045-0.210" in deadband
