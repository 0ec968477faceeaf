"""A faithful simulated study: no goal-index leak, one belief update per action (or per sample),
and the study software's gates exercised on study-code trials."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from nudgecli.config import load_experiment
from nudgecli.model.disambiguation import DisambiguationModel
from nudgecli.model.interface import (
    HARD_PUFF,
    LABELS,
    NO_INPUT,
    SOFT_PUFF,
    default_distortion_table,
    default_mapping_table,
)
from nudgecli.model.mdp import solve_layout
from nudgecli.model.world import MODE_NAMES, N_STATES, Layout, state_index
from nudgecli.rng import generator
from nudgecli.sim.participants import Participant, mapping_with_error
from nudgecli.sim.protocol import ProtocolSettings, TrialSession, TrialSpec
from nudgecli.sim.study import build_layouts, participant_schedule
from nudgecli.sim.trials import run_trial

SOFT, HARD, DEAD = -0.15, -0.8, -0.4  # puff pressures in the soft band, the hard band, the deadband


@pytest.fixture(scope="module")
def paper():
    config = load_experiment("paper")
    return config, ProtocolSettings.from_config(config), build_layouts(config, 11)


class TableModel:
    """The agent's model with a likelihood that is the same in every state (hand-computable)."""

    def __init__(self, per_label: dict[int, list[float]], n_goals: int) -> None:
        self.likelihood = np.full((n_goals, N_STATES, 4), 0.25)
        for label, values in per_label.items():
            self.likelihood[:, :, label] = np.asarray(values)[:, None]

    def label_likelihood(self, state: int, label: int) -> np.ndarray:
        return self.likelihood[:, state, label]


def session(paper, update: str, model, condition: str = "control") -> TrialSession:
    _, settings, layouts = paper
    layout = layouts[0].layout  # 3 goals
    spec = TrialSpec(participant=0, condition=condition, block=0, trial=0, layout_index=0, layout=layout)
    return TrialSession(spec, replace(settings, update=update), model, handover_idle_steps=50,
                        rng=np.random.default_rng(0))


@pytest.mark.parametrize(("update", "expected_powers"), [
    # two blows of Soft Puff (3 samples, then 2): one update per blow, or one per sample
    ("action", (2, 0)), ("sample", (5, 0)),
])
def test_belief_updates_per_blow_or_per_sample(paper, update, expected_powers) -> None:
    soft = [0.6, 0.3, 0.1]
    tr = session(paper, update, TableModel({SOFT_PUFF: soft}, 3))
    for pressure in (SOFT, SOFT, SOFT, 0.0, SOFT, SOFT):
        tr.human_step(SOFT_PUFF if pressure else NO_INPUT, pressure)
    n_soft = expected_powers[0]
    # hand-computed posterior from a uniform prior: b(g) proportional to soft(g) ** n
    expected = np.array(soft) ** n_soft / np.sum(np.array(soft) ** n_soft)
    np.testing.assert_allclose(tr.belief, expected, rtol=1e-12)


@pytest.mark.parametrize(("update", "n_soft", "n_hard"), [("action", 1, 1), ("sample", 2, 2)])
def test_a_change_of_label_within_a_blow_is_a_new_event(paper, update, n_soft, n_hard) -> None:
    """Soft, soft, deadband, hard, hard in one blow: the deadband is no observation; 'action'
    counts the soft and the hard label once each."""
    soft, hard = [0.6, 0.3, 0.1], [0.2, 0.2, 0.6]
    tr = session(paper, update, TableModel({SOFT_PUFF: soft, HARD_PUFF: hard}, 3))
    for pressure in (SOFT, SOFT, DEAD, HARD, HARD):
        tr.human_step(HARD_PUFF, pressure)
    expected = np.array(soft) ** n_soft * np.array(hard) ** n_hard
    np.testing.assert_allclose(tr.belief, expected / expected.sum(), rtol=1e-12)
    assert tr.human_switches == 1  # one switch per blow


def test_tied_leaders_name_no_goal_and_give_no_blending(paper) -> None:
    """b = (0.4, 0.4, 0.2): p(g') = 0.4 passes rho1 and a first-index argmax would blend towards
    goal 0 with alpha 0.8; the tie names no goal."""
    tr = session(paper, "action", TableModel({SOFT_PUFF: [0.4, 0.4, 0.2]}, 3))
    tr.human_step(SOFT_PUFF, SOFT)
    np.testing.assert_allclose(tr.belief, [0.4, 0.4, 0.2])
    tr.human_step(SOFT_PUFF, SOFT)  # the same blow: no update; the row shows this step's g' and alpha
    assert tr.columns["inferred_goal"][-1] == -1 and tr.columns["alpha"][-1] == 0.0
    tr2 = session(paper, "action", TableModel({SOFT_PUFF: [0.5, 0.3, 0.2]}, 3))
    tr2.human_step(SOFT_PUFF, SOFT)
    tr2.human_step(SOFT_PUFF, SOFT)
    assert tr2.columns["inferred_goal"][-1] == 0 and tr2.columns["alpha"][-1] == pytest.approx(0.8)


def test_a_confident_step_with_tied_leaders_goes_to_their_mean(paper) -> None:
    tr = session(paper, "action", TableModel({}, 3), condition="disambiguation")
    tr._set_belief(np.array([0.5, 0.5, 0.0]))  # normalised entropy 0.63 < kappa: confident
    tr._start_autonomy_turn()
    goals = tr.goal_poses[:2, :2].mean(axis=0)
    position = np.array([tr.x, tr.y])
    direction = (tr.autonomy_target[:2] - position) / np.linalg.norm(tr.autonomy_target[:2] - position)
    np.testing.assert_allclose(direction, (goals - position) / np.linalg.norm(goals - position), atol=1e-12)
    assert tr.autonomy_target[2] == tr.theta and tr.autonomy_inferred == -1


def test_the_true_goal_index_is_uniform_over_trials() -> None:
    config = load_experiment("paper")
    layouts = build_layouts(config, 2022)
    specs = [s for p in range(30) for s in participant_schedule(config, 2022, p, layouts)]
    for n_goals in (3, 4):
        index = np.array([s.true_goal for s in specs if s.layout.n_goals == n_goals])
        counts = np.bincount(index, minlength=n_goals)
        assert counts.size == n_goals
        assert stats.chisquare(counts).pvalue > 0.001, counts
    # and it is the trial's own draw: the same layout has different true goals across participants
    first_layout = [s.true_goal for s in specs if s.layout_index == 0]
    assert len(set(first_layout)) > 1


def _permuted(layout: Layout, order: np.ndarray) -> Layout:
    return replace(layout, goal_cells=layout.goal_cells[order], goal_headings=layout.goal_headings[order])


def _trial(layout: Layout, true_goal: int, condition: str, participant: Participant, settings, seed: int):
    solved = solve_layout(layout.goal_cells, layout.goal_headings)
    model = DisambiguationModel(layout.goal_cells, solved.p_a_given_sg, default_mapping_table(),
                                default_distortion_table())
    spec = TrialSpec(participant=0, condition=condition, block=0, trial=0, layout_index=0, layout=layout,
                     true_goal=true_goal)
    return run_trial(spec, settings, solved, model, participant, generator(seed, "permutation"))


@pytest.mark.parametrize("condition", ["disambiguation", "control"])
def test_permuting_the_goal_order_changes_nothing(paper, condition) -> None:
    """The same trial with the layout's goals listed in another order (and the true goal moved
    with them) is the same trial: every trajectory, alpha and verdict is identical, and the
    beliefs are the permuted beliefs. Nothing in the protocol depends on a goal's index."""
    _, settings, layouts = paper
    participant = Participant(index=0, seed_key="perm", pressure_level=np.array([-0.75, 0.7, -0.18, 0.24]),
                              pressure_spread=np.array([0.12, 0.12, 0.07, 0.1]),
                              mapping=mapping_with_error(0.05), epsilon=0.1, rest_s=0.5, operate_s=3.0,
                              action_pause_s=0.2, hard_blow_s=0.5, reaction_s=0.5, onset_ramp_samples=1)
    compared = 0
    for k, item in enumerate(layouts[:48:6]):
        layout = item.layout
        order = np.random.default_rng(k).permutation(layout.n_goals)
        true_goal = k % layout.n_goals
        a = _trial(layout, true_goal, condition, participant, settings, k)
        b = _trial(_permuted(layout, order), int(np.flatnonzero(order == true_goal)[0]), condition,
                   participant, settings, k)
        for key in ("success", "duration_s", "human_turns", "autonomy_turns", "nudges", "human_mode_switches",
                    "timed_out"):
            assert a.summary[key] == b.summary[key], (k, key)
        sa, sb = pd.DataFrame(a.steps), pd.DataFrame(b.steps)
        for column in ("x", "y", "theta", "mode", "alpha", "phi_m", "event", "turn"):
            assert sa[column].tolist() == sb[column].tolist(), (k, column)
        np.testing.assert_allclose(np.array(sa["belief"].tolist())[:, order], np.array(sb["belief"].tolist()),
                                   atol=1e-12)
        named = sa["inferred_goal"].to_numpy()
        expected = np.where(named >= 0, np.argsort(order)[np.maximum(named, 0)], -1)
        np.testing.assert_array_equal(expected, sb["inferred_goal"].to_numpy())
        compared += 1
    assert compared == 8


def test_study_code_trials_run_every_gate_of_the_study_software(tmp_path) -> None:
    """Simulated study-code trials, checked step by step against the study software's rules
    written out here (study notes section 6): alpha = 0 while H > kappa, for 1 s after the turn's
    first input, else the paper's ramp times w(d) = 1 - 0.4 d / 35 (d <= 35) or 0.6 exp(-(d - 35));
    one belief update per labelled sample; forgetting after more than 10 empty samples."""
    config = load_experiment("study-code", ["model.tables=default"])
    settings = ProtocolSettings.from_config(config)
    layouts = build_layouts(config, 5)
    participant = Participant(index=0, seed_key="study", pressure_level=np.array([-0.75, 0.7, -0.18, 0.3]),
                              pressure_spread=np.array([0.12, 0.12, 0.07, 0.1]),
                              mapping=mapping_with_error(0.05),
                              epsilon=0.1, rest_s=0.5, operate_s=3.0, action_pause_s=0.2, hard_blow_s=0.5,
                              reaction_s=0.5, onset_ramp_samples=1,
                              # longer than the study's 1 s, or the turn ends before forgetting acts
                              handover_idle_s=2.0)
    checked = {"entropy_gate": 0, "startup": 0, "weighted": 0, "updates": 0, "forgetting": 0}
    for k in (0, 9, 30, 40):
        item = layouts[k]
        solved = solve_layout(item.layout.goal_cells, item.layout.goal_headings)
        model = DisambiguationModel(item.layout.goal_cells, solved.p_a_given_sg, default_mapping_table(),
                                    default_distortion_table())
        spec = TrialSpec(0, item.condition, 0, 0, k, item.layout, true_goal=k % item.n_goals)
        result = run_trial(spec, settings, solved, model, participant, generator(k, "study"))
        steps = pd.DataFrame(result.steps)
        goals = item.layout.goal_poses
        n = item.n_goals
        turn_id = (steps["turn"] != steps["turn"].shift()).cumsum()
        beliefs = np.array(steps["belief"].tolist())
        for _, turn in steps[steps["turn"] == "human"].groupby(turn_id):
            measured = turn["phi_m"].to_numpy() != ""
            first = turn["step"].to_numpy()[measured][0] if measured.any() else math.inf
            for row in turn.itertuples():
                b = np.asarray(row.belief)
                entropy = -np.sum(b[b > 0] * np.log(b[b > 0])) / np.log(n)
                leader = int(np.argmax(b))
                if entropy > 0.65 or np.sum(b >= b.max() - 1e-9) > 1:
                    assert row.alpha == 0.0 and row.inferred_goal == -1
                    checked["entropy_gate"] += entropy > 0.65
                    continue
                assert row.inferred_goal == leader
                if row.step - first < 10:
                    assert row.alpha == 0.0
                    checked["startup"] += 1
                    continue
                d = math.hypot(goals[leader, 0] - row.x, goals[leader, 1] - row.y)
                weight = 1 - 0.4 * d / 35 if d <= 35 else 0.6 * math.exp(-(d - 35))
                ramp = min(max((b.max() - 1.1 / n) / (0.1 / n), 0.0), 1.0) * 0.8
                assert row.alpha == pytest.approx(ramp * weight, abs=1e-12)
                checked["weighted"] += ramp * weight > 0
        # one update per labelled sample (Eq. 7 by hand, with the state at the start of the step;
        # a row's belief is the belief after its step)
        for i in np.flatnonzero(steps["phi_m"].isin(LABELS).to_numpy()):
            row = steps.iloc[i]
            state = state_index(row.cell_x, row.cell_y, row.heading, MODE_NAMES.index(row["mode"]))
            posterior = beliefs[i - 1] * model.likelihood[:, state, LABELS.index(row.phi_m)]
            np.testing.assert_allclose(beliefs[i], posterior / posterior.sum(), rtol=1e-9)
            checked["updates"] += 1
        # forgetting: in a human turn, after its first input, each empty sample beyond the 11th in
        # a row pulls the belief towards uniform (the 11th mixes with weight 1 - exp(0) = 0)
        for _, turn in steps[steps["turn"] == "human"].groupby(turn_id):
            labels = turn["phi_m"].to_numpy()
            started = np.cumsum(labels != "") > 0
            run = 0
            for position, i in enumerate(turn.index):
                # empty samples count from the turn's first input on (a deadband reading is one)
                run = 0 if labels[position] in LABELS or not started[position] else run + 1
                if started[position] and run > 11 and labels[position] not in LABELS:
                    before, after = (np.abs(beliefs[j] - 1 / n).sum() for j in (i - 1, i))
                    if before > 1e-9:
                        assert after < before
                        checked["forgetting"] += 1
    assert all(v > 0 for v in checked.values()), checked


def test_one_informative_observation_from_uniform_passes_rho2() -> None:
    """Why strength of assistance is 0.8 almost always (README, 'What the simulation shows'):
    from a uniform belief, one observation leaves p(g') either at 1/|G| (the goals agree on it)
    or beyond rho2 = 1.2/|G|, never on the ramp (rho1, rho2], in every layout of the paper's
    design, every state and every label (default tables, Eq. 7 by hand)."""
    config = load_experiment("paper")
    for item in build_layouts(config, 2022):
        n = item.n_goals
        solved = solve_layout(item.layout.goal_cells, item.layout.goal_headings)
        model = DisambiguationModel(item.layout.goal_cells, solved.p_a_given_sg, default_mapping_table(),
                                    default_distortion_table())
        posterior = model.likelihood / model.likelihood.sum(axis=0, keepdims=True)  # (G, S, F), uniform prior
        leader = posterior.max(axis=0)
        on_ramp = (leader > 1.1 / n + 1e-12) & (leader <= 1.2 / n)
        assert not on_ramp.any()
        assert (leader > 1.2 / n).any() and np.isclose(leader, 1 / n).any()
