"""A twin's reactions are read from events that are reactions, as the simulator makes them
(``_saw_event``, ``_decide``, ``sim/behaviour.py``): a reaction ends in the first blow after a
release (a stop -> switch with none, a soft blow straying hard as the robot stops, is no reaction),
and that blow starts when the reaction ends or after the person's own pause, whichever is later (a
pause hides a shorter reaction: a censored observation). Hand-built cells and figures (fast)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from nudgecli.report.twin_sources import reaction_releases
from nudgecli.sim.twin_fit import (
    HabitFigures,
    Mechanics,
    censored_lognormal,
    fit_twin,
    reaction_observations,
    released_median,
)

N, DB, S, H = 0, 1, 2, 3  # neutral, deadband, soft, hard cells


def _trial(trial: str, kinds: list[int], moving: list[int], switch: list[int], waypoint: int) -> pd.DataFrame:
    n = len(kinds)
    return pd.DataFrame({"participant": "p", "trial": trial, "kind": kinds,
                         "moving": [bool(m) for m in moving], "switch": [bool(s) for s in switch],
                         "at_waypoint": [i == waypoint for i in range(n)], "waypoints_known": True})


def test_each_reaction_event_carries_the_release_before_the_blow_that_ends_it() -> None:
    # a stop, 0.2 s of hold-on, a 0.3 s release, a pulse (onset, switch), 0.2 s release, a soft blow
    reacted = _trial("1", [S, S, S, S, S, S, N, N, N, S, H, H, N, N, S, S],
                     [1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 1],
                     [0] * 10 + [1] + [0] * 5, waypoint=3)
    # a soft blow straying hard as the robot stops: the switch with no release, then 0.1 s and a blow
    strayed = _trial("2", [S, S, S, S, H, N, S, S], [1, 1, 1, 1, 0, 0, 1, 1],
                     [0, 0, 0, 0, 1, 0, 0, 0], waypoint=3)
    found = reaction_releases(pd.concat([reacted, strayed], ignore_index=True), 10.0)
    # (as measured, from the event's start to the blow after the first release, that release)
    assert found["p", "reaction_stop_to_switch"] == [pytest.approx((0.6, 0.5, 0.3)), (0.0, 0.0, 0.0)]
    # the switch is seen the step after it: 0.3 s to the soft blow after a 0.2 s release
    assert found["p", "reaction_switch_to_motion"] == [pytest.approx((0.4, 0.3, 0.2)),
                                                       pytest.approx((0.2, 0.1, 0.1))]


def test_a_reaction_ends_at_the_first_blow_after_its_release() -> None:
    """A blow that goes nowhere between the stop and the switch (a move the waypoint does not allow,
    then a stall and a new reaction): the stop's reaction ended when that blow started (0.5 s), not
    at the switch 2 s later, which the event measures."""
    kinds = [S, S, S, S, S, N, N, N, S] + [S] * 10 + [N] * 5 + [H, H, N]
    moving = [1, 1, 1, 1] + [0] * (len(kinds) - 4)
    switch = [0] * 24 + [1, 0, 0]
    found = reaction_releases(_trial("1", kinds, moving, switch, waypoint=3), 10.0)
    assert found["p", "reaction_stop_to_switch"] == [pytest.approx((2.0, 0.4, 0.3))]


def test_events_with_no_release_are_no_reactions() -> None:
    """The pilot run's person 2 (``ciaa-teleop --participants 3 --seed 2020``): a quarter of her
    stop -> switch events were 0-0.1 s with no release, which made her event_reaction_s 0.68 s (true
    0.83 s; 0.81 s read as reactions). Here: three switches with no release among reactions of
    0.8-1.1 s; their median is 1.0 s, all events' 0.85 s."""
    values = (0.0, 0.1, 0.0, 0.8, 0.9, 1.0, 1.1, 1.0)
    releases = (0.0, 0.0, 0.0, 0.3, 0.4, 0.5, 0.6, 0.5)
    stop = HabitFigures(8, 0.85, 0.075, 1.0, values=values, blow_after=values, releases=releases)
    assert released_median(stop) == pytest.approx(1.0)
    motion = HabitFigures(8, 1.0, 0.8, 1.3)  # a habits table: its median, as given
    assert released_median(motion) == 1.0
    pulse = {"hard_band_per_excursion": HabitFigures(40, 0.3), "hard_blow_whole": HabitFigures(40, 0.5)}
    mechanics = Mechanics()
    offsets = mechanics.reaction_offsets(2, 1)
    both = fit_twin({"reaction_stop_to_switch": stop, "reaction_switch_to_motion": motion, **pulse},
                    mechanics=mechanics)["event_reaction_s"]
    expected = (1.0 - offsets["reaction_stop_to_switch"] + 1.0 - offsets["reaction_switch_to_motion"]) / 2
    assert both == pytest.approx(expected, abs=0.03)  # the fitted pulse's offsets, near 2 and 1's
    all_events = (0.85 - offsets["reaction_stop_to_switch"] + 1.0 - offsets["reaction_switch_to_motion"]) / 2
    assert both > all_events + 0.02


def _simulated_reactions(rng: np.random.Generator, median: float, log_sd: float, before: np.ndarray,
                         reads_after: np.ndarray, offset: np.ndarray) -> HabitFigures:
    """Reaction events as the simulator makes them: the next blow after ``max(before + pause,
    reaction)`` (``before``: the hold-on, or the pulse's rest), read ``reads_after`` later (a soft
    blow's first samples may read no input), ``offset`` later the event's end."""
    n = len(before)
    reaction = np.round(median * np.exp(log_sd * rng.standard_normal(n)) / 0.1) * 0.1
    pause = rng.integers(1, 7, n) * 0.1  # [population] action_pause_s 0.1-0.4, jittered by half
    blow = np.maximum(before + pause, reaction) + reads_after
    return HabitFigures(n, float(np.median(blow + offset)), values=tuple(blow + offset),
                        blow_after=tuple(blow), releases=tuple(blow - before))


def test_a_pause_that_hides_a_short_reaction_is_a_censored_observation() -> None:
    """A person of 0.5 s reactions (log-sd 0.35) whose pauses (0.1-0.6 s) after a hold-on or the
    pulse's rest hide most of them: the events' medians less their offsets read 0.6 s; the censored
    likelihood's median, 0.49 s (0.48-0.55 s over other seeds of these draws)."""
    rng = np.random.default_rng(29)
    mechanics = Mechanics()
    # the switch: the pulse's onset samples below the hard band (1.4 on average, as the population's);
    # the motion: seen a step after the switch, and a soft blow's first samples that read no input
    onset = rng.choice([0.1, 0.2], 600, p=[0.6, 0.4])
    reads = rng.choice(mechanics.draws.motion_wait, 600) * 0.1
    stop = _simulated_reactions(rng, 0.5, 0.35, rng.integers(1, 4, 600) * 0.1, np.zeros(600), onset)
    motion = _simulated_reactions(rng, 0.5, 0.35, rng.integers(1, 3, 600) * 0.1, reads, np.full(600, 0.1))
    pulse = {"hard_band_per_excursion": HabitFigures(40, 0.3), "hard_blow_whole": HabitFigures(40, 0.5)}
    habits = {"reaction_stop_to_switch": stop, "reaction_switch_to_motion": motion, **pulse}
    exact, bounds = reaction_observations(habits, mechanics)
    assert len(bounds) > len(exact) > 50  # most read only as at most so long
    median, _ = censored_lognormal(exact, bounds, (0.27, 0.42), 0.05)
    assert median == pytest.approx(0.5, abs=0.05)
    assert fit_twin(habits, mechanics=mechanics)["event_reaction_s"] == pytest.approx(median)
    old_rule = (stop.median - 0.14 + motion.median - 0.15) / 2  # the events' medians less their offsets
    assert old_rule > 0.58
