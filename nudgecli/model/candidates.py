"""The candidate domains s* is searched over: the window around the robot, the robot's cell in
every mode, and every state (with the rotation gate)."""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from nudgecli.model.world import (
    CELL_HEIGHT,
    CELL_WIDTH,
    N_CELLS_X,
    N_CELLS_Y,
    N_HEADINGS,
    N_MODES,
    X_MIN,
    Y_MIN,
    all_state_coordinates,
    cell_centre,
    state_coordinates,
    state_index,
)


@dataclass(frozen=True)
class Candidates:
    """The states s* is chosen from, in search order.

    Attributes
    ----------
    states
        ``(C,)`` flat state indices.
    cells
        ``(C, 2)`` cell indices ``(i, j)``.
    positions
        ``(C, 2)`` world positions used by world-unit distances and the rotation gate.
    """

    states: np.ndarray
    cells: np.ndarray
    positions: np.ndarray


def _goal_cell_ids(goal_cells: np.ndarray) -> np.ndarray:
    """``(N_X * N_Y,)`` bool: which flat cell ids ``i * N_Y + j`` hold a goal."""
    cells = np.asarray(goal_cells, dtype=int).reshape(-1, 2)
    occupied = np.zeros(N_CELLS_X * N_CELLS_Y, dtype=bool)
    occupied[cells[:, 0] * N_CELLS_Y + cells[:, 1]] = True
    return occupied


def _mean_goal_position(goal_cells: np.ndarray) -> np.ndarray:
    """``(2,)`` unweighted mean of the goals' cell centres (the rotation gate's reference)."""
    cells = np.asarray(goal_cells, dtype=int).reshape(-1, 2)
    return cell_centre(cells[:, 0], cells[:, 1]).mean(axis=0)


def _rotation_gate_keep(modes: np.ndarray, positions: np.ndarray, mean_goal: np.ndarray,
                        rotation_gate: float) -> np.ndarray:
    """``(C,)`` bool: False for theta-mode candidates farther than the gate from ``mean_goal``."""
    dx = positions[:, 0] - mean_goal[0]
    dy = positions[:, 1] - mean_goal[1]
    return (modes != N_MODES - 1) | (np.sqrt(dx * dx + dy * dy) <= rotation_gate)


class WindowTable:
    """Every window slot's validity for every cell of one goal layout, built once.

    A slot is ``(dx, dy, mode)``, ordered row-major over dx, dy, mode. With the flat index
    ``((i * 10 + j) * 8 + h) * 3 + m``, the slot's state is ``cell_id * 24 + h * 3 +
    slot_offset`` with ``slot_offset = (dx * 10 + dy) * 24 + mode``, so a query is a row lookup
    and one masked add.
    """

    def __init__(self, goal_cells: np.ndarray, window: int) -> None:
        if window < 1 or window % 2 == 0:
            raise ValueError(f"window must be a positive odd number of cells, got {window}")
        half = window // 2
        dx, dy, mode = (a.ravel() for a in np.meshgrid(np.arange(-half, half + 1), np.arange(-half, half + 1),
                                                       np.arange(N_MODES), indexing="ij"))
        self.offsets = np.stack([dx, dy], axis=1)  # (K, 2)
        self.modes = mode
        self.slot_offset = (dx * N_CELLS_Y + dy) * (N_HEADINGS * N_MODES) + mode
        self.displacement = np.stack([dx * CELL_WIDTH, dy * CELL_HEIGHT], axis=1)
        i, j = np.divmod(np.arange(N_CELLS_X * N_CELLS_Y), N_CELLS_Y)
        ci = i[:, None] + dx[None, :]
        cj = j[:, None] + dy[None, :]
        on_grid = (ci >= 0) & (ci < N_CELLS_X) & (cj >= 0) & (cj < N_CELLS_Y)
        occupied = _goal_cell_ids(goal_cells)
        cell_ids = np.where(on_grid, ci * N_CELLS_Y + cj, 0)
        self.valid = on_grid & ~occupied[cell_ids]  # (cells, K)
        self.mean_goal = _mean_goal_position(goal_cells)
        # shared by every model of the layout (window_table)
        for table in (self.offsets, self.modes, self.slot_offset, self.displacement, self.valid,
                      self.mean_goal):
            table.flags.writeable = False

    def candidates(self, current_state: int, robot_position: np.ndarray | None,
                   rotation_gate: float | None) -> Candidates:
        # Integer arithmetic on the flat index (cheaper than np.unravel_index for one state).
        cell_id, rest = divmod(int(current_state), N_HEADINGS * N_MODES)
        i, j = divmod(cell_id, N_CELLS_Y)
        if robot_position is None:
            origin = np.array([X_MIN + CELL_WIDTH * (i + 0.5), Y_MIN + CELL_HEIGHT * (j + 0.5)])
        else:
            origin = np.asarray(robot_position, dtype=float)[:2]
        keep = self.valid[cell_id]
        positions = self.displacement + origin
        if rotation_gate is not None:
            keep = keep & _rotation_gate_keep(self.modes, positions, self.mean_goal, rotation_gate)
        base = cell_id * (N_HEADINGS * N_MODES) + (rest // N_MODES) * N_MODES
        return Candidates(states=self.slot_offset[keep] + base, cells=self.offsets[keep] + (i, j),
                          positions=positions[keep])


def window_table(goal_cells: np.ndarray, window: int) -> WindowTable:
    """The :class:`WindowTable` of a layout's ``(G, 2)`` goal cells, built once per process: it
    depends on the layout alone, and a worker simulates every participant on the same layouts."""
    cells = np.ascontiguousarray(goal_cells, dtype=np.int64).reshape(-1, 2)
    return _window_table(cells.tobytes(), int(window))


@functools.lru_cache(maxsize=256)  # a few studies' layouts; a table is a few kB
def _window_table(goal_cells: bytes, window: int) -> WindowTable:
    return WindowTable(np.frombuffer(goal_cells, dtype=np.int64).reshape(-1, 2), window)


def window_candidates(current_state: int, goal_cells: np.ndarray, window: int,
                      robot_position: np.ndarray | None = None,
                      rotation_gate: float | None = None) -> Candidates:
    """The ``window x window`` cells around the current cell, all modes, the current heading.

    Order: row-major over ``dx``, then ``dy``, then mode. Off-grid cells and goal cells are never
    candidates. A candidate's world position is the study's ``robot_position + (dx * 4.2, dy *
    3.4)`` (the cell centre when the robot sits at its cell's centre). The layout's table is
    built once (:func:`window_table`).

    Parameters
    ----------
    current_state
        Flat index of the robot's discrete state.
    goal_cells
        ``(G, 2)`` goal cells.
    window
        Odd window side (3 or 5).
    robot_position
        ``(2,)`` continuous robot position; ``None`` uses the current cell's centre.
    rotation_gate
        See :class:`nudgecli.model.disambiguation.DisambiguationSettings`.

    Returns
    -------
    Candidates
    """
    return window_table(goal_cells, window).candidates(current_state, robot_position, rotation_gate)


def mode_candidates(current_state: int, robot_position: np.ndarray | None = None) -> Candidates:
    """The states that differ from ``current_state`` in mode alone: its cell and heading, every
    mode, in mode order (the current state included: keeping the mode is a choice too).

    Parameters
    ----------
    current_state
        Flat index of the robot's discrete state.
    robot_position
        ``(2,)`` continuous robot position (every candidate's); ``None`` uses the cell's centre.

    Returns
    -------
    Candidates
    """
    i, j, h, _ = (int(v) for v in state_coordinates(int(current_state)))
    modes = np.arange(N_MODES)
    position = cell_centre(i, j) if robot_position is None else np.asarray(robot_position, dtype=float)[:2]
    return Candidates(states=np.asarray(state_index(i, j, h, modes), dtype=np.int64),
                      cells=np.tile([i, j], (N_MODES, 1)), positions=np.tile(position, (N_MODES, 1)))


def global_candidates(goal_cells: np.ndarray, rotation_gate: float | None = None) -> Candidates:
    """Every state whose cell is not a goal cell (all headings and modes), in flat-index order.

    World positions are cell centres.

    Parameters
    ----------
    goal_cells
        ``(G, 2)`` goal cells.
    rotation_gate
        See :class:`nudgecli.model.disambiguation.DisambiguationSettings`.

    Returns
    -------
    Candidates
    """
    i, j, _, m = all_state_coordinates().T
    positions = cell_centre(i, j)
    keep = ~_goal_cell_ids(goal_cells)[i * N_CELLS_Y + j]
    if rotation_gate is not None:
        keep &= _rotation_gate_keep(m, positions, _mean_goal_position(goal_cells), rotation_gate)
    return Candidates(states=np.flatnonzero(keep), cells=np.column_stack([i[keep], j[keep]]),
                      positions=positions[keep])
