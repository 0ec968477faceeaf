"""The simulation-based validation of D(s) (``nudgecli.sim.validation``, ``nudge validate``)."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.errors import ConfigError
from nudgecli.model.disambiguation import (
    monte_carlo_mutual_information,
    mutual_information,
    observation_likelihood,
)
from nudgecli.model.inference import bayes_update
from nudgecli.model.interface import (
    HARD_PUFF,
    MOVE_N,
    MOVE_P,
    TO_MODE_R,
    default_distortion_table,
    default_mapping_table,
    observation_model,
)
from nudgecli.rng import generator
from nudgecli.sim.validation import (
    QUERY_COLUMNS,
    ValidationSettings,
    distinct_margin,
    expected_top_two_gap,
    goal_transitions,
    monte_carlo_estimates,
    neighbourhoods,
    run_validation,
    sample_world,
    solve_goal_policies,
    tolerant_argmax,
    unweighted_limit,
    world_states,
)

# --- the ground truth ------------------------------------------------------------------------


def test_ground_truth_hand_computed_two_goals_two_states() -> None:
    # b = (0.6, 0.4), two labels f0, f1.
    # State A: p(f | g0) = (0.9, 0.1), p(f | g1) = (0.1, 0.9).
    #   f0: p(f0 | A) = 0.6*0.9 + 0.4*0.1 = 0.58, b' = (0.54, 0.04) / 0.58, gap 0.50 / 0.58
    #   f1: p(f1 | A) = 0.6*0.1 + 0.4*0.9 = 0.42, b' = (0.06, 0.36) / 0.42, gap 0.30 / 0.42
    #   E[gap] = 0.58 * 0.50 / 0.58 + 0.42 * 0.30 / 0.42 = 0.50 + 0.30 = 0.80
    # State B: p(f | g0) = (0.7, 0.3), p(f | g1) = (0.4, 0.6).
    #   f0: joint (0.42, 0.16) -> 0.26;  f1: joint (0.18, 0.24) -> 0.06;  E[gap] = 0.32
    belief = np.array([0.6, 0.4])
    likelihood = np.array([[[0.9, 0.1], [0.7, 0.3]],
                           [[0.1, 0.9], [0.4, 0.6]]])  # (G, C, F)
    gap = expected_top_two_gap(belief, likelihood)
    np.testing.assert_allclose(gap, [0.80, 0.32], rtol=0, atol=1e-15)
    best, margin, tie = tolerant_argmax(gap[None, :])
    assert best[0] == 0 and not tie[0]
    np.testing.assert_allclose(margin, [0.48])


def test_ground_truth_equals_enumeration_with_bayes_update() -> None:
    rng = generator(3, "test")
    world = sample_world(rng, 6, 5, 4)
    belief = rng.dirichlet(np.ones(6))
    gap = expected_top_two_gap(belief, world.likelihood)
    expected = []
    for s in range(world.n_states):
        p_label = belief @ world.likelihood[:, s, :]
        total = 0.0
        for f in range(4):
            posterior = np.sort(bayes_update(belief, world.likelihood[:, s, f]))
            total += p_label[f] * (posterior[-1] - posterior[-2])
        expected.append(total)
    np.testing.assert_allclose(gap, expected, rtol=1e-12, atol=1e-15)


def test_batched_mutual_information_equals_the_model() -> None:
    rng = generator(4, "test")
    world = sample_world(rng, 9, 6, 5)
    beliefs = rng.dirichlet(np.ones(9), size=3)
    lik = np.broadcast_to(world.likelihood, (3, *world.likelihood.shape))
    batched = mutual_information(beliefs, lik)
    for q in range(3):
        np.testing.assert_allclose(batched[q], mutual_information(beliefs[q], world.likelihood),
                                   rtol=1e-12, atol=1e-15)


def test_the_two_criteria_can_disagree() -> None:
    # Why the match rate is not 100%: I(s) rewards splitting the whole belief, the ground truth
    # only separating the leader from the runner-up. Each candidate is a pattern of optimal
    # actions per goal (default tables); b = (0.4, 0.3, 0.15, 0.15).
    obs = observation_model(default_mapping_table(), default_distortion_table())[0]  # (A, F)
    patterns = [(0, 1, 1, 1), (0, 0, 1, 2)]  # leader alone | top two together, tail split
    p_a = 0.025 + 0.9 * np.eye(4)
    likelihood = np.stack([p_a[list(p)] @ obs for p in patterns], axis=1)  # (G, C, F)
    belief = np.array([0.4, 0.3, 0.15, 0.15])
    info = mutual_information(belief, likelihood)
    gap = expected_top_two_gap(belief, likelihood)
    assert info[1] > info[0]  # 0.2411 > 0.2266 nats
    assert gap[0] > gap[1]  # 0.3645 > 0.1986
    np.testing.assert_allclose(info, [0.2266, 0.2411], atol=5e-5)
    np.testing.assert_allclose(gap, [0.3645, 0.1986], atol=5e-5)


def test_tolerant_argmax_takes_the_first_of_last_bit_ties() -> None:
    values = np.array([[0.3, 0.5, 0.5 + 1e-16, 0.1], [0.2, 0.1, 0.4, 0.4 - 1e-3]])
    valid = np.array([[True, True, True, True], [True, False, True, True]])
    best, margin, tie = tolerant_argmax(values, valid, 1e-9)
    assert best.tolist() == [1, 2]
    assert tie.tolist() == [True, False]
    np.testing.assert_allclose(margin[1], 1e-3)


def test_distinct_margin_ignores_equivalent_candidates() -> None:
    # Candidates 0 and 1 share a likelihood column, candidate 2 differs.
    values = np.array([[0.5, 0.5, 0.2]])
    equivalent = np.array([[[True, True, False], [True, True, False], [False, False, True]]])
    valid = np.ones((1, 3), dtype=bool)
    best, margin, tie = tolerant_argmax(values, valid)
    assert best[0] == 0 and tie[0] and margin[0] == 0.0
    np.testing.assert_allclose(distinct_margin(values, best, equivalent, valid), [0.3])


# --- the world --------------------------------------------------------------------------------


def test_world_policy_and_likelihood() -> None:
    # 4 x 3 grid, goal 0 at (3, 1), goal 1 at (0, 0); state (i, j, m) = (i * 3 + j) * 2 + m.
    width, height = 4, 3
    goals = np.array([[3, 1], [0, 0]])
    cells, modes = world_states(width, height)
    next_state, reward = goal_transitions(width, height, goals)
    policy = solve_goal_policies(next_state, reward, 0.1)
    np.testing.assert_allclose(policy.sum(-1), 1.0)
    assert set(np.round(policy, 6).ravel()) == {0.925, 0.025}

    def state(i: int, j: int, m: int) -> int:
        return (i * height + j) * 2 + m

    greedy = np.argmax(policy[0], axis=-1)
    for i in range(3):  # same row as goal 0, mode x: move towards it
        assert greedy[state(i, 1, 0)] == MOVE_P
        assert greedy[state(i, 1, 1)] == TO_MODE_R  # mode y: switch (a Hard Puff)
    assert greedy[state(1, 0, 1)] == MOVE_P  # mode y below the goal's row: go up first
    assert greedy[state(3, 2, 1)] == MOVE_N  # mode y above it: go down
    # Goal 1's cell is an obstacle for goal 0: from (0, 1) in mode y, move_n would bump.
    assert next_state[0, state(0, 1, 1), MOVE_N] == state(0, 1, 1)
    assert reward[0, state(0, 1, 1), MOVE_N] == -100.0
    assert reward[0, state(2, 1, 0), MOVE_P] == 100.0  # the step into the goal
    assert int(np.argmax(default_mapping_table()[0, TO_MODE_R])) == HARD_PUFF

    likelihood = observation_likelihood(policy, default_mapping_table(), default_distortion_table(),
                                        modes=modes)
    np.testing.assert_allclose(likelihood.sum(-1), 1.0)
    assert likelihood.shape == (2, cells.shape[0], 4)
    world = sample_world(generator(5, "test"), 2, width, height)
    assert world.on_goal.sum() == 4 and world.likelihood.shape == (2, 24, 4)


def test_neighbourhood_window_clips_and_skips_goals() -> None:
    rng = generator(6, "test")
    world = sample_world(rng, 3, 10, 10)
    corner = 0  # cell (0, 0), mode x
    if world.on_goal[corner]:
        pytest.skip("the corner is a goal in this draw")
    cand = neighbourhoods(world, np.array([corner]))[0]
    real = cand[cand >= 0]
    assert np.all(np.diff(real) > 0)
    assert np.all(cand[len(real):] == -1)
    assert not world.on_goal[real].any()
    cells = {tuple(c) for c in world.cells[real]}
    assert cells <= {(0, 0), (0, 1), (1, 0), (1, 1)}
    assert len(real) == 2 * len(cells)


# --- the run ----------------------------------------------------------------------------------


def test_paper_scale_match_rate_is_reported(capsys: pytest.CaptureFixture[str]) -> None:
    settings = ValidationSettings(simulations=100, min_goals=3, max_goals=30, states=200, seed=0,
                                  mc_queries=0)
    result = run_validation(settings)
    summary = result.summary()
    goals = settings.goal_counts()
    assert summary["queries"] == int(np.sum(200 - 2 * goals))
    assert sorted(int(g) for g in summary["by_goals"]) == list(range(3, 31))
    assert sum(row["queries"] for row in summary["by_goals"].values()) == summary["queries"]
    assert 0.0 <= summary["match_rate"] <= 1.0
    assert 0 <= summary["near_ties"] <= summary["queries"]
    assert set(result.queries) == set(QUERY_COLUMNS)
    json.dumps(summary, allow_nan=False)
    with capsys.disabled():
        print(f"\npaper-scale validation (seed 0): match {summary['match_rate']:.3f}, "
              f"excluding {summary['near_ties']} near-ties {summary['match_rate_excluding_near_ties']:.3f}, "
              f"choice optimal for the ground truth {summary['truth_optimal_rate']:.3f}")


def test_monte_carlo_uses_the_models_estimator_and_converges() -> None:
    rng = generator(7, "test")
    world = sample_world(rng, 5, 6, 6)
    belief = rng.dirichlet(np.ones(5))
    states = np.flatnonzero(~world.on_goal)[:6]
    mapping, distortion = default_mapping_table(), default_distortion_table()
    policy, modes = world.policy[:, states], world.modes[states]

    est = monte_carlo_estimates(generator(1, "mc"), belief, policy, modes, mapping, distortion, 200)
    # The same draws as the model's estimator on the re-indexed states (s % 3 = mode).
    p_a = np.full((5, 3 * len(states), 4), 0.25)
    p_a[:, 3 * np.arange(len(states)) + modes] = policy
    direct = monte_carlo_mutual_information(belief, 3 * np.arange(len(states)) + modes, p_a, mapping,
                                            distortion, generator(1, "mc"), samples=200, weighting="belief")
    np.testing.assert_array_equal(est["belief"], direct)

    exact = mutual_information(belief, world.likelihood[:, states])
    big = monte_carlo_estimates(generator(2, "mc"), belief, policy, modes, mapping, distortion, 100_000)
    np.testing.assert_allclose(big["belief"], exact, atol=0.01)
    limit = unweighted_limit(belief, world.likelihood[:, states])
    np.testing.assert_allclose(big["unweighted"], limit, atol=0.01)


def test_run_records_convergence_rows() -> None:
    result = run_validation(ValidationSettings(simulations=4, min_goals=3, max_goals=6, mc_queries=4,
                                               mc_samples=(10, 1000), seed=2))
    rows = result.convergence
    assert [(r["n_samples"], r["variant"]) for r in rows] == [
        (10, "unweighted"), (10, "belief"), (1000, "unweighted"), (1000, "belief")]
    assert all(r["queries"] == 4 and 0 <= r["argmax_agreement"] <= 1 for r in rows)
    assert rows[3]["mae"] < rows[1]["mae"]
    assert set(result.convergence_limit) == {"unweighted", "belief"}


# --- the command line -------------------------------------------------------------------------

SMALL = ["validate", "--simulations", "6", "--min-goals", "3", "--max-goals", "5", "--mc-queries", "3"]


def test_same_seed_gives_identical_json() -> None:
    runner = CliRunner()
    first = runner.invoke(main, [*SMALL, "--seed", "11", "--format", "json"])
    second = runner.invoke(main, [*SMALL, "--seed", "11", "--format", "json"])
    other = runner.invoke(main, [*SMALL, "--seed", "12", "--format", "json"])
    assert first.exit_code == 0, first.output
    assert first.stdout == second.stdout
    assert first.stdout != other.stdout
    data = json.loads(first.stdout)
    assert data["simulations"] == 6 and data["seed"] == 11
    for key in ("match_rate", "by_goals", "near_ties", "convergence", "settings"):
        assert key in data


def test_out_writes_json_csv_and_figures(tmp_path: Path) -> None:
    out = tmp_path / "val"
    result = CliRunner().invoke(main, [*SMALL, "--out", str(out), "--format", "json"])
    assert result.exit_code == 0, result.output
    names = sorted(p.name for p in out.iterdir())
    assert names == ["validation.csv", "validation.json", "validation.pdf", "validation.png"]
    assert json.loads((out / "validation.json").read_text()) == json.loads(result.stdout)
    header = (out / "validation.csv").read_text().splitlines()[0]
    assert header.split(",") == list(QUERY_COLUMNS)
    table = CliRunner().invoke(main, [*SMALL])
    assert table.exit_code == 0 and "match" in table.stdout


@pytest.mark.parametrize(("args", "option"), [
    (["--simulations", "0"], "--simulations"),
    (["--min-goals", "5", "--max-goals", "4"], "--min-goals"),
    (["--min-goals", "1"], "--min-goals"),
    (["--states", "10"], "--states"),
    (["--states", "201"], "--states"),
    (["--states", "22"], "--states"),
    (["--max-goals", "60"], "--max-goals"),
    (["--seed", "-1"], "--seed"),
    (["--mc-queries", "-1"], "--mc-queries"),
    (["--belief-concentration", "0"], "--belief-concentration"),
])
def test_out_of_range_options_exit_1_with_one_error_line(args: list[str], option: str) -> None:
    result = CliRunner().invoke(main, ["validate", *args])
    assert result.exit_code == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: ") and option in lines[0]
    assert result.stdout == ""


def test_settings_check_raises_config_error() -> None:
    with pytest.raises(ConfigError, match="--max-goals"):
        ValidationSettings(min_goals=3, max_goals=2).check()


def test_the_belief_concentration_changes_the_queries_and_is_reported() -> None:
    base = ValidationSettings(simulations=2, min_goals=3, max_goals=4, states=72, mc_queries=0)
    spread = run_validation(base)
    near_uniform = run_validation(replace(base, belief_concentration=50.0))
    assert spread.summary()["settings"]["belief"] == "Dirichlet(1) per query"
    assert near_uniform.summary()["settings"]["belief"] == "Dirichlet(50) per query"
    # other beliefs, other choices (the worlds are the same: they come from the same seed)
    np.testing.assert_array_equal(spread.queries["state"], near_uniform.queries["state"])
    assert not np.array_equal(spread.queries["metric_choice"], near_uniform.queries["metric_choice"])
