"""Quiet runs: the steps a simulated person certainly gives no input in run at once
(``run_session(quiet_runs=True)``, the default), and give the same trials, step for step, as
asking the person at every step."""

from __future__ import annotations

import copy
import dataclasses
import functools
from types import SimpleNamespace
from typing import Any

import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_sim_behaviour import DT, View, person_with

from nudgecli.config import load_experiment
from nudgecli.model.interface import NO_INPUT
from nudgecli.sim import trials
from nudgecli.sim.behaviour import Phase, SimulatedPerson
from nudgecli.sim.behaviour_settings import BehaviourSettings
from nudgecli.sim.study import StudyPlan, simulate_participant

#: Each preset's conditions, and settings the presets leave off: a start-up delay, the entropy
#: gate and distance weighting on alpha without the belief's decay (study-code decays), and no
#: handover (teleoperation only), so every rule a quiet run holds constant is exercised.
CASES = [
    ("paper", (), (0, 3)),
    ("baselines", (), (1,)),
    ("study-code", (), (2,)),
    ("study-code", ("inference.decay=false",), (4,)),
    ("study-code", ("inference.decay_delay=1",), (5,)),
    ("ciaa-teleop", (), (0,)),
    ("smoke", ("assistance.startup_delay_s=0.35", "behaviour.planning=false"), (0, 1)),
]

_NEXT_INPUT = SimulatedPerson.next_input  # the real one (the tests wrap it)


def _participant(plan: StudyPlan, index: int, quiet_runs: bool,
                 monkeypatch: pytest.MonkeyPatch) -> tuple[pd.DataFrame, pd.DataFrame, int]:
    """One participant's trials and steps, and how often the person was asked for an input."""
    asked = 0

    def counting(self: SimulatedPerson, view):  # type: ignore[no-untyped-def]
        nonlocal asked
        asked += 1
        return _NEXT_INPUT(self, view)

    with monkeypatch.context() as patch:
        patch.setattr(SimulatedPerson, "next_input", counting)
        if quiet_runs:
            _check_skips(patch)
        patch.setattr(trials, "run_session", functools.partial(trials.run_session, quiet_runs=quiet_runs))
        result = simulate_participant(plan, index)
    return result.trials, result.steps, asked


@pytest.mark.parametrize(("experiment", "overrides", "participants"), CASES)
def test_quiet_runs_give_the_same_trials_as_every_step_asked(experiment, overrides, participants,
                                                             monkeypatch) -> None:
    config = load_experiment(experiment, list(overrides))
    plan = StudyPlan.build(config, config.experiment.seed)
    for index in participants:
        every_trials, every_steps, every_asked = _participant(plan, index, False, monkeypatch)
        quiet_trials, quiet_steps, quiet_asked = _participant(plan, index, True, monkeypatch)
        pd.testing.assert_frame_equal(quiet_trials, every_trials, check_exact=True)
        pd.testing.assert_frame_equal(quiet_steps, every_steps, check_exact=True)
        # the quiet runs did happen: the person was not asked for their silent steps
        assert every_asked == int((every_steps["turn"] == "human").sum())
        assert quiet_asked < every_asked


def _person_state(person: SimulatedPerson) -> dict[str, Any]:
    state = {name: value for name, value in vars(person).items()
             if name not in ("rng", "world", "participant", "policy", "next_mark", "settings")}
    return {**state, "rng": person.rng.bit_generator.state}


def _check_skips(patch: pytest.MonkeyPatch) -> None:
    """Hold every ``skip_quiet`` to ``next_input`` asked as many times (on a copy of the person,
    the robot where the quiet run began), and its pose and mode to the run's start."""
    quiet_steps, skip_quiet = SimulatedPerson.quiet_steps, SimulatedPerson.skip_quiet  # the real ones
    started: dict[int, tuple[Any, ...]] = {}

    def asked(self: SimulatedPerson, view) -> int:  # type: ignore[no-untyped-def]
        started[id(self)] = (view.x, view.y, view.theta, view.mode)
        return quiet_steps(self, view)

    def checked(self: SimulatedPerson, steps: int, pose: tuple[float, float, float], mode: int) -> None:
        assert (*pose, mode) == started[id(self)]
        # a deep copy but for what the person only reads (their world, physiology and policy)
        every = copy.deepcopy(self, {id(v): v for v in (self.world, self.participant, self.policy)})
        view = SimpleNamespace(x=pose[0], y=pose[1], theta=pose[2], mode=mode)
        assert [_NEXT_INPUT(every, view) for _ in range(steps)] == [(NO_INPUT, 0.0)] * steps
        skip_quiet(self, steps, pose, mode)
        assert _person_state(self) == _person_state(every)

    patch.setattr(SimulatedPerson, "quiet_steps", asked)
    patch.setattr(SimulatedPerson, "skip_quiet", checked)


def test_a_release_pause_is_quiet_only_once_the_mode_on_display_was_seen() -> None:
    settings = BehaviourSettings(dt=DT, rest_jitter=0.0, operate_jitter=0.0, pause_jitter=0.0,
                                 hard_blow_jitter=0.0, event_reactions=True, pause_tail=False)
    person = person_with(pause_s=0.5, settings=settings)
    person.start_turn(after_autonomy=False)
    person.phase, person.pause_left, person.seen_mode, person.operate_left = Phase.OPERATING, 4, 0, 20
    assert person.quiet_steps(View(40.0, 30.0, 0.0, mode=0)) == 4
    switched = View(40.0, 30.0, 0.0, mode=1)  # the mode changed since the last step: an event
    assert person.quiet_steps(switched) == 0
    assert person.next_input(switched) == (NO_INPUT, 0.0) and person.react_at >= 0  # the step in full
    assert person.quiet_steps(switched) == 3


def test_resting_and_idling_are_quiet() -> None:
    person = person_with(rest_s=0.7)
    person.start_turn(after_autonomy=False)
    assert person.phase is Phase.RESTING and person.quiet_steps(View(40.0, 30.0, 0.0, mode=0)) == 7
    person.phase = Phase.IDLE
    assert person.quiet_steps(View(40.0, 30.0, 0.0, mode=0)) > 10**9  # until the turn ends


@st.composite
def _settings(draw: st.DrawFn) -> list[str]:
    """``--set`` overrides of the paper experiment over every habit and rule a quiet run holds."""
    flags = ("event_reactions", "planning", "hard_pulses", "hold_on", "pause_tail", "notice_mode_errors",
             "lean_on_blending", "release_when_dragged")
    overrides = [f"behaviour.{flag}={str(draw(st.booleans())).lower()}" for flag in flags]
    decay, decay_delay = draw(st.booleans()), draw(st.sampled_from([0, 1, 3, 10]))
    overrides += [
        f"behaviour.decisions={draw(st.sampled_from(['events', 'grid']))}",
        f"behaviour.after_autonomy={draw(st.sampled_from(['replan', 'resume']))}",
        f"behaviour.stall_s={draw(st.sampled_from([0.0, 0.5, 1.0]))}",
        f"inference.update={draw(st.sampled_from(['action', 'sample']))}",
        f"inference.decay={str(decay).lower()}",
        # the delay is the decay's: without it, it is refused (nudgecli.config_switches)
        *([f"inference.decay_delay={decay_delay}"] if decay else []),
        f"assistance.startup_delay_s={draw(st.sampled_from([0.0, 0.35, 1.0]))}",
        f"assistance.entropy_gate={str(draw(st.booleans())).lower()}",
        f"assistance.distance_weighting={str(draw(st.booleans())).lower()}",
    ]
    return overrides


@functools.cache
def _paper_plan() -> StudyPlan:
    config = load_experiment("paper")
    return StudyPlan.build(config, config.experiment.seed)


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(overrides=_settings(), index=st.integers(0, 8))
def test_quiet_runs_give_the_same_trials_under_any_habits_and_rules(overrides, index, monkeypatch) -> None:
    # the layouts depend on neither section: the plan's, with the drawn settings
    plan = dataclasses.replace(_paper_plan(), config=load_experiment("paper", overrides))
    every_trials, every_steps, _ = _participant(plan, index, False, monkeypatch)
    quiet_trials, quiet_steps, _ = _participant(plan, index, True, monkeypatch)
    pd.testing.assert_frame_equal(quiet_trials, every_trials, check_exact=True)
    pd.testing.assert_frame_equal(quiet_steps, every_steps, check_exact=True)


@pytest.mark.parametrize(("experiment", "overrides"), [
    ("paper", ()), ("smoke", ("behaviour.hard_pulses=false", "behaviour.event_reactions=false")),
    ("baselines", ()),
])
def test_no_quiet_run_starts_right_after_a_step_with_input(experiment, overrides, monkeypatch) -> None:
    """The trial loop does not ask ``quiet_steps`` after a step that gave input: hold that it
    would have answered 0 at every such step (operating, no pause begun)."""
    checked = 0

    def checking(self: SimulatedPerson, view):  # type: ignore[no-untyped-def]
        nonlocal checked
        intended, pressure = _NEXT_INPUT(self, view)
        if intended != NO_INPUT:
            assert self.phase is Phase.OPERATING and self.pause_left <= 0
            assert self.quiet_steps(view) == 0
            checked += 1
        return intended, pressure

    skipped_in: set[Phase] = set()
    skip_quiet = SimulatedPerson.skip_quiet

    def skipping(self: SimulatedPerson, steps: int, pose, mode: int) -> None:  # type: ignore[no-untyped-def]
        skipped_in.add(self.phase)
        skip_quiet(self, steps, pose, mode)

    config = load_experiment(experiment, list(overrides))
    plan = StudyPlan.build(config, config.experiment.seed)
    monkeypatch.setattr(SimulatedPerson, "next_input", checking)
    monkeypatch.setattr(SimulatedPerson, "skip_quiet", skipping)
    simulate_participant(plan, 1)
    assert checked > 500
    # and the quiet runs still come: rests, pauses between blows and the idling before a handover
    assert skipped_in == {Phase.RESTING, Phase.OPERATING, Phase.IDLE}
