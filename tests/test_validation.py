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
from nudgecli.model.disambiguation import observation_likelihood
from nudgecli.model.inference import bayes_update
from nudgecli.model.information import monte_carlo_mutual_information, mutual_information
from nudgecli.model.interface import (
    HARD_PUFF,
    MOVE_N,
    MOVE_P,
    TO_MODE_R,
    default_distortion_table,
    default_mapping_table,
    observation_model,
)
from nudgecli.model.mdp import OUTCOME_GOAL_ABSORBING, OUTCOME_GOAL_ENTRY, OUTCOME_INSIDE_OBSTACLE
from nudgecli.rng import generator
from nudgecli.sim.validation import (
    QUERY_COLUMNS,
    READINGS,
    ValidationSettings,
    distinct_margin,
    expected_entropy_drop,
    expected_goal_distance,
    expected_top_two_gap,
    get_reading,
    goal_transitions,
    monte_carlo_estimates,
    neighbourhoods,
    query_beliefs,
    run_all_readings,
    run_validation,
    sample_study_world,
    sample_world,
    solve_goal_policies,
    study_queries,
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
    transitions = goal_transitions(width, height, goals)
    next_state, reward = transitions.next_state, transitions.rewards()  # (G, A, S), the model's axes
    policy = solve_goal_policies(transitions, 0.1)
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
    assert next_state[0, MOVE_N, state(0, 1, 1)] == state(0, 1, 1)
    assert reward[0, MOVE_N, state(0, 1, 1)] == -100.0
    assert reward[0, MOVE_P, state(2, 1, 0)] == 100.0  # the step into the goal
    assert transitions.outcome[0, MOVE_P, state(2, 1, 0)] == OUTCOME_GOAL_ENTRY
    assert transitions.outcome[1, MOVE_P, state(3, 1, 0)] == OUTCOME_INSIDE_OBSTACLE  # goal 0 for goal 1
    assert transitions.outcome[0, MOVE_P, state(3, 1, 1)] == OUTCOME_GOAL_ABSORBING
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


# --- the readings side by side ------------------------------------------------------------------

SMALL_SETTINGS = ValidationSettings(simulations=6, min_goals=3, max_goals=5, states=72, seed=0, mc_queries=0)


def _brute_force_choices(settings: ValidationSettings) -> tuple[list[int], list[int]]:
    """s* and the ground truth's choice of every query, by explicit loops (an independent
    implementation: Bayes' rule per label, MI from its definition, first maximum by scanning)."""
    metric_choices, truth_choices = [], []
    for k, n_goals in enumerate(settings.goal_counts()):
        rng = generator(settings.seed, "validation", k)
        width, height = settings.grid_shape
        world = sample_world(rng, int(n_goals), width, height)
        queries = np.flatnonzero(~world.on_goal)
        beliefs = rng.dirichlet(np.ones(int(n_goals)), size=queries.size)
        for q, s in enumerate(queries):
            ci, cj = world.cells[s]
            candidates = [((i * height + j) * 2 + m)
                          for i in range(ci - 1, ci + 2) for j in range(cj - 1, cj + 2) for m in range(2)
                          if 0 <= i < width and 0 <= j < height and not world.on_goal[(i * height + j) * 2]]
            b = beliefs[q]
            info, gap = [], []
            for c in candidates:
                lik = world.likelihood[:, c, :]  # (G, F)
                marginal = b @ lik
                info.append(sum(b[g] * lik[g, f] * np.log(lik[g, f] / marginal[f])
                                for g in range(len(b)) for f in range(4)))
                total = 0.0
                for f in range(4):
                    post = np.sort(bayes_update(b, lik[:, f]))
                    total += marginal[f] * (post[-1] - post[-2])
                gap.append(total)

            def first_max(values: list[float]) -> int:
                top = max(values)
                return next(i for i, v in enumerate(values) if v >= top - 1e-9 * max(1.0, abs(top)))

            metric_choices.append(candidates[first_max(info)])
            truth_choices.append(candidates[first_max(gap)])
    return metric_choices, truth_choices


def test_small_fixed_seed_match_rate_is_pinned_and_equals_brute_force() -> None:
    result = run_validation(SMALL_SETTINGS)
    metric, truth = _brute_force_choices(SMALL_SETTINGS)
    assert result.queries["metric_choice"].tolist() == metric
    assert result.queries["truth_choice"].tolist() == truth
    matches = int(np.sum(np.asarray(metric) == np.asarray(truth)))
    assert (matches, len(metric)) == (247, 384)  # pinned: 64.3 %
    assert result.summary()["match_rate"] == pytest.approx(247 / 384)


def test_expected_entropy_drop_is_the_mutual_information() -> None:
    # H(b) - E[H(b')] with scipy's entropy on each posterior (an independent route) equals Eq. 13.
    from scipy.stats import entropy

    rng = generator(8, "test")
    world = sample_world(rng, 5, 5, 4)
    belief = rng.dirichlet(np.ones(5))
    drop = expected_entropy_drop(belief, world.likelihood)
    manual = []
    for s in range(world.n_states):
        marginal = belief @ world.likelihood[:, s, :]
        posteriors = [bayes_update(belief, world.likelihood[:, s, f]) for f in range(4)]
        manual.append(entropy(belief) - sum(marginal[f] * entropy(posteriors[f]) for f in range(4)))
    np.testing.assert_allclose(drop, manual, atol=1e-12)
    np.testing.assert_allclose(drop, mutual_information(belief, world.likelihood), atol=1e-12)


def test_gap_under_the_true_goal_hand_computed() -> None:
    # b = (0.6, 0.4); the state of test_ground_truth_hand_computed_two_goals_two_states:
    # p(f | g0) = (0.9, 0.1), p(f | g1) = (0.1, 0.9); posterior gaps 0.50/0.58 and 0.30/0.42.
    # Under the true goal g1 the labels come from (0.1, 0.9): 0.1 * 0.862069 + 0.9 * 0.714286.
    belief = np.array([0.6, 0.4])
    likelihood = np.array([[[0.9, 0.1]], [[0.1, 0.9]]])  # (G, C, F)
    under_g1 = expected_top_two_gap(belief, likelihood, label_weights=likelihood[1])
    np.testing.assert_allclose(under_g1, [0.1 * 0.50 / 0.58 + 0.9 * 0.30 / 0.42], rtol=1e-12)
    marginal = belief @ likelihood.transpose(1, 0, 2)  # (C, F) p(f | s)
    under_belief = expected_top_two_gap(belief, likelihood, label_weights=marginal)
    np.testing.assert_allclose(under_belief, expected_top_two_gap(belief, likelihood), rtol=1e-12)


def test_two_goal_beliefs_split_between_two_goals() -> None:
    beliefs = query_beliefs(generator(1, "test"), get_reading("two-goal"), 6, 500, 1.0)
    np.testing.assert_allclose(beliefs.sum(axis=1), 1.0)
    top_two = np.sort(beliefs, axis=1)[:, -2:]
    np.testing.assert_allclose(top_two.sum(axis=1), 0.99)
    assert np.all(top_two[:, 1] >= 0.99 * 0.5) and np.all(top_two[:, 1] <= 0.99 * 0.75)
    np.testing.assert_allclose(np.sort(beliefs, axis=1)[:, :-2], 0.01 / 4)
    assert len({tuple(np.argsort(b)[-2:]) for b in beliefs}) > 20  # the pair varies
    pair_only = query_beliefs(generator(1, "test"), get_reading("two-goal"), 2, 10, 1.0)
    np.testing.assert_allclose(pair_only.sum(axis=1), 1.0)


def test_expected_goal_distance_is_the_models_regulariser() -> None:
    # Hand-computed: goals at cells (0, 0) and (3, 4); candidate (0, 4); b = (0.25, 0.75):
    # 0.25 * 4 + 0.75 * 3 = 3.25 cells.
    got = expected_goal_distance(np.array([[0.25, 0.75]]), np.array([[0, 0], [3, 4]]), np.array([[[0, 4]]]))
    np.testing.assert_allclose(got, [[3.25]])


@pytest.mark.parametrize(("reading", "pinned"), [
    ("two-goal", (193, 384)), ("true-goal", (228, 384)), ("lambda-1", (86, 384)),
    ("reaches-maximum", (295, 384)), ("entropy-drop", (384, 384)),
])
def test_each_reading_changes_what_it_says_and_is_pinned(reading: str, pinned: tuple[int, int]) -> None:
    base = run_validation(SMALL_SETTINGS)
    other = run_validation(replace(SMALL_SETTINGS, reading=reading))
    q, b = other.queries, base.queries
    assert (int(q["match"].sum()), q["match"].size) == pinned
    np.testing.assert_array_equal(q["state"], b["state"])  # the same worlds
    if reading == "reaches-maximum":  # same choices, a looser rule: every same-state match counts
        np.testing.assert_array_equal(q["metric_choice"], b["metric_choice"])
        np.testing.assert_array_equal(q["match"], b["truth_optimal"])
        assert np.all(q["match"] >= b["match"])
    if reading == "lambda-1":  # the metric is the regularised D(s) the default reports beside it
        np.testing.assert_array_equal(q["metric_choice"], b["regularised_choice"])
    if reading == "true-goal":  # same metric, another ground truth
        np.testing.assert_array_equal(q["metric_choice"], b["metric_choice"])
        assert not np.array_equal(q["truth_choice"], b["truth_choice"])
    if reading == "entropy-drop":  # by construction: the ground truth is I(s) itself
        np.testing.assert_array_equal(q["truth_choice"], q["metric_choice"])


def test_three_mode_world_is_the_models() -> None:
    from nudgecli.model.candidates import window_candidates
    from nudgecli.model.mdp import solve_layout

    rng = generator(9, "test")
    world = sample_study_world(rng, 4, 0.1, default_mapping_table(), default_distortion_table())
    assert world.likelihood.shape == (4, 2400, 4) and world.on_goal.sum() == 4 * 8 * 3
    headings = generator(9, "test")
    headings.choice(100, size=4, replace=False)
    solved = solve_layout(world.goal_cells, headings.integers(0, 8, size=4))
    np.testing.assert_array_equal(world.policy, solved.p_a_given_sg)
    queries, cand = study_queries(rng, world)
    assert queries.size == 96 and cand.shape == (96, 27)
    for q in (0, 40, 95):
        expected = window_candidates(int(queries[q]), world.goal_cells, 3).states
        np.testing.assert_array_equal(cand[q][cand[q] >= 0], expected)
    result = run_validation(ValidationSettings(simulations=3, min_goals=3, max_goals=5, seed=0, mc_queries=0,
                                               reading="three-mode"))
    assert (int(result.queries["match"].sum()), result.queries["match"].size) == (197, 288)


def test_all_readings_share_worlds_and_equal_single_runs() -> None:
    names = ["dirichlet", "two-goal", "three-mode"]
    settings = replace(SMALL_SETTINGS, simulations=3)
    together = run_all_readings(settings, names)
    for name, result in zip(names, together, strict=True):
        alone = run_validation(replace(settings, reading=name))
        for column in QUERY_COLUMNS:
            np.testing.assert_array_equal(result.queries[column], alone.queries[column])


def test_cli_reading_and_all_readings(tmp_path: Path) -> None:
    small = ["validate", "--simulations", "4", "--min-goals", "3", "--max-goals", "4", "--states", "72",
             "--mc-queries", "0"]
    one = CliRunner().invoke(main, [*small, "--reading", "two-goal", "--format", "json"])
    assert one.exit_code == 0, one.output
    assert json.loads(one.stdout)["settings"]["reading"]["name"] == "two-goal"
    every = CliRunner().invoke(main, [*small, "--all-readings", "--out", str(tmp_path / "r")])
    assert every.exit_code == 0, every.output
    lines = every.stdout.splitlines()
    header = lines[1].split()
    assert header == ["reading", "match", "3", "4"]
    rows = {line.split()[0]: line.split() for line in lines[2:2 + len(READINGS)]}
    assert list(rows) == list(READINGS)
    assert rows["entropy-drop"][1:] == ["100.0%", "100", "100"]
    assert "by construction" in every.stdout
    saved = json.loads((tmp_path / "r" / "readings.json").read_text())
    assert [r["reading"]["name"] for r in saved] == list(READINGS)
    both = CliRunner().invoke(main, [*small, "--all-readings", "--reading", "two-goal"])
    assert both.exit_code == 2
    unknown = CliRunner().invoke(main, [*small, "--reading", "dirichlett"])
    assert unknown.exit_code == 2


def test_validate_checks_the_out_folder_before_computing(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    result = CliRunner().invoke(main, ["validate", "--simulations", "1", "--out", str(blocker / "sub")])
    assert result.exit_code == 1
    # one Error: line naming the path and the cause, before any simulation ran
    assert result.stderr.startswith("Error: ") and str(blocker) in result.stderr
    assert "Not a directory" in result.stderr and "validation:" not in result.stderr


def test_validation_panels_draw_the_summarys_rates_on_given_axes() -> None:
    from matplotlib.figure import Figure

    from nudgecli.report.validation_figure import convergence_panel, match_rate_panel

    summary = run_validation(replace(SMALL_SETTINGS, mc_queries=2, mc_samples=(10, 100))).summary()
    fig = Figure()
    left, right = fig.subplots(1, 2)
    assert match_rate_panel(summary, ax=left) is left
    match_line = next(line for line in left.lines if line.get_label() == "match")
    expected = [100.0 * row["match_rate"] for row in summary["by_goals"].values()]
    np.testing.assert_allclose(match_line.get_ydata(), expected)
    np.testing.assert_array_equal(match_line.get_xdata(), [int(g) for g in summary["by_goals"]])
    assert convergence_panel(summary, "mae", ax=right) is right
    assert fig.get_axes() == [left, right]
