"""Conditions as named policies: each policy's defining rule, the mode-selection criteria against
brute force, the policies' bad input, and the baselines preset's determinism across workers."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from dask_helpers import local_cluster
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.cli import main
from nudgecli.config import experiment_from_toml, load_experiment
from nudgecli.config_files import default_plan_name
from nudgecli.model import hindsight, mode_criteria, policies
from nudgecli.model.candidates import mode_candidates
from nudgecli.model.conditions import policy_name
from nudgecli.model.disambiguation import DisambiguationModel
from nudgecli.model.interface import (
    HARD_PUFF,
    NO_INPUT,
    SOFT_PUFF,
    SOFT_SIP,
    default_distortion_table,
    default_mapping_table,
)
from nudgecli.model.mdp import solve_layout
from nudgecli.model.world import (
    N_CELLS_X,
    N_CELLS_Y,
    N_HEADINGS,
    N_MODES,
    GridWorld,
    cell_centre,
    sample_layout,
    state_index,
)
from nudgecli.report.plans import load_plan
from nudgecli.rng import generator
from nudgecli.runs.study import run_study
from nudgecli.sim.builtin_policies import Teleoperation
from nudgecli.sim.policy_registry import make_policy
from nudgecli.sim.protocol import ProtocolSettings, TrialSession, TrialSpec
from nudgecli.sim.study import StudyPlan, build_layouts, participant_schedule, simulate_participant
from nudgecli.steplog import AUTONOMY_TURN, HUMAN_TURN, MODE_SELECT, MODE_SWITCH_AUTONOMY, has_event
from tests.test_sim_study import assert_same_run

SIX = '["disambiguation", "control", "teleoperation", "blending", "mode-switch", "hindsight"]'
POLICY_TOML = f"""
[experiment]
name = "policies"
seed = 11
[study]
participants = 1
conditions = {SIX}
goal_counts = [3, 4]
corners = ["tr", "bl"]
start_modes = ["x", "theta"]
blocks_per_condition = 1
shared_layouts = 1
time_limit_s = 60.0
[blending]
gate = "gap"
gap = 0.4
[mode-switch]
criterion = "paper-mi"
[hindsight]
"""


@pytest.fixture(scope="module")
def policy_steps() -> pd.DataFrame:
    """One participant's 48 trials (8 shared layouts x 6 conditions), steps with their condition."""
    config = experiment_from_toml(POLICY_TOML)
    result = simulate_participant(StudyPlan.build(config, 11), 0)
    steps = result.steps.merge(result.trials[["trial", "condition", "n_goals"]], on="trial")
    return steps.sort_values(["trial", "step"]).reset_index(drop=True)


def of(steps: pd.DataFrame, condition: str) -> pd.DataFrame:
    return steps[steps["condition"] == condition]


# --- mode-switch ----------------------------------------------------------------------------------

def test_mode_switch_never_moves_the_robot_in_its_turn(policy_steps):
    steps = policy_steps
    following = steps.groupby("trial")[["x", "y", "theta"]].shift(-1)
    turn = of(steps, "mode-switch")
    autonomy = turn[turn["turn"] == AUTONOMY_TURN]
    assert len(autonomy) > 5 and has_event(autonomy["event"], MODE_SWITCH_AUTONOMY).sum() > 0
    assert has_event(autonomy["event"], MODE_SELECT).all()
    assert (autonomy[["u_a_x", "u_a_y", "u_a_theta"]].to_numpy() == 0).all()
    after = following.loc[autonomy.index].dropna()
    np.testing.assert_array_equal(after.to_numpy(), autonomy.loc[after.index, ["x", "y", "theta"]].to_numpy())
    # the other turn-taking conditions do move in theirs: the check above can see motion
    control = of(steps, "control")
    assert (control.loc[control["turn"] == AUTONOMY_TURN, ["u_a_x", "u_a_y"]].abs().to_numpy() > 0).any()


def _layout_model(seed: int, n_goals: int = 3) -> tuple[object, DisambiguationModel]:
    layout = sample_layout(generator(seed, "layout", 0), "tr", n_goals, 0)
    solved = solve_layout(layout.goal_cells, layout.goal_headings)
    # noisier tables than the defaults, so the label distributions differ between states
    model = DisambiguationModel(layout.goal_cells, solved.p_a_given_sg, default_mapping_table(0.3),
                                default_distortion_table(0.3))
    return layout, model


def _spec(condition: str, layout: object) -> TrialSpec:
    return TrialSpec(participant=0, condition=condition, block=0, trial=0, layout_index=0, layout=layout)


def _brute_force_scores(criterion: str, belief: np.ndarray, likelihood: np.ndarray) -> np.ndarray:
    """Per mode (rows of ``likelihood``: (M, G, F)), higher is better: the mutual information by
    explicit loops, or the 2017 criteria of beliefs projected by repeated Bayes updates in loops
    (their formulas are held to the published MATLAB by tests/test_mode_criteria.py), one update
    per 0.1 s of the projection whatever the study's rate (the MATLAB's ``t_stamps = 0:0.1:1``:
    10 updates for 1 s, 20 for 2 s)."""
    def project(p: np.ndarray, label: int, steps: int) -> np.ndarray:
        b = belief.copy()
        for _ in range(steps):
            b = np.array([b[g] * p[g, label] for g in range(len(b))])
            b = b / b.sum()
        return b

    scores = []
    for p in likelihood:
        n_goals, n_labels = p.shape
        if criterion == "paper-mi":  # I(s) = H(b) - E H(b'); the distance term is the same for every mode
            expected_entropy = 0.0
            prior_entropy = -sum(b * math.log(b) for b in belief if b > 0)
            for f in range(n_labels):
                marginal = sum(belief[g] * p[g, f] for g in range(n_goals))
                if marginal == 0:
                    continue
                posterior = [belief[g] * p[g, f] / marginal for g in range(n_goals)]
                expected_entropy += marginal * -sum(q * math.log(q) for q in posterior if q > 0)
            scores.append(prior_entropy - expected_entropy)
        elif criterion == "gopinath2017":  # 1 s and 2 s projections, + and - motion summed
            scores.append(sum(float(mode_criteria.gopinath_disamb_metric(project(p, label, 10),
                                                                           project(p, label, 20)))
                              for label in (SOFT_PUFF, SOFT_SIP)))
        else:  # KL(projected 1 s || current) in bits, averaged over + and - motion
            kls = [sum(q * math.log2(q / b)
                       for q, b in zip(project(p, label, 10), belief, strict=True) if q > 0)
                   for label in (SOFT_PUFF, SOFT_SIP)]
            scores.append(sum(kls) / 2)
    return np.array(scores)


@pytest.mark.parametrize("rate_hz", [10.0, 20.0])  # the 2017 projections: 0.1 s updates at any rate
@pytest.mark.parametrize("criterion", ["paper-mi", "gopinath2017", "gopinath2017-kl"])
def test_mode_switch_selects_the_mode_its_criterion_ranks_best(criterion, rate_hz):
    toml = POLICY_TOML.replace('criterion = "paper-mi"', f'criterion = "{criterion}"')
    config = experiment_from_toml(toml.replace("[blending]", f"rate_hz = {rate_hz}\n[blending]"))
    assert config.study.rate_hz == rate_hz
    settings_ = ProtocolSettings.from_config(config)
    layout, model = _layout_model(3)
    rng = np.random.default_rng(0)
    switched = 0
    for _ in range(40):
        i, j = int(rng.integers(N_CELLS_X)), int(rng.integers(N_CELLS_Y))
        h, m = int(rng.integers(N_HEADINGS)), int(rng.integers(N_MODES))
        session = TrialSession(_spec("mode-switch", layout), settings_, model, 10, np.random.default_rng(1))
        session.x, session.y = (float(v) for v in cell_centre(i, j))
        session.theta, session.mode = h * math.pi / 4, m
        assert session.state == state_index(i, j, h, m)
        belief = rng.dirichlet(np.ones(3))
        session._set_belief(belief)
        session._start_autonomy_turn()
        states = [int(state_index(i, j, h, mode)) for mode in range(N_MODES)]
        scores = _brute_force_scores(criterion, belief, model.likelihood[:, states, :].transpose(1, 0, 2))
        best = scores.max()
        # the modes whose score ties the best (two modes can give the same label distributions)
        tied = [mode for mode in range(N_MODES)
                if math.isclose(scores[mode], best, rel_tol=1e-6, abs_tol=1e-9)]
        expected = m if m in tied else tied[0]  # the current mode wins ties, else the first in mode order
        assert session.mode == expected, (criterion, scores, m)
        switched += expected != m
    assert switched >= 5  # the criterion did choose another mode, often


def test_mode_only_candidates_are_the_states_that_differ_in_mode_alone():
    rng = np.random.default_rng(4)
    for _ in range(20):
        i, j, h, m = (int(rng.integers(n)) for n in (N_CELLS_X, N_CELLS_Y, N_HEADINGS, N_MODES))
        current = int(state_index(i, j, h, m))
        brute = [s for s in range(N_CELLS_X * N_CELLS_Y * N_HEADINGS * N_MODES)
                 if s // N_MODES == current // N_MODES]
        assert mode_candidates(current).states.tolist() == brute


# --- hindsight ------------------------------------------------------------------------------------

def _hindsight_step(toml: str, belief: np.ndarray, pressure: float):
    """One step of a hindsight trial from layout 5's start with ``belief``: (session, pose before, row)."""
    settings_ = ProtocolSettings.from_config(experiment_from_toml(toml))
    layout, model = _layout_model(5)
    session = TrialSession(_spec("hindsight", layout), settings_, model, 10, np.random.default_rng(2))
    session._set_belief(belief)
    pose = (session.x, session.y, session.theta)
    session.human_step(SOFT_PUFF if pressure else NO_INPUT, pressure)
    row = {c: v[-1] for c, v in session.columns.items()}
    return session, pose, row, layout


def test_hindsight_with_a_one_hot_belief_adds_that_goals_ada_assistance_to_the_persons_command():
    for goal in range(3):
        session, pose, row, layout = _hindsight_step(POLICY_TOML, np.eye(3)[goal], -0.2)
        s = session.settings
        u_h = np.array([row["u_h_x"], row["u_h_y"], row["u_h_theta"]])
        u_a = np.array([row["u_a_x"], row["u_a_y"], row["u_a_theta"]])
        # ADA's one-goal assistance, evaluated after the person's command (the source's 0.1 s)
        goal_command = hindsight.goal_command(*pose, tuple(layout.goal_poses[goal]), s.hindsight, s.dt,
                                              tuple(u_h))
        assert np.abs(u_h).sum() > 0 and np.abs(goal_command).sum() > 0
        np.testing.assert_array_equal(u_a, goal_command)
        # far from every goal its speed is the source's share of the person's full command, 0.306
        far_speed = hindsight.SOURCE_STRENGTH * s.human_speed
        assert math.hypot(u_a[0], u_a[1]) == pytest.approx(far_speed, rel=1e-12)
        expected = GridWorld(layout, 1.0, 0.2).move(*pose, u_h + u_a, s.dt)
        np.testing.assert_allclose((session.x, session.y, session.theta), expected, atol=1e-12)
        assert row["turn"] == HUMAN_TURN and row["alpha"] == 1.0 and row["inferred_goal"] == goal


def test_hindsight_always_assists_without_input_and_on_command_only_with_it():
    belief = np.array([0.2, 0.5, 0.3])
    _, pose, row, _ = _hindsight_step(POLICY_TOML, belief, 0.0)
    assert row["alpha"] == 1.0 and abs(row["u_a_x"]) + abs(row["u_a_y"]) > 0  # the source: every step
    on_command = POLICY_TOML.replace("[hindsight]", '[hindsight]\nassist = "on-command"')
    session, pose, row, _ = _hindsight_step(on_command, belief, 0.0)
    assert row["alpha"] == 0.0 and (row["u_a_x"], row["u_a_y"], row["u_a_theta"]) == (0.0, 0.0, 0.0)
    assert (session.x, session.y, session.theta) == pose  # no input, no assistance: the robot stands
    _, _, row, _ = _hindsight_step(on_command, belief, -0.2)
    assert row["alpha"] == 1.0


def test_hindsight_strength_and_zone_are_read_from_its_section():
    settings_ = ProtocolSettings.from_config(experiment_from_toml(POLICY_TOML))
    assert settings_.hindsight.strength == hindsight.SOURCE_STRENGTH
    scaled_zone = hindsight.TRANSLATION_DELTA_SWITCH * 3.0 / 0.2  # the source's 0.07 m, 15 units a metre
    assert settings_.hindsight.zone == pytest.approx(scaled_zone, rel=1e-12)
    changed = POLICY_TOML.replace("[hindsight]", "[hindsight]\nstrength = 1.0\nzone = 4.0")
    settings_ = ProtocolSettings.from_config(experiment_from_toml(changed))
    assert (settings_.hindsight.strength, settings_.hindsight.zone) == (1.0, 4.0)


# --- blending -------------------------------------------------------------------------------------

@given(st.lists(st.floats(0.0, 1.0), min_size=2, max_size=6).filter(lambda w: sum(w) > 0),
       st.floats(0.0, 1.0), st.floats(0.0, 0.99))
@settings(max_examples=80, deadline=None)
def test_the_gap_gate_passes_alpha_only_above_the_gap(weights, alpha, gap):
    belief = np.array(weights) / sum(weights)
    top = sorted(belief, reverse=True)
    expected = alpha if top[0] - top[1] > gap else 0.0
    assert policies.gap_gated_alpha(alpha, belief, gap) == expected


def test_blending_with_the_gap_gate_gives_alpha_0_when_p1_minus_p2_is_at_most_the_gap(policy_steps):
    rows = of(policy_steps, "blending")
    beliefs = [sorted(b, reverse=True) for b in rows["belief"]]
    gap = np.array([b[0] - b[1] for b in beliefs])
    p1 = np.array([b[0] for b in beliefs])
    alpha = rows["alpha"].to_numpy()
    closed = gap <= 0.4
    assert (alpha[closed] == 0).all()
    # the gate mattered: the paper's rule alone would have assisted some of those steps
    ungated = p1 > 1.1 / rows["n_goals"].to_numpy()
    assert (closed & ungated).sum() > 0 and (alpha > 0).any()
    assert (rows["turn"] == HUMAN_TURN).all()


def test_the_gap_gate_is_read_from_the_blending_section():
    config = experiment_from_toml(POLICY_TOML.replace('gate = "gap"\ngap = 0.4', 'gate = "none"'))
    assert ProtocolSettings.from_config(config).blending_gap is None
    assert ProtocolSettings.from_config(experiment_from_toml(POLICY_TOML)).blending_gap == 0.4


# --- teleoperation and the turn structure ----------------------------------------------------------

def test_teleoperation_never_infers_blends_or_moves_autonomously(policy_steps):
    rows = of(policy_steps, "teleoperation")
    assert (rows["phi_m"] != "").sum() > 50  # the person gave input ...
    uniform = np.array([np.allclose(b, 1.0 / len(b)) for b in rows["belief"]])
    assert uniform.all()  # ... and no belief update ever followed
    assert (rows["turn"] == HUMAN_TURN).all() and (rows["alpha"] == 0).all()
    assert (rows["inferred_goal"] == -1).all()
    assert (rows[["u_a_x", "u_a_y", "u_a_theta"]].to_numpy() == 0).all()


@pytest.mark.parametrize("condition", ["blending", "hindsight"])
def test_policies_without_turn_taking_have_one_human_turn(policy_steps, condition):
    rows = of(policy_steps, condition)
    assert (rows["turn"] == HUMAN_TURN).all()
    assert not np.array([np.allclose(b, 1.0 / len(b)) for b in rows["belief"]]).all()  # they infer


def test_no_assistance_is_the_teleoperation_policy():
    assert policy_name("no_assistance") == "teleoperation"
    assert policy_name("control") == "control"
    config = experiment_from_toml(POLICY_TOML)
    assert isinstance(make_policy("no_assistance", ProtocolSettings.from_config(config)), Teleoperation)


# --- bad input ------------------------------------------------------------------------------------

@pytest.mark.parametrize(("study", "extra", "message"), [
    ('["disambiguation", "blendng"]', "", "unknown condition 'blendng' (did you mean 'blending'?)"),
    ('["disambiguation", "hindsight"]', "", "no [hindsight] section"),
    ('["disambiguation", "mode-switch"]', "", "no [mode-switch] section"),
    ('["disambiguation"]', "", "only one condition"),
    ('["disambiguation", "control", "teleoperation"]', "", "cannot balance 3 conditions"),
])
def test_bad_conditions_fail_with_one_error_line_and_no_folder(tmp_path, study, extra, message):
    path = tmp_path / "bad.toml"
    path.write_text(f"[study]\nparticipants = 1\nconditions = {study}\n{extra}")
    out = tmp_path / "never"
    result = CliRunner().invoke(main, ["simulate", str(path), "--out", str(out)])
    assert result.exit_code == 1, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error: ") and message in lines[0], lines
    assert str(path) in lines[0] and not out.exists()


def test_an_odd_count_is_balanced_by_the_pair_of_squares():
    config = experiment_from_toml('[study]\nconditions = ["disambiguation", "control", "teleoperation"]\n'
                                  'counterbalancing = "williams-pair"\n')
    assert config.study.counterbalancing == "williams-pair"


def test_a_policy_section_round_trips_through_the_run_folders_toml():
    toml = POLICY_TOML.replace('criterion = "paper-mi"', 'criterion = "gopinath2017-kl"')
    config = experiment_from_toml(toml)
    text = config.to_toml()
    assert "[mode-switch]" in text and 'criterion = "gopinath2017-kl"' in text
    assert experiment_from_toml(text) == config


# --- the baselines preset ------------------------------------------------------------------------

def test_the_baselines_preset_runs_the_papers_48_layouts_under_seven_conditions():
    config = load_experiment("baselines")
    paper = load_experiment("paper")
    assert config.study.conditions == (*SIX.strip("[]").replace('"', "").split(", "), "turn-taking")
    layouts, paper_layouts = build_layouts(config, 2022), build_layouts(paper, 2022)
    assert len(layouts) == 48
    for ours, theirs in zip(layouts, paper_layouts, strict=True):
        np.testing.assert_array_equal(ours.layout.goal_cells, theirs.layout.goal_cells)
        np.testing.assert_array_equal(ours.layout.start_pose, theirs.layout.start_pose)
    schedule = participant_schedule(config, 2022, 0, layouts)
    assert len(schedule) == 7 * 48
    for condition in config.study.conditions:
        assert sorted(s.layout_index for s in schedule if s.condition == condition) == list(range(48))


def test_baselines_tables_are_identical_with_one_and_two_workers_and_dask(tmp_path):
    config = load_experiment("baselines", ["study.blocks_per_condition=1", "study.corners=['tr']",
                                           "study.start_modes=['x']", "study.goal_counts=[3]"])
    run_study(config, tmp_path / "one", participants=2, workers=1)
    run_study(config, tmp_path / "two", participants=2, workers=2)
    assert_same_run(tmp_path / "one", tmp_path / "two")
    with local_cluster(2) as cluster:  # on this machine only (127.0.0.1)
        run_study(config, tmp_path / "dask", participants=2, scheduler=cluster.scheduler_address)
    assert_same_run(tmp_path / "one", tmp_path / "dask")
    trials = pd.read_parquet(tmp_path / "one" / "trials")
    assert set(trials["condition"]) == set(config.study.conditions)


def test_the_manifest_records_every_participants_condition_order(tmp_path: Path):
    config = experiment_from_toml(POLICY_TOML)
    run = run_study(config, tmp_path / "run", participants=2)
    manifest = json.loads((run.path / "manifest.json").read_text())
    record = manifest["counterbalancing"]
    assert record["design"] == "williams" and len(record["orders"]) == 6
    trials = pd.read_parquet(run.path / "trials")
    for participant in (0, 1):
        seen = list(dict.fromkeys(trials.loc[trials["participant"] == participant, "condition"]))
        assert seen == record["participant_orders"][str(participant)]


def test_the_baselines_plan_orders_the_experiments_conditions():
    plan = load_plan("baselines")
    assert plan.conditions == load_experiment("baselines").study.conditions
    assert default_plan_name("baselines") == "baselines"


def test_the_confidence_gap_of_one_goal_is_its_belief_and_of_none_zero():
    assert policies.confidence_gap(np.array([1.0])) == 1.0
    assert policies.confidence_gap(np.array([])) == 0.0
    assert policies.gap_gated_alpha(0.7, np.array([1.0]), 0.4) == 0.7
    assert policies.confidence_gap(np.array([0.2, 0.5, 0.3])) == pytest.approx(0.2, abs=1e-15)


def test_additive_blending_adds_the_leaders_whole_ada_assistance_only_past_the_gap():
    toml = POLICY_TOML.replace('gate = "gap"', 'kind = "additive"\ngate = "gap"')
    settings_ = ProtocolSettings.from_config(experiment_from_toml(toml))
    layout, model = _layout_model(5)
    for belief, acts in ((np.array([0.1, 0.8, 0.1]), True), (np.array([0.35, 0.45, 0.2]), False)):
        session = TrialSession(_spec("blending", layout), settings_, model, 10, np.random.default_rng(2))
        session._set_belief(belief)
        pose = (session.x, session.y, session.theta)
        session.human_step(NO_INPUT, 0.0)  # ADA's blend acts with or without input
        row = {c: v[-1] for c, v in session.columns.items()}
        u_a = (row["u_a_x"], row["u_a_y"], row["u_a_theta"])
        if acts:  # p1 - p2 = 0.7 > 0.4: goal 1's whole assistance, alpha 1
            expected = hindsight.goal_command(*pose, tuple(layout.goal_poses[1]), settings_.hindsight,
                                              settings_.dt, (0.0, 0.0, 0.0))
            assert u_a == expected and row["alpha"] == 1.0 and row["inferred_goal"] == 1
            assert (session.x, session.y) != pose[:2]
        else:  # p1 - p2 = 0.1: the person's command alone
            assert u_a == (0.0, 0.0, 0.0) and row["alpha"] == 0.0
            assert (session.x, session.y, session.theta) == pose


def test_herlant2016_switches_to_the_mode_of_the_axis_still_to_travel():
    # hand-made: the goal lies straight along y from the robot, same heading: in mode x nothing is
    # left to travel along x, so the time-optimal plan's next mode is y; in mode y it stays
    toml = POLICY_TOML.replace('criterion = "paper-mi"', 'criterion = "herlant2016"')
    settings_ = ProtocolSettings.from_config(experiment_from_toml(toml))
    layout, model = _layout_model(3)
    goal = layout.goal_poses[0]
    for mode, expected in ((0, 1), (1, 1), (2, 1)):
        session = TrialSession(_spec("mode-switch", layout), settings_, model, 10, np.random.default_rng(1))
        session.x, session.y = float(goal[0]), float(goal[1]) + 10.0
        session.theta, session.mode = float(goal[2]), mode
        session._set_belief(np.array([0.8, 0.1, 0.1]))
        session._start_autonomy_turn()
        assert session.mode == expected
    # x and the heading still to travel: stay in either of their modes, from y go to x (mode order)
    for mode, expected in ((0, 0), (1, 0), (2, 2)):
        session = TrialSession(_spec("mode-switch", layout), settings_, model, 10, np.random.default_rng(1))
        session.x, session.y = float(goal[0]) + 10.0, float(goal[1])
        session.theta, session.mode = float(goal[2]) + 1.0, mode
        session._set_belief(np.array([0.8, 0.1, 0.1]))
        session._start_autonomy_turn()
        assert session.mode == expected
    # no unique leader: no goal to plan for, the mode is kept
    session = TrialSession(_spec("mode-switch", layout), settings_, model, 10, np.random.default_rng(1))
    session.mode = 2
    session._set_belief(np.array([0.4, 0.4, 0.2]))
    session._start_autonomy_turn()
    assert session.mode == 2


# --- mode-switch on request -----------------------------------------------------------------------

def _request_session(criterion: str, layout, model, mode: int, belief: np.ndarray) -> TrialSession:
    toml = POLICY_TOML.replace('criterion = "paper-mi"', f'criterion = "{criterion}"\ntrigger = "request"')
    settings_ = ProtocolSettings.from_config(experiment_from_toml(toml))
    session = TrialSession(_spec("mode-switch", layout), settings_, model, 10, np.random.default_rng(1))
    session.mode = mode
    session._set_belief(belief)
    return session


def test_on_request_a_persons_switch_goes_to_the_criterions_best_other_mode():
    layout, model = _layout_model(3)
    rng = np.random.default_rng(3)
    chose_other = 0
    for _ in range(30):
        mode = int(rng.integers(N_MODES))
        belief = rng.dirichlet(np.ones(3))
        session = _request_session("paper-mi", layout, model, mode, belief)
        assert not session.turn_taking  # no autonomy turns: requests only
        state = session.state
        session.human_step(HARD_PUFF, -0.9)  # a hard puff: the person asks for a switch
        requested = (mode + 1) % N_MODES  # Hard Puff cycles x -> y -> theta -> x
        # the belief the choice saw: after this step's update (the hard puff is an observation)
        mode_only = [state - state % N_MODES + m for m in range(N_MODES)]  # the same cell and heading
        likelihood = model.likelihood[:, mode_only, :].transpose(1, 0, 2)
        scores = _brute_force_scores("paper-mi", session.belief, likelihood)
        others = [m for m in range(N_MODES) if m != mode]
        best = max(scores[m] for m in others)
        tied = [m for m in others if math.isclose(scores[m], best, rel_tol=1e-6, abs_tol=1e-9)]
        expected = requested if requested in tied else tied[0]
        assert session.mode == expected != mode
        assert session.human_switches == 1
        assert has_event(session.columns["event"], MODE_SELECT)[-1]
        chose_other += expected != requested
    assert chose_other >= 3  # the choice overrode the person's own often


def test_herlant_on_request_skips_the_current_mode_and_falls_back_to_the_request():
    layout, model = _layout_model(3)
    goal = layout.goal_poses[0]
    # (mode, offset from goal 0 in x, y, heading, the mode the blow asked for, the answer)
    cases = ((0, 10.0, 0.0, 1.0, 1, 2),  # x and the heading to travel, in x: the plan's next, theta
             (1, 0.0, 10.0, 0.0, 0, 0))  # only y to travel, in y: nothing else needed, the request
    for mode, dx, dy, dtheta, requested, expected in cases:
        session = _request_session("herlant2016", layout, model, mode, np.array([0.8, 0.1, 0.1]))
        session.x, session.y = float(goal[0]) + dx, float(goal[1]) + dy
        session.theta = float(goal[2]) + dtheta
        assert session.choose_mode is not None  # asked as the protocol asks it on a hard blow
        assert session.choose_mode(session, requested) == expected


def test_with_handover_the_persons_switch_is_their_own():
    layout, model = _layout_model(3)
    settings_ = ProtocolSettings.from_config(experiment_from_toml(POLICY_TOML))
    session = TrialSession(_spec("mode-switch", layout), settings_, model, 10, np.random.default_rng(1))
    session.mode = 0
    session.human_step(HARD_PUFF, -0.9)
    assert session.mode == 1 and session.turn_taking
    assert not has_event(session.columns["event"], MODE_SELECT).any()
