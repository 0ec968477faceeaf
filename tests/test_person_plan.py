"""The simulated person plans with their own task costs (``[behaviour]`` ``plan_*``), not the
agent's assumption of them (``[model]``): a condition without an agent does not change with
``[model]``, and the person's plan keys change what the person does."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from nudgecli.config import load_experiment
from nudgecli.errors import ConfigError
from nudgecli.runs.solved_layouts import build_plan
from nudgecli.sim.study import StudyPlan, simulate_participant_columns

#: One layout per condition: the smallest study in which teleoperation runs a trial.
TINY = ['study.conditions=["teleoperation","control"]', "study.goal_counts=[3]", 'study.corners=["tr"]']


def _trials_of(condition: str, *settings: str) -> tuple[list[dict[str, Any]], dict[str, list[Any]]]:
    """Participant 0's trial rows and step log rows of ``condition`` in the tiny smoke study."""
    plan = StudyPlan.build(load_experiment("smoke", [*TINY, *settings]), 5)
    columns = simulate_participant_columns(plan, 0)
    trials = [row for row in columns.trials if row["condition"] == condition]
    numbers = {row["trial"] for row in trials}
    keep = [i for i, trial in enumerate(np.asarray(columns.steps["trial"]).tolist()) if trial in numbers]
    steps = {}
    for name, values in columns.steps.items():
        rows = values.tolist() if isinstance(values, np.ndarray) else list(values)
        steps[name] = [rows[i] for i in keep]
    return trials, steps


def _same_rows(a: dict[str, list[Any]], b: dict[str, list[Any]]) -> bool:
    return a.keys() == b.keys() and all(repr(a[name]) == repr(b[name]) for name in a)


def test_teleoperation_does_not_change_with_the_agents_model():
    trials, steps = _trials_of("teleoperation")
    assert trials and len(steps["trial"]) > 10
    # gamma 0.01 made the person's plan myopic: every teleoperation trial timed out
    for setting in ("model.gamma=0.01", "model.move_reward=-90"):
        other_trials, other_steps = _trials_of("teleoperation", setting)
        assert other_trials == trials, setting
        assert _same_rows(other_steps, steps), setting


def test_the_persons_own_plan_keys_change_what_they_do():
    trials, steps = _trials_of("teleoperation")
    other_trials, other_steps = _trials_of("teleoperation", "behaviour.plan_gamma=0.01")
    assert other_trials != trials
    assert other_trials[0]["timed_out"]  # a myopic plan never weighs the goal's reward
    assert not _same_rows(other_steps, steps)


def test_a_person_who_plans_as_the_agent_assumes_is_solved_once(solves):
    plan = StudyPlan.build(load_experiment("smoke"), 3)
    assert plan.person_policies is None and len(solves) == 8
    assert build_plan(load_experiment("smoke"), 3).person_policies is None and len(solves) == 16
    # the cache: the person's costs are the agent's, in another [model] key than tables
    cached = build_plan(load_experiment("smoke", ["model.tables=default"]), 3)
    assert len(solves) == 16 and cached.person_policies is None


def test_a_person_with_other_costs_gets_their_own_plan_and_the_agent_keeps_its_own(solves):
    default = StudyPlan.build(load_experiment("smoke"), 3)
    config = load_experiment("smoke", ["behaviour.plan_bump_reward=-5", "behaviour.plan_gamma=0.5"])
    plan = build_plan(config, 3)
    assert len(solves) == 8 + 16  # the agent's 8 and the person's 8
    assert plan.person_policies is not None
    for index, (mine, theirs) in enumerate(zip(plan.solved, default.solved, strict=True)):
        assert mine.p_a_given_sg.tobytes() == theirs.p_a_given_sg.tobytes()
        assert plan.person_policy(index).tobytes() != theirs.policy.tobytes()
    again = StudyPlan.build(config, 3)
    assert again.person_policies is not None
    assert [p.tobytes() for p in again.person_policies] == [p.tobytes() for p in plan.person_policies]
    # the person's plan from their costs is the agent's when [model] says the same
    agent = StudyPlan.build(load_experiment("smoke", ["model.bump_reward=-5", "model.gamma=0.5"]), 3)
    assert [s.policy.tobytes() for s in agent.solved] == [p.tobytes() for p in plan.person_policies]


@pytest.mark.parametrize("key", ["plan_gamma", "plan_move_reward", "plan_mode_switch_reward",
                                 "plan_bump_reward", "plan_goal_reward"])
def test_the_ciaa_world_refuses_the_persons_plan_keys(key):
    with pytest.raises(ConfigError, match=rf"behaviour.{key} = .*does not read it"):
        load_experiment("ciaa-teleop", [f"behaviour.{key}=0.5"])
    load_experiment("smoke", [f"behaviour.{key}=0.5"])  # the grid reads them
