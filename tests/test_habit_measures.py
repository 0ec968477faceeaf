"""Two of `nudge habits`' measures against HABITS.md's own definitions, each on a small log whose
answer is counted by hand and by a plain loop written apart from the measuring code:

- the time in the hard band per excursion: a run of n contiguous Hard cells lasts n * 0.1 s (not
  (n - 1) * 0.1 s from its first to its last sample);
- the share of soft-blow time in the deadband: per person, their deadband cells over all their
  soft-blow cells summed over their trials; pooled, the same ratio over everyone's cells; the
  people range is that of the per-person ratios.
"""

from __future__ import annotations

import math
from fractions import Fraction
from pathlib import Path

import pandas as pd

from nudgecli.report.habit_cells import DEADBAND, HARD, NEUTRAL, SOFT
from nudgecli.report.habits import habits_of, measure_habits, summarise_habits

N, D, S, H = NEUTRAL, DEADBAND, SOFT, HARD

# --- time in the hard band per excursion -----------------------------------------------------------

#: An event-driven real log (a row per change), times in hundredths of a second: (time, label).
#: The Hard holds last 0.2 s (1.0-1.2), 0.1 s (2.0-2.1), 0.4 s (3.2-3.6), 0.2 s (3.7-3.9, after a
#: deadband cell: a second excursion of the same blow) and 0.2 s (4.25-4.45, off the 0.1 s grid:
#: read at 4.3 and 4.4).
HARD_LOG = [(0, "Zero Band"), (80, "Soft Puff"), (100, "Hard Puff"), (120, "Soft-Hard Puff Deadband"),
            (130, "Zero Band"), (200, "Hard Sip"), (210, "Zero Band"), (300, "Soft Sip"), (320, "Hard Sip"),
            (360, "Soft-Hard Sip Deadband"), (370, "Hard Sip"), (390, "input stopped"), (425, "Hard Puff"),
            (445, "Zero Band"), (500, "Zero Band")]


def loop_hard_excursions(rows: list[tuple[int, str]]) -> list[float]:
    """HABITS.md's "time in the hard band per excursion", one cell at a time.

    HABITS.md, "How they were measured": the label stream is held between events and read at
    t = 0, 0.1, 0.2 ... s, "so each real sample is a 0.1 s cell"; the habit is "a run of contiguous
    Hard cells", so a run of n Hard cells lasts n * 0.1 s. (The same reading makes its merge rule
    hold: "one or two neutral cells merge, three split" at "at most 0.25 s".)
    """
    end = rows[-1][0]
    labels = []
    for k in range(end // 10):  # the cell [k * 0.1, (k + 1) * 0.1) s holds the label read at its start
        labels.append([label for time, label in rows if time <= k * 10][-1])
    out, run = [], 0
    for label in [*labels, "Zero Band"]:
        if label.startswith("Hard"):
            run += 1
        elif run:
            out.append(round(run * 0.1, 6))
            run = 0
    return out


def test_the_time_in_the_hard_band_of_a_real_log_is_its_cells_at_0_1_s_each(tmp_path: Path) -> None:
    log = tmp_path / "hard.csv"
    log.write_text("t,trial,label,x,y,theta,mode_switch\n" +
                   "".join(f"{time / 100:.2f},1,{label},0,0,0,\n" for time, label in HARD_LOG))
    events = habits_of(log).events
    measured = events.loc[events["habit"] == "hard_band_per_excursion", "value"].tolist()
    # by hand: the holds' own lengths, each Hard cell 0.1 s (a single cell 0.1 s, not 0)
    assert measured == [0.2, 0.1, 0.4, 0.2, 0.2]
    assert measured == loop_hard_excursions(HARD_LOG)


# --- share of soft-blow time in the deadband ----------------------------------------------------------

#: Three people's trials as cell kinds. By hand (a soft blow holds no Hard cell; a gap of one or two
#: neutral cells is inside its blow and counts among its cells):
#: person 0: 1 deadband cell of 4, then 0 of 8 (the hard blow 12-13 not counted): 1/12;
#: person 1: cells 0-4 merged across one neutral cell, 2 of 5; cells 8-9 after a 3-cell split, 1 of 2: 3/7;
#: person 2: 1 of 4, 0 of 16, 2 of 4: 3/24.
#: Pooled: 7/43 (0.163). The mean of the people's shares (0.212) and of the trials' (0.238) differ.
PEOPLE = {
    0: [[N, S, S, D, S, N], [N, S, S, S, S, S, S, S, S, N, N, N, H, D, N]],
    1: [[S, D, D, N, S, N, N, N, D, S]],
    2: [[N, S, S, S, D, N], [S] * 16, [D, D, S, S]],
}


def loop_deadband_counts(trials: list[list[int]], gap_cells: int = 2) -> tuple[int, int]:
    """(deadband cells, all cells) of a person's soft blows, summed over their trials.

    HABITS.md, "Inside a soft blow": "deadband cells / all cells of soft blows (per person: summed
    over their 12 trials)"; a blow is "a run of non-neutral cells, merged across neutral gaps of at
    most 0.25 s", a soft blow one "without a Hard cell".
    """
    deadband = cells = 0
    for kinds in trials:
        blows: list[list[int]] = []  # [first, last] cells
        for i, kind in enumerate(kinds):
            if kind == N:
                continue
            if blows and i - blows[-1][1] - 1 <= gap_cells:
                blows[-1][1] = i
            else:
                blows.append([i, i])
        for first, last in blows:
            blow = kinds[first:last + 1]
            if H not in blow:
                deadband += blow.count(D)
                cells += len(blow)
    return deadband, cells


def test_the_deadband_share_is_a_ratio_per_person_and_one_pooled_over_everyones_cells() -> None:
    cells = pd.concat([pd.DataFrame({"participant": person, "trial": k, "kind": kinds, "moving": False,
                                     "switch": False, "at_waypoint": False, "waypoints_known": True})
                       for person, trials in PEOPLE.items() for k, kinds in enumerate(trials)],
                      ignore_index=True)
    result = summarise_habits(measure_habits(cells), "three people")
    counts = {person: loop_deadband_counts(trials) for person, trials in PEOPLE.items()}
    own = {person: Fraction(d, n) for person, (d, n) in counts.items()}
    assert own == {0: Fraction(1, 12), 1: Fraction(3, 7), 2: Fraction(3, 24)}  # by hand, as above

    people = result.people[result.people["habit"] == "deadband_share_soft_blows"].set_index("participant")
    for person, share in own.items():
        assert math.isclose(people.loc[person, "median"], float(share), abs_tol=1e-6)
    pooled = result.pooled.set_index("habit").loc["deadband_share_soft_blows"]
    # HABITS.md's "0.083 (pooled)": everyone's deadband cells over everyone's soft-blow cells
    assert math.isclose(pooled["median"], 7 / 43, abs_tol=1e-6)
    # HABITS.md's "range of the 10 people": that of the per-person ratios
    assert math.isclose(pooled["people_min"], 1 / 12, abs_tol=1e-6)
    assert math.isclose(pooled["people_max"], 3 / 7, abs_tol=1e-6)
    assert pooled["participants"] == 3
