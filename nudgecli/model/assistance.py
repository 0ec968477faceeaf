"""Assistance: the blending factor alpha, the autonomy's velocity, blending, and the autonomy
turn's targets (the nudge into s*, the step towards the inferred goal, the Control target).

Paper Section 4 and Algorithm 1, with the study software's extras as options (DESIGN 2.6,
study notes section 6).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nudgecli.model import portable_math
from nudgecli.model.ties import tied_indices
from nudgecli.model.world import (
    CELL_HEIGHT,
    CELL_WIDTH,
    cell_centre,
    heading_angle,
    state_coordinates,
    turn_between,
)

# One cell along x, y and the diagonal; the study's list used the rounded diagonals
# sqrt(4.2^2 + 3.4^2) = 5.40 and twice that, 10.81.
_DIAGONAL = 5.40
_DOUBLE_DIAGONAL = 10.81
#: Step sizes R of the confident / Control autonomy turn for the 3 x 3 window.
STEP_SIZES_3X3 = (CELL_WIDTH, CELL_HEIGHT, _DIAGONAL)
#: The 5 x 5 window (the study) adds two-cell steps.
STEP_SIZES_5X5 = (*STEP_SIZES_3X3, 2 * CELL_WIDTH, 2 * CELL_HEIGHT, _DOUBLE_DIAGONAL)


def blending_factor(p_goal: float | np.ndarray, n_goals: int, rho1_factor: float, rho2_factor: float,
                    rho3: float) -> float | np.ndarray:
    """The paper's piecewise-linear ``alpha(p(g'))`` (Section 4).

    ``alpha = 0`` for ``p <= rho1``, ``rho3 (p - rho1) / (rho2 - rho1)`` for ``rho1 < p <= rho2``
    and ``rho3`` above, with ``rho1 = rho1_factor / n_goals`` and ``rho2 = rho2_factor / n_goals``.

    Parameters
    ----------
    p_goal
        ``(...)`` belief of the inferred goal ``g'``.
    n_goals
        Number of goals.
    rho1_factor, rho2_factor, rho3
        The breakpoints' factors and the plateau (``[assistance]``; the paper: 1.1, 1.2, 0.8).

    Returns
    -------
    float or np.ndarray
        ``(...)`` alpha in ``[0, rho3]``.
    """
    if n_goals < 1:
        raise ValueError(f"n_goals must be at least 1, got {n_goals}")
    rho1, rho2 = rho1_factor / n_goals, rho2_factor / n_goals
    if not rho2 > rho1:
        raise ValueError(f"rho2 ({rho2:g}) must exceed rho1 ({rho1:g})")
    p = np.asarray(p_goal, dtype=float)
    alpha = np.clip((p - rho1) / (rho2 - rho1), 0.0, 1.0) * rho3
    return float(alpha) if alpha.ndim == 0 else alpha


def distance_weight(distance: float | np.ndarray, knee: float, drop: float) -> float | np.ndarray:
    """The study's distance weight on alpha: ``1 - drop d / knee`` up to the knee, then
    ``(1 - drop) exp(-(d - knee))`` (continuous at the knee: ``1 - drop`` there).

    Parameters
    ----------
    distance
        ``(...)`` distance from the robot to ``g'`` in world units.
    knee, drop
        ``[assistance] distance_knee`` and ``distance_drop`` (the study: 35 and 0.4).

    Returns
    -------
    float or np.ndarray
        ``(...)`` weights in ``(0, 1]``.
    """
    d = np.asarray(distance, dtype=float)
    near = 1.0 - drop * d / knee
    far = (1.0 - drop) * portable_math.exp(-np.maximum(d - knee, 0.0))
    w = np.where(d <= knee, near, far)
    return float(w) if w.ndim == 0 else w


@dataclass(frozen=True)
class BlendingSettings:
    """How alpha is computed during the human's turn (the ``[assistance]`` keys, which hold the
    defaults: ``nudgecli.sim.protocol.ProtocolSettings.from_config`` builds it).

    Attributes
    ----------
    rho1_factor, rho2_factor, rho3
        The paper's piecewise-linear alpha.
    entropy_gate
        ``kappa``: alpha is 0 while the normalised entropy exceeds it; ``None`` disables.
    startup_delay
        Seconds after the human's first input of a turn during which alpha is 0.
    distance_weighting
        Multiply alpha by :func:`distance_weight` of the distance to ``g'``.
    distance_knee, distance_drop
        The distance weight's knee (world units) and its drop at the knee (study: 35 and 0.4).
    """

    rho1_factor: float
    rho2_factor: float
    rho3: float
    entropy_gate: float | None
    startup_delay: float
    distance_weighting: bool
    distance_knee: float
    distance_drop: float


def entropy_gated(normalised_entropy: float, gate: float | None) -> bool:
    """Whether the study's confidence gate holds blending off: the belief's normalised entropy
    exceeds ``gate`` (``kappa``; ``None``: no gate)."""
    return gate is not None and normalised_entropy > gate


def assistance_alpha(p_goal: float, n_goals: int, normalised_entropy: float,
                     seconds_since_first_input: float, distance_to_goal: float,
                     settings: BlendingSettings) -> float:
    """alpha with the optional study gates: the paper's alpha, zeroed while the belief is too
    uncertain or the turn has just started, and optionally scaled by the distance weight.

    Parameters
    ----------
    p_goal
        Belief of the inferred goal ``g'``.
    n_goals
        Number of goals.
    normalised_entropy
        ``H(b) / log |G|``.
    seconds_since_first_input
        Time since the human's first input of the current turn (``-inf`` before it).
    distance_to_goal
        Robot-to-``g'`` distance in world units.
    settings
        The ramp, the gates and the distance weight.

    Returns
    -------
    float
    """
    if entropy_gated(normalised_entropy, settings.entropy_gate):
        return 0.0
    if settings.startup_delay > 0 and seconds_since_first_input < settings.startup_delay:
        return 0.0
    # scalar math (this runs on every simulated step); the same rules as blending_factor and
    # distance_weight, which a test holds them to
    rho1, rho2 = settings.rho1_factor / n_goals, settings.rho2_factor / n_goals
    alpha = min(max((p_goal - rho1) / (rho2 - rho1), 0.0), 1.0) * settings.rho3
    if settings.distance_weighting and alpha > 0.0:
        alpha *= float(distance_weight(distance_to_goal, settings.distance_knee, settings.distance_drop))
    return alpha


def startup_delay_end(initiated_at: int, dt: float, startup_delay: float) -> int:
    """The first step at which :func:`assistance_alpha`'s start-up gate no longer holds alpha at 0:
    the least ``step >= initiated_at`` with ``(step - initiated_at) * dt`` not below ``startup_delay``,
    decided by that very float test (the product is monotone in the step count, so the first step
    it passes at is bracketed around the estimate ``ceil(startup_delay / dt)`` and found by bisection,
    a few dozen tests at most for any finite delay).

    Parameters
    ----------
    initiated_at
        The step of the turn's first measured input (``>= 0``).
    dt
        The step's length, s (positive).
    startup_delay
        The gate's delay, s (finite; ``<= 0`` gates nothing: ``initiated_at`` itself).

    Returns
    -------
    int
    """
    if not dt > 0.0 or not math.isfinite(startup_delay):
        raise ValueError(f"dt must be positive and startup_delay finite, got {dt} and {startup_delay}")
    if startup_delay <= 0.0:
        return initiated_at
    estimate = startup_delay / dt
    if not math.isfinite(estimate):
        raise ValueError(f"startup_delay / dt = {startup_delay:g} / {dt:g} is more steps than a float holds")
    # The estimate is off by a step or two either way, but where the floats are sparse (a delay of
    # 1e30 s) a walk of single steps never moved the product and hung; instead bracket the first
    # passing count by doubling steps out from the estimate (low fails, high passes), then bisect.
    high, stride = max(1, math.ceil(estimate)), 1
    while high * dt < startup_delay:
        high, stride = high + stride, stride * 2
    low, stride = high - 1, 1
    while low * dt >= startup_delay:  # count 0 always fails: the delay is positive
        low, stride = max(0, low - stride), stride * 2
    while high - low > 1:
        middle = (low + high) // 2
        if middle * dt >= startup_delay:
            high = middle
        else:
            low = middle
    return initiated_at + high


Pose = np.ndarray | tuple[float, float, float]


def autonomy_velocity(pose: Pose, target_pose: Pose, speed: float, turn_rate: float,
                      dt: float = 0.01) -> np.ndarray:
    """``u_a``: straight towards the target position at constant speed, bang-bang rotation.

    The translation is ``speed`` along the line to the target, reduced to ``distance / dt`` when a
    full-speed step of length ``dt`` would overshoot; the rotation is ``turn_rate`` in the shortest
    direction (clockwise, i.e. negative, at exactly 180 degrees), reduced to ``|error| / dt`` near
    alignment, and zero when aligned (the study's chatter removed).

    Parameters
    ----------
    pose
        ``(3,)`` current ``(x, y, theta)``.
    target_pose
        ``(3,)`` target ``(x, y, theta)``.
    speed, turn_rate
        Maximum translational (units/s) and angular (rad/s) speeds.
    dt
        The step the command will be applied for, in seconds.

    Returns
    -------
    np.ndarray
        ``(3,)`` ``(vx, vy, omega)``: :func:`autonomy_command` as an array.
    """
    x, y, theta = (float(v) for v in pose)
    tx, ty, ttheta = (float(v) for v in target_pose)
    return np.array(autonomy_command(x, y, theta, tx, ty, ttheta, speed, turn_rate, dt))


def autonomy_command(x: float, y: float, theta: float, tx: float, ty: float, ttheta: float,
                     speed: float, turn_rate: float, dt: float) -> tuple[float, float, float]:
    """:func:`autonomy_velocity` from ``(x, y, theta)`` to ``(tx, ty, ttheta)`` as a tuple of floats.

    The rule's one implementation, in plain float arithmetic: it runs on every simulated step of
    the autonomy's turn and of blending, where numpy's per-call overhead was most of its cost.
    """
    if dt <= 0:
        raise ValueError(f"dt must be positive, got {dt}")
    vx = vy = omega = 0.0
    dx, dy = tx - x, ty - y
    distance = math.hypot(dx, dy)
    if distance > 0.0:
        scale = min(speed, distance / dt) / distance
        vx, vy = dx * scale, dy * scale
    error = turn_between(ttheta, theta)  # in [-pi, pi)
    if error != 0.0:
        omega = math.copysign(min(turn_rate, abs(error) / dt), error)
    return vx, vy, omega


def blend(u_a: np.ndarray, u_h: np.ndarray, alpha: float) -> np.ndarray:
    """``u_f = alpha u_a + (1 - alpha) u_h`` (Algorithm 1, line 8).

    Parameters
    ----------
    u_a, u_h
        ``(3,)`` autonomy and human commands.
    alpha
        Blending factor in ``[0, 1]``.

    Returns
    -------
    np.ndarray
        ``(3,)``: :func:`blend_command` as an array.
    """
    return np.array(list(blend_command((float(u_a[0]), float(u_a[1]), float(u_a[2])),
                                       (float(u_h[0]), float(u_h[1]), float(u_h[2])), alpha)))


def blend_command(u_a: tuple[float, float, float], u_h: tuple[float, float, float],
                  alpha: float) -> tuple[float, float, float]:
    """:func:`blend` of two commands given as tuples of floats (the rule's one implementation;
    every blended step of a simulation runs it)."""
    keep = 1.0 - alpha
    return (alpha * u_a[0] + keep * u_h[0], alpha * u_a[1] + keep * u_h[1], alpha * u_a[2] + keep * u_h[2])


def step_sizes(window: int) -> tuple[float, ...]:
    """The step sizes ``R`` drawn from for a window side (3 or 5)."""
    if window == 3:
        return STEP_SIZES_3X3
    if window == 5:
        return STEP_SIZES_5X5
    raise ValueError(f"step sizes are defined for windows 3 and 5, got {window}")


def draw_step_size(rng: np.random.Generator, window: int) -> float:
    """One ``R`` drawn uniformly from :func:`step_sizes`."""
    sizes = step_sizes(window)
    return float(sizes[int(rng.integers(len(sizes)))])


def step_target(position: np.ndarray, target_xy: np.ndarray, step: float) -> np.ndarray:
    """The point ``R' = min(R, D / 2)`` along the line from ``position`` to ``target_xy``.

    ``D`` is the distance to the target, so the autonomy never covers more than half of what is
    left (the study's beta <= 0.5).

    Parameters
    ----------
    position
        ``(2,)`` robot position.
    target_xy
        ``(2,)`` where the line points.
    step
        ``R``.

    Returns
    -------
    np.ndarray
        ``(2,)`` the target point (``position`` itself when already at the target).
    """
    p = np.asarray(position, dtype=float)[:2]
    offset = np.asarray(target_xy, dtype=float)[:2] - p
    distance = float(np.hypot(offset[0], offset[1]))
    if distance == 0.0:
        return p.copy()
    return p + offset * (min(step, distance / 2.0) / distance)


def control_target(belief: np.ndarray, goal_positions: np.ndarray, atol: float = 1e-9) -> np.ndarray:
    """The Control condition's target: the mean position of the goals tied for the highest belief.

    With a uniform belief every goal is tied, so the target is the mean of all goals.

    Parameters
    ----------
    belief
        ``(G,)`` belief.
    goal_positions
        ``(G, 2)`` goal positions.
    atol
        Beliefs within ``atol`` of the maximum count as tied.

    Returns
    -------
    np.ndarray
        ``(2,)``.
    """
    b = np.asarray(belief, dtype=float)
    goals = np.asarray(goal_positions, dtype=float)[:, :2]
    if b.shape != (goals.shape[0],):
        raise ValueError(f"belief shape {b.shape} does not match {goals.shape[0]} goals")
    tied = tied_indices(b, atol)
    if not tied:  # a NaN belief: no goal is tied, and the mean of none is NaN
        return np.full(2, np.nan)
    # numpy's mean over the rows, in plain floats (every Control turn asks): the rows added in
    # order from the first, then divided by their number
    x, y = goals[tied[0]].tolist()
    for index in tied[1:]:
        gx, gy = goals[index].tolist()
        x, y = x + gx, y + gy
    return np.array([x / len(tied), y / len(tied)])


def nudge_target(state: int) -> tuple[np.ndarray, int]:
    """Where the autonomy drives for s*: the centre of its cell at its discrete heading, and its mode.

    Parameters
    ----------
    state
        Flat index of s*.

    Returns
    -------
    pose : np.ndarray
        ``(3,)`` ``(x, y, heading * 45 deg)``.
    mode : int
        The mode to switch to (instantly).
    """
    i, j, h, m = (int(v) for v in state_coordinates(int(state)))
    xy = cell_centre(i, j)
    return np.array([xy[0], xy[1], float(heading_angle(h))]), m
