"""The workspace, its discretisation, the robot's kinematics and the goal layouts.

Conventions used everywhere in the toolkit:

- continuous pose ``(x, y, theta)`` in world units and radians, ``theta`` in ``[0, 2 pi)``;
- modes ``0 = x`` (Horizontal), ``1 = y`` (Vertical), ``2 = theta`` (Rotational);
- the grid has ``N_CELLS_X x N_CELLS_Y`` cells, ``N_HEADINGS`` headings and ``N_MODES`` modes;
  a discrete state ``(i, j, h, m)`` has the flat index ``((i * 10 + j) * 8 + h) * 3 + m``
  (C order of an array shaped ``GRID_SHAPE``), the same order the study software used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Protocol

import numpy as np

X_MIN, X_MAX = 3.0, 45.0
Y_MIN, Y_MAX = 2.0, 36.0
ROBOT_RADIUS = 0.7
GOAL_RADIUS = 0.7

N_CELLS_X = 10
N_CELLS_Y = 10
N_HEADINGS = 8
N_MODES = 3
GRID_SHAPE = (N_CELLS_X, N_CELLS_Y, N_HEADINGS, N_MODES)
N_STATES = N_CELLS_X * N_CELLS_Y * N_HEADINGS * N_MODES

CELL_WIDTH = (X_MAX - X_MIN) / N_CELLS_X  # 4.2
CELL_HEIGHT = (Y_MAX - Y_MIN) / N_CELLS_Y  # 3.4
HEADING_STEP = 2.0 * np.pi / N_HEADINGS  # 45 degrees

MODE_NAMES = ("x", "y", "theta")
MODE_TITLES = ("Horizontal", "Vertical", "Rotational")

# Start-corner regions and the goal region "diametrically opposite" each (cell index ranges,
# inclusive), as the study's trial generator drew them.
START_REGIONS: dict[str, tuple[tuple[int, int], tuple[int, int]]] = {
    "tr": ((7, 8), (7, 8)),
    "tl": ((0, 2), (7, 8)),
    "bl": ((0, 2), (0, 2)),
    "br": ((7, 8), (0, 2)),
}
GOAL_REGIONS: dict[str, tuple[tuple[int, int], tuple[int, int]]] = {
    "tr": ((0, 5), (0, 3)),
    "tl": ((4, 8), (0, 3)),
    "bl": ((4, 8), (6, 8)),
    "br": ((0, 5), (6, 8)),
}
CORNERS = ("tr", "tl", "bl", "br")
#: Goals must be more than this many cells apart (orthogonal neighbours are forbidden).
INTER_GOAL_MIN_CELLS = 1.0


def wrap_angle(theta: np.ndarray | float) -> np.ndarray | float:
    """Wrap angles into ``[0, 2 pi)``."""
    return np.mod(theta, 2.0 * np.pi)


def angle_difference(a: np.ndarray | float, b: np.ndarray | float) -> np.ndarray | float:
    """Signed smallest difference ``a - b`` in ``[-pi, pi)`` (arrays; :func:`turn_between` for two floats)."""
    return np.mod(np.asarray(a) - np.asarray(b) + np.pi, 2.0 * np.pi) - np.pi


def turn_between(a: float, b: float) -> float:
    """:func:`angle_difference` of two floats with plain float arithmetic, bit for bit the same.

    Python's ``%`` on floats and ``np.mod`` both take ``fmod`` and then move a remainder whose
    sign differs from the divisor's by one divisor, so the two agree exactly (a test holds them
    to it); numpy's per-call overhead was the larger part of every simulated step's turn checks.
    """
    return (a - b + math.pi) % (2.0 * math.pi) - math.pi


def cell_centre(i: np.ndarray | int, j: np.ndarray | int) -> np.ndarray:
    """Continuous centre of cell ``(i, j)``.

    Returns
    -------
    np.ndarray
        ``(..., 2)`` array of ``(x, y)``.
    """
    if isinstance(i, int | np.integer) and isinstance(j, int | np.integer):  # one cell: float math
        return np.array([X_MIN + CELL_WIDTH * float(i) + CELL_WIDTH / 2.0,
                         Y_MIN + CELL_HEIGHT * float(j) + CELL_HEIGHT / 2.0])
    x = X_MIN + CELL_WIDTH * np.asarray(i, dtype=float) + CELL_WIDTH / 2.0
    y = Y_MIN + CELL_HEIGHT * np.asarray(j, dtype=float) + CELL_HEIGHT / 2.0
    if np.shape(x) != np.shape(y):
        x, y = np.broadcast_arrays(x, y)
    # filled in place: np.stack was most of the cost of a trial's few calls (goals, start, nudges)
    centre = np.empty((*np.shape(x), 2))
    centre[..., 0] = x
    centre[..., 1] = y
    return centre


def heading_angle(h: np.ndarray | int) -> np.ndarray | float:
    """The continuous angle of heading index ``h`` (``h * 45 deg``)."""
    return np.asarray(h) * HEADING_STEP


#: How close, in units of a grid's spacing, a coordinate counts as on one of its marks: a robot turned
#: onto a goal's or a target's heading (a multiple of 45 degrees) stops a last bit or two short of it.
MARK_TOLERANCE = 1e-9


def discretise(x: float, y: float, theta: float) -> tuple[int, int, int]:
    """The cell and heading of a continuous pose: nearest cell centre, ``floor(theta / 45 deg)``.

    A heading within :data:`MARK_TOLERANCE` of a bin's lower edge is in that bin: the edges are the
    goals' and the nudges' headings, which a turn reaches up to rounding (``pi/2`` less one last bit
    is the goal's heading 2, not heading 1).
    """
    # plain floats and comparisons (min/max calls cost more than the rule): this runs every simulated step
    i = math.floor((x - X_MIN) / CELL_WIDTH)
    i = 0 if i < 0 else N_CELLS_X - 1 if i > N_CELLS_X - 1 else i
    j = math.floor((y - Y_MIN) / CELL_HEIGHT)
    j = 0 if j < 0 else N_CELLS_Y - 1 if j > N_CELLS_Y - 1 else j
    h = math.floor((theta % (2.0 * math.pi)) / HEADING_STEP + MARK_TOLERANCE) % N_HEADINGS
    return i, j, h


def state_index(i: np.ndarray | int, j: np.ndarray | int, h: np.ndarray | int,
                m: np.ndarray | int) -> np.ndarray | int:
    """Flat index of the discrete state ``(i, j, h, m)`` (ints or broadcastable arrays)."""
    return ((i * N_CELLS_Y + j) * N_HEADINGS + h) * N_MODES + m


def state_coordinates(s: np.ndarray | int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Inverse of :func:`state_index`: ``(i, j, h, m)`` arrays for flat indices ``s``."""
    return np.unravel_index(np.asarray(s), GRID_SHAPE)  # type: ignore[return-value]


def all_state_coordinates() -> np.ndarray:
    """``(S, 4)`` integer array of ``(i, j, h, m)`` for every flat state index, in order."""
    return np.stack(np.unravel_index(np.arange(N_STATES), GRID_SHAPE), axis=-1)


#: A robot command ``(vx, vy, omega)``: a tuple of floats in the simulation's step loop, or a ``(3,)`` array.
Command = tuple[float, float, float] | np.ndarray


_X_LOW, _X_HIGH = X_MIN + ROBOT_RADIUS, X_MAX - ROBOT_RADIUS
_Y_LOW, _Y_HIGH = Y_MIN + ROBOT_RADIUS, Y_MAX - ROBOT_RADIUS


def clamp_position(x: float, y: float) -> tuple[float, float]:
    """Keep a robot position inside the workspace shrunk by the robot radius (per axis)."""
    # min(max(v, low), high) as comparisons (the same value: max keeps v unless low > v), every step
    x = _X_LOW if x < _X_LOW else x
    y = _Y_LOW if y < _Y_LOW else y
    return (_X_HIGH if x > _X_HIGH else x), (_Y_HIGH if y > _Y_HIGH else y)


@dataclass(frozen=True)
class Layout:
    """One trial's world: where the robot starts and where the goals are.

    Attributes
    ----------
    goal_cells
        ``(G, 2)`` cell indices of the goals; goal 0 is the true goal.
    goal_headings
        ``(G,)`` heading indices of the goals.
    start_cell, start_heading, start_mode
        The robot's start: cell ``(i, j)``, heading index and mode index.
    corner
        The start corner (``tr``, ``tl``, ``bl``, ``br``).
    """

    goal_cells: np.ndarray
    goal_headings: np.ndarray
    start_cell: tuple[int, int]
    start_heading: int
    start_mode: int
    corner: str

    @property
    def n_goals(self) -> int:
        return int(self.goal_cells.shape[0])

    @cached_property
    def goal_poses(self) -> np.ndarray:
        """``(G, 3)`` continuous goal poses (cell centre, ``heading * 45 deg``); read-only (made once
        per layout, not once per trial)."""
        xy = cell_centre(self.goal_cells[:, 0], self.goal_cells[:, 1])
        poses = np.column_stack([xy, heading_angle(self.goal_headings)])
        poses.setflags(write=False)
        return poses

    @cached_property
    def start_pose(self) -> np.ndarray:
        """``(3,)`` continuous start pose; read-only."""
        xy = cell_centre(*self.start_cell)
        pose = np.array([xy[0], xy[1], float(heading_angle(self.start_heading))])
        pose.setflags(write=False)
        return pose


def _region_cells(region: tuple[tuple[int, int], tuple[int, int]]) -> np.ndarray:
    (x0, x1), (y0, y1) = region
    xs, ys = np.meshgrid(np.arange(x0, x1 + 1), np.arange(y0, y1 + 1), indexing="ij")
    return np.column_stack([xs.ravel(), ys.ravel()])


#: Tries of the goals' one-at-a-time draw before a layout is declared impossible. With 5 goals
#: 0.5 % of first tries and with 6 about 19 % run out of cells (2026-11-28, 2,000 layouts each),
#: so a sweep over goal counts that the configuration allows crashed now and then.
GOAL_PLACEMENT_TRIES = 1000


def _place_goals(rng: np.random.Generator, candidates: np.ndarray, n_goals: int, corner: str) -> np.ndarray:
    """``(n_goals, 2)`` goal cells drawn one at a time among ``candidates`` (``(C, 2)``), each
    more than ``INTER_GOAL_MIN_CELLS`` from those before; a draw that runs out of cells is
    started again (rejection: the layouts are the one-at-a-time draw's, conditioned on fitting).

    A first try that fits consumes the same draws as the single try did before, so every layout
    that could be drawn then is drawn now, from the same seed.
    """
    for _ in range(GOAL_PLACEMENT_TRIES):
        goals: list[np.ndarray] = []
        for _ in range(n_goals):
            if goals:
                d = np.linalg.norm(candidates[:, None, :] - np.array(goals)[None, :, :], axis=-1)
                valid = candidates[(d > INTER_GOAL_MIN_CELLS).all(axis=1)]
            else:
                valid = candidates
            if len(valid) == 0:
                break
            goals.append(valid[rng.integers(len(valid))])
        else:
            return np.array(goals, dtype=int)
    raise ValueError(f"cannot place {n_goals} goals in the region opposite {corner} "
                     f"({GOAL_PLACEMENT_TRIES} tries)")


def sample_layout(rng: np.random.Generator, corner: str, n_goals: int, start_mode: int) -> Layout:
    """Draw one trial layout the way the study's generator did.

    The start cell is uniform in the corner's region with a uniform heading; goals are drawn
    one at a time, uniformly among the cells of the opposite region that are more than
    ``INTER_GOAL_MIN_CELLS`` from every goal drawn before, each with a uniform heading.

    Parameters
    ----------
    rng
        Source of randomness.
    corner
        One of ``CORNERS``.
    n_goals
        Number of goals (goal 0 is the true one).
    start_mode
        Mode index the trial starts in.
    """
    if corner not in START_REGIONS:
        raise ValueError(f"unknown corner {corner!r}; expected one of {CORNERS}")
    starts = _region_cells(START_REGIONS[corner])
    start = starts[rng.integers(len(starts))]
    start_heading = int(rng.integers(N_HEADINGS))
    goals = _place_goals(rng, _region_cells(GOAL_REGIONS[corner]), n_goals, corner)
    headings = rng.integers(N_HEADINGS, size=n_goals)
    return Layout(
        goal_cells=goals,
        goal_headings=np.asarray(headings, dtype=int),
        start_cell=(int(start[0]), int(start[1])),
        start_heading=start_heading,
        start_mode=int(start_mode),
        corner=corner,
    )


# --- the world interface ------------------------------------------------------------------------

class World(Protocol):
    """One trial's world, as the trial session and the simulated person consult it.

    Two implementations: :class:`GridWorld` (the paper's open workspace with its 10 x 10 x 8 x 3
    grid) and :class:`nudgecli.model.path_world.PathWorld` (the CIAA path-constrained task). A
    world is made per trial; it may keep per-trial state of its own (the path world's current
    waypoint and whether the turn is done), updated only by :meth:`move`.
    """

    @property
    def n_goals(self) -> int:
        """Number of goals of the trial."""

    @property
    def goal_poses(self) -> np.ndarray:
        """``(G, 3)`` the goals' poses."""

    @property
    def start_pose(self) -> np.ndarray:
        """``(3,)`` the robot's start pose."""

    @property
    def start_mode(self) -> int:
        """The mode the trial starts in."""

    def state(self, x: float, y: float, theta: float, mode: int) -> int:
        """The discrete state of a pose and mode (the index into policies and likelihoods)."""

    def cells(self, state: int) -> tuple[int, int, int]:
        """``(cell_x, cell_y, heading)`` of a discrete state, as the step log records them."""

    def move(self, x: float, y: float, theta: float, velocity: Command,
             dt: float) -> tuple[float, float, float]:
        """The pose after one step of ``velocity`` ``(vx, vy, omega)`` (units/s, rad/s anticlockwise)
        for ``dt`` s, under the world's constraints."""

    def goal_reached(self, x: float, y: float, theta: float) -> int:
        """The index of the goal whose success rule the pose meets, or -1."""

    def next_mark(self, coordinate: float, direction: float, axis: int) -> float:
        """The next mark a person can see along ``axis`` strictly beyond ``coordinate`` in ``direction``."""

    def holds_still(self, x: float, y: float, theta: float, velocity: Command) -> bool:
        """Whether a command of ``velocity`` ``(vx, vy, omega)`` leaves the robot at ``(x, y, theta)``
        (a wall, a direction the world does not allow); asks without moving anything."""


#: A step short enough that a probe of the workspace's bounds moves the robot by a rounding's width.
_PROBE_DT = 1e-6


class GridWorld:
    """The paper's world: the open workspace (clamped to its bounds), the grid's discrete states,
    success within ``success_distance`` and ``success_angle`` of any goal pose, and the cell
    centres (and multiples of 45 degrees) as the marks a person sees.

    Parameters
    ----------
    layout
        The trial's layout.
    success_distance, success_angle
        The success tolerance (units, rad).
    """

    def __init__(self, layout: Layout, success_distance: float, success_angle: float) -> None:
        self.layout = layout
        self.success_distance = success_distance
        self.success_angle = success_angle
        self._goal_poses = layout.goal_poses
        self._goal_list = [(float(x), float(y), float(t)) for x, y, t in self._goal_poses]
        # The last query's answer: both are pure functions of the pose, asked every step, and the
        # robot stands still in about half of a person's steps (no input, a mode switch).
        self._last_state: tuple[tuple[float, float, float, int], int] = ((math.nan,) * 3 + (0,), -1)
        self._last_goal: tuple[tuple[float, float, float], int] = ((math.nan,) * 3, -1)

    @property
    def n_goals(self) -> int:
        return self.layout.n_goals

    @property
    def goal_poses(self) -> np.ndarray:
        return self._goal_poses

    @property
    def start_pose(self) -> np.ndarray:
        return self.layout.start_pose

    @property
    def start_mode(self) -> int:
        return int(self.layout.start_mode)

    def state(self, x: float, y: float, theta: float, mode: int) -> int:
        pose = (x, y, theta, mode)
        last, answer = self._last_state
        if pose == last:
            return answer
        i, j, h = discretise(x, y, theta)
        answer = ((i * N_CELLS_Y + j) * N_HEADINGS + h) * N_MODES + int(mode)  # state_index on ints
        self._last_state = (pose, answer)
        return answer

    def cells(self, state: int) -> tuple[int, int, int]:
        cell, h = divmod(state // N_MODES, N_HEADINGS)
        i, j = divmod(cell, N_CELLS_Y)
        return int(i), int(j), int(h)

    def move(self, x: float, y: float, theta: float, velocity: Command,
             dt: float) -> tuple[float, float, float]:
        x, y = clamp_position(x + float(velocity[0]) * dt, y + float(velocity[1]) * dt)
        return x, y, (theta + float(velocity[2]) * dt) % (2.0 * math.pi)

    def goal_reached(self, x: float, y: float, theta: float) -> int:
        # scalar math: this runs every step
        pose = (x, y, theta)
        last, answer = self._last_goal
        if pose == last:
            return answer
        answer = -1
        distance, hypot = self.success_distance, math.hypot  # read once for the goals' loop
        for index, (gx, gy, gth) in enumerate(self._goal_list):
            if hypot(gx - x, gy - y) <= distance and abs(turn_between(gth, theta)) <= self.success_angle:
                answer = index
                break
        self._last_goal = (pose, answer)
        return answer

    def next_mark(self, coordinate: float, direction: float, axis: int) -> float:
        return grid_next_mark(coordinate, direction, axis)

    def holds_still(self, x: float, y: float, theta: float, velocity: Command) -> bool:
        # only the workspace's bounds stop the robot; a turn always turns
        if abs(float(velocity[2])) > 0.0:
            return False
        probe = clamp_position(x + float(velocity[0]) * _PROBE_DT, y + float(velocity[1]) * _PROBE_DT)
        return probe == (x, y)


def grid_next_mark(coordinate: float, direction: float, axis: int) -> float:
    """The grid world's next visible mark: the next cell centre along x or y
    (``X_MIN + w (k + 1/2)``), or the next multiple of 45 degrees for the heading (where goal
    headings lie), strictly beyond ``coordinate`` in ``direction`` (a sign)."""
    if axis == 2:
        origin, width = 0.0, HEADING_STEP
    else:
        origin, width = ((X_MIN, CELL_WIDTH), (Y_MIN, CELL_HEIGHT))[axis]
        origin += width / 2.0
    return next_multiple(coordinate, direction, origin, width)


def next_multiple(coordinate: float, direction: float, origin: float, width: float) -> float:
    """The next point ``origin + k width`` strictly beyond ``coordinate`` in ``direction`` (a sign)."""
    u = (coordinate - origin) / width
    k = math.floor(u + MARK_TOLERANCE) + 1 if direction > 0 else math.ceil(u - MARK_TOLERANCE) - 1
    return origin + k * width
