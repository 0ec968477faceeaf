"""Hindsight-optimisation assistance and ADA's blend (nudgecli.model.hindsight) against the
authors' open code: personalrobotics/ada_assistance_policy (HuberAssistancePolicy.py,
AssistancePolicy.py, AssistancePolicyOneTarget.py, AdaAssistancePolicy.py) and
personalrobotics/ada_teleoperation (input_handlers/UserInputListener.py).

The numbers below are worked by hand from the source's formulas, with its constants typed here
again (not read from the module), and the per-goal action is recomputed by
:func:`source_action`, a re-derivation of ``HuberAssistancePolicy.get_action`` on quaternions.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from nudgecli.model import hindsight as hs
from nudgecli.model.ties import tied_indices

# The source's constants, typed again: HuberAssistancePolicy's Huber constants and divisors,
# AssistancePolicyOneTarget.ACTION_APPLY_TIME, UserInputListener's weightings.
LIN, SWITCH, ADD, COST = 2.25, 0.07, 0.2, 40.0
ROT_LIN, ROT_SWITCH, ROT_ADD, ROT_MULT, ROT_COST = 0.20, math.pi / 32, 0.01, 0.07, 0.05
TAPER, ROT_TAPER, APPLY_TIME = 0.02, math.pi / 12, 0.1
USER_SPEED, USER_TURN = 0.2, 0.4
#: The toolkit's person: ``[interface] human_speed`` and ``human_turn_rate``.
HUMAN_SPEED, HUMAN_TURN = 3.0, 1.95
#: World units a metre (the person's full speed over ADA's user's) and turn-rate scale.
UNITS_PER_METRE, TURN_SCALE = HUMAN_SPEED / USER_SPEED, HUMAN_TURN / USER_TURN

ADA = hs.HindsightSettings.from_source(USER_SPEED, USER_TURN)
WORLD = hs.HindsightSettings.from_source(HUMAN_SPEED, HUMAN_TURN)


# --- an independent re-derivation of the source's per-goal action (planar poses) -----------------

def _quat_yaw(yaw: float) -> np.ndarray:
    """A rotation by ``yaw`` about z as ``[x, y, z, w]`` (tf.transformations' order)."""
    return np.array([0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])


def _qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The Hamilton product ``a b`` in ``[x, y, z, w]``."""
    x1, y1, z1, w1 = a
    x2, y2, z2, w2 = b
    return np.array([w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
                     w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2])


def _qinv(q: np.ndarray) -> np.ndarray:
    return np.array([-q[0], -q[1], -q[2], q[3]]) / float(q @ q)


def _quaternion_distance(q1: np.ndarray, q2: np.ndarray) -> float:
    """Utils.QuaternionDistance: the angle of ``q2 q1^-1``, its ``w`` clipped, folded to [0, pi]."""
    w = min(0.9999999, max(-0.999999, float(_qmul(q2, _qinv(q1))[3])))
    phi = 2.0 * math.acos(w)
    return min(phi, 2.0 * math.pi - phi)


def source_action(position: np.ndarray, yaw: float, goal_position: np.ndarray, goal_yaw: float,
                  user_twist: np.ndarray) -> np.ndarray:
    """``HuberAssistancePolicy.get_action`` (= ``-get_q_derivative``) for a planar pose, in m/s and
    rad/s: ``(vx, vy, omega_z)``.

    ``user_twist`` ``(vx, vy, omega_z)`` is applied for ``ACTION_APPLY_TIME`` first
    (``state_after_action`` -> ``Utils.ApplyTwistToTransform``: the position moves by
    ``time * v``; the rotation by ``time * |omega|`` about its axis, when ``|omega| > 1e-3``).
    """
    after = np.append(position + APPLY_TIME * user_twist[:2], 0.0)
    q_after = _quat_yaw(yaw)
    if abs(user_twist[2]) > 1e-3:
        q_after = _qmul(_quat_yaw(APPLY_TIME * user_twist[2]), q_after)
    # get_qderivative_translation
    diff = after - np.append(goal_position, 0.0)
    d = float(np.linalg.norm(diff))
    derivative = (LIN + ADD) * diff / d if d > SWITCH else ADD * diff / d + (LIN / SWITCH) * diff
    if d < TAPER:
        derivative = derivative * d / TAPER
    translation = derivative / COST
    # get_qderivative_rotation
    q_goal = _quat_yaw(goal_yaw)
    between = _qmul(q_goal, _qinv(q_after))
    rotation = between[:3] / np.linalg.norm(between[:3])
    r = _quaternion_distance(q_after, q_goal)
    magnitude = ROT_LIN + ROT_ADD if r > ROT_SWITCH else ROT_ADD + (ROT_LIN / ROT_SWITCH) * r
    rotation = rotation * ROT_MULT * magnitude / ROT_COST
    if float(q_goal @ q_after) > 0:
        rotation = -rotation
    if r < ROT_TAPER:
        rotation = rotation * r / ROT_TAPER
    return -np.array([translation[0], translation[1], rotation[2]])


# --- the source's magnitudes, by hand ----------------------------------------------------------

def test_ada_translation_far_from_the_goal() -> None:
    # beyond 7 cm the slope is the linear part's (2.25 + 0.2) over 40: 0.06125 m/s at 1 m and 8 cm
    assert hs.ada_translation_speed(1.0) == pytest.approx(0.06125, rel=1e-12)
    assert hs.ada_translation_speed(0.08) == pytest.approx(0.06125, rel=1e-12)


def test_ada_translation_inside_the_huber_zone() -> None:
    # at 5 cm: (0.2 + (2.25 / 0.07) 0.05) / 40 = (0.2 + 1.607142857) / 40 = 0.0451785714 m/s
    assert hs.ada_translation_speed(0.05) == pytest.approx(0.0451785714285714, rel=1e-12)
    # at 1 cm the 2 cm taper halves it: (0.2 + 0.3214285714) / 40 / 2 = 0.0065178571 m/s
    assert hs.ada_translation_speed(0.01) == pytest.approx(0.0065178571428571, rel=1e-12)
    # at the switch both formulas give 2.45 / 40 (the source takes the inner one there)
    assert hs.ada_translation_speed(0.07) == pytest.approx(0.06125, rel=1e-12)
    assert hs.ada_translation_speed(0.0) == 0.0


def test_ada_rotation_rate_by_hand() -> None:
    # beyond pi/12 (the taper) and pi/32 (the switch): 0.07 (0.20 + 0.01) / 0.05 = 0.294 rad/s
    assert hs.ada_rotation_rate(1.0) == pytest.approx(0.294, rel=1e-12)
    # 0.2 rad: beyond the switch, inside the taper: 0.294 * 0.2 / (pi / 12)
    assert hs.ada_rotation_rate(0.2) == pytest.approx(0.294 * 0.2 * 12 / math.pi, rel=1e-12)
    # pi/64: inside both: 0.07 (0.01 + (0.2 / (pi/32)) pi/64) / 0.05 = 0.154, times (pi/64)/(pi/12)
    assert hs.ada_rotation_rate(math.pi / 64) == pytest.approx(0.154 * 12 / 64, rel=1e-12)


def test_the_derived_ratios_and_zones() -> None:
    # 0.06125 m/s of assistance against the user's 0.2 m/s: 0.30625; 0.294 rad/s against 0.4: 0.735
    assert WORLD.strength == pytest.approx(0.30625, rel=1e-12)
    assert WORLD.turn_strength == pytest.approx(0.735, rel=1e-12)
    # 15 world units a metre (3.0 / 0.2): the 7 cm zone is 1.05 units, the 2 cm taper 0.3
    assert WORLD.zone == pytest.approx(1.05, rel=1e-12)
    assert WORLD.taper == pytest.approx(0.3, rel=1e-12)
    # angles unchanged; the turn's look-ahead is 0.1 s of the user's full turn (0.04 rad) here
    assert (WORLD.turn_zone, WORLD.turn_taper) == (pytest.approx(math.pi / 32), pytest.approx(math.pi / 12))
    assert WORLD.lookahead == pytest.approx(0.1)
    assert WORLD.turn_lookahead * HUMAN_TURN == pytest.approx(0.1 * USER_TURN, rel=1e-12)


def test_the_world_speeds_by_hand() -> None:
    # far: 0.30625 of the person's 3.0 units/s; 0.75 units is 5 cm: 15 x 0.0451785714 units/s
    assert WORLD.speed_at(15.0) == pytest.approx(0.91875, rel=1e-12)
    assert WORLD.speed_at(0.75) == pytest.approx(15 * 0.0451785714285714, rel=1e-12)
    # the turn far from the goal's heading: 0.735 of the person's 1.95 rad/s
    assert WORLD.turn_rate_at(1.0) == pytest.approx(1.43325, rel=1e-12)


def test_from_source_with_ada_s_own_user_is_ada() -> None:
    for d in (0.005, 0.02, 0.05, 0.07, 0.3):
        assert ADA.speed_at(d) == pytest.approx(hs.ada_translation_speed(d), rel=1e-12)
    for r in (0.01, ROT_SWITCH, 0.2, 2.0):
        assert ADA.turn_rate_at(r) == pytest.approx(hs.ada_rotation_rate(r), rel=1e-12)


# --- the per-goal action against the source's ----------------------------------------------------

coordinate = st.floats(-0.6, 0.6, allow_nan=False)
angle = st.floats(-2 * math.pi, 2 * math.pi, allow_nan=False)
twist_xy = st.floats(-USER_SPEED, USER_SPEED, allow_nan=False)
twist_w = st.floats(-USER_TURN, USER_TURN, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(x=coordinate, y=coordinate, yaw=angle, gx=coordinate, gy=coordinate, gyaw=angle,
       ux=twist_xy, uy=twist_xy, uw=twist_w, with_command=st.booleans())
def test_goal_command_is_the_source_s_action(x: float, y: float, yaw: float, gx: float, gy: float,
                                             gyaw: float, ux: float, uy: float, uw: float,
                                             with_command: bool) -> None:
    user = np.array([ux, uy, uw]) if with_command else np.zeros(3)
    if abs(user[2]) <= 1e-3:  # the source skips a turn this small (ApplyTwistToTransform)
        user[2] = 0.0
    # the look-ahead pose's distance and heading error, away from the source's 0/0 and the clip
    ex, ey = x + APPLY_TIME * user[0], y + APPLY_TIME * user[1]
    error = math.remainder(gyaw - (yaw + APPLY_TIME * user[2]), 2 * math.pi)
    assume(math.hypot(gx - ex, gy - ey) > 1e-6)
    assume(0.01 < abs(error) < math.pi - 1e-6)
    expected = source_action(np.array([x, y]), yaw, np.array([gx, gy]), gyaw, user)
    command = (float(user[0]), float(user[1]), float(user[2])) if with_command else None
    got = hs.goal_command(x, y, yaw, (gx, gy, gyaw), ADA, user_command=command)
    assert np.allclose(got, expected, rtol=1e-9, atol=1e-12)


@settings(max_examples=200, deadline=None)
@given(x=coordinate, y=coordinate, yaw=angle, gx=coordinate, gy=coordinate, gyaw=angle,
       ux=twist_xy, uy=twist_xy, uw=twist_w)
def test_the_world_is_ada_scaled(x: float, y: float, yaw: float, gx: float, gy: float, gyaw: float,
                                 ux: float, uy: float, uw: float) -> None:
    # lengths and speeds x15, turn rates x4.875, angles and translation's seconds unchanged
    ada = hs.goal_command(x, y, yaw, (gx, gy, gyaw), ADA, user_command=(ux, uy, uw))
    world = hs.goal_command(UNITS_PER_METRE * x, UNITS_PER_METRE * y, yaw,
                            (UNITS_PER_METRE * gx, UNITS_PER_METRE * gy, gyaw), WORLD,
                            user_command=(UNITS_PER_METRE * ux, UNITS_PER_METRE * uy, TURN_SCALE * uw))
    expected = (UNITS_PER_METRE * ada[0], UNITS_PER_METRE * ada[1], TURN_SCALE * ada[2])
    assert np.allclose(world, expected, rtol=1e-7, atol=1e-9)


def test_the_command_points_at_the_goal_and_turns_the_short_way() -> None:
    # the goal 20 units east and 0.5 rad anticlockwise: full far speed along +x, a positive turn
    vx, vy, omega = hs.goal_command(10.0, 10.0, 0.0, (30.0, 10.0, 0.5), WORLD)
    assert (vx, vy) == (pytest.approx(0.91875), 0.0)
    assert omega == pytest.approx(1.43325)
    # 0.5 rad clockwise (written as 2 pi - 0.5): a negative turn
    clockwise = hs.goal_command(10.0, 10.0, 0.0, (30.0, 10.0, 2 * math.pi - 0.5), WORLD)
    assert clockwise[2] == pytest.approx(-1.43325)
    # exactly pi: clockwise, as the autonomy turns
    assert hs.goal_command(10.0, 10.0, 0.0, (30.0, 10.0, math.pi), WORLD)[2] < 0


distance = st.floats(0.0, 40.0, allow_nan=False)


@given(a=distance, b=distance)
def test_the_assistance_slows_down_towards_the_goal(a: float, b: float) -> None:
    near, far = sorted((a, b))
    assert WORLD.speed_at(near) <= WORLD.speed_at(far)
    assert WORLD.turn_rate_at(near / 40 * math.pi) <= WORLD.turn_rate_at(far / 40 * math.pi)


def test_the_assistance_is_zero_at_the_goal_and_positive_elsewhere() -> None:
    assert hs.goal_command(12.0, 7.0, 1.0, (12.0, 7.0, 1.0), WORLD) == (0.0, 0.0, 0.0)
    assert WORLD.speed_at(0.0) == 0.0 and WORLD.turn_rate_at(0.0) == 0.0
    assert all(WORLD.speed_at(d) > 0 for d in (1e-6, 0.1, 0.3, 1.0, 1.05, 2.0, 40.0))
    # strictly slower inside the zone than beyond it
    assert WORLD.speed_at(0.5) < WORLD.speed_at(1.0) < WORLD.speed_at(1.1) == WORLD.speed_at(30.0)


def test_the_look_ahead_takes_the_gradient_after_the_person_s_command() -> None:
    user = (2.0, -1.0, 0.8)
    with_command = hs.goal_command(10.0, 10.0, 0.3, (11.0, 10.5, 0.6), WORLD, user_command=user)
    moved = hs.goal_command(10.0 + 0.1 * 2.0, 10.0 - 0.1 * 1.0, 0.3 + WORLD.turn_lookahead * 0.8,
                            (11.0, 10.5, 0.6), WORLD)
    assert with_command == pytest.approx(moved, rel=1e-12)


# --- the step's cap ------------------------------------------------------------------------------

def test_a_long_step_is_capped_at_the_goal() -> None:
    # 2 units and 0.5 rad to go, a 10 s step: 0.91875 x 10 and 1.43325 x 10 would overshoot
    vx, vy, omega = hs.hindsight_command(10.0, 10.0, 0.0, [(12.0, 10.0, 0.5)], [1.0], WORLD, 10.0)
    assert (vx, vy, omega) == (pytest.approx(0.2), 0.0, pytest.approx(0.05))


def velocity(pose, goals, belief, settings, user=None) -> np.ndarray:
    """``hindsight_command`` uncapped (no step), as an array."""
    return np.array(hs.hindsight_command(*pose, goals, belief, settings, None, user))


def goal_velocities(pose, goals, settings) -> np.ndarray:
    """``(G, 3)``: each goal's ``goal_command``, uncapped."""
    return np.array([hs.goal_command(*pose, tuple(goal), settings) for goal in goals])


def blended(u_h: np.ndarray, belief, commands: np.ndarray,
            threshold=hs.BLEND_PROB_DIFF_REQUIRED) -> np.ndarray:
    """ADA's blend of ``u_h`` with the goal ``ada_blend_goal`` picks (the person's alone for none)."""
    goal = hs.ada_blend_goal(belief, threshold)
    return u_h.copy() if goal < 0 else u_h + commands[goal]


@settings(max_examples=200, deadline=None)
@given(x=st.floats(3, 45), y=st.floats(2, 36), theta=angle, gx=st.floats(3, 45), gy=st.floats(2, 36),
       gtheta=angle, dt=st.floats(1e-3, 20.0))
def test_a_step_never_passes_the_goal(x: float, y: float, theta: float, gx: float, gy: float, gtheta: float,
                                      dt: float) -> None:
    vx, vy, omega = hs.hindsight_command(x, y, theta, [(gx, gy, gtheta)], [1.0], WORLD, dt)
    assert math.hypot(vx, vy) * dt <= math.hypot(gx - x, gy - y) * (1 + 1e-9) + 1e-12
    assert abs(omega) * dt <= abs(math.remainder(gtheta - theta, 2 * math.pi)) * (1 + 1e-9) + 1e-12
    # a short step is the uncapped assistance
    short = hs.hindsight_command(x, y, theta, [(gx, gy, gtheta)], [1.0], WORLD, 1e-9)
    uncapped = velocity((x, y, theta), [(gx, gy, gtheta)], [1.0], WORLD)
    assert np.allclose(short, uncapped, rtol=1e-9, atol=1e-12)


def test_a_non_positive_step_is_refused() -> None:
    with pytest.raises(ValueError, match="dt"):
        hs.hindsight_command(10.0, 10.0, 0.0, [(12.0, 10.0, 0.5)], [1.0], WORLD, 0.0)


# --- the belief's weighting ----------------------------------------------------------------------

GOALS = np.array([[40.0, 10.0, 0.0], [10.0, 33.0, 0.0], [30.0, 30.0, 1.0], [12.0, 11.0, -2.0]])


def test_two_far_goals_by_hand() -> None:
    # from (10, 10, 0): goal 0 is 30 units east, goal 1 23 units north, both at the robot's heading;
    # each pulls at the far speed 0.91875, weighted 1/4 and 3/4
    v = velocity((10.0, 10.0, 0.0), GOALS[:2], [0.25, 0.75], WORLD)
    assert v == pytest.approx([0.25 * 0.91875, 0.75 * 0.91875, 0.0], rel=1e-12)


@pytest.mark.parametrize("k", range(len(GOALS)))
def test_a_one_hot_belief_gives_that_goal_s_command(k: int) -> None:
    belief = np.eye(len(GOALS))[k]
    pose = (15.0, 14.0, 0.4)
    expected = hs.goal_command(*pose, tuple(GOALS[k]), WORLD)
    assert velocity(pose, GOALS, belief, WORLD) == pytest.approx(expected, rel=1e-12)
    assert goal_velocities(pose, GOALS, WORLD)[k] == pytest.approx(expected, rel=1e-12)


def test_the_belief_is_normalised_by_its_sum() -> None:
    # AssistancePolicy.get_assisted_action divides the weighted sum by sum(goal_distribution)
    pose, belief = (15.0, 14.0, 0.4), np.array([0.1, 0.2, 0.3, 0.4])
    expected = belief @ goal_velocities(pose, GOALS, WORLD)
    assert velocity(pose, GOALS, 3.0 * belief, WORLD) == pytest.approx(expected, rel=1e-12)


@settings(max_examples=100, deadline=None)
@given(data=st.data(), n=st.integers(2, 5))
def test_permuting_goals_and_belief_together_changes_nothing(data: st.DataObject, n: int) -> None:
    goals = np.array(data.draw(st.lists(st.tuples(st.floats(3, 45), st.floats(2, 36), angle),
                                        min_size=n, max_size=n)))
    belief = np.array(data.draw(st.lists(st.floats(0.01, 1.0), min_size=n, max_size=n)))
    order = np.array(data.draw(st.permutations(range(n))))
    pose = (data.draw(st.floats(3, 45)), data.draw(st.floats(2, 36)), data.draw(angle))
    user = (1.0, -2.0, 0.5)
    same = velocity(pose, goals, belief, WORLD, user)
    permuted = velocity(pose, goals[order], belief[order], WORLD, user)
    assert np.allclose(same, permuted, rtol=1e-9, atol=1e-12)


def test_a_belief_that_does_not_fit_is_refused() -> None:
    with pytest.raises(ValueError, match="positive"):
        velocity((10.0, 10.0, 0.0), GOALS, np.zeros(4), WORLD)
    with pytest.raises(ValueError, match="entries"):
        velocity((10.0, 10.0, 0.0), GOALS, np.ones(3), WORLD)


def test_settings_out_of_range_are_refused() -> None:
    fields = {**WORLD.__dict__}
    for name, value in (("zone", 0.0), ("strength", -0.1), ("constant_share", 1.5), ("turn_lookahead", -1.0)):
        with pytest.raises(ValueError, match=name):
            hs.HindsightSettings(**{**fields, name: value})


# --- ADA's blend ---------------------------------------------------------------------------------

U_H = np.array([0.3, -0.2, 0.1])
COMMANDS = np.array([[1.0, 0.0, 0.5], [0.0, 2.0, -0.5], [-1.0, -1.0, 0.0]])


def test_the_blend_gate_is_strict_at_the_threshold() -> None:
    # a lead of exactly 0.5 (0.75 - 0.25, both exact in binary) does not pass a threshold of 0.5
    assert np.array_equal(blended(U_H, [0.75, 0.25], COMMANDS[:2], 0.5), U_H)
    just_below = 0.5 - 2**-20
    assisted = blended(U_H, [0.75, 0.25], COMMANDS[:2], just_below)
    assert np.array_equal(assisted, U_H + COMMANDS[0])


def test_the_blend_adds_the_leader_s_full_command() -> None:
    # the default 0.4: a lead of 0.7 assists with goal 1's whole command; 0.25 does not
    assert blended(U_H, [0.1, 0.8, 0.1], COMMANDS) == pytest.approx(U_H + COMMANDS[1])
    assert np.array_equal(blended(U_H, [0.5, 0.25, 0.25], COMMANDS), U_H)
    # the lead is over the second goal, not the last: 0.45 - 0.45 = 0, not 0.45 - 0.1
    assert np.array_equal(blended(U_H, [0.45, 0.45, 0.1], COMMANDS, 0.3), U_H)
    # a tie for the highest belief assists no goal, even past a negative threshold: none is
    # favoured by its index (nudgecli.model.ties.unique_argmax)
    assert np.array_equal(blended(U_H, [0.4, 0.4, 0.2], COMMANDS, -0.1), U_H)
    # one goal always passes
    assert blended(U_H, [0.2], COMMANDS[:1]) == pytest.approx(U_H + COMMANDS[0])
    assert hs.BLEND_PROB_DIFF_REQUIRED == 0.4


@given(belief=st.lists(st.floats(0.0, 1.0), min_size=3, max_size=3), threshold=st.floats(-0.5, 1.0))
def test_the_blend_is_the_person_or_the_person_plus_the_leader(belief: list[float], threshold: float) -> None:
    out = blended(U_H, belief, COMMANDS, threshold)
    leader = max(range(3), key=lambda g: (belief[g], -g))
    lead = belief[leader] - max(belief[g] for g in range(3) if g != leader)
    unique = len(tied_indices(belief)) == 1  # a tie for the maximum assists no goal
    expected = U_H + COMMANDS[leader] if lead > threshold and unique else U_H
    assert np.array_equal(out, expected)
