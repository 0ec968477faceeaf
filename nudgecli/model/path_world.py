"""The CIAA path-constrained teleoperation world (the sibling study's task; TASK.md of the task data).

A point robot in SE(2) must follow a polyline of waypoints from its start to the goal. Each leg
allows one mode and one direction; the rotation (from heading 0 to the goal heading, +-pi/2) is
allowed only at the turn waypoint. Per step (TASK.md section 4), in this module's order:

1. the velocity is masked: every component but the allowed mode's is zeroed, and the allowed
   one too when it points the wrong way (against the leg, or away from the goal heading), so a
   command in a disallowed mode or direction leaves the robot still;
2. the pose is integrated for ``dt`` (the caller's velocity is in wall-clock units: the study's
   effective speeds, 1.6 units/s and 0.64 rad/s, section 6);
3. within ``snap_tolerance`` of the next waypoint on both axes the position snaps onto it and
   the location advances (not past the turn waypoint before the turn is done); within
   ``heading_tolerance`` of the goal heading the heading snaps onto it and the turn is done;
4. the goal is reached when the location is the last waypoint.

The study snapped at the start of its next step and integrated once more after the goal snap,
so its logged final position overshoots by one 0.039-unit physics step; here the trial ends at
the snap (the same sequence, without the overshoot that a 10 Hz step would make 0.16 units long).
The robot then lies exactly on the goal, so the study's analysis rule (a final Manhattan
distance of at most 0.1, :data:`SUCCESS_DISTANCE`) holds by construction: success is reaching
the goal waypoint.

The discrete state is ``(location, turn done, mode)``, flat index
``(location * 2 + turn_done) * 3 + mode``: what the person sees (the waypoint reached, whether
the robot has turned, the mode display) and what their optimal command plan is defined on.
The step log's ``cell_x``, ``cell_y`` and ``heading`` hold the location, the turn flag and 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nudgecli.model import interface
from nudgecli.model.world import N_MODES, Command, angle_difference, next_multiple, turn_between

#: Mode letters of the task files, in the toolkit's mode order (x, y, theta).
MODE_LETTERS = ("x", "y", "t")
#: Where the goal's heading marks lie: multiples of a quarter turn (goal headings are +-pi/2).
HEADING_MARK = math.pi / 2.0


@dataclass(frozen=True)
class PathLayout:
    """One CIAA trial layout.

    Attributes
    ----------
    index
        The study's trial index (0-35).
    condition
        The study's condition of this index (``no_assistance``, ``filter_assistance``, ...).
    waypoints
        ``(W, 2)`` the path's waypoints, start first, goal last.
    leg_modes
        ``(W - 1,)`` the mode each leg allows (0 = x, 1 = y).
    leg_directions
        ``(W - 1,)`` the allowed direction of each leg along its axis (+1 or -1).
    turn_waypoint
        Index of the interior waypoint where the rotation must happen.
    goal_theta
        The goal heading in ``[0, 2 pi)`` (the start heading is 0).
    start_mode
        The mode the trial starts in.
    """

    index: int
    condition: str
    waypoints: np.ndarray
    leg_modes: tuple[int, ...]
    leg_directions: tuple[int, ...]
    turn_waypoint: int
    goal_theta: float
    start_mode: int

    @property
    def n_goals(self) -> int:
        return 1

    @property
    def goal_poses(self) -> np.ndarray:
        """``(1, 3)`` the goal pose."""
        gx, gy = self.waypoints[-1]
        return np.array([[float(gx), float(gy), self.goal_theta]])

    @property
    def start_pose(self) -> np.ndarray:
        """``(3,)`` the start pose (heading 0)."""
        return np.array([float(self.waypoints[0, 0]), float(self.waypoints[0, 1]), 0.0])

    @property
    def rotation_direction(self) -> int:
        """+1 when the turn is anticlockwise (to +pi/2), -1 when clockwise."""
        return 1 if float(angle_difference(self.goal_theta, 0.0)) > 0 else -1

    @property
    def n_states(self) -> int:
        return len(self.waypoints) * 2 * N_MODES


def build_waypoints(start: tuple[float, float], goal: tuple[float, float], n_turns: int,
                    first_axis: int) -> np.ndarray:
    """The waypoint path of TASK.md section 3.

    Parameters
    ----------
    start, goal
        ``(x, y)`` of the start and the goal.
    n_turns
        Number of turns ``n``: the path has ``n + 2`` waypoints.
    first_axis
        0 when the first leg runs along x, 1 along y.

    Returns
    -------
    np.ndarray
        ``(n + 2, 2)`` waypoints.
    """
    delta = np.subtract(goal, start, dtype=float)
    step = np.zeros(2)
    if n_turns % 2:
        step[:] = delta / ((n_turns + 1) // 2)
    else:
        k = n_turns // 2 + 1
        step[first_axis] = delta[first_axis] / k
        step[1 - first_axis] = delta[1 - first_axis] / (k - 1)
    points = [np.asarray(start, dtype=float)]
    for i in range(1, n_turns + 1):
        axis = first_axis if i % 2 else 1 - first_axis
        point = points[-1].copy()
        point[axis] += step[axis]
        points.append(point)
    points.append(np.asarray(goal, dtype=float))
    return np.array(points)


def optimal_policy(layout: PathLayout) -> np.ndarray:
    """``(S,)`` the optimal task action in every discrete state ``(location, turn done, mode)``.

    In the allowed mode: the move in the allowed direction (``move_p`` is +x, +y, or clockwise;
    ``move_n`` the opposite). In another mode: the one hard blow that reaches the allowed mode
    (with three modes every other mode is one switch away, so this is the 0-1 shortest path of
    TASK.md section 8: a switch costs 1, a useful move 0). At the goal: the last leg's move.
    """
    policy = np.empty(layout.n_states, dtype=np.int64)
    for location in range(len(layout.waypoints)):
        for turned in (0, 1):
            allowed, direction = allowed_motion(layout, location, bool(turned))
            for mode in range(N_MODES):
                if mode != allowed:
                    action = interface.TO_MODE_R if (allowed - mode) % N_MODES == 1 else interface.TO_MODE_L
                elif allowed == 2:  # anticlockwise (+1) is move_n
                    action = interface.MOVE_N if direction > 0 else interface.MOVE_P
                else:
                    action = interface.MOVE_P if direction > 0 else interface.MOVE_N
                policy[(location * 2 + turned) * N_MODES + mode] = action
    return policy


def allowed_motion(layout: PathLayout, location: int, turned: bool) -> tuple[int, int]:
    """``(mode, direction)`` allowed at ``location`` (TASK.md section 4, step 3): the rotation at
    the turn waypoint before the turn is done, else the leg that starts here (the last leg's at
    the goal). The direction is the sign along the axis (anticlockwise positive for the turn)."""
    if location == layout.turn_waypoint and not turned:
        return 2, layout.rotation_direction
    leg = min(location, len(layout.leg_modes) - 1)
    return layout.leg_modes[leg], layout.leg_directions[leg]


#: TASK.md's tolerances (section 4), the defaults of ``[world]``: the robot snaps onto the next
#: waypoint within this many units on both axes, and onto the goal heading within this many rad.
SNAP_TOLERANCE = 0.1
HEADING_TOLERANCE = 0.1
#: The study's analysis rule (TASK.md section 7): a success ends within this Manhattan distance of
#: the goal. The goal snap puts the robot exactly on the goal, so in this world the rule is met by
#: reaching the goal waypoint; ``world.success_distance`` is taken at this value only.
SUCCESS_DISTANCE = 0.1
#: The shortest leg of the study's layouts (TASK.md section 3: legs of 7.5 units along x, 5 along y).
#: A snap tolerance of half of it or more lets a snap skip half a leg or more (at 5 or more, a whole
#: leg with no input), so ``world.snap_tolerance`` must stay below half of it.
SHORTEST_LEG = 5.0
#: The rotation of every layout: from heading 0 to the goal heading, +-pi/2 (TASK.md section 1). The
#: heading snap is tested at every step, so a tolerance of pi/2 or more turns the robot at the start
#: with no input; ``world.heading_tolerance`` must stay below half of it, as the snap below half a leg.
ROTATION = math.pi / 2.0


def path_gaps(position: np.ndarray, waypoints: np.ndarray) -> np.ndarray:
    """``(N,)`` how far each position ``(N, 2)`` lies from the path through ``waypoints`` ``(W, 2)``:
    the per-axis (larger of x and y) distance to its nearest leg, as the snap measures it. Its
    legs are axis-aligned, so a leg's nearest point is the position clipped to the leg. A robot
    that follows the path stays on it, but for a logged overshoot within ``snap_tolerance``."""
    low, high = np.minimum(waypoints[:-1], waypoints[1:]), np.maximum(waypoints[:-1], waypoints[1:])
    nearest = np.clip(position[:, None, :], low[None], high[None])
    return np.abs(position[:, None, :] - nearest).max(axis=2).min(axis=1)


class PathWorld:
    """One trial of the CIAA task: the :class:`~nudgecli.model.world.World` of a path layout.

    Parameters
    ----------
    layout
        The trial's layout.
    snap_tolerance
        Per-axis distance (units) within which the robot snaps onto the next waypoint (0.1).
    heading_tolerance
        Heading error (rad) within which it snaps onto the goal heading (0.1).

    A trial succeeds when the robot reaches the goal waypoint: the snap puts it exactly on the
    goal, within the study's final Manhattan distance (:data:`SUCCESS_DISTANCE`) by construction.
    """

    def __init__(self, layout: PathLayout, snap_tolerance: float = SNAP_TOLERANCE,
                 heading_tolerance: float = HEADING_TOLERANCE) -> None:
        self.layout = layout
        self.snap_tolerance = snap_tolerance
        self.heading_tolerance = heading_tolerance
        self.location = 0
        self.turned = False
        self._goal = self.layout.goal_poses
        xs, ys = np.unique(layout.waypoints[:, 0]), np.unique(layout.waypoints[:, 1])
        self._marks = (xs.tolist(), ys.tolist())

    @property
    def n_goals(self) -> int:
        return 1

    @property
    def goal_poses(self) -> np.ndarray:
        return self._goal

    @property
    def start_pose(self) -> np.ndarray:
        return self.layout.start_pose

    @property
    def start_mode(self) -> int:
        return self.layout.start_mode

    @property
    def allowed(self) -> tuple[int, int]:
        """``(mode, direction)`` allowed now."""
        return allowed_motion(self.layout, self.location, self.turned)

    def state(self, x: float, y: float, theta: float, mode: int) -> int:
        return (self.location * 2 + int(self.turned)) * N_MODES + int(mode)

    def cells(self, state: int) -> tuple[int, int, int]:
        location, turned = divmod(state // N_MODES, 2)
        return int(location), int(turned), 0

    def move(self, x: float, y: float, theta: float, velocity: Command,
             dt: float) -> tuple[float, float, float]:
        last = len(self.layout.waypoints) - 1
        if self.location < last:
            mode, direction = self.allowed
            v = float(velocity[mode])
            if v * direction > 0:  # the allowed component, the allowed way; all else is masked
                if mode == 0:
                    x += v * dt
                elif mode == 1:
                    y += v * dt
                else:
                    theta = (theta + v * dt) % (2.0 * math.pi)
            x, y = self._snap_location(x, y)
            if abs(turn_between(theta, self.layout.goal_theta)) < self.heading_tolerance:
                theta, self.turned = self.layout.goal_theta, True
        return x, y, theta

    def holds_still(self, x: float, y: float, theta: float, velocity: Command) -> bool:
        if self.location >= len(self.layout.waypoints) - 1:
            return True
        mode, direction = self.allowed
        return not float(velocity[mode]) * direction > 0  # masked: another mode, or the wrong way

    def _snap_location(self, x: float, y: float) -> tuple[float, float]:
        if self.location == self.layout.turn_waypoint and not self.turned:
            return x, y  # the next leg is entered only after the rotation
        wx, wy = self.layout.waypoints[self.location + 1]
        if abs(x - wx) < self.snap_tolerance and abs(y - wy) < self.snap_tolerance:
            self.location += 1
            return float(wx), float(wy)
        return x, y

    def goal_reached(self, x: float, y: float, theta: float) -> int:
        """0 once the location is the goal waypoint, else -1: the snap that reaches it puts the robot
        exactly on the goal, so the study's distance rule (:data:`SUCCESS_DISTANCE`) holds there
        and needs no test (its time rule is the session's limit)."""
        return 0 if self.location >= len(self.layout.waypoints) - 1 else -1

    def next_mark(self, coordinate: float, direction: float, axis: int) -> float:
        """The next waypoint coordinate along x or y (``+-inf`` when none lies ahead), or the next
        quarter turn for the heading (where the goal heading lies)."""
        if axis == 2:
            return next_multiple(coordinate, direction, 0.0, HEADING_MARK)
        ahead = [m for m in self._marks[axis] if (m - coordinate) * direction > 1e-9]
        if not ahead:
            return math.inf * direction
        return min(ahead) if direction > 0 else max(ahead)
