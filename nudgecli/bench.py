"""``nudge bench``: the performance figures of DESIGN section 8, measured in one run.

Each figure is a function returning one row (a dict with the keys of ``COLUMNS``); ``FIGURES``
lists them in report order, so adding a figure is adding a function to that list. Times are in
seconds; ratios are ``baseline / time`` (how many times faster than the baseline measured in the
same run). Timings use ``time.perf_counter``: fast calls are looped in batches and the best
(minimum) per-call time over several batches is reported, the slow baselines are timed whole and
the best of a few runs is reported. The minimum is the usual estimate of a computation's own cost
on a machine shared with other work (other processes only ever add time); both sides of a ratio
use it, so the ratio is not flattered by load on one side.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from nudgecli.model import interface, world
from nudgecli.model.disambiguation import (
    Candidates,
    DisambiguationModel,
    DisambiguationSettings,
    disambiguation_scores,
    maximally_disambiguating_state,
    monte_carlo_mutual_information_per_sample,
)
from nudgecli.model.mdp import build_transitions, solve_layout, value_iteration
from nudgecli.rng import generator

COLUMNS = ("what", "time_s", "baseline_s", "ratio", "target", "ok", "note")
BENCH_SEED = 20220214
MC_SAMPLES = 250


@dataclass(frozen=True)
class BenchOptions:
    """How hard ``nudge bench`` measures.

    Attributes
    ----------
    repeats
        Batches of each fast measurement (the best is reported).
    baseline_repeats
        Runs of each slow per-sample Monte-Carlo baseline (the best is reported).
    mc_states
        States the full-grid Monte-Carlo baseline is timed on (then scaled to 2400).
    """

    repeats: int = 7
    baseline_repeats: int = 3
    mc_states: int = 75


def best_call_time(func: Callable[[], object], repeats: int = 7, min_duration: float = 0.05) -> float:
    """Minimum over ``repeats`` batches of the seconds per call of ``func``, each batch long enough
    to last about ``min_duration`` (after one warm-up call)."""
    func()
    start = time.perf_counter()
    func()
    single = max(time.perf_counter() - start, 1e-7)
    number = max(1, int(min_duration / single))
    per_call = []
    for _ in range(max(1, repeats)):
        start = time.perf_counter()
        for _ in range(number):
            func()
        per_call.append((time.perf_counter() - start) / number)
    return min(per_call)


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


def _row(what: str, time_s: float, baseline_s: float | None, target: str, ok: bool,
         note: str) -> dict[str, Any]:
    ratio = None if baseline_s is None else baseline_s / time_s
    return {"what": what, "time_s": time_s, "baseline_s": baseline_s, "ratio": ratio, "target": target,
            "ok": bool(ok), "note": note}


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
    rng = generator(BENCH_SEED, "bench", "window-mc")
    baseline = min(
        _time_once(lambda: monte_carlo_mutual_information_per_sample(
            _BELIEF, candidates.states, model.p_a_given_sg, model.mapping, model.distortion, rng, MC_SAMPLES))
        for _ in range(max(1, options.baseline_repeats)))
    ratio = baseline / exact
    return _row("D(s), one 5x5 window (75 states), exact vs per-sample MC 250", exact, baseline,
                ">= 5000x (and <= 0.1 ms)", ratio >= 5000.0,
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
    rng = generator(BENCH_SEED, "bench", "grid-mc")
    subset_time = min(
        _time_once(lambda: monte_carlo_mutual_information_per_sample(
            _BELIEF, subset, model.p_a_given_sg, model.mapping, model.distortion, rng, MC_SAMPLES))
        for _ in range(max(1, options.baseline_repeats)))
    baseline = subset_time * world.N_STATES / n_subset
    ratio = baseline / exact
    return _row("D(s), full grid (2400 states x 4 goals), exact vs per-sample MC 250", exact, baseline,
                ">= 500x (and <= 2 ms)", ratio >= 500.0,
                f"MC timed on {n_subset} evenly spaced states, scaled linearly to {world.N_STATES}")


def figure_value_iteration(options: BenchOptions) -> dict[str, Any]:
    """Batched value iteration of the 4 goal MDPs of one layout (transitions built once)."""
    layout = _bench_layout()
    transitions = build_transitions(layout.goal_cells, layout.goal_headings)
    rewards = transitions.rewards()
    iterations = value_iteration(transitions.next_state, rewards)[2]
    elapsed = best_call_time(lambda: value_iteration(transitions.next_state, rewards), options.repeats,
                               min_duration=0.2)
    solve = best_call_time(lambda: solve_layout(layout.goal_cells, layout.goal_headings), options.repeats,
                             min_duration=0.2)
    return _row("value iteration, 4 goals x 2400 states", elapsed, None, "<= 50 ms", elapsed <= 0.050,
                f"{iterations} sweeps; solve_layout incl. transitions, policy, p(a|s,g): "
                f"{solve * 1e3:.1f} ms; study: about 2 s per goal (not measured here)")


FIGURES: list[Callable[[BenchOptions], dict[str, Any]]] = [
    figure_window,
    figure_grid,
    figure_value_iteration,
]


def _time_once(func: Callable[[], object]) -> float:
    start = time.perf_counter()
    func()
    return time.perf_counter() - start


def run_bench(options: BenchOptions | None = None,
              figures: list[Callable[[BenchOptions], dict[str, Any]]] | None = None,
              progress: Callable[[str], None] | None = None) -> list[dict[str, Any]]:
    """Measure every figure.

    Parameters
    ----------
    options
        Repeats and subset sizes (defaults when ``None``).
    figures
        The figure functions to run (``FIGURES`` when ``None``).
    progress
        Called with the name of each figure before it runs (e.g. to log to stderr).

    Returns
    -------
    list of dict
        One row per figure with the keys of ``COLUMNS``.
    """
    options = options or BenchOptions()
    rows = []
    for figure in figures if figures is not None else FIGURES:
        if progress is not None:
            progress(f"bench: {figure.__name__.removeprefix('figure_')}")
        rows.append(figure(options))
    return rows


def _format_seconds(seconds: float | None) -> str:
    if seconds is None:
        return "-"
    if seconds >= 1.0:
        return f"{seconds:.2f} s"
    if seconds >= 1e-3:
        return f"{seconds * 1e3:.2f} ms"
    return f"{seconds * 1e6:.1f} us"


def format_table(rows: list[dict[str, Any]]) -> str:
    """A plain-text table of bench rows (columns what, time, baseline, ratio, target, ok), with
    each row's note on the line below it."""
    header = ("what", "time", "baseline", "ratio", "target", "ok")
    cells = [(row["what"], _format_seconds(row["time_s"]), _format_seconds(row["baseline_s"]),
              "-" if row["ratio"] is None else f"{row['ratio']:,.0f}x", row["target"],
              "yes" if row["ok"] else "NO") for row in rows]
    widths = [max(len(header[k]), *(len(c[k]) for c in cells)) for k in range(len(header))]
    lines = ["  ".join(h.ljust(w) for h, w in zip(header, widths, strict=True)).rstrip(),
             "  ".join("-" * w for w in widths)]
    for row, cell in zip(rows, cells, strict=True):
        lines.append("  ".join(c.ljust(w) for c, w in zip(cell, widths, strict=True)).rstrip())
        if row.get("note"):
            lines.append(f"    {row['note']}")
    return "\n".join(lines)
