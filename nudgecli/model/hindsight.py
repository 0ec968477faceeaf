"""Hindsight-optimisation assistance and ADA's blend, as the authors' open code computes them.

The ``hindsight`` baseline (Javdani et al. 2015, RSS; 2018, IJRR) adds the belief-weighted sum
of each goal's assistance to the person's command. Its open implementation is
``personalrobotics/ada_assistance_policy`` (commit ``e1ece9c``); the user's teleoperation it is
added to is ``personalrobotics/ada_teleoperation`` (``UserInputListener.py``, commit ``1fd4ae0``).
What this module takes from them:

- The per-goal action (``HuberAssistancePolicy.get_action`` = ``-get_q_derivative``): the
  gradient of a Huber cost-to-go on the distance to the goal, linear far from it and quadratic
  within ``TRANSLATION_DELTA_SWITCH``, tapered to zero within 2 cm ("hacky part to make it not
  jumpy"), divided by ``ROBOT_TRANSLATION_COST_MULTIPLIER``; the same for the rotation on the
  quaternion angle, with its own constants. The gradient is taken at the pose the user's command
  reaches after ``ACTION_APPLY_TIME`` (``AssistancePolicyOneTarget.update``).
- The assisted action (``AssistancePolicy.get_assisted_action``): ``sum_g b_g a_g / sum_g b_g``
  added to the user's twist.
- The blend (``AdaAssistancePolicy.get_blend_action``): the most likely goal's full action added
  to the user's twist when ``blend_confidence_function_prob_diff`` holds, else the user's twist.

Mapping ADA into this world (:meth:`HindsightSettings.from_source`): a translation speed keeps
its ratio to the user's full command (ADA: 0.2 m/s an axis; here ``human_speed``), so the far
field is ``(2.25 + 0.2) / 40 / 0.2 = 0.306`` of the person's full command; lengths scale by the
same factor as speeds (``human_speed / 0.2`` units a metre), which keeps every duration (the
seconds a full command takes to cross the Huber zone, the look-ahead) as in ADA. Rotation keeps
its ratio to the user's full turn (``0.07 * 0.21 / 0.05 / 0.4 = 0.735``) and its angles (radians
are radians), so its durations scale by ``0.4 / human_turn_rate``.

Where this differs from the source, and why: a goal here is one pose (the source's goal holds
several grasp poses and acts for the one of least cost-to-go, ``AssistancePolicyOneGoal``); the
rotation is the yaw alone, its angle the exact wrapped heading error (``Utils.QuaternionDistance``
clips the quaternion's ``w``, which leaves about 1e-3 rad at the goal's heading); and exactly at
the goal the command is zero, the limit of the taper (the source divides 0 by 0 there).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from nudgecli.model.policies import confidence_gap
from nudgecli.model.ties import unique_argmax
from nudgecli.model.world import turn_between

# --- the source's constants ---------------------------------------------------------------------
# personalrobotics/ada_assistance_policy, src/ada_assistance_policy/HuberAssistancePolicy.py,
# class HuberAssistancePolicy ("HUBER CONSTANTS, values used when assistance always on"):
#: Slope of the Huber cost's linear part beyond the switch (translation, cost per metre).
TRANSLATION_LINEAR_MULTIPLIER = 2.25
#: Distance (m) where the translation cost turns from quadratic to linear.
TRANSLATION_DELTA_SWITCH = 0.07
#: Constant slope added everywhere (translation), so the gradient stays non-zero inside the zone.
TRANSLATION_CONSTANT_ADD = 0.2
#: Rotation: the same three on the quaternion angle (rad), and a factor on the whole cost.
ROTATION_LINEAR_MULTIPLIER = 0.20
ROTATION_DELTA_SWITCH = math.pi / 32.0
ROTATION_CONSTANT_ADD = 0.01
ROTATION_MULTIPLIER = 0.07
#: The divisors that turn the cost gradients into a twist (m/s, rad/s).
ROBOT_TRANSLATION_COST_MULTIPLIER = 40.0
ROBOT_ROTATION_COST_MULTIPLIER = 0.05
# HuberAssistancePolicy.get_qderivative_translation / get_qderivative_rotation: the gradient is
# scaled by distance / limit below these ("hacky part to make it not jumpy").
#: Translation taper (m): ``dist_translation_limit``.
TRANSLATION_TAPER = 2e-2
#: Rotation taper (rad): ``dist_rotation_limit``.
ROTATION_TAPER = math.pi / 12.0
# src/ada_assistance_policy/AssistancePolicyOneTarget.py, AssistancePolicyOneTarget:
#: Seconds the user's command is applied for before the gradient is taken (``update`` ->
#: ``state_after_user_action``).
ACTION_APPLY_TIME = 0.1
# src/ada_assistance_policy/AdaAssistancePolicy.py, blend_confidence_function_prob_diff:
#: The blend assists when the most likely goal's probability exceeds the second's by more than this.
BLEND_PROB_DIFF_REQUIRED = 0.4
# personalrobotics/ada_teleoperation, src/ada_teleoperation/input_handlers/UserInputListener.py,
# translation_weightings / angular_weightings (translation_input_conversion,
# rotation_input_conversion: an axis in [-1, 1] times these):
#: The user's full command along one axis (m/s).
ADA_USER_SPEED = 0.2
#: The user's full turn about one axis (rad/s).
ADA_USER_TURN_RATE = 0.4

# --- what follows from them -----------------------------------------------------------------------
#: ADA's translation assistance beyond the zone (m/s): the linear part's full slope over 40.
ADA_FAR_TRANSLATION_SPEED = (TRANSLATION_LINEAR_MULTIPLIER + TRANSLATION_CONSTANT_ADD) \
    / ROBOT_TRANSLATION_COST_MULTIPLIER
#: ADA's rotation assistance beyond the zone (rad/s).
ADA_FAR_ROTATION_RATE = ROTATION_MULTIPLIER * (ROTATION_LINEAR_MULTIPLIER + ROTATION_CONSTANT_ADD) \
    / ROBOT_ROTATION_COST_MULTIPLIER
#: The far-field translation assistance over the user's full command (about 0.306).
SOURCE_STRENGTH = ADA_FAR_TRANSLATION_SPEED / ADA_USER_SPEED
#: The far-field rotation assistance over the user's full turn (0.735).
SOURCE_TURN_STRENGTH = ADA_FAR_ROTATION_RATE / ADA_USER_TURN_RATE
#: The share of the far-field gradient left at the zone's goal side (before the taper): the
#: constant slope's part of the total (0.2 / 2.45; rotation 0.01 / 0.21).
SOURCE_CONSTANT_SHARE = TRANSLATION_CONSTANT_ADD / (TRANSLATION_LINEAR_MULTIPLIER + TRANSLATION_CONSTANT_ADD)
SOURCE_TURN_CONSTANT_SHARE = ROTATION_CONSTANT_ADD / (ROTATION_LINEAR_MULTIPLIER + ROTATION_CONSTANT_ADD)

#: A pose ``(x, y, theta)`` or a command ``(vx, vy, omega)`` as three floats.
Triple = tuple[float, float, float]


def huber_gradient_magnitude(distance: float, linear: float, switch: float, constant: float,
                             taper: float) -> float:
    """The size of the source's Huber cost gradient at ``distance`` from the goal, with its taper.

    The cost (``HuberAssistancePolicy.get_value_translation``) is ``l d^2 / (2 delta) + c d`` up to
    ``delta`` and ``(l + c) d - l delta / 2`` beyond, so its slope
    (``get_qderivative_translation``) is ``c + l d / delta`` inside and ``l + c`` outside
    (continuous at ``delta``); below ``taper`` it is scaled by ``d / taper``, which takes it to 0
    at the goal. The rotation's slope (``get_qderivative_rotation``) is the same function of the
    angle.

    Parameters
    ----------
    distance
        ``d >= 0`` (m or rad in the source).
    linear, switch, constant
        ``l``, ``delta``, ``c``.
    taper
        Below this distance the slope is scaled by ``distance / taper``.

    Returns
    -------
    float
        The slope (the source's cost per unit of distance), before its division into a velocity.
    """
    slope = linear + constant if distance > switch else constant + linear * distance / switch
    if distance < taper:
        slope *= distance / taper
    return slope


def ada_translation_speed(distance: float) -> float:
    """ADA's translation assistance towards one goal at ``distance`` m from it (m/s): the Huber
    slope over ``ROBOT_TRANSLATION_COST_MULTIPLIER`` (0.06125 beyond 7 cm)."""
    slope = huber_gradient_magnitude(distance, TRANSLATION_LINEAR_MULTIPLIER, TRANSLATION_DELTA_SWITCH,
                                     TRANSLATION_CONSTANT_ADD, TRANSLATION_TAPER)
    return slope / ROBOT_TRANSLATION_COST_MULTIPLIER


def ada_rotation_rate(angle: float) -> float:
    """ADA's rotation assistance towards one goal ``angle`` rad from its orientation (rad/s):
    ``ROTATION_MULTIPLIER`` times the Huber slope over ``ROBOT_ROTATION_COST_MULTIPLIER`` (0.294
    beyond pi/32, tapered below pi/12)."""
    return ROTATION_MULTIPLIER * huber_gradient_magnitude(
        angle, ROTATION_LINEAR_MULTIPLIER, ROTATION_DELTA_SWITCH, ROTATION_CONSTANT_ADD,
        ROTATION_TAPER) / ROBOT_ROTATION_COST_MULTIPLIER


@dataclass(frozen=True)
class HindsightSettings:
    """The per-goal assistance in this world's units (:meth:`from_source` maps ADA's into it).

    Attributes
    ----------
    strength
        The translation assistance beyond the zone over the person's full command ``human_speed``.
    zone
        Where the Huber cost turns quadratic (world units): the assistance slows inside it.
    human_speed, human_turn_rate
        The person's full translation (units/s) and turn (rad/s) commands.
    taper
        Below this distance to the goal (world units) the assistance is scaled by distance / taper.
    constant_share
        The share of the far-field speed left at the zone's goal side before the taper (in [0, 1]).
    turn_strength, turn_zone, turn_taper, turn_constant_share
        The same four for rotation (the far-field turn over ``human_turn_rate``; angles in rad).
    lookahead, turn_lookahead
        Seconds of the person's translation / turn command applied to the pose before the
        assistance is evaluated (the source's ``ACTION_APPLY_TIME``; 0: at the pose itself).
    """

    strength: float
    zone: float
    human_speed: float
    human_turn_rate: float
    taper: float
    constant_share: float
    turn_strength: float
    turn_zone: float
    turn_taper: float
    turn_constant_share: float
    lookahead: float
    turn_lookahead: float

    def __post_init__(self) -> None:
        positive = ("zone", "human_speed", "human_turn_rate", "taper", "turn_zone", "turn_taper")
        for name in positive:
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        for name in ("strength", "turn_strength", "lookahead", "turn_lookahead"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be at least 0, got {getattr(self, name)}")
        for name in ("constant_share", "turn_constant_share"):
            if not 0 <= getattr(self, name) <= 1:
                raise ValueError(f"{name} must lie in [0, 1], got {getattr(self, name)}")

    @classmethod
    def from_source(cls, human_speed: float, human_turn_rate: float) -> HindsightSettings:
        """ADA's assistance mapped into a world whose person commands ``human_speed`` (units/s)
        and ``human_turn_rate`` (rad/s) at full input.

        Speeds keep their ratio to the user's full command and lengths scale with speeds
        (``human_speed / ADA_USER_SPEED`` units a metre), so translation's durations are ADA's;
        turn rates keep their ratio to the user's full turn and angles are unchanged, so the
        turn's look-ahead is ADA's scaled by ``ADA_USER_TURN_RATE / human_turn_rate``.
        ``from_source(ADA_USER_SPEED, ADA_USER_TURN_RATE)`` is ADA itself.
        """
        units_per_metre = human_speed / ADA_USER_SPEED
        return cls(strength=SOURCE_STRENGTH, zone=TRANSLATION_DELTA_SWITCH * units_per_metre,
                   human_speed=human_speed, human_turn_rate=human_turn_rate,
                   taper=TRANSLATION_TAPER * units_per_metre, constant_share=SOURCE_CONSTANT_SHARE,
                   turn_strength=SOURCE_TURN_STRENGTH, turn_zone=ROTATION_DELTA_SWITCH,
                   turn_taper=ROTATION_TAPER, turn_constant_share=SOURCE_TURN_CONSTANT_SHARE,
                   lookahead=ACTION_APPLY_TIME,
                   turn_lookahead=ACTION_APPLY_TIME * ADA_USER_TURN_RATE / human_turn_rate)

    def speed_at(self, distance: float) -> float:
        """The translation assistance's speed (units/s) at ``distance`` from a goal."""
        share = self.constant_share
        return self.strength * self.human_speed * huber_gradient_magnitude(
            distance, 1.0 - share, self.zone, share, self.taper)

    def turn_rate_at(self, angle: float) -> float:
        """The rotation assistance's rate (rad/s) at ``angle`` (rad, in [0, pi]) from a goal's heading."""
        share = self.turn_constant_share
        return self.turn_strength * self.human_turn_rate * huber_gradient_magnitude(
            angle, 1.0 - share, self.turn_zone, share, self.turn_taper)


def goal_command(x: float, y: float, theta: float, goal: Triple, settings: HindsightSettings,
                 dt: float | None = None, user_command: Triple | None = None) -> Triple:
    """One goal's assistance ``(vx, vy, omega)`` at the pose ``(x, y, theta)``, as plain floats.

    ``HuberAssistancePolicy.get_action`` in this world: the pose is first moved by the person's
    command for the look-ahead; from there the translation points straight at the goal at
    :meth:`HindsightSettings.speed_at` of the distance, and the rotation turns the shorter way to
    the goal's heading at :meth:`HindsightSettings.turn_rate_at` (at exactly pi, where the
    source's sign rule depends on how the two quaternions happen to be written, clockwise, as
    :func:`~nudgecli.model.world.turn_between` and the autonomy's command turn).
    With ``dt`` the speed and the rate are capped so that a step of ``dt`` s does not carry the
    robot past the goal's position or heading from ``(x, y, theta)`` (the convention of
    :func:`nudgecli.model.assistance.autonomy_command`).

    Parameters
    ----------
    x, y, theta
        The robot's pose (world units, rad).
    goal
        ``(gx, gy, gtheta)``.
    settings
        The assistance's strength, zones and look-ahead.
    dt
        The step the command will be applied for (s); ``None``: no cap.
    user_command
        The person's ``(vx, vy, omega)`` this step; ``None``: no command (no look-ahead).

    Returns
    -------
    tuple of float
        ``(vx, vy, omega)`` in units/s and rad/s.
    """
    if dt is not None and dt <= 0:
        raise ValueError(f"dt must be positive, got {dt}")
    gx, gy, gtheta = goal
    ex, ey, etheta = x, y, theta  # where the gradient is taken: after the person's command
    if user_command is not None:
        ex += settings.lookahead * user_command[0]
        ey += settings.lookahead * user_command[1]
        etheta += settings.turn_lookahead * user_command[2]
    vx = vy = omega = 0.0
    dx, dy = gx - ex, gy - ey
    distance = math.hypot(dx, dy)
    if distance > 0.0:
        speed = settings.speed_at(distance)
        if dt is not None:
            speed = min(speed, math.hypot(gx - x, gy - y) / dt)
        vx, vy = dx * speed / distance, dy * speed / distance
    error = turn_between(gtheta, etheta)  # in [-pi, pi): the source's shorter way, -pi at pi
    if error != 0.0:
        rate = settings.turn_rate_at(abs(error))
        if dt is not None:
            rate = min(rate, abs(turn_between(gtheta, theta)) / dt)
        omega = math.copysign(rate, error)
    return vx, vy, omega


def _poses(goal_poses: np.ndarray | Sequence[Triple]) -> list[Triple]:
    """``(G, 3)`` goal poses as a list of float triples."""
    return [(float(g[0]), float(g[1]), float(g[2])) for g in goal_poses]


def _belief_weights(belief: np.ndarray | Sequence[float], n_goals: int) -> list[float]:
    """``b_g / sum_g b_g`` (``AssistancePolicy.get_assisted_action`` divides by the sum)."""
    b = [float(p) for p in belief]
    if len(b) != n_goals:
        raise ValueError(f"belief has {len(b)} entries for {n_goals} goals")
    total = math.fsum(b)
    if not total > 0:
        raise ValueError(f"the belief's sum must be positive, got {total}")
    return [p / total for p in b]


def hindsight_command(x: float, y: float, theta: float, goal_poses: np.ndarray | Sequence[Triple],
                      belief: np.ndarray | Sequence[float], settings: HindsightSettings, dt: float | None,
                      user_command: Triple | None = None) -> Triple:
    """``sum_g b_g u_a^g / sum_g b_g``: the belief-weighted per-goal assistance
    (:func:`goal_command` for each goal, capped for a step of ``dt`` s), to be added to the
    person's command (``AssistancePolicy.get_assisted_action``).

    Each goal's command is capped before the weighting, so no goal's part carries the robot past
    that goal within ``dt``; a one-hot belief gives that goal's command.

    Parameters
    ----------
    x, y, theta
        The robot's pose.
    goal_poses
        ``(G, 3)`` goal poses.
    belief
        ``(G,)`` non-negative, with a positive sum (normalised here).
    settings
        The assistance's settings.
    dt
        The step (s); ``None``: uncapped.
    user_command
        The person's ``(vx, vy, omega)`` (the look-ahead); ``None``: none.

    Returns
    -------
    tuple of float
        ``(vx, vy, omega)``.
    """
    goals = _poses(goal_poses)
    weights = _belief_weights(belief, len(goals))
    vx = vy = omega = 0.0
    for goal, weight in zip(goals, weights, strict=True):
        if weight == 0.0:
            continue
        gx, gy, gw = goal_command(x, y, theta, goal, settings, dt, user_command)
        vx, vy, omega = vx + weight * gx, vy + weight * gy, omega + weight * gw
    return vx, vy, omega


def blend_confident(belief: np.ndarray | Sequence[float],
                    threshold: float = BLEND_PROB_DIFF_REQUIRED) -> bool:
    """ADA's blend confidence (``blend_confidence_function_prob_diff``): one goal or none always
    passes; otherwise the highest probability must exceed the second highest by more than
    ``threshold`` (strictly; the gap is :func:`nudgecli.model.policies.confidence_gap`)."""
    b = np.asarray(belief, dtype=float).reshape(-1)
    return b.size <= 1 or confidence_gap(b) > threshold


def ada_blend_goal(belief: np.ndarray | Sequence[float],
                   threshold: float | None = BLEND_PROB_DIFF_REQUIRED) -> int:
    """The goal whose whole assistance ADA's additive blend adds to the person's command
    (``AdaAssistancePolicy.get_blend_action``), or -1 for none (direct teleoperation).

    The most likely goal when :func:`blend_confident` holds; ``threshold=None`` has no gate (the
    most likely goal whenever one leads: none when two or more tie for the highest belief, which
    the gate's strict lead never passes either, :func:`nudgecli.model.ties.unique_argmax`).

    Parameters
    ----------
    belief
        ``(G,)``.
    threshold
        The required lead of the most likely goal over the second, or ``None``.

    Returns
    -------
    int
    """
    b = np.asarray(belief, dtype=float).reshape(-1)
    if b.size == 0 or (threshold is not None and not blend_confident(b, threshold)):
        return -1
    return unique_argmax(b)
