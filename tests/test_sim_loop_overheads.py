"""The trial loop's written-out paths (issue 39 item 2) where the presets do not reach them: the
hold-on after the robot stopped at a mark spends the hold's samples like any held sample, so a
hold whose samples run out ends the hold-on early."""

from __future__ import annotations

import numpy as np
import pytest

from nudgecli.model.interface import HARD_PUFF, MOVE_P, SOFT_PUFF, TO_MODE_R
from nudgecli.model.world import N_STATES, discretise, grid_next_mark, state_index
from tests.test_sim_operating_habits import (
    DT,
    SPEED,
    StopAtMark,
    View,
    drive,
    exact_participant,
    person,
    settings_with,
)


@pytest.mark.parametrize("left_at_arrival", [1, 2, 3, 30])
def test_a_hold_on_ends_when_the_holds_samples_run_out(left_at_arrival: int) -> None:
    # as test_they_blow_on_after_the_robot_stops_at_a_mark (a hold-on of 3 samples, 0.3 s), with
    # the hold's samples (max_hold_steps) running out left_at_arrival samples after the arrival
    world = StopAtMark(stop_x=grid_next_mark(18.0, 1.0, 0))
    policy = np.full(N_STATES, MOVE_P)
    i, j, h = discretise(world.stop_x, 30.0, 0.0)
    policy[int(state_index(i, j, h, 0))] = TO_MODE_R
    arrived = next(k for k in range(100) if 18.0 + SPEED * DT * (k + 1) >= world.stop_x - 1e-9)
    settings = settings_with(hold_on=True)
    object.__setattr__(settings, "max_hold_steps", arrived + 1 + left_at_arrival)
    p = person(policy, exact_participant(planning_s=0.0, hold_on_s=0.3, event_reaction_s=1.0), settings,
               world=world)
    p.start_turn(after_autonomy=False)
    labels = drive(p, View(18.0, 30.0, 0.0, 0), 40, world=world)
    soft = [k for k, label in enumerate(labels[:labels.index(HARD_PUFF)]) if label == SOFT_PUFF]
    # the samples up to the arrival, then the hold-on's samples while the hold has any: the step
    # that sees the mark is the hold-on's first (it decides nothing), and each hold-on step spends
    # one of the hold's samples
    blown_on = min(3, left_at_arrival)
    assert soft == list(range(0, arrived + 1 + blown_on))
