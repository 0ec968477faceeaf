"""The step-based metrics (numpy only) against a brute-force loop over each trial's steps, and
their independence from pandas (a batch's workers compute them without it)."""

from __future__ import annotations

import math
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from import_guard import run_refusing

from nudgecli.errors import DataError
from nudgecli.model.interface import LABELS
from nudgecli.report.step_metrics import STEP_METRIC_NAMES, step_metric_arrays, trial_rows_of_steps

H, A = "human", "autonomy"
EVENT_CELLS = ["", "mode_switch_human", "nudge|mode_switch_human", "mode_switch_human|mode_switch_human",
               "mode_switch_autonomy", "handover_to_human|nudge"]
PHI_M = ["", *LABELS, "Soft Puff deadband"]


def brute_force(trials: dict[str, list[Any]], steps: dict[str, list[Any]], engagement: str, strength: str,
                mode_switches: str) -> dict[str, list[float]]:
    """Each definition of :mod:`nudgecli.report.metrics`, one trial at a time, with plain loops."""
    out: dict[str, list[float]] = {name: [] for name in STEP_METRIC_NAMES}
    has_input = "phi_m" in steps
    for p, k, goal in zip(trials["participant"], trials["trial"], trials["true_goal"], strict=True):
        rows = sorted((i for i in range(len(steps["step"])) if steps["participant"][i] == p
                       and steps["trial"][i] == k), key=lambda i: steps["step"][i])
        if not rows:
            for name in STEP_METRIC_NAMES:
                out[name].append(math.nan)
            continue
        human = [i for i in rows if steps["turn"][i] == H]
        assisted = [i for i in human if steps["alpha"][i] > 0 and steps["inferred_goal"][i] == goal]
        counted = [i for i in rows if mode_switches == "any_turn" or steps["turn"][i] == H]
        switches = sum(steps["event"][i].split("|").count("mode_switch_human") for i in counted)
        # human turns: maximal runs of consecutive human steps in step order
        turns: list[list[int]] = []
        for position, i in enumerate(rows):
            if steps["turn"][i] != H:
                continue
            if position > 0 and steps["turn"][rows[position - 1]] == H:
                turns[-1].append(i)
            else:
                turns.append([i])

        def turn_strength(turn: list[int], assisted: list[int] = assisted) -> float:
            a = [steps["alpha"][i] for i in turn if i in assisted]
            return sum(a) / len(a) if a else 0.0

        per_step_engagement = len(assisted) / len(human) if human else math.nan
        per_step_strength = sum(steps["alpha"][i] for i in assisted) / len(assisted) if assisted else math.nan
        per_turn_engagement = (sum(sum(i in assisted for i in t) / len(t) for t in turns) / len(turns)
                               if turns else math.nan)
        per_turn_strength = sum(turn_strength(t) for t in turns) / len(turns) if turns else math.nan
        out["assistance_engagement"].append(per_step_engagement if engagement == "per_step"
                                            else per_turn_engagement)
        out["assistance_strength"].append(per_step_strength if strength == "per_step" else per_turn_strength)
        out["mode_switches"].append(float(switches))
        out["human_effort"].append(len(human) / len(rows))
        commands = [steps["t"][i] for i in rows if steps["phi_m"][i] in LABELS] if has_input else []
        out["first_input_latency"].append(min(commands) if commands else math.nan)
        out["active_input_fraction"].append(sum(steps["phi_m"][i] != "" for i in rows) / len(rows)
                                            if has_input else math.nan)
        named = [steps["inferred_goal"][i] for i in rows if steps["inferred_goal"][i] >= 0]
        out["last_inferred_goal"].append(float(named[-1]) if named else math.nan)
    return out


@st.composite
def step_logs(draw: st.DrawFn) -> tuple[dict[str, list[Any]], dict[str, list[Any]]]:
    """A trial table of 1-4 trials (two participants) and a shuffled step log: some trials without
    steps, some steps of trials not in the table, each trial's steps numbered 0..n-1."""
    keys = draw(st.lists(st.tuples(st.integers(0, 1), st.integers(0, 5)), min_size=1, max_size=4,
                         unique=True))
    trials = {"participant": [p for p, _ in keys], "trial": [k for _, k in keys],
              "true_goal": draw(st.lists(st.integers(0, 2), min_size=len(keys), max_size=len(keys)))}
    logged = draw(st.lists(st.tuples(st.integers(0, 1), st.integers(0, 6)), max_size=5, unique=True))
    steps: dict[str, list[Any]] = {c: [] for c in ("participant", "trial", "step", "turn", "alpha",
                                                   "inferred_goal", "event", "t", "phi_m")}
    for p, k in logged:
        n = draw(st.integers(1, 14))
        steps["participant"] += [p] * n
        steps["trial"] += [k] * n
        steps["step"] += list(range(n))
        steps["t"] += [round(0.1 * s, 10) for s in range(n)]
        steps["turn"] += draw(st.lists(st.sampled_from([H, A]), min_size=n, max_size=n))
        steps["alpha"] += draw(st.lists(st.sampled_from([0.0, 0.1, 0.35, 0.8, 1.0]), min_size=n, max_size=n))
        steps["inferred_goal"] += draw(st.lists(st.integers(-1, 2), min_size=n, max_size=n))
        steps["event"] += draw(st.lists(st.sampled_from(EVENT_CELLS), min_size=n, max_size=n))
        steps["phi_m"] += draw(st.lists(st.sampled_from(PHI_M), min_size=n, max_size=n))
    order = draw(st.permutations(range(len(steps["step"]))))
    return trials, {c: [v[i] for i in order] for c, v in steps.items()}


@settings(max_examples=150, deadline=None)
@given(log=step_logs(), engagement=st.sampled_from(["per_step", "per_turn"]),
       strength=st.sampled_from(["per_step", "per_turn"]),
       switches=st.sampled_from(["any_turn", "human_turn"]), with_input=st.booleans())
def test_every_step_metric_is_the_brute_force_loops(log: tuple[dict[str, list[Any]], dict[str, list[Any]]],
                                                     engagement: str, strength: str, switches: str,
                                                     with_input: bool) -> None:
    trials, steps = log
    if not with_input:
        steps = {c: v for c, v in steps.items() if c not in ("t", "phi_m")}
    arrays = {c: np.array(v, dtype=object if c in ("turn", "event", "phi_m") else None)
              for c, v in steps.items()}
    got = step_metric_arrays(trials, arrays, engagement=engagement, strength=strength,  # type: ignore[arg-type]
                             mode_switches=switches)  # type: ignore[arg-type]
    expected = brute_force(trials, steps, engagement, strength, switches)
    for name in STEP_METRIC_NAMES:
        assert got[name].shape == (len(trials["trial"]),)
        assert got[name].tolist() == pytest.approx(expected[name], abs=1e-11, nan_ok=True), name


def test_a_step_log_without_rows_gives_missing_values() -> None:
    trials = {"participant": [0, 0], "trial": [0, 1], "true_goal": [1, 2]}
    numeric = ("participant", "trial", "step", "alpha", "inferred_goal", "t")
    empty: dict[str, Any] = {c: np.zeros(0) for c in numeric}
    empty.update({c: np.zeros(0, dtype=object) for c in ("turn", "event", "phi_m")})
    got = step_metric_arrays(trials, empty, engagement="per_turn", strength="per_turn")
    assert all(np.isnan(got[name]).all() for name in STEP_METRIC_NAMES)


def test_steps_are_matched_to_their_trial_by_participant_and_trial() -> None:
    rows = trial_rows_of_steps([0, 1, 1], [3, 3, 4], [1, 0, 2, 1, 1], [3, 3, 3, 4, 5])
    assert rows.tolist() == [1, 0, -1, 2, -1]
    with pytest.raises(DataError, match=r"\(participant, trial\) = \(1, 3\) more than once"):
        trial_rows_of_steps([0, 1, 1], [3, 3, 3], [], [])


def test_a_worker_computes_the_step_metrics_without_pandas(tmp_path: Path) -> None:
    script = textwrap.dedent("""
        import sys

        from nudgecli.report.step_metrics import step_metric_arrays
        got = step_metric_arrays({"participant": [0], "trial": [0], "true_goal": [1]},
                                 {"participant": [0, 0], "trial": [0, 0], "step": [1, 0],
                                  "turn": ["human"] * 2, "alpha": [0.5, 0.0], "inferred_goal": [1, 1],
                                  "event": ["", "mode_switch_human"]})
        assert got["assistance_engagement"].tolist() == [0.5] and got["mode_switches"].tolist() == [1.0]
        assert "pandas" not in sys.modules
        print("ok")
        """)
    done = run_refusing(script, ("pandas", "pyarrow"))
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(st.integers(-1, 3), st.integers(0, 3)), max_size=12))
def test_a_log_is_read_unsorted_exactly_where_the_stable_sort_keeps_it(pairs: list[tuple[int, int]]) -> None:
    # the fast path's test against the sort it skips: every step kept and lexsort's order unchanged
    from nudgecli.report.step_metrics import _in_row_and_step_order

    row = np.array([r for r, _ in pairs], dtype=np.int64)
    step = np.array([s for _, s in pairs], dtype=np.int64)
    unchanged = bool((row >= 0).all()) and np.array_equal(np.lexsort((step, row)), np.arange(len(pairs)))
    assert _in_row_and_step_order(row, step) == unchanged


@settings(max_examples=100, deadline=None)
@given(log=step_logs(), engagement=st.sampled_from(["per_step", "per_turn"]),
       strength=st.sampled_from(["per_step", "per_turn"]),
       switches=st.sampled_from(["any_turn", "human_turn"]))
def test_a_log_in_trial_and_step_order_gives_the_sorted_logs_values(
        log: tuple[dict[str, list[Any]], dict[str, list[Any]]], engagement: str, strength: str,
        switches: str) -> None:
    # a participant task's log: only the table's trials, in its order, each trial's steps in order
    trials, steps = log
    position = {key: k for k, key in enumerate(zip(trials["participant"], trials["trial"], strict=True))}
    rows = [i for i in range(len(steps["step"])) if (steps["participant"][i], steps["trial"][i]) in position]
    rows.sort(key=lambda i: (position[steps["participant"][i], steps["trial"][i]], steps["step"][i]))
    # text columns as lists, as a participant task's step columns hold them
    in_order = {c: [v[i] for i in rows] if c in ("turn", "event", "phi_m") else np.array([v[i] for i in rows])
                for c, v in steps.items()}
    reversed_log = {c: v[::-1] for c, v in in_order.items()}  # the same steps through the sort
    kinds: dict[str, Any] = {"engagement": engagement, "strength": strength, "mode_switches": switches}
    got = step_metric_arrays(trials, in_order, **kinds)
    sorted_values = step_metric_arrays(trials, reversed_log, **kinds)
    expected = brute_force(trials, {c: list(v) for c, v in in_order.items()}, engagement, strength, switches)
    for name in STEP_METRIC_NAMES:
        np.testing.assert_array_equal(got[name], sorted_values[name], err_msg=name)
        assert got[name].tolist() == pytest.approx(expected[name], abs=1e-11, nan_ok=True), name
