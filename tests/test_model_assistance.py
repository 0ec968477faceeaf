"""Assistance: alpha and its study gates, autonomy velocity, blending, step/control/nudge targets."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.config import AssistanceSection
from nudgecli.model import assistance as ast
from nudgecli.model import interface
from nudgecli.model.world import angle_difference, state_index, turn_between

#: The defaults of ``[assistance]`` (the paper's): the model's functions take them as arguments.
PAPER = AssistanceSection()
RAMP = {"rho1_factor": PAPER.rho1_factor, "rho2_factor": PAPER.rho2_factor, "rho3": PAPER.rho3}
KNEE = {"knee": PAPER.distance_knee, "drop": PAPER.distance_drop}
AUTONOMY = {"speed": PAPER.autonomy_speed, "turn_rate": PAPER.autonomy_turn_rate}


def blending(entropy_gate: float | None = None, startup_delay: float = 0.0,
             distance_weighting: bool = False) -> ast.BlendingSettings:
    """The paper's ramp and distance weight, with the study's gates as asked."""
    return ast.BlendingSettings(**RAMP, entropy_gate=entropy_gate, startup_delay=startup_delay,
                                distance_weighting=distance_weighting, distance_knee=KNEE["knee"],
                                distance_drop=KNEE["drop"])


@pytest.mark.parametrize(("p", "expected"), [
    (0.0, 0.0),
    (0.275, 0.0),  # rho1 = 1.1 / 4
    (0.2875, 0.4),  # half-way up the ramp
    (0.3, 0.8),  # rho2 = 1.2 / 4
    (0.31, 0.8),
    (1.0, 0.8),
])
def test_alpha_breakpoints_four_goals(p: float, expected: float) -> None:
    assert ast.blending_factor(p, 4, **RAMP) == pytest.approx(expected, abs=1e-12)


def test_alpha_three_goals_and_vectorised() -> None:
    rho1, rho2 = 1.1 / 3, 1.2 / 3
    values = ast.blending_factor(np.array([rho1, (rho1 + rho2) / 2, rho2, 0.9]), 3, **RAMP)
    np.testing.assert_allclose(values, [0.0, 0.4, 0.8, 0.8], atol=1e-12)
    with pytest.raises(ValueError):
        ast.blending_factor(0.5, 3, rho1_factor=1.2, rho2_factor=1.1, rho3=0.8)


def test_distance_weight() -> None:
    assert ast.distance_weight(0.0, **KNEE) == 1.0
    assert ast.distance_weight(17.5, **KNEE) == pytest.approx(0.8)
    assert ast.distance_weight(35.0, **KNEE) == pytest.approx(0.6)
    assert ast.distance_weight(36.0, **KNEE) == pytest.approx(0.6 * math.exp(-1.0))
    assert ast.distance_weight(35.0 + 1e-9, **KNEE) == pytest.approx(0.6, abs=1e-8)  # continuous at the knee


def test_assistance_alpha_gates() -> None:
    study = blending(entropy_gate=0.65, startup_delay=1.0, distance_weighting=True)  # the study software
    # uncertain belief or too early in the turn -> 0
    assert ast.assistance_alpha(0.9, 4, 0.7, 5.0, 0.0, study) == 0.0
    assert ast.assistance_alpha(0.9, 4, 0.3, 0.5, 0.0, study) == 0.0
    assert ast.assistance_alpha(0.9, 4, 0.3, 1.0, 17.5, study) == pytest.approx(0.8 * 0.8)
    # the paper: no gates
    assert ast.assistance_alpha(0.9, 4, 0.99, 0.0, 100.0, blending()) == pytest.approx(0.8)


def test_entropy_gate_holds_only_while_the_entropy_exceeds_kappa() -> None:
    # DESIGN 2.6: alpha is 0 while H > kappa; at H == kappa the belief is confident enough
    assert not ast.entropy_gated(0.65, 0.65) and ast.entropy_gated(0.6500001, 0.65)
    assert not ast.entropy_gated(1.0, None)
    study = blending(entropy_gate=0.65)
    assert ast.assistance_alpha(0.9, 4, 0.65, 5.0, 0.0, study) == pytest.approx(0.8)
    assert ast.assistance_alpha(0.9, 4, 0.6500001, 5.0, 0.0, study) == 0.0


@settings(max_examples=200, deadline=None)
@given(x=st.floats(3, 45), y=st.floats(2, 36), theta=st.floats(0, 2 * math.pi - 1e-9),
       tx=st.floats(3, 45), ty=st.floats(2, 36), ttheta=st.floats(0, 2 * math.pi - 1e-9),
       dt=st.sampled_from([0.01, 0.05, 0.1, 1.0]))
def test_autonomy_velocity_never_overshoots(x: float, y: float, theta: float, tx: float, ty: float,
                                            ttheta: float, dt: float) -> None:
    pose = np.array([x, y, theta])
    target = np.array([tx, ty, ttheta])
    v = ast.autonomy_velocity(pose, target, **AUTONOMY, dt=dt)
    assert math.hypot(v[0], v[1]) <= 5.0 + 1e-9
    assert abs(v[2]) <= 1.5 + 1e-12
    distance = math.hypot(tx - x, ty - y)
    after = np.array([x, y]) + v[:2] * dt
    # moves straight along the line and ends no farther than max(0, D - speed dt) from the target
    assert math.hypot(tx - after[0], ty - after[1]) == pytest.approx(max(0.0, distance - 5.0 * dt), abs=1e-9)
    error_before = float(angle_difference(ttheta, theta))
    error_after = float(angle_difference(ttheta, theta + v[2] * dt))
    assert abs(error_after) <= abs(error_before) + 1e-12
    # never turns past the target heading, up to the rounding of theta + omega dt (a few ulp of 2 pi)
    assert error_after * error_before >= -1e-14
    if error_before == 0.0:
        assert v[2] == 0.0


def test_autonomy_velocity_examples() -> None:
    v = ast.autonomy_velocity(np.array([10.0, 10.0, 0.0]), np.array([20.0, 10.0, 0.0]), **AUTONOMY)
    np.testing.assert_allclose(v, [5.0, 0.0, 0.0])
    # shortest direction: target 90 deg anticlockwise -> positive omega; 90 deg clockwise -> negative
    assert ast.autonomy_velocity(np.zeros(3), np.array([0.0, 0.0, math.pi / 2]), **AUTONOMY)[2] == 1.5
    assert ast.autonomy_velocity(np.zeros(3), np.array([0.0, 0.0, 3 * math.pi / 2]), **AUTONOMY)[2] == -1.5
    # near the target: slows to land exactly on it in one step
    v = ast.autonomy_velocity(np.array([10.0, 10.0, 1.0]), np.array([10.02, 10.0, 1.001]), **AUTONOMY,
                              dt=0.01)
    np.testing.assert_allclose(v, [2.0, 0.0, 0.1], atol=1e-9)
    np.testing.assert_array_equal(ast.autonomy_velocity(np.array([1.0, 2.0, 3.0]), np.array([1.0, 2.0, 3.0]),
                                                        **AUTONOMY),
                                  np.zeros(3))


def test_blend() -> None:
    np.testing.assert_allclose(ast.blend(np.array([5.0, 0.0, 1.0]), np.array([0.0, 3.0, 0.0]), 0.8),
                               [4.0, 0.6, 0.8])


# --- the scalar twins the simulation's step loop runs: bit for bit the array rules --------------

angles = st.one_of(st.floats(-1e6, 1e6, allow_nan=False),
                   st.sampled_from([0.0, -0.0, math.pi, -math.pi, 2 * math.pi, -2 * math.pi, math.pi / 4,
                                    7 * math.pi / 4, 1e-300, -1e-300, math.nextafter(math.pi, 0.0)]))


@settings(max_examples=500, deadline=None)
@given(a=angles, b=angles)
def test_turn_between_is_angle_difference_bit_for_bit(a: float, b: float) -> None:
    assert turn_between(a, b).hex() == float(angle_difference(a, b)).hex()
    assert turn_between(a, b).hex() == float(angle_difference(np.array([a]), np.array([b]))[0]).hex()


commands = st.tuples(*[st.floats(-10, 10, allow_nan=False)] * 3)


@settings(max_examples=300, deadline=None)
@given(u_a=commands, u_h=st.one_of(commands, st.just((0.0, 0.0, 0.0))), alpha=st.floats(0, 1))
def test_blend_command_is_the_array_blend_bit_for_bit(u_a: tuple[float, float, float],
                                                      u_h: tuple[float, float, float], alpha: float) -> None:
    expected = alpha * np.asarray(u_a) + (1.0 - alpha) * np.asarray(u_h)  # Algorithm 1, line 8, on arrays
    assert [v.hex() for v in ast.blend_command(u_a, u_h, alpha)] == [float(v).hex() for v in expected]
    assert ast.blend(np.asarray(u_a), np.asarray(u_h), alpha).tolist() == expected.tolist()


@settings(max_examples=300, deadline=None)
@given(x=st.floats(0, 50), y=st.floats(0, 40), theta=st.floats(-10, 10), tx=st.floats(0, 50),
       ty=st.floats(0, 40), ttheta=st.floats(-10, 10), dt=st.sampled_from([0.01, 0.1, 1.0]))
def test_autonomy_command_is_the_array_rule_bit_for_bit(x: float, y: float, theta: float, tx: float,
                                                        ty: float, ttheta: float, dt: float) -> None:
    """Against the rule written out with numpy's angle arithmetic (``np.mod``), as it read before the
    step loop moved to plain floats."""
    dx, dy = np.float64(tx) - x, np.float64(ty) - y
    distance = math.hypot(dx, dy)
    vx = vy = omega = np.float64(0.0)
    if distance > 0.0:
        scale = min(np.float64(5.0), distance / dt) / distance
        vx, vy = dx * scale, dy * scale
    error = np.mod(np.float64(ttheta) - theta + np.pi, 2.0 * np.pi) - np.pi
    if error != 0.0:
        omega = np.copysign(min(np.float64(1.5), abs(error) / dt), error)
    command = ast.autonomy_command(x, y, theta, tx, ty, ttheta, 5.0, 1.5, dt)
    assert [v.hex() for v in command] == [float(v).hex() for v in (vx, vy, omega)]
    assert ast.autonomy_velocity((x, y, theta), (tx, ty, ttheta), 5.0, 1.5, dt).tolist() == list(command)


@pytest.mark.parametrize("mode", [0, 1, 2])
@pytest.mark.parametrize("label", [interface.NO_INPUT, *range(6)])
def test_human_command_is_the_label_table(label: int, mode: int) -> None:
    expected = np.zeros(3)
    if label in (interface.SOFT_PUFF, interface.SOFT_SIP):  # Upsilon: soft labels move, the rest do not
        expected[mode] = (1.0 if label == interface.SOFT_PUFF else -1.0) * (3.0 if mode < 2 else -1.95)
    assert [v.hex() for v in interface.human_command(label, mode, 3.0, 1.95)] == [v.hex() for v in expected]
    assert interface.human_velocity(label, mode, 3.0, 1.95).tolist() == expected.tolist()


def test_step_sizes() -> None:
    assert ast.step_sizes(3) == pytest.approx((4.2, 3.4, 5.4))
    assert ast.step_sizes(3)[2] == pytest.approx(math.hypot(4.2, 3.4), abs=0.01)
    assert sorted(ast.step_sizes(5)) == pytest.approx(sorted([4.2, 3.4, 5.4, 8.4, 6.8, 10.81]))
    rng = np.random.default_rng(0)
    assert {ast.draw_step_size(rng, 5) for _ in range(200)} == set(ast.step_sizes(5))
    with pytest.raises(ValueError):
        ast.step_sizes(7)


def test_step_target() -> None:
    start, goal = np.array([0.0, 0.0]), np.array([30.0, 40.0])  # D = 50
    np.testing.assert_allclose(ast.step_target(start, goal, 5.0), [3.0, 4.0])
    np.testing.assert_allclose(ast.step_target(start, np.array([6.0, 8.0]), 8.4), [3.0, 4.0])  # D/2 = 5 < R
    np.testing.assert_array_equal(ast.step_target(goal, goal, 4.2), goal)


def test_control_target_ties() -> None:
    goals = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    np.testing.assert_allclose(ast.control_target(np.array([0.4, 0.4, 0.2]), goals), [5.0, 0.0])
    np.testing.assert_allclose(ast.control_target(np.full(3, 1 / 3), goals), [10 / 3, 10 / 3])
    np.testing.assert_allclose(ast.control_target(np.array([0.5, 0.3, 0.2]), goals), [0.0, 0.0])
    near_tie = np.array([0.4, 0.4 - 1e-12, 0.2 + 1e-12])
    np.testing.assert_allclose(ast.control_target(near_tie, goals), [5.0, 0.0])


@given(st.lists(st.tuples(st.sampled_from([0.1, 0.2, 0.2 + 1e-12, 0.3, 1 / 3, 0.7]),
                          st.floats(3.0, 45.0), st.floats(2.0, 36.0)), min_size=1, max_size=8))
def test_control_target_is_numpys_mean_of_the_tied_goals_bit_for_bit(rows) -> None:
    # the mean computed as numpy computes it over the rows of the tied goals (the rule's
    # reference in arrays, as it was written before it was made plain floats)
    from nudgecli.model.ties import tied_with_max

    belief, goals = np.array([r[0] for r in rows]), np.array([r[1:] for r in rows])
    expected = goals[tied_with_max(belief, 1e-9)].mean(axis=0)
    assert ast.control_target(belief, goals).tobytes() == expected.tobytes()


def test_nudge_target() -> None:
    pose, mode = ast.nudge_target(int(state_index(2, 7, 3, 1)))
    np.testing.assert_allclose(pose, [3 + 4.2 * 2 + 2.1, 2 + 3.4 * 7 + 1.7, 3 * math.pi / 4])
    assert mode == 1


@given(st.floats(0.0, 1.0), st.integers(2, 8), st.floats(0.0, 1.0), st.floats(-5.0, 5.0),
       st.floats(0.0, 80.0),
       st.booleans(), st.booleans(), st.booleans())
def test_assistance_alpha_is_the_ramp_with_the_gates(p, n, entropy, since, distance, gate, delay,
                                                     weighting) -> None:
    """The protocol's one alpha rule against its parts: blending_factor, the gates, distance_weight."""
    settings = blending(entropy_gate=0.65 if gate else None, startup_delay=1.0 if delay else 0.0,
                        distance_weighting=weighting)
    expected = float(ast.blending_factor(p, n, **RAMP))
    if (gate and entropy > 0.65) or (delay and since < 1.0):
        expected = 0.0
    elif weighting:
        expected *= float(ast.distance_weight(distance, **KNEE))
    got = ast.assistance_alpha(p, n, entropy, since, distance, settings)
    assert got == pytest.approx(expected, abs=1e-12)
