"""The turn-taking protocol (Algorithm 1) checked on its own step logs."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pandas as pd
import pytest

from nudgecli.config import load_experiment
from nudgecli.model import assistance
from nudgecli.model.disambiguation import DisambiguationModel, maximally_disambiguating_state
from nudgecli.model.interface import NO_INPUT, SOFT_PUFF, default_distortion_table, default_mapping_table
from nudgecli.model.mdp import solve_layout
from nudgecli.model.world import MODE_NAMES, cell_centre, discretise, state_index
from nudgecli.rng import generator
from nudgecli.sim.participants import Participant, mapping_with_error
from nudgecli.sim.protocol import ProtocolSettings, TrialSession, TrialSpec, goal_transition_matrix
from nudgecli.sim.study import build_layouts
from nudgecli.sim.trials import handover_steps, run_trial

DT = 0.1


def ideal_participant() -> Participant:
    """Noise-free and epsilon-0: every blow lands in its band, the mapping is the true one."""
    return Participant(index=0, seed_key="ideal", pressure_level=np.array([-0.8, 0.8, -0.15, 0.15]),
                       pressure_spread=np.zeros(4), mapping=mapping_with_error(0.0), epsilon=0.0,
                       rest_s=0.5, operate_s=3.0, action_pause_s=0.2, hard_blow_s=0.4, reaction_s=0.5)


def noisy_participant() -> Participant:
    return Participant(index=1, seed_key="noisy", pressure_level=np.array([-0.75, 0.7, -0.18, 0.24]),
                       pressure_spread=np.array([0.12, 0.12, 0.07, 0.1]), mapping=mapping_with_error(0.05),
                       epsilon=0.1, rest_s=0.8, operate_s=3.5, action_pause_s=0.3, hard_blow_s=0.5,
                       reaction_s=0.5, onset_ramp_samples=1)


@pytest.fixture(scope="module")
def paper():
    config = load_experiment("paper")
    return config, ProtocolSettings.from_config(config), build_layouts(config, 11)


def simulate(paper, layout_index: int, participant: Participant, seed: int = 0, condition: str | None = None):
    _config, settings, layouts = paper
    item = layouts[layout_index]
    solved = solve_layout(item.layout.goal_cells, item.layout.goal_headings)
    model = DisambiguationModel(item.layout.goal_cells, solved.p_a_given_sg, default_mapping_table(),
                                default_distortion_table())
    spec = TrialSpec(participant=participant.index, condition=condition or item.condition, block=0, trial=0,
                     layout_index=item.index, layout=item.layout)
    result = run_trial(spec, settings, solved, model, participant, generator(seed, "test", layout_index))
    return result, pd.DataFrame(result.steps), item, model


@pytest.mark.parametrize("layout_index", [0, 5, 13, 22, 30, 41])
def test_ideal_participant_reaches_the_true_goal(paper, layout_index):
    result, steps, _, _ = simulate(paper, layout_index, ideal_participant())
    assert result.summary["success"], result.summary
    assert result.summary["reached_goal"] == 0
    assert not result.summary["timed_out"]
    # it ends in the human's turn, as a trial must
    assert steps["turn"].iloc[-1] == "human"
    assert steps["turn"].iloc[0] == "human"


@pytest.mark.parametrize("layout_index", [2, 9, 26, 40])
def test_blending_arithmetic_in_the_human_turn(paper, layout_index):
    _, steps, _, _ = simulate(paper, layout_index, noisy_participant(), seed=3)
    nxt = steps.shift(-1)
    human = steps[(steps["turn"] == "human") & nxt["step"].notna()]
    u_h = human[["u_h_x", "u_h_y", "u_h_theta"]].to_numpy()
    u_a = human[["u_a_x", "u_a_y", "u_a_theta"]].to_numpy()
    alpha = human["alpha"].to_numpy()[:, None]
    moving = np.abs(u_h).sum(axis=1) > 0
    expected = np.where(moving[:, None], alpha * u_a + (1 - alpha) * u_h, 0.0)
    dx = nxt.loc[human.index, "x"].to_numpy() - human["x"].to_numpy()
    dy = nxt.loc[human.index, "y"].to_numpy() - human["y"].to_numpy()
    dth = np.angle(np.exp(1j * (nxt.loc[human.index, "theta"].to_numpy() - human["theta"].to_numpy())))
    # away from the walls, one step moves by u_f * dt exactly (Algorithm 1, lines 8-9)
    inside = ((human["x"] > 5) & (human["x"] < 43) & (human["y"] > 4) & (human["y"] < 34)).to_numpy()
    assert moving.sum() > 10 and (alpha[moving] > 0).sum() > 0, "the trial must exercise blending"
    np.testing.assert_allclose(dx[inside], expected[inside, 0] * DT, atol=1e-12)
    np.testing.assert_allclose(dy[inside], expected[inside, 1] * DT, atol=1e-12)
    np.testing.assert_allclose(dth[inside], expected[inside, 2] * DT, atol=1e-12)


def test_alpha_follows_the_paper_rule(paper):
    _, steps, _, _ = simulate(paper, 7, noisy_participant(), seed=5)
    ramp = paper[0].assistance
    human = steps[steps["turn"] == "human"]
    for belief, alpha, inferred in zip(human["belief"], human["alpha"], human["inferred_goal"], strict=True):
        b = np.asarray(belief)
        leaders = np.flatnonzero(b == b.max())  # exact ties: the belief starts uniform
        if leaders.size > 1:  # no g' while the leaders are tied: blind to which goal is true
            assert inferred == -1 and alpha == 0.0
            continue
        assert inferred == leaders[0]
        expected = assistance.blending_factor(b.max(), b.size, ramp.rho1_factor, ramp.rho2_factor, ramp.rho3)
        assert alpha == pytest.approx(expected, abs=1e-12)


def turns(steps: pd.DataFrame) -> list[pd.DataFrame]:
    change = (steps["turn"] != steps["turn"].shift()).cumsum()
    return [group for _, group in steps.groupby(change, sort=True)]


def test_belief_is_frozen_during_the_autonomy_turn(paper):
    _, steps, _, _ = simulate(paper, 3, noisy_participant(), seed=1)
    autonomy = [t for t in turns(steps) if t["turn"].iloc[0] == "autonomy"]
    assert autonomy
    for turn in autonomy:
        beliefs = np.array(turn["belief"].tolist())
        assert (beliefs == beliefs[0]).all()
        assert (turn["phi_m"] == "").all()


def test_handover_only_after_the_idle_time(paper):
    _config, settings, _ = paper
    _, steps, _, _ = simulate(paper, 12, noisy_participant(), seed=2)
    blocks = turns(steps)
    idle_needed = handover_steps(noisy_participant().handover_idle_s, settings.dt)
    handed_over = 0
    for human, autonomy in itertools.pairwise(blocks):
        if human["turn"].iloc[0] != "human":
            continue
        handed_over += 1
        assert autonomy["event"].iloc[0].startswith("handover_to_autonomy")
        commands = (human[["u_h_x", "u_h_y", "u_h_theta"]].abs().sum(axis=1) > 0) | \
            human["event"].str.contains("mode_switch_human")
        # the last idle_needed steps of the turn carry no command: the idle time handed it over
        assert not commands.iloc[-idle_needed:].any()
        assert commands.any(), "a human turn hands over only after the human has given an input"
    assert handed_over >= 1


def test_control_step_goes_towards_the_tied_goals(paper):
    _, steps, item, _ = simulate(paper, 30, noisy_participant(), seed=4, condition="control")
    goals = item.layout.goal_poses
    sizes = assistance.step_sizes(3)
    checked = 0
    for turn in turns(steps):
        if turn["turn"].iloc[0] != "autonomy":
            continue
        start = turn[["x", "y"]].iloc[0].to_numpy()
        belief = np.asarray(turn["belief"].iloc[0])
        end_index = turn.index[-1] + 1
        if end_index not in steps.index:
            continue
        end = steps.loc[end_index, ["x", "y"]].to_numpy(dtype=float)
        target = assistance.control_target(belief, goals[:, :2])
        direction = (target - start) / np.linalg.norm(target - start)
        moved = end - start
        # on the line towards the mean of the tied goals, by min(R, D / 2) with R from the window's steps
        assert np.linalg.norm(moved - direction * np.dot(moved, direction)) < 0.11
        distance = np.linalg.norm(target - start)
        assert any(abs(np.linalg.norm(moved) - min(r, distance / 2)) <= 0.11 for r in sizes)
        # heading and mode are kept
        assert turn["mode"].nunique() == 1
        assert steps.loc[end_index, "theta"] == pytest.approx(turn["theta"].iloc[0])
        checked += 1
    assert checked >= 1


def test_nudge_goes_to_s_star_within_the_window(paper):
    _config, settings, _layouts = paper
    checked = 0
    for layout_index, seed in ((0, 1), (4, 2), (8, 3), (16, 4)):
        _, steps, item, model = simulate(paper, layout_index, noisy_participant(), seed=seed,
                                         condition="disambiguation")
        for turn in turns(steps):
            first = turn.iloc[0]
            if first["turn"] != "autonomy" or "nudge" not in first["event"]:
                continue
            belief = np.asarray(first["belief"])
            i, j, h = discretise(first["x"], first["y"], first["theta"])
            mode_before = steps.loc[turn.index[0] - 1, "mode"]
            state = state_index(i, j, h, MODE_NAMES.index(mode_before))
            choice = maximally_disambiguating_state(belief, model, state, settings.disambiguation,
                                                    robot_position=np.array([first["x"], first["y"]]))
            ci, cj, ch, cm = np.unravel_index(choice.state, (10, 10, 8, 3))
            assert abs(ci - i) <= 1 and abs(cj - j) <= 1 and ch == h
            assert not any((ci, cj) == tuple(c) for c in item.layout.goal_cells)
            assert MODE_NAMES[cm] == first["mode"]  # switched instantly to s*'s mode
            end_index = turn.index[-1] + 1
            if end_index in steps.index:
                end = steps.loc[end_index, ["x", "y"]].to_numpy(dtype=float)
                assert np.linalg.norm(end - cell_centre(ci, cj)) <= settings.arrival_tolerance + 1e-9
            checked += 1
    assert checked >= 2


def test_entropy_above_kappa_nudges_and_below_steps(paper):
    _config, settings, _ = paper
    _, steps, _, _ = simulate(paper, 1, noisy_participant(), seed=6, condition="disambiguation")
    for turn in turns(steps):
        first = turn.iloc[0]
        if first["turn"] != "autonomy":
            continue
        if first["entropy"] > settings.kappa:
            assert "nudge" in first["event"]
        else:
            assert "step" in first["event"]


def test_trial_times_out_at_the_limit(paper):
    _config, _, layouts = paper
    short = load_experiment("paper", ["study.time_limit_s=3.0"])
    settings = ProtocolSettings.from_config(short)
    item = layouts[0]
    solved = solve_layout(item.layout.goal_cells, item.layout.goal_headings)
    model = DisambiguationModel(item.layout.goal_cells, solved.p_a_given_sg, default_mapping_table(),
                                default_distortion_table())
    spec = TrialSpec(0, item.condition, 0, 0, item.index, item.layout)
    result = run_trial(spec, settings, solved, model, ideal_participant(), generator(0, "t"))
    assert result.summary["timed_out"] and not result.summary["success"]
    assert result.summary["duration_s"] == pytest.approx(3.0)
    assert len(result.steps["step"]) == 30


def poses_after_each_step(steps: pd.DataFrame, summary: dict) -> np.ndarray:
    """``(N, 3)``: the pose at the end of every step (the next row's start, the summary's last)."""
    poses = steps[["x", "y", "theta"]].to_numpy(dtype=float)
    final = np.array([[summary["final_x"], summary["final_y"], summary["final_theta"]]])
    return np.vstack([poses[1:], final])


@pytest.mark.parametrize("layout_index", [6, 20, 33])
def test_the_trial_ends_at_the_first_human_step_within_tolerance(paper, layout_index):
    result, steps, item, _ = simulate(paper, layout_index, noisy_participant(), seed=8)
    goals = item.layout.goal_poses
    after = poses_after_each_step(steps, result.summary)
    distance = np.hypot(after[:, None, 0] - goals[None, :, 0], after[:, None, 1] - goals[None, :, 1])
    angle = np.abs(np.angle(np.exp(1j * (after[:, None, 2] - goals[None, :, 2]))))
    within = ((distance <= 1.0) & (angle <= 0.2)).any(axis=1)
    if result.summary["timed_out"]:
        assert result.summary["reached_goal"] == -1
        return
    reached = result.summary["reached_goal"]
    assert distance[-1, reached] <= 1.0 and angle[-1, reached] <= 0.2
    assert result.summary["success"] == (reached == 0)
    # no earlier human step (after the turn's first input) ended within the tolerance
    human = (steps["turn"] == "human").to_numpy()
    earlier = within[:-1] & human[:-1]
    if earlier.any():
        # only before the first input of that human turn (the rule needs an input first)
        for k in np.flatnonzero(earlier):
            turn_start = k
            while turn_start > 0 and steps["turn"].iloc[turn_start - 1] == "human":
                turn_start -= 1
            assert (steps["phi_m"].iloc[turn_start:k + 1] == "").all()
    assert result.summary["duration_s"] == pytest.approx(len(steps) * DT)


def test_step_log_times() -> None:
    from nudgecli.steplog import step_times

    assert step_times(0.1, 5)[:6] == [round(k * 0.1, 10) for k in range(6)] == [0.0, 0.1, 0.2, 0.3, 0.4, 0.5]
    longer = step_times(0.1, 5000)  # past the first table: a longer one, the same values
    assert len(longer) > 5000 and longer[4999] == round(4999 * 0.1, 10) == 499.9
    assert step_times(0.25, 3)[:4] == [0.0, 0.25, 0.5, 0.75]


def _row_by_row_step_log(trials) -> pd.DataFrame:
    """The step log of raw trials, one row at a time in plain Python (the schema read literally)."""
    from nudgecli.model.interface import LABELS
    from nudgecli.sim.step_record import ROW_FIELDS, STREAM_LABEL

    out = []
    for rows, participant, trial, dt, cells in trials:
        for row in rows:
            f = dict(zip(ROW_FIELDS, row, strict=True))
            cell_x, cell_y, heading = cells(f["state"])
            u_h, u_a = [float(v) for v in f["u_h"]], [float(v) for v in f["u_a"]]
            out.append({
                "participant": participant, "trial": trial, "step": f["step"],
                "t": round(f["step"] * dt, 10), "turn": f["turn"], "x": f["x"], "y": f["y"],
                "theta": f["theta"], "mode": MODE_NAMES[f["mode"]], "cell_x": cell_x, "cell_y": cell_y,
                "heading": heading, "phi_i": LABELS[f["intended"]] if f["intended"] >= 0 else "",
                "pressure": f["pressure"], "phi_m": STREAM_LABEL.get(f["measured"], ""),
                "u_h_x": u_h[0], "u_h_y": u_h[1], "u_h_theta": u_h[2], "u_a_x": u_a[0], "u_a_y": u_a[1],
                "u_a_theta": u_a[2], "alpha": f["alpha"], "inferred_goal": f["inferred"],
                "belief": [float(b) for b in f["belief"]], "entropy": f["entropy"],
                "event": "|".join(f["events"]),  # DESIGN section 4: the step's events joined by "|"
            })
    return pd.DataFrame(out)


def test_a_participants_step_log_is_each_trials_rows_in_turn() -> None:
    # one call formats all of a participant's trials: each with its own ids, step length, world
    # (cells), belief length and command types, the same as reading every row literally
    from nudgecli.sim.step_record import StepRecording, step_columns
    from nudgecli.steplog import STEP_COLUMNS, steps_frame

    rng = np.random.default_rng(11)

    def rows(n: int, goals: int) -> list[tuple]:
        out = []
        for k in range(n):
            pose = rng.uniform(0, 5, size=3).tolist()
            codes = int(rng.integers(3)), int(rng.integers(900)), int(rng.integers(-1, 4))  # mode, state, phi
            pressure, measured = float(rng.uniform(-1, 1)), int(rng.choice([-1, 0, 1, 2, 3, 4, 5]))
            u_a = tuple(rng.normal(size=3).tolist()) if k % 3 else rng.normal(size=3)  # hindsight's arrays
            events = [] if k % 5 else ["nudge", "step"][: 1 + k % 2]
            out.append((k, "human" if k % 4 else "autonomy", *pose, *codes, pressure, measured,
                        (1.0, -2.0, 0.5), u_a, float(rng.uniform()), int(rng.integers(-1, goals)),
                        rng.dirichlet(np.ones(goals)), float(rng.uniform()), events))
        return out

    def cells_a(state: int) -> tuple[int, int, int]:
        return state // 100, state % 100 // 10, state % 10

    def cells_b(state: int) -> tuple[int, int, int]:
        return state % 7, -state, 0

    raw = [(rows(23, 3), 4, 0, 0.1, cells_a), ([], 4, 1, 0.1, cells_a), (rows(40, 5), 4, 2, 0.25, cells_b),
           (rows(1, 2), 4, 7, 0.1, cells_b)]
    recordings = [StepRecording.of_rows(*trial) for trial in raw]
    expected = _row_by_row_step_log(raw)
    columns = step_columns(recordings)
    assert tuple(columns) == STEP_COLUMNS
    pd.testing.assert_frame_equal(steps_frame(columns), expected, check_exact=True)
    # each trial alone gives its own rows of the same log
    alone = pd.concat([steps_frame(step_columns([r])) for r in recordings if len(r)], ignore_index=True)
    pd.testing.assert_frame_equal(alone, expected, check_exact=True)
    empty = steps_frame(step_columns([]))
    assert list(empty.columns) == list(STEP_COLUMNS) and len(empty) == 0
    # a recording for some columns keeps only the fields they are made of (the metrics' batches
    # ask for a third of the columns), and gives those columns as the full recording does
    for name in STEP_COLUMNS:  # each column alone, from a recording kept for it
        alone_kept = [StepRecording.of_rows(*trial, names=(name,)) for trial in raw]
        pd.testing.assert_frame_equal(steps_frame(step_columns(alone_kept, (name,))), expected[[name]],
                                      check_exact=True)
    kept_fields = {("phi_m", "trial"): {"step", "measured"},
                   ("t", "cell_y", "u_a_x", "event"): {"step", "state", "u_a", "events"}}
    for names, fields in kept_fields.items():
        partial = [StepRecording.of_rows(*trial, names=names) for trial in raw]
        assert set(partial[0].fields) == fields
        in_order = [name for name in STEP_COLUMNS if name in names]
        pd.testing.assert_frame_equal(steps_frame(step_columns(partial, names)), expected[in_order],
                                      check_exact=True)


def test_a_trial_keeps_the_step_log_columns_asked_for(paper) -> None:
    # the metrics' batches keep a third of the columns: the same values, in the schema's order
    from nudgecli.steplog import STEP_COLUMNS

    _config, settings, layouts = paper
    item = layouts[5]
    solved = solve_layout(item.layout.goal_cells, item.layout.goal_headings)
    model = DisambiguationModel(item.layout.goal_cells, solved.p_a_given_sg, default_mapping_table(),
                                default_distortion_table())
    spec = TrialSpec(participant=1, condition=item.condition, block=0, trial=0, layout_index=item.index,
                     layout=item.layout)

    def steps(names=STEP_COLUMNS):
        rng = generator(3, "test", 5)
        return run_trial(spec, settings, solved, model, noisy_participant(), rng, names).steps

    full = steps()
    assert tuple(full) == STEP_COLUMNS and len(full["step"]) > 20
    # the cell columns are the discretised pose at the start of each step
    poses = zip(full["x"], full["y"], full["theta"], strict=True)
    assert [discretise(*pose) for pose in poses] == list(zip(full["cell_x"], full["cell_y"], full["heading"],
                                                                 strict=True))
    for names in (("event", "belief", "participant", "cell_y", "u_a_theta", "t"), ("phi_m",), ()):
        kept = steps(names)
        assert list(kept) == [name for name in STEP_COLUMNS if name in names]
        assert {name: list(v) for name, v in kept.items()} == {name: list(full[name]) for name in kept}


# --- the turn-taking rules, step by step on a session --------------------------------------------

def session_of(paper, condition: str, layout_index: int = 0, handover: int = 3, **changes) -> TrialSession:
    """A fresh session on one of the paper's layouts with the default tables (``changes`` to the settings)."""
    _config, settings, layouts = paper
    item = layouts[layout_index]
    solved = solve_layout(item.layout.goal_cells, item.layout.goal_headings)
    model = DisambiguationModel(item.layout.goal_cells, solved.p_a_given_sg, default_mapping_table(),
                                default_distortion_table())
    spec = TrialSpec(participant=0, condition=condition, block=0, trial=0, layout_index=item.index,
                     layout=item.layout)
    changed = dataclasses.replace(settings, **changes)
    return TrialSession(spec, changed, model, handover, generator(0, "session"))


def confident(n_goals: int, leader: int) -> np.ndarray:
    """A belief with a unique leader and a normalised entropy well below kappa (0.65)."""
    belief = np.full(n_goals, 0.1 / (n_goals - 1))
    belief[leader] = 0.9
    return belief


def test_the_disambiguation_step_heads_for_the_leader_and_control_keeps_its_heading(paper):
    # Algorithm 1, lines 13-15: below kappa the Disambiguation condition steps towards g' and turns
    # to g''s heading (inferred_goal = g'); Control steps towards the mean of the tied leaders (here
    # the one leader) and keeps the robot's heading, with no g' logged
    sizes = assistance.step_sizes(paper[1].window)
    for condition in ("disambiguation", "control"):
        session = session_of(paper, condition, layout_index=5)
        goals = session.goal_poses
        leader = goals.shape[0] - 1
        session._set_belief(confident(goals.shape[0], leader))
        assert session.entropy < paper[1].kappa
        start = np.array([session.x, session.y, session.theta])
        session._start_autonomy_turn()
        assert session.pending_events[-1] == "step"
        target = session.autonomy_target
        assert any(np.allclose(target[:2], assistance.step_target(start[:2], goals[leader, :2], r),
                               atol=1e-12) for r in sizes)
        if condition == "disambiguation":
            assert session.autonomy_inferred == leader and target[2] == goals[leader, 2] != start[2]
        else:
            assert session.autonomy_inferred == -1 and target[2] == start[2]
        session.autonomy_step()
        assert pd.DataFrame(session.columns)["inferred_goal"].iloc[-1] == session.autonomy_inferred


def test_the_autonomy_nudges_only_when_the_entropy_exceeds_kappa(paper):
    # "nudges to s* when the normalised entropy exceeds kappa": an entropy equal to kappa steps
    belief = np.array([0.5, 0.3, 0.2])
    entropy = float(-(belief * np.log(belief)).sum() / np.log(3))
    session = session_of(paper, "disambiguation", layout_index=0)
    assert session.goal_poses.shape[0] == 3
    session._set_belief(belief)
    at_kappa = session_of(paper, "disambiguation", layout_index=0, kappa=session.entropy)
    assert session.entropy == pytest.approx(entropy, abs=1e-12)
    at_kappa._set_belief(belief)
    at_kappa._start_autonomy_turn()
    assert at_kappa.pending_events[-1] == "step" and at_kappa.nudges == 0
    below = session_of(paper, "disambiguation", layout_index=0, kappa=float(np.nextafter(session.entropy, 0)))
    below._set_belief(belief)
    below._start_autonomy_turn()
    assert "nudge" in below.pending_events and below.nudges == 1


def test_the_autonomy_hands_back_at_exactly_the_arrival_tolerance(paper):
    # the turn ends when the robot is within (<=) arrival_tolerance of its target position
    probe = session_of(paper, "control", layout_index=2)
    probe._set_belief(confident(probe.goal_poses.shape[0], 0))
    probe._start_autonomy_turn()
    target = probe.autonomy_target.copy()
    probe.autonomy_step()
    left = float(np.hypot(target[0] - probe.x, target[1] - probe.y))
    assert left > 0
    for tolerance, turn in ((left, "human"), (float(np.nextafter(left, 0)), "autonomy")):
        session = session_of(paper, "control", layout_index=2, arrival_tolerance=tolerance)
        session._set_belief(confident(session.goal_poses.shape[0], 0))
        session._start_autonomy_turn()
        np.testing.assert_array_equal(session.autonomy_target, target)  # the same draw of R
        session.autonomy_step()
        assert session.turn == turn, tolerance


def test_idle_steps_count_from_the_turns_first_input(paper):
    # samples without input before the turn's first input are not idle time; from a first input
    # that commands nothing (a deadband sample) the turn passes once the idle count reaches 3: 0.3 s
    # without a command (the paper: handover after not issuing commands for the idle time)
    session = session_of(paper, "disambiguation", handover=3)
    for _ in range(10):
        session.human_step(NO_INPUT, 0.0)
    assert session.turn == "human" and session.idle == 0
    session.human_step(SOFT_PUFF, -0.4)  # the puff deadband: an input, no command
    assert session.idle == 1
    session.human_step(NO_INPUT, 0.0)
    assert session.turn == "human" and session.idle == 2
    session.human_step(NO_INPUT, 0.0)  # the 3rd idle step: 0.3 s without a command
    assert session.turn == "autonomy" and session.autonomy_turns == 1


def test_a_goal_counts_only_after_the_turns_first_input(paper):
    session = session_of(paper, "disambiguation", layout_index=3)
    session.x, session.y, session.theta = (float(v) for v in session.goal_poses[1])
    session.human_step(NO_INPUT, 0.0)  # at the goal, but nothing was given yet
    assert session.reached == -1 and not session.finished
    session.human_step(SOFT_PUFF, -0.4)  # a deadband input: the robot stands, the goal counts
    assert session.reached == 1 and session.summary()["reached_goal"] == 1


def test_the_summary_counts_agree_with_the_step_log(paper):
    checked = 0
    for layout_index, seed in ((1, 6), (0, 1), (4, 2), (8, 3), (16, 4)):
        result, steps, _, _ = simulate(paper, layout_index, noisy_participant(), seed=seed,
                                       condition="disambiguation")
        summary, events = result.summary, steps["event"]
        blocks = turns(steps)
        assert summary["human_turns"] == sum(t["turn"].iloc[0] == "human" for t in blocks)
        assert summary["autonomy_turns"] == events.str.contains("handover_to_autonomy").sum()
        assert summary["nudges"] == events.str.contains("nudge").sum()
        assert summary["human_mode_switches"] == events.str.contains("mode_switch_human").sum()
        assert summary["steps"] == len(steps)
        checked += (0 < summary["nudges"] < summary["autonomy_turns"]) and summary["human_mode_switches"] > 0
    assert checked >= 1, "a trial must hold nudges, steps and mode switches for the counts to be told apart"


def test_the_gap_gate_applies_to_the_blending_policy_only(paper):
    # [blending] gate = "gap" is the blending baseline's; the turn-taking conditions keep the paper's alpha
    belief = np.array([0.6, 0.3, 0.1])  # p1 - p2 = 0.3 <= 0.4
    alphas = {}
    for condition in ("blending", "disambiguation"):
        session = session_of(paper, condition, layout_index=0, blending_gap=0.4)
        session._set_belief(belief)
        session.u_h = (3.0, 0.0, 0.0)  # a motion command this step
        alphas[condition] = session.policy.assist(session).alpha
    assert alphas["blending"] == 0.0 and alphas["disambiguation"] > 0.0


def test_the_goal_transition_keeps_stay_on_the_diagonal_and_spreads_the_rest_evenly():
    # hand-solved: 3 goals, stay 0.8 -> 0.1 to each other goal; stay 1 is the identity (None)
    matrix = goal_transition_matrix(3, 0.8)
    np.testing.assert_allclose(matrix, [[0.8, 0.1, 0.1], [0.1, 0.8, 0.1], [0.1, 0.1, 0.8]], atol=1e-15)
    np.testing.assert_allclose(goal_transition_matrix(5, 0.6).sum(axis=1), 1.0, atol=1e-15)
    assert goal_transition_matrix(4, 1.0) is None


def test_the_handover_idle_time_rounds_to_whole_steps():
    # 0.7 s at 0.1 s is 7 steps although 0.7 / 0.1 is 6.999...; at least one step
    assert 0.7 / 0.1 < 7 and 0.3 / 0.1 < 3
    assert handover_steps(0.7, 0.1) == 7 and handover_steps(0.3, 0.1) == 3 and handover_steps(1.5, 0.1) == 15
    assert handover_steps(0.26, 0.1) == 3 and handover_steps(0.24, 0.1) == 2
    assert handover_steps(0.01, 0.1) == 1 and handover_steps(0.0, 0.1) == 1
