"""The model figures of ``nudge bench`` (``--only model``): the exact disambiguation metric D(s)
against the per-sample Monte-Carlo baseline, over one window and over the full grid, and the
batched value iteration of one layout's goal MDPs."""

from __future__ import annotations

from typing import Any

import numpy as np

from nudgecli.bench.common import BENCH_SEED, MC_SAMPLES, BenchOptions, best_call_time, row, time_once
from nudgecli.bench.targets import (
    GRID_SPEEDUP_TARGET,
    GRID_TIME_TARGET_S,
    VI_TARGET_PER_LAYOUT_S,
    WINDOW_SPEEDUP_TARGET,
    WINDOW_TIME_TARGET_S,
)
from nudgecli.model import interface, world
from nudgecli.model.candidates import Candidates
from nudgecli.model.disambiguation import (
    DisambiguationModel,
    DisambiguationSettings,
    disambiguation_scores,
    maximally_disambiguating_state,
)
from nudgecli.model.information import monte_carlo_mutual_information_per_sample
from nudgecli.model.mdp import build_transitions, goal_fixed_point, solve_layout, value_iteration
from nudgecli.rng import generator


def _bench_layout() -> world.Layout:
    """A fixed 4-goal layout (goals in the bottom-left region, y <= 3) whose 5 x 5 window
    around cell (6, 6) holds no goal, so the window has all 75 candidates."""
    return world.sample_layout(generator(BENCH_SEED, "bench", "layout"), "tr", 4, 0)


def _bench_model(layout: world.Layout) -> DisambiguationModel:
    solved = solve_layout(layout.goal_cells, layout.goal_headings)
    return DisambiguationModel(layout.goal_cells, solved.p_a_given_sg, interface.default_mapping_table(),
                               interface.default_distortion_table())


_BELIEF = np.array([0.4, 0.3, 0.2, 0.1])
_WINDOW_STATE = int(world.state_index(6, 6, 3, 1))


def speedup_ok(exact_s: float, baseline_s: float, speedup_target: float, time_target_s: float) -> bool:
    """Whether a D(s) row meets DESIGN section 8: the exact computation at least ``speedup_target``
    times faster than the Monte Carlo baseline *and* within ``time_target_s`` seconds (a fast ratio
    over a slow baseline is not enough).

    Parameters
    ----------
    exact_s, baseline_s
        Best times of the exact computation and of the baseline, s.
    speedup_target, time_target_s
        The row's targets (:mod:`nudgecli.bench.targets`).
    """
    return baseline_s / exact_s >= speedup_target and exact_s <= time_target_s


def figure_window(options: BenchOptions) -> dict[str, Any]:
    """Exact MI + D(s) + s* over one 5 x 5 window (75 states) vs per-sample MC at 250 samples."""
    layout = _bench_layout()
    model = _bench_model(layout)
    settings = DisambiguationSettings(window=5)
    candidates = model.candidates(_WINDOW_STATE, settings)
    if candidates.states.size != 75:
        raise RuntimeError(f"bench window has {candidates.states.size} candidates, expected 75")
    exact = best_call_time(lambda: maximally_disambiguating_state(_BELIEF, model, _WINDOW_STATE, settings),
                             options.repeats)
    rng, table = generator(BENCH_SEED, "bench", "window-mc"), np.asarray(model.p_a_given_sg)
    baseline = min(
        time_once(lambda: monte_carlo_mutual_information_per_sample(
            _BELIEF, candidates.states, table, model.mapping, model.distortion, rng, MC_SAMPLES))
        for _ in range(max(1, options.baseline_repeats)))
    return row("D(s), one 5x5 window (75 states), exact vs per-sample MC 250", exact, baseline,
               f">= {WINDOW_SPEEDUP_TARGET:.0f}x (and <= {WINDOW_TIME_TARGET_S * 1e3:g} ms)",
               speedup_ok(exact, baseline, WINDOW_SPEEDUP_TARGET, WINDOW_TIME_TARGET_S),
               "exact: candidates + Eq. 13 + R(s) + D(s) + argmax; baseline: MC MI only")


def figure_grid(options: BenchOptions) -> dict[str, Any]:
    """Exact MI + D(s) over all 2400 states x 4 goals vs per-sample MC (timed on a subset, scaled)."""
    layout = _bench_layout()
    model = _bench_model(layout)
    coords = world.all_state_coordinates()
    every_state = Candidates(states=np.arange(world.N_STATES), cells=coords[:, :2],
                             positions=world.cell_centre(coords[:, 0], coords[:, 1]))
    settings = DisambiguationSettings()
    exact = best_call_time(lambda: disambiguation_scores(_BELIEF, model, every_state, settings),
                             options.repeats)
    n_subset = max(1, min(options.mc_states, world.N_STATES))
    subset = np.linspace(0, world.N_STATES - 1, n_subset).round().astype(int)
    rng, table = generator(BENCH_SEED, "bench", "grid-mc"), np.asarray(model.p_a_given_sg)
    subset_time = min(
        time_once(lambda: monte_carlo_mutual_information_per_sample(
            _BELIEF, subset, table, model.mapping, model.distortion, rng, MC_SAMPLES))
        for _ in range(max(1, options.baseline_repeats)))
    baseline = subset_time * world.N_STATES / n_subset
    return row("D(s), full grid (2400 states x 4 goals), exact vs per-sample MC 250", exact, baseline,
               f">= {GRID_SPEEDUP_TARGET:.0f}x (and <= {GRID_TIME_TARGET_S * 1e3:g} ms)",
               speedup_ok(exact, baseline, GRID_SPEEDUP_TARGET, GRID_TIME_TARGET_S),
               f"MC timed on {n_subset} evenly spaced states, scaled linearly to {world.N_STATES}")


def figure_value_iteration(options: BenchOptions) -> dict[str, Any]:
    """The goal MDPs of one layout solved as the study solves them (transitions built once): the
    fixed point ``V*`` (:func:`~nudgecli.model.mdp.goal_fixed_point`), beside value iteration to
    the span rule whose policy it gives."""
    layout = _bench_layout()
    transitions = build_transitions(layout.goal_cells, layout.goal_headings)
    rewards = transitions.rewards()
    solution = goal_fixed_point(transitions)
    if solution is None:  # pragma: no cover - the bench layout has no walled-in cell
        raise RuntimeError("the bench layout is outside goal_fixed_point's argument")
    sweeps = solution[2]
    elapsed = best_call_time(lambda: goal_fixed_point(transitions), options.repeats, min_duration=0.2)
    iterations = value_iteration(transitions.next_state, rewards)[2]
    span_rule = best_call_time(lambda: value_iteration(transitions.next_state, rewards), options.repeats,
                               min_duration=0.2)
    solve = best_call_time(lambda: solve_layout(layout.goal_cells, layout.goal_headings), options.repeats,
                             min_duration=0.2)
    return row("value iteration, 4 goals x 2400 states", elapsed, None,
               f"<= {VI_TARGET_PER_LAYOUT_S * 1e3:.0f} ms", elapsed <= VI_TARGET_PER_LAYOUT_S,
               f"fixed point V* in {sweeps} sweeps (the span rule's policy; the rule itself: "
               f"{iterations} sweeps, {span_rule * 1e3:.1f} ms); solve_layout incl. transitions, policy, "
               f"p(a|s,g): {solve * 1e3:.1f} ms; study: about 2 s per goal (not measured here)")
