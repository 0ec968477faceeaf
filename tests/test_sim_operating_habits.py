"""The operating habits of real sip-and-puff users in the simulated person (issue 19): a planning
latency, a reaction delay at every visible event, hard blows as short pulses, blowing on after the
robot stopped, a per-person tail of pauses, and mode errors noticed after a reaction. Each mechanism
on a hand-built situation whose right timing is known, and each switch restores the earlier person."""

from __future__ import annotations

import copy
from dataclasses import dataclass, replace

import numpy as np
import pytest
from scipy import stats

from nudgecli.config import BehaviourSection, PopulationSection
from nudgecli.model.interface import (
    HARD_PUFF,
    MOVE_P,
    NO_INPUT,
    SOFT_PUFF,
    TO_MODE_R,
    human_velocity,
    label_of_pressure,
    switch_mode,
)
from nudgecli.model.path_world import PathWorld
from nudgecli.model.world import N_MODES, N_STATES, GridWorld, discretise, grid_next_mark, state_index
from nudgecli.sim.behaviour import SimulatedPerson
from nudgecli.sim.behaviour_settings import BehaviourSettings
from nudgecli.sim.ciaa import packaged_task, task_layouts
from nudgecli.sim.participants import Participant, draw_participant, mapping_with_error
from nudgecli.sim.pressure_model import lognormal_delays, pulse_fractions

DT = 0.1
SPEED = 3.0  # units/s of a soft command in the hand-driven robot below
ALL_ON = dict(event_reactions=True, planning=True, hard_pulses=True, hold_on=True, pause_tail=False,
              notice_mode_errors=True)


@dataclass
class View:
    x: float
    y: float
    theta: float
    mode: int

    @property
    def state(self) -> int:
        i, j, h = discretise(self.x, self.y, self.theta)
        return int(state_index(i, j, h, self.mode))


class StopAtMark:
    """A world whose marks are the grid's and where the robot cannot go on past ``stop_x``."""

    def __init__(self, stop_x: float) -> None:
        self.stop_x = stop_x

    def next_mark(self, coordinate: float, direction: float, axis: int) -> float:
        return grid_next_mark(coordinate, direction, axis)

    def holds_still(self, x: float, y: float, theta: float, velocity: np.ndarray) -> bool:
        return x >= self.stop_x - 1e-9 and float(velocity[0]) > 0


def exact_participant(**habits: float) -> Participant:
    """Noise-free pressures (0.15 soft, 0.8 hard), no onset ramp, the true mapping, epsilon 0."""
    values = dict(rest_s=0.5, operate_s=60.0, action_pause_s=0.2, hard_blow_s=0.5, reaction_s=1.0,
                  planning_s=2.3, event_reaction_s=1.0, event_reaction_log_sd=0.0, hold_on_s=0.3,
                  hard_peak_s=0.2, offset_ramp_samples=0)
    values.update(habits)
    return Participant(index=0, seed_key="test", pressure_level=np.array([-0.8, 0.8, -0.15, 0.15]),
                       pressure_spread=np.zeros(4), mapping=mapping_with_error(0.0), epsilon=0.0, **values)


def settings_with(**switches: bool) -> BehaviourSettings:
    return BehaviourSettings(dt=DT, rest_jitter=0.0, operate_jitter=0.0, pause_jitter=0.0,
                             hard_blow_jitter=0.0,
                             planning_jitter=0.0, hold_on_jitter=0.0, **{**ALL_ON, **switches})


def person(policy: np.ndarray, participant: Participant, settings: BehaviourSettings, world: object = None,
           seed: int = 0) -> SimulatedPerson:
    goal = (40.0, 30.0, 0.0)
    i, j, h = discretise(*goal)
    goal_cell = int(state_index(i, j, h, 0)) // N_MODES
    return SimulatedPerson(participant, settings, policy, np.array(goal), goal_cell,
                           np.random.default_rng(seed), world=world)  # type: ignore[arg-type]


def drive(p: SimulatedPerson, view: View, steps: int, world: StopAtMark | None = None) -> list[int]:
    """The driver's side, by hand: soft x commands move the robot, a hard label switches the mode
    once per blow (until a no-input sample); returns the measured labels."""
    labels, locked = [], False
    for _ in range(steps):
        _, pressure = p.next_input(view)
        measured = label_of_pressure(pressure, 0.3, 0.5)
        labels.append(measured)
        if measured == NO_INPUT:
            locked = False
        elif measured in (HARD_PUFF,) and not locked:
            view.mode, locked = switch_mode(view.mode, measured), True
        elif measured == SOFT_PUFF and view.mode == 0 and not locked:
            velocity = human_velocity(SOFT_PUFF, 0, SPEED, 1.0)
            if world is None or not world.holds_still(view.x, view.y, view.theta, velocity):
                view.x += SPEED * DT
    return labels


def first_input(labels: list[int], start: int = 0) -> int:
    return next(k for k in range(start, len(labels)) if labels[k] != NO_INPUT)


# --- planning before the first command ---------------------------------------------------------

@pytest.mark.parametrize("planning", [True, False])
def test_the_first_command_comes_after_the_planning_latency_or_the_rest(planning: bool) -> None:
    p = person(np.full(N_STATES, MOVE_P), exact_participant(planning_s=2.3, rest_s=0.5),
               settings_with(planning=planning))
    p.start_turn(after_autonomy=False)
    labels = drive(p, View(20.0, 30.0, 0.0, 0), 40)
    assert first_input(labels) == (23 if planning else 5)
    # a later turn of the same trial (here: no reactions) rests again, it does not plan again
    p.settings = replace(p.settings, event_reactions=False)
    p.start_turn(after_autonomy=True)
    assert first_input(drive(p, View(20.0, 30.0, 0.0, 0), 20)) == 5


@pytest.mark.parametrize("reactions", [True, False])
def test_a_turn_handed_back_is_acted_on_after_a_reaction(reactions: bool) -> None:
    p = person(np.full(N_STATES, MOVE_P), exact_participant(event_reaction_s=1.2, rest_s=0.5),
               settings_with(event_reactions=reactions))
    p.start_turn(after_autonomy=False)
    drive(p, View(20.0, 30.0, 0.0, 0), 30)
    p.start_turn(after_autonomy=True)
    assert first_input(drive(p, View(20.0, 30.0, 0.0, 0), 30)) == (12 if reactions else 5)


# --- reactions to what they see ------------------------------------------------------------------

def switch_then_move_policy() -> np.ndarray:
    """Switch from mode x to mode y, then move (``move_p``) in mode y."""
    policy = np.full(N_STATES, MOVE_P)
    policy[np.arange(N_STATES) % N_MODES == 0] = TO_MODE_R
    return policy


@pytest.mark.parametrize("reactions", [True, False])
def test_the_next_blow_after_a_mode_switch_waits_for_the_reaction(reactions: bool) -> None:
    p = person(switch_then_move_policy(), exact_participant(planning_s=0.0, event_reaction_s=1.0),
               settings_with(event_reactions=reactions))
    p.start_turn(after_autonomy=False)
    view = View(20.0, 30.0, 0.0, 0)
    labels = drive(p, view, 40)
    assert labels[0] == HARD_PUFF and view.mode == 1
    switch_step = 0  # the mode changes with the first hard sample
    pulse_end = labels.index(NO_INPUT)
    nxt = first_input(labels, pulse_end)
    if reactions:
        assert nxt == switch_step + 1 + 10  # seen at the next step, acted on 1.0 s later
    else:
        assert nxt == pulse_end + 2  # only their 0.2 s release


def test_reaction_delays_follow_the_persons_log_normal() -> None:
    rng = np.random.default_rng(5)
    delays = lognormal_delays(0.9, 0.4, 20000, rng)
    shape, _, scale = stats.lognorm.fit(delays, floc=0)  # scipy: s is the log-sd, scale the median
    assert scale == pytest.approx(0.9, rel=0.02)
    assert shape == pytest.approx(0.4, rel=0.03)
    p = exact_participant(event_reaction_s=0.9, event_reaction_log_sd=0.4)
    draws = np.array([p.event_reaction(rng) for _ in range(4000)])
    assert np.median(draws) == pytest.approx(0.9, rel=0.05)
    assert np.std(np.log(draws)) == pytest.approx(0.4, rel=0.06)


@pytest.mark.parametrize("tail", [True, False])
def test_pauses_have_the_persons_tail_or_none(tail: bool) -> None:
    gaps = set()
    for seed in range(12):
        p = person(switch_then_move_policy(), exact_participant(planning_s=0.0, event_reaction_s=1.0,
                                                                event_reaction_log_sd=0.5),
                   settings_with(pause_tail=tail), seed=seed)
        p.start_turn(after_autonomy=False)
        labels = drive(p, View(20.0, 30.0, 0.0, 0), 60)
        gaps.add(first_input(labels, labels.index(NO_INPUT)))
    assert (len(gaps) > 3) if tail else (gaps == {11})


# --- hard pulses -----------------------------------------------------------------------------------

def test_pulse_fractions_by_hand() -> None:
    np.testing.assert_allclose(pulse_fractions(2, 2, 2), [1 / 3, 2 / 3, 1, 1, 2 / 3, 1 / 3])
    np.testing.assert_allclose(pulse_fractions(0, 1, 0), [1.0])
    np.testing.assert_allclose(pulse_fractions(1, 3, 3), [0.5, 1, 1, 1, 0.75, 0.5, 0.25])


@pytest.mark.parametrize("pulses", [True, False])
def test_a_mode_switch_is_a_short_pulse_with_an_offset_ramp(pulses: bool) -> None:
    participant = exact_participant(planning_s=0.0, hard_peak_s=0.2, hard_blow_s=0.6, offset_ramp_samples=2)
    participant = replace(participant, onset_ramp_samples=1)
    p = person(switch_then_move_policy(), participant, settings_with(hard_pulses=pulses))
    p.start_turn(after_autonomy=False)
    view = View(20.0, 30.0, 0.0, 0)
    pressures = []
    for _ in range(12):
        _, pressure = p.next_input(view)
        pressures.append(pressure)
    pulse = np.array(pressures[:pressures.index(0.0)])
    if pulses:  # onset 1 + peak 2 + offset 2, falling to the last sample
        np.testing.assert_allclose(pulse, -0.8 * pulse_fractions(1, 2, 2), rtol=2e-3)
    else:  # the earlier plateau of hard_blow_s: the onset ramp, then the level to the end
        np.testing.assert_allclose(pulse, -0.8 * np.array([0.5, 1, 1, 1, 1, 1]), rtol=2e-3)


# --- blowing on after the robot stopped ------------------------------------------------------------

@pytest.mark.parametrize("hold_on", [True, False])
def test_they_blow_on_after_the_robot_stops_at_a_mark(hold_on: bool) -> None:
    # the robot stops at the cell centre ahead (x = 21.9, one cell on); there the
    # plan is to switch mode
    world = StopAtMark(stop_x=grid_next_mark(18.0, 1.0, 0))
    policy = np.full(N_STATES, MOVE_P)
    i, j, h = discretise(world.stop_x, 30.0, 0.0)
    policy[int(state_index(i, j, h, 0))] = TO_MODE_R
    p = person(policy, exact_participant(planning_s=0.0, hold_on_s=0.3, event_reaction_s=1.0),
               settings_with(hold_on=hold_on), world=world)
    p.start_turn(after_autonomy=False)
    view = View(18.0, 30.0, 0.0, 0)
    labels = drive(p, view, 40, world=world)
    soft = [k for k, label in enumerate(labels[:labels.index(HARD_PUFF)]) if label == SOFT_PUFF]
    arrived = next(k for k in range(len(labels)) if 18.0 + SPEED * DT * (k + 1) >= world.stop_x - 1e-9)
    assert soft == list(range(0, arrived + 1 + (3 if hold_on else 0)))
    # then the switch comes a reaction after the arrival (at least one release sample after the hold-on)
    assert labels.index(HARD_PUFF) == arrived + 1 + 10


def test_the_worlds_say_where_a_command_holds_the_robot_still() -> None:
    from nudgecli.model.world import sample_layout

    layout = sample_layout(np.random.default_rng(0), "bl", 3, 0)
    grid = GridWorld(layout, 0.5, 0.2)
    assert not grid.holds_still(20.0, 30.0, 0.0, np.array([1.0, 0.0, 0.0]))
    right_wall = grid.move(20.0, 30.0, 0.0, np.array([1e6, 0.0, 0.0]), 1.0)
    assert grid.holds_still(right_wall[0], 30.0, 0.0, np.array([1.0, 0.0, 0.0]))
    assert not grid.holds_still(right_wall[0], 30.0, 0.0, np.array([-1.0, 0.0, 0.0]))
    # the path world: the probe agrees with a real step from a copy, for every command at every leg
    for layout in list(task_layouts(packaged_task()).values())[:3]:
        world = PathWorld(layout)
        x, y, theta = (float(v) for v in layout.start_pose)
        for _ in range(400):
            for velocity in np.eye(3).tolist() + (-np.eye(3)).tolist():
                v = np.array(velocity)
                probe = copy.deepcopy(world)
                moved = probe.move(x, y, theta, v, 0.1) != (x, y, theta)
                assert world.holds_still(x, y, theta, v) == (not moved)
            action = int(optimal_policy_step(world, layout))
            x, y, theta = world.move(x, y, theta, action_velocity(world, action), 0.1)
            if world.goal_reached(x, y, theta) >= 0:
                break


def optimal_policy_step(world: PathWorld, layout: object) -> int:
    mode, _ = world.allowed
    return mode


def action_velocity(world: PathWorld, mode: int) -> np.ndarray:
    _, direction = world.allowed
    v = np.zeros(3)
    v[mode] = direction * (1.6 if mode < 2 else 0.64)
    return v


# --- mode errors noticed after a reaction ------------------------------------------------------------

@pytest.mark.parametrize("notice", [True, False])
def test_an_unintended_switch_is_noticed_after_the_reaction(notice: bool) -> None:
    p = person(np.full(N_STATES, MOVE_P), exact_participant(planning_s=0.0, event_reaction_s=0.8),
               settings_with(notice_mode_errors=notice))
    p.start_turn(after_autonomy=False)
    view = View(20.0, 30.0, 0.0, 0)
    labels = drive(p, view, 3)
    assert labels == [SOFT_PUFF] * 3
    view.mode = 1  # the mode changes under their soft blow (a spike into the hard band)
    after = []
    for _ in range(15):
        _, pressure = p.next_input(view)
        after.append(label_of_pressure(pressure, 0.3, 0.5))
    held = after.index(NO_INPUT)
    # noticed at the step they first see it (0) plus 8 steps of reaction; else at once
    assert held == (8 if notice else 0)


# --- the population ------------------------------------------------------------------------------

def test_every_new_habit_is_drawn_inside_its_population_range() -> None:
    population = PopulationSection()
    for index in range(60):
        p = draw_participant(population, index, np.random.default_rng(index))
        for name in ("planning_s", "event_reaction_s", "event_reaction_log_sd", "hold_on_s", "hard_peak_s"):
            lo, hi = getattr(population, name)
            assert lo <= getattr(p, name) <= hi, name
        lo, hi = population.offset_ramp_samples
        assert lo <= p.offset_ramp_samples <= hi
    # a record without the new fields (a run folder from before them) still loads
    record = exact_participant().to_record()
    for name in ("planning_s", "event_reaction_s", "event_reaction_log_sd", "hold_on_s", "hard_peak_s",
                 "offset_ramp_samples"):
        record.pop(name)
    assert Participant.from_record(record).planning_s == 2.0
    full = exact_participant(offset_ramp_samples=2)
    assert Participant.from_record(full.to_record()) == full


def test_the_behaviour_keys_reach_the_person() -> None:
    from nudgecli.config import load_experiment

    config = load_experiment("ciaa-teleop", overrides=["behaviour.hold_on=false", "behaviour.planning=false"])
    settings = BehaviourSettings.from_config(config)
    assert (settings.hold_on, settings.planning, settings.event_reactions) == (False, False, True)
    defaults = BehaviourSection()
    assert all(getattr(defaults, key) for key in ALL_ON)
