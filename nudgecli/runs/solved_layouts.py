"""A worker's cache of solved layouts: value iteration once per layout and model, not once per study.

A study's plan (:class:`~nudgecli.sim.study.StudyPlan`) solves each of its layouts' goal MDPs
(:func:`~nudgecli.sim.study.solve_layouts`, about 0.16 s for the paper's 48 layouts) with the
agent's task costs (``[model]``) and, where they differ, with the simulated person's own
(``[behaviour]`` ``plan_*``, :func:`~nudgecli.sim.study.person_policies`). What a solution
depends on is the layout's goals and those costs (:class:`~nudgecli.sim.study.TaskCosts`),
nothing else; the plan cache (:mod:`nudgecli.runs.batch_tasks`) is keyed more broadly (every
section but those known not to draw or solve layouts), so the points of a sweep over, say, a
``[behaviour]`` or ``[blending]`` key, or ``study.time_limit_s``, draw the same layouts under
different plan keys. This cache, keyed by exactly what the solver reads (the goal cells and
headings, and the costs), gives such a plan the solutions it already has, and a person whose
costs are the agent's the agent's solutions. Replications draw new layouts (the 20
replications of ``replicate paper`` hold 960 distinct layouts), so there it only misses.

:func:`~nudgecli.model.mdp.solve_layout` is a pure function of those inputs, and a solved layout
is never written to after it is made (plans share them between participants already), so a
cached solution is the solution, bit for bit. A worker keeps at most :data:`SOLVED_CACHE_SIZE`
(least recently used dropped); while a held plan uses them they cost no memory of their own.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Sequence

from nudgecli.config import ExperimentConfig
from nudgecli.model.mdp import SolvedLayout
from nudgecli.sim.study import (
    StudyLayout,
    StudyPlan,
    TaskCosts,
    agent_costs,
    build_layouts,
    person_policies,
    solve_layouts,
)

#: Solved layouts a worker keeps: one ``paper`` study's (48, about 20 MB when no plan holds them).
SOLVED_CACHE_SIZE = 48

SolveKey = tuple[str, tuple[int, ...], bytes, bytes]

_SOLVED: OrderedDict[SolveKey, SolvedLayout] = OrderedDict()
_SOLVED_LOCK = threading.Lock()  # a dask worker may run tasks in several threads


def solve_key(config: ExperimentConfig, item: StudyLayout, costs: TaskCosts | None = None) -> SolveKey:
    """What a layout's solution depends on: the task costs (the agent's, ``[model]``, when ``None``)
    and the goals' cells and headings."""
    cells = item.layout.goal_cells
    # repr: each reward, gamma and epsilon as the shortest text that reads back the same float
    return (repr(agent_costs(config) if costs is None else costs), tuple(cells.shape),
            cells.astype("<i8").tobytes(), item.layout.goal_headings.astype("<i8").tobytes())


def solve_layouts_cached(config: ExperimentConfig, layouts: Sequence[StudyLayout],
                         costs: TaskCosts | None = None) -> list[SolvedLayout]:
    """:func:`~nudgecli.sim.study.solve_layouts` of ``layouts`` with ``costs`` (the agent's when
    ``None``), each found in this process's cache or solved (the misses together) and remembered.

    Returns
    -------
    list[SolvedLayout]
        One per layout, in the given order.
    """
    keys = [solve_key(config, item, costs) for item in layouts]
    with _SOLVED_LOCK:
        found = {key: _SOLVED[key] for key in keys if key in _SOLVED}
    missing = [i for i, key in enumerate(keys) if key not in found]
    if missing:
        solutions = solve_layouts(config, [layouts[i] for i in missing], costs)
        for i, solved in zip(missing, solutions, strict=True):
            found[keys[i]] = solved
    remember_solved(keys, [found[key] for key in keys])
    return [found[key] for key in keys]


def remember_solved(keys: Sequence[SolveKey], solved: Sequence[SolvedLayout]) -> None:
    """Make ``solved`` (the solutions of ``keys``) the cache's most recent, the oldest beyond
    :data:`SOLVED_CACHE_SIZE` dropped."""
    with _SOLVED_LOCK:
        for key, layout in zip(keys, solved, strict=True):
            _SOLVED[key] = layout
            _SOLVED.move_to_end(key)
        while len(_SOLVED) > SOLVED_CACHE_SIZE:
            _SOLVED.popitem(last=False)


def remember_plan(plan: StudyPlan) -> None:
    """Remember a grid-world plan's solutions (one assembled from other workers' pieces)."""
    if plan.paths is None:
        remember_solved([solve_key(plan.config, item) for item in plan.layouts], plan.solved)


def build_plan(config: ExperimentConfig, seed: int) -> StudyPlan:
    """:meth:`StudyPlan.build <nudgecli.sim.study.StudyPlan.build>`, its layouts solved through
    this process's cache (the CIAA world, which solves no layouts, as ``build`` itself)."""
    if config.world.kind == "ciaa":
        return StudyPlan.build(config, seed)
    layouts = build_layouts(config, seed)
    return StudyPlan(config=config, seed=seed, layouts=layouts, solved=solve_layouts_cached(config, layouts),
                     person_policies=person_policies(config, layouts, solve_layouts_cached))


def clear_solved() -> None:
    """Empty this process's cache (tests)."""
    with _SOLVED_LOCK:
        _SOLVED.clear()


__all__ = ["SOLVED_CACHE_SIZE", "build_plan", "clear_solved", "remember_plan", "remember_solved",
           "solve_key", "solve_layouts_cached"]
