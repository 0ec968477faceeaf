"""The simulated person's state machine (sim/behaviour.py) on hand-built situations whose right
action is known: rest, decisions at visible events, leaning on blending, letting go when blending
drags the robot away, the reaction to the autonomy's turn, and going idle to hand over."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pytest

from nudgecli.model.interface import (
    HARD_PUFF,
    MOVE_N,
    MOVE_P,
    NO_INPUT,
    SOFT_PUFF,
    SOFT_SIP,
    TO_MODE_L,
    TO_MODE_R,
    TRUE_MAPPING,
    human_command,
    label_of_pressure,
)
from nudgecli.model.world import CELL_WIDTH, N_MODES, N_STATES, X_MIN, discretise, state_index
from nudgecli.sim.behaviour import Phase, SimulatedPerson, mark_reached, move_action, next_centre
from nudgecli.sim.behaviour_settings import BehaviourSettings
from nudgecli.sim.participants import Participant, mapping_with_error

DT = 0.1
SPEED = 3.0  # units/s of a soft command


@dataclass
class View:
    """A robot the test moves by hand."""

    x: float
    y: float
    theta: float
    mode: int

    @property
    def state(self) -> int:
        i, j, h = discretise(self.x, self.y, self.theta)
        return int(state_index(i, j, h, self.mode))


def person_with(policy_action: int = MOVE_P, *, rest_s: float = 0.0, operate_s: float = 30.0,
                pause_s: float = 0.0, settings: BehaviourSettings | None = None,
                goal: tuple[float, float, float] = (40.0, 30.0, 0.0), seed: int = 0) -> SimulatedPerson:
    """An exact person: epsilon 0, the true mapping, noise-free pressures (0.15 soft, 0.8 hard)."""
    participant = Participant(index=0, seed_key="test", pressure_level=np.array([-0.8, 0.8, -0.15, 0.15]),
                              pressure_spread=np.zeros(4), mapping=mapping_with_error(0.0), epsilon=0.0,
                              rest_s=rest_s, operate_s=operate_s, action_pause_s=pause_s, hard_blow_s=0.3,
                              reaction_s=0.5)
    settings = settings or BehaviourSettings(dt=DT, rest_jitter=0.0, operate_jitter=0.0, pause_jitter=0.0,
                                             hard_blow_jitter=0.0)
    policy = np.full(N_STATES, policy_action)
    gx, gy, gth = goal
    i, j, h = discretise(gx, gy, gth)
    goal_cell = int(state_index(i, j, h, 0)) // N_MODES
    rng = np.random.default_rng(seed)
    return SimulatedPerson(participant, settings, policy, np.array(goal), goal_cell, rng)


def drive(person: SimulatedPerson, view: View, steps: int,
          extra: tuple[float, float] = (0.0, 0.0)) -> list[int]:
    """Run ``steps`` steps moving the robot like the driver would (soft x commands only, plus an
    ``extra`` (dx, dy) per step standing in for blending); return the measured labels."""
    labels = []
    for _ in range(steps):
        _, pressure = person.next_input(view)
        measured = label_of_pressure(pressure, 0.3, 0.5)
        labels.append(measured)
        if measured == SOFT_PUFF and view.mode == 0:
            view.x += SPEED * DT
        elif measured == SOFT_SIP and view.mode == 0:
            view.x -= SPEED * DT
        if measured != NO_INPUT:
            view.x += extra[0]
            view.y += extra[1]
    return labels


def test_marks_are_the_next_cell_centre_or_heading_strictly_ahead() -> None:
    centre = X_MIN + 2.5 * CELL_WIDTH  # the centre of cell 2 along x
    assert next_centre(centre, +1.0, 0) == pytest.approx(centre + CELL_WIDTH)
    assert next_centre(centre, -1.0, 0) == pytest.approx(centre - CELL_WIDTH)
    assert next_centre(centre + 0.1, -1.0, 0) == pytest.approx(centre)
    assert next_centre(0.0, -1.0, 2) == pytest.approx(-np.pi / 4)  # clockwise from 0: 315 degrees
    assert mark_reached(6.0, 6.2, -1.0, 2)  # 6.0 rad is past 6.2 going clockwise
    assert mark_reached(6.25, 6.2, +1.0, 2) and not mark_reached(6.15, 6.2, +1.0, 2)
    assert mark_reached(17.7, 17.7, +1.0, 0) and not mark_reached(17.6, 17.7, +1.0, 0)


def test_rests_then_operates_and_goes_idle_after_operating() -> None:
    person = person_with(rest_s=0.5, operate_s=1.0)
    person.start_turn(after_autonomy=False)
    view = View(13.5, 7.1, 0.0, 0)
    labels = drive(person, view, 30)
    assert labels[:5] == [NO_INPUT] * 5  # 0.5 s of rest
    assert labels[5] == SOFT_PUFF
    # operating time (1 s) is up during the first move: they finish it (one cell, 4.2 units at
    # 3 units/s: 14 samples) and then stay idle
    assert labels[5:19] == [SOFT_PUFF] * 14 and labels[19:] == [NO_INPUT] * 11
    assert person.phase is Phase.IDLE


def test_events_decide_at_the_next_cell_centre_grid_at_the_boundary() -> None:
    """From the centre of cell 2 (x = 13.5) moving +x: the next centre is 17.7, the boundary 15.6."""
    decided: dict[str, list[float]] = {}
    for mode in ("events", "grid"):
        settings = BehaviourSettings(dt=DT, decisions=mode, rest_jitter=0.0, operate_jitter=0.0)
        person = person_with(settings=settings)
        positions = []
        original = person._decide

        def spy(view, original=original, positions=positions):
            positions.append(round(view.x, 6))
            return original(view)

        person._decide = spy  # type: ignore[method-assign]
        person.start_turn(after_autonomy=False)
        drive(person, View(13.5, 7.1, 0.0, 0), 20)
        decided[mode] = positions
    assert decided["events"][:2] == [13.5, 17.7]
    assert decided["grid"][:2] == [13.5, 15.6]


def test_a_person_notices_the_robot_going_the_wrong_way() -> None:
    """They meant move_n (-x), their mapping produced a Soft Puff (+x): they decide again at once."""
    person = person_with(MOVE_N)
    person.start_turn(after_autonomy=False)
    view = View(13.5, 7.1, 0.0, 0)
    person.next_input(view)  # first decision: Soft Sip (the true mapping) ...
    person.held_label = SOFT_PUFF  # ... stand in for a mapping slip
    person.blow = np.full(30, -0.15)
    view.x += SPEED * DT  # the robot went +x
    assert person._decision_due(view)
    assert not person._decision_due(replace(view, x=view.x - 2 * SPEED * DT))


def _holding_x_puff(settings: BehaviourSettings, policy_action: int) -> tuple[SimulatedPerson, View]:
    person = person_with(policy_action, settings=settings, goal=(30.0, 20.0, 0.0))
    person.start_turn(after_autonomy=False)
    view = View(13.5, 7.1, 0.0, 0)
    person.next_input(view)
    person.held_label, person.held_action, person.hold_mode, person.hold_axis = SOFT_PUFF, MOVE_P, 0, 0
    person.hold_direction, person.hold_target = 1.0, 17.7
    person.blow = np.full(60, -0.15)
    person.blow_pos = 0
    return person, view


@pytest.mark.parametrize("lean", [True, False])
def test_leaning_on_blending_keeps_the_command_instead_of_switching_mode(lean: bool) -> None:
    settings = BehaviourSettings(dt=DT, lean_on_blending=lean, rest_jitter=0.0, operate_jitter=0.0)
    person, view = _holding_x_puff(settings, TO_MODE_R)
    # blending moved the robot diagonally towards the goal at (30, 20); the policy says "switch mode"
    person.previous_pose = (view.x, view.y, view.theta)
    view.x, view.y = 17.7, 8.0
    intended, _ = person.next_input(view)
    if lean:
        assert intended == SOFT_PUFF and person.held_action == MOVE_P
    else:
        assert person.held_label == HARD_PUFF and person.held_action == TO_MODE_R


def test_no_leaning_without_blending_or_when_it_does_not_help() -> None:
    settings = BehaviourSettings(dt=DT, rest_jitter=0.0, operate_jitter=0.0)
    person, view = _holding_x_puff(settings, TO_MODE_R)
    person.previous_pose = (view.x, view.y, view.theta)
    view.x = 17.7  # moved along x only: the person's own command, no blending seen
    person.next_input(view)
    assert person.held_label == HARD_PUFF


@pytest.mark.parametrize("release", [True, False])
def test_blending_that_drags_the_robot_away_makes_them_let_go(release: bool) -> None:
    settings = BehaviourSettings(dt=DT, release_when_dragged=release, rest_jitter=0.0, operate_jitter=0.0)
    person, view = _holding_x_puff(settings, MOVE_P)
    person.previous_pose = (view.x, view.y, view.theta)
    view.x, view.y = view.x + 0.1, view.y - 0.6  # blending pulled the robot away from (30, 20)
    intended, _ = person.next_input(view)
    if release:  # a new blow: one sample released first, then Soft Puff again
        assert intended == NO_INPUT
        assert person.next_input(view)[0] == SOFT_PUFF
    else:
        assert intended == SOFT_PUFF


@pytest.mark.parametrize("after", ["replan", "resume"])
def test_after_the_autonomys_turn_replan_or_resume(after: str) -> None:
    settings = BehaviourSettings(dt=DT, after_autonomy=after, rest_jitter=0.0, operate_jitter=0.0)
    person = person_with(MOVE_N, settings=settings)
    person.last_action = MOVE_P  # they were moving +x before the autonomy's turn
    person.start_turn(after_autonomy=True)
    person.next_input(View(13.5, 7.1, 0.0, 0))
    assert person.held_action == (MOVE_N if after == "replan" else MOVE_P)
    # the resumed action is used once; the next decision follows the policy
    assert person.resume_action == -1


def test_a_new_turn_draws_its_own_rest() -> None:
    settings = BehaviourSettings(dt=DT, rest_jitter=0.5)
    person = person_with(rest_s=2.0, settings=settings)
    rests = set()
    for _ in range(20):
        person.start_turn(after_autonomy=False)
        rests.add(person.rest_left)
    assert len(rests) > 5 and min(rests) >= 10 and max(rests) <= 30  # 2 s x U(0.5, 1.5) at 10 Hz


def test_two_hard_blows_are_separated_by_a_release() -> None:
    """Two mode switches in a row: the driver needs an 'input stopped' between them."""
    person = person_with(TO_MODE_R)
    person.start_turn(after_autonomy=False)
    view = View(13.5, 7.1, 0.0, 0)
    labels = []
    for _ in range(12):
        labels.append(person.next_input(view)[0])
    first_release = labels.index(NO_INPUT)
    assert labels[:first_release] == [HARD_PUFF] * 3  # 0.3 s blow
    assert labels[first_release + 1] == HARD_PUFF


def test_a_held_soft_blow_drifts_on_across_decisions() -> None:
    """A soft command held through several decisions is one blow: its pressure drifts on from the
    last sample (lag-1 correlation 0.99), it does not jump to a fresh draw at each cell centre."""
    person = person_with()
    person.participant = replace(person.participant, pressure_spread=np.full(4, 0.02), drift_correlation=0.99)
    person.start_turn(after_autonomy=False)
    view = View(13.5, 7.1, 0.0, 0)
    pressures = []
    decisions = 0
    original = person._decide

    def count(view: View) -> int:
        nonlocal decisions
        decisions += 1
        return original(view)

    person._decide = count  # type: ignore[method-assign]
    for _ in range(80):
        label, pressure = person.next_input(view)
        assert label == SOFT_PUFF
        pressures.append(pressure)
        view.x += SPEED * DT
    assert decisions >= 5  # a decision at every cell centre, each continuing the same blow
    # within the blow a step moves 0.02 * sqrt(2 * 0.01) = 0.0028 (sd); a fresh draw would move ~0.028
    assert np.max(np.abs(np.diff(pressures))) < 0.015


@pytest.mark.parametrize("stall_steps", [0, 10])
def test_a_robot_that_stands_still_is_noticed_after_the_stall_time(stall_steps: int) -> None:
    """A soft command under which the robot does not move (a wall, a disallowed direction, a
    deadband reading) is let go after ``stall_steps`` still steps and tried again with a new blow;
    with 0 it is held for ``max_hold_s``."""
    settings = BehaviourSettings(dt=DT, rest_jitter=0.0, operate_jitter=0.0, pause_jitter=0.0,
                                 hard_blow_jitter=0.0, stall_steps=stall_steps, max_hold_steps=30)
    person = person_with(settings=settings, pause_s=0.2)
    person.start_turn(after_autonomy=False)
    view = View(13.5, 7.1, 0.0, 0)  # never moved by the test: the robot stands still
    labels = [person.next_input(view)[0] for _ in range(40)]
    if stall_steps:
        # steps 1..10 see a robot that did not move: the hold ends at step 10 (1 s of standing still)
        assert labels[:10] == [SOFT_PUFF] * 10
        assert labels[10:12] == [NO_INPUT] * 2 and labels[12] == SOFT_PUFF  # a 0.2 s release, a new blow
    else:
        assert labels == [SOFT_PUFF] * 40  # re-decided at max_hold_s, and the same blow goes on


def test_the_stall_time_is_an_experiment_key() -> None:
    from nudgecli.config import load_experiment

    assert BehaviourSettings.from_config(load_experiment("paper")).stall_steps == 10  # 1 s at 10 Hz
    off = load_experiment("paper", ["behaviour.stall_s=0"])
    assert BehaviourSettings.from_config(off).stall_steps == 0


def test_the_longest_hold_defaults_to_the_behaviour_sections_seconds_at_any_step_length() -> None:
    # one rule for seconds -> steps, shared with from_config; a written-out 30 held only at 10 Hz
    from nudgecli.config_people import BehaviourSection

    seconds = BehaviourSection().max_hold_s
    for dt in (0.1, 0.05, 0.2):
        assert BehaviourSettings(dt=dt).max_hold_steps == max(1, round(seconds / dt))
    assert BehaviourSettings(dt=0.1, max_hold_steps=7).max_hold_steps == 7


def test_operating_time_runs_out_only_after_its_last_sample() -> None:
    # 1.5 s of operating is 15 samples: the decision at the 15th (the end of the first one-cell
    # move, 14 samples on) is still inside it, so they start a second move and go idle at its end
    person = person_with(rest_s=0.0, operate_s=1.5)
    person.start_turn(after_autonomy=False)
    labels = drive(person, View(13.5, 7.1, 0.0, 0), 40)
    assert labels[:28] == [SOFT_PUFF] * 28 and labels[28:] == [NO_INPUT] * 12
    assert person.phase is Phase.IDLE


def test_a_random_action_is_any_of_the_four() -> None:
    # epsilon 1: every decision is the uniform random action of Eq. 1, over all four actions
    person = person_with(MOVE_P)
    person.participant = replace(person.participant, epsilon=1.0)
    view = View(13.5, 7.1, 0.0, 0)
    actions = [person._policy_action(view)[0] for _ in range(4000)]
    counts = np.bincount(actions, minlength=4)
    assert counts.size == 4 and np.all(np.abs(counts / 4000 - 0.25) < 0.03), counts


@pytest.mark.parametrize("mode", [0, 1, 2])
@pytest.mark.parametrize("error", [-0.7, 0.4])
def test_move_action_commands_the_robot_towards_the_error(mode: int, error: float) -> None:
    # the action's label under the true mapping moves the robot along the active axis with the
    # sign of the error (theta: move_p turns clockwise, so a positive error needs move_n)
    label = int(TRUE_MAPPING[move_action(mode, error)])
    velocity = human_command(label, mode, 1.0, 1.0)
    assert np.sign(velocity[mode]) == np.sign(error)


def test_a_person_notices_the_robot_turning_the_wrong_way() -> None:
    """Theta mode: they meant move_p (clockwise, theta falls), a Soft Sip turned it anticlockwise."""
    person = person_with(MOVE_P)
    person.start_turn(after_autonomy=False)
    view = View(13.5, 7.1, 1.0, 2)
    person.next_input(view)  # first decision: Soft Puff, a clockwise turn ...
    assert person.held_action == MOVE_P and person.hold_axis == 2
    person.held_label = SOFT_SIP  # ... stand in for a mapping slip
    person.blow = np.full(30, 0.15)
    assert person._decision_due(replace(view, theta=1.1))  # the robot turned anticlockwise
    assert not person._decision_due(replace(view, theta=0.9))  # clockwise, as they meant


def test_jitter_spreads_both_ways_around_the_habit() -> None:
    # rest 2 s x U(0.5, 1.5) at 10 Hz: rests from 10 to 30 steps, about half of them above 20
    person = person_with(rest_s=2.0, settings=BehaviourSettings(dt=DT, rest_jitter=0.5))
    rests = []
    for _ in range(400):
        person.start_turn(after_autonomy=False)
        rests.append(person.rest_left)
    rests = np.array(rests)
    assert rests.min() >= 10 and rests.max() <= 30
    assert abs(rests.mean() - 20.0) < 1.0  # standard error of the mean: 5.8 / sqrt(400) = 0.29
    assert 0.4 < (rests > 20).mean() < 0.6


def test_fine_positioning_uses_each_axis_tolerance() -> None:
    # position tolerance 0.5 on x and y, heading tolerance 0.15: a y error of 0.3 needs nothing,
    # a heading error of 0.3 needs a turn
    person = person_with(goal=(40.0, 30.0, 0.0))
    s = person.settings
    assert s.fine_heading_tolerance < 0.3 < s.fine_position_tolerance
    assert person._fine_action(View(40.0, 29.7, 0.0, 1)) is None
    assert person._fine_action(View(40.0, 30.0, -0.3, 2)) == move_action(2, 0.3)


@pytest.mark.parametrize(("mode", "target"), [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)])
def test_fine_positioning_switches_to_the_needed_mode_in_one_step(mode: int, target: int) -> None:
    # the only remaining error lies on `target`'s axis; to_mode_r cycles the mode +1, to_mode_l -1
    errors = {0: (39.0, 30.0, 0.0), 1: (40.0, 29.0, 0.0), 2: (40.0, 30.0, -0.3)}
    x, y, theta = errors[target]
    person = person_with(goal=(40.0, 30.0, 0.0))
    action = person._fine_action(View(x, y, theta, mode))
    assert action in (TO_MODE_R, TO_MODE_L)
    assert (mode + (1 if action == TO_MODE_R else -1)) % N_MODES == target


@pytest.mark.parametrize(("axis", "target"), [(0, 17.7), (1, 9.0), (2, 0.785), (2, 6.2)])
@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_a_soft_hold_ends_at_its_mark_by_mark_reached(axis: int, target: float, direction: float) -> None:
    # _decision_due has mark_reached written out: held to it, at the mark, around it, and for a NaN
    settings = BehaviourSettings(dt=DT, rest_jitter=0.0, operate_jitter=0.0, hold_on=False)
    person, view = _holding_x_puff(settings, MOVE_P)
    person.hold_mode = view.mode = axis
    person.hold_axis, person.hold_direction, person.hold_target = axis, direction, target
    person.previous_pose = None  # no motion seen: only the mark decides
    offsets = [0.0, 1e-10, -1e-10, 2e-9, -2e-9, 0.3, -0.3, 3.0, -3.0, 6.1, -6.1, 6.3, float("nan")]
    for offset in offsets:
        coordinate = target + offset
        moved = replace(view, **{("x", "y", "theta")[axis]: coordinate})
        assert person._decision_due(moved) == mark_reached(coordinate, target, direction, axis), offset
