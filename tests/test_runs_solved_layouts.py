"""A worker's cache of solved layouts (nudgecli.runs.solved_layouts): a plan whose layouts and
[model] were solved before takes the solutions without value iteration, and they are the solver's
own, bit for bit; another [model], other goals or another seed solve again."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import nudgecli.sim.study as sim_study
from nudgecli.config import load_experiment
from nudgecli.runs import batch_tasks, solved_layouts
from nudgecli.runs.solved_layouts import build_plan, clear_solved, remember_plan, solve_layouts_cached
from nudgecli.runs.study import solve_layout_chunk
from nudgecli.sim.study import StudyPlan, build_layouts


def _assert_same_solutions(plan: StudyPlan, reference: StudyPlan) -> None:
    assert len(plan.solved) == len(reference.solved) > 0
    for mine, theirs in zip(plan.solved, reference.solved, strict=True):
        for name in ("policy", "values", "p_a_given_sg"):
            a, b = getattr(mine, name), getattr(theirs, name)
            assert a.dtype == b.dtype and a.tobytes() == b.tobytes()
        assert mine.iterations == theirs.iterations


def test_a_sweep_point_that_draws_the_same_layouts_solves_none(solves):
    first = load_experiment("smoke")
    # another time limit and another person's habit: another plan key, the same layouts and [model]
    other = load_experiment("smoke", ["study.time_limit_s=90", "behaviour.stall_s=1.5"])
    assert batch_tasks.layout_key(first, 3) != batch_tasks.layout_key(other, 3)
    built = build_plan(first, 3)
    assert len(solves) == len(built.layouts) == 8
    again = build_plan(other, 3)
    assert len(solves) == 8  # no value iteration for the second plan
    assert again.config is other and again.seed == 3
    assert [item.layout.goal_cells.tolist() for item in again.layouts] == \
        [item.layout.goal_cells.tolist() for item in built.layouts]
    _assert_same_solutions(again, StudyPlan.build(other, 3))


@pytest.mark.parametrize("override", ["model.epsilon=0.2", "model.gamma=0.9", "model.bump_reward=-50"])
def test_another_model_solves_again_with_its_own_numbers(solves, override):
    build_plan(load_experiment("smoke"), 3)
    changed = load_experiment("smoke", [override])
    plan = build_plan(changed, 3)
    assert len(solves) == 16
    _assert_same_solutions(plan, StudyPlan.build(changed, 3))


def test_another_seed_draws_other_layouts_and_solves_them(solves):
    config = load_experiment("smoke")
    build_plan(config, 3)
    plan = build_plan(config, 4)
    assert len(solves) == 16
    _assert_same_solutions(plan, StudyPlan.build(config, 4))


def test_only_the_missing_layouts_are_solved_in_the_given_order(solves):
    config = load_experiment("smoke")
    layouts = build_layouts(config, 3)
    solve_layouts_cached(config, layouts[2:5])
    assert len(solves) == 3
    solved = solve_layouts_cached(config, layouts)
    assert len(solves) == 8  # the five others
    reference = sim_study.solve_layouts(config, layouts)
    for mine, theirs in zip(solved, reference, strict=True):
        assert mine.policy.tobytes() == theirs.policy.tobytes()
        assert mine.values.tobytes() == theirs.values.tobytes()


def test_a_plan_assembled_from_other_workers_chunks_feeds_this_workers_chunks(solves):
    config = load_experiment("smoke")
    remember_plan(StudyPlan.assemble(config, 3, [sim_study.solve_layouts(config, build_layouts(config, 3))]))
    assert len(solves) == 8
    other = load_experiment("smoke", ["study.time_limit_s=90"])
    chunk = solve_layout_chunk(other, 3, 2, 6)
    assert len(solves) == 8 and len(chunk) == 4


def test_the_oldest_solutions_are_dropped_beyond_the_cache_size(solves, monkeypatch):
    monkeypatch.setattr(solved_layouts, "SOLVED_CACHE_SIZE", 5)
    config = load_experiment("smoke")
    layouts = build_layouts(config, 3)
    solve_layouts_cached(config, layouts)  # 8 solved, the first 3 dropped
    assert len(solved_layouts._SOLVED) == 5
    solve_layouts_cached(config, layouts[5:])
    assert len(solves) == 8  # the three most recent were kept
    solve_layouts_cached(config, layouts[:1])
    assert len(solves) == 9  # the oldest was not


def test_the_ciaa_world_builds_its_plan_as_before(solves):
    config = load_experiment("ciaa-teleop")
    plan = build_plan(config, 3)
    assert plan.paths is not None and plan.solved == [] and solves == []
    remember_plan(plan)  # nothing to remember, no error
    assert not solved_layouts._SOLVED
    reference = StudyPlan.build(config, 3)
    assert sorted(plan.paths) == sorted(reference.paths)
    assert np.array_equal(plan.paths[0].goal_poses, reference.paths[0].goal_poses)


def test_the_key_is_what_the_solver_reads():
    config = load_experiment("smoke")
    item = build_layouts(config, 3)[0]
    key = solved_layouts.solve_key(config, item)
    turned = dataclasses.replace(item, layout=dataclasses.replace(
        item.layout, goal_headings=(item.layout.goal_headings + 1) % 8))
    moved = dataclasses.replace(item, layout=dataclasses.replace(
        item.layout, goal_cells=item.layout.goal_cells[::-1]))
    started = dataclasses.replace(item, index=7, layout=dataclasses.replace(item.layout, start_mode=2))
    assert solved_layouts.solve_key(config, turned) != key
    assert solved_layouts.solve_key(config, moved) != key  # goal 0 is the true goal: order matters
    assert solved_layouts.solve_key(config, started) == key  # the start is not the solver's
    assert solved_layouts.solve_key(load_experiment("smoke", ["model.goal_reward=50"]), item) != key


def test_a_workers_plan_cache_and_its_plans_from_files_use_the_solutions(solves, tmp_path):
    from nudgecli.runs.study import solve_layout_chunk_into

    config = load_experiment("smoke")
    files = [solve_layout_chunk_into(str(tmp_path / f"{a}.pickle"), config, 3, a, b)
             for a, b in ((0, 4), (4, 8))]
    assert len(solves) == 8
    clear_solved()
    batch_tasks._PLANS.clear()
    batch_tasks.install_plan_of_files(config, 3, files)  # as a worker does with the layout tasks' files
    other = load_experiment("smoke", ["study.time_limit_s=90"])
    plan = batch_tasks.cached_plan(other, 3)  # another plan key: a miss of the plan cache
    assert len(solves) == 8
    _assert_same_solutions(plan, StudyPlan.build(other, 3))
    batch_tasks._PLANS.clear()


def test_a_solution_used_again_is_kept_over_older_ones(solves, monkeypatch):
    monkeypatch.setattr(solved_layouts, "SOLVED_CACHE_SIZE", 5)
    config = load_experiment("smoke")
    layouts = build_layouts(config, 3)
    solve_layouts_cached(config, layouts[:5])
    solve_layouts_cached(config, layouts[:1])  # a hit: layout 0 is now the most recent
    solve_layouts_cached(config, layouts[5:6])  # drops layout 1, the least recently used
    assert len(solves) == 6
    solve_layouts_cached(config, layouts[:1])
    assert len(solves) == 6
    solve_layouts_cached(config, layouts[1:2])
    assert len(solves) == 7
