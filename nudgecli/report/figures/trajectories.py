"""One trial's path through the workspace: who drove, where the mode changed, the goals."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.colors import to_rgba
from matplotlib.lines import Line2D

from nudgecli.errors import DataError
from nudgecli.model import world
from nudgecli.report.figures.common import TrialLayout, axes_or_new
from nudgecli.report.style import AUTONOMY_COLOUR, FULL_WIDTH_IN, HUMAN_COLOUR, figure_style, goal_style
from nudgecli.report.trial_steps import require_columns, runs, sorted_steps
from nudgecli.steplog import (
    AUTONOMY_TURN,
    MODE_SWITCH_AUTONOMY,
    MODE_SWITCH_HUMAN,
    NUDGE,
    event_tokens,
    has_event,
)

TRAJECTORY_FIGSIZE = (FULL_WIDTH_IN, 4.3)
MODE_MARKERS = {"x": ">", "y": "^", "theta": "o"}
MODE_NAMES = {"x": "x (Horizontal)", "y": "y (Vertical)", "theta": "θ (Rotational)"}
#: Marker face of a mode change: filled when the human switched, open when the autonomy did.
SWITCH_FILL = {"human": "black", "autonomy": "white"}
NUDGE_COLOUR = "#CC79A7"


@dataclass
class TrajectoryArtists:
    """What :func:`trajectory` drew.

    Attributes
    ----------
    ax
        The axes.
    goals
        One disc per goal, by goal index.
    goal_labels
        One label per goal (``g2 (true)`` for the true goal).
    path
        ``(who, line)`` per turn: who is ``"human"`` or ``"autonomy"``.
    switches
        ``(who, marker)`` per mode change, in time order.
    handles
        Legend handles.
    """

    ax: Axes
    goals: list[Line2D] = field(default_factory=list)
    goal_labels: list[Any] = field(default_factory=list)
    path: list[tuple[str, Line2D]] = field(default_factory=list)
    switches: list[tuple[str, Line2D]] = field(default_factory=list)
    handles: list[Any] = field(default_factory=list)


def mode_switch_authors(steps: pd.DataFrame) -> list[tuple[int, str]]:
    """``(step index, "human" | "autonomy")`` of every mode change of sorted steps.

    A change is the autonomy's when its event says so, or when the event names neither and the
    step is in the autonomy's turn.
    """
    if "mode" not in steps.columns:
        return []
    modes = steps["mode"].astype(str).to_numpy()
    turns = steps["turn"].astype(str).to_numpy()
    events = steps["event"] if "event" in steps.columns else pd.Series([""] * len(steps))
    out = []
    for k in np.flatnonzero(modes[1:] != modes[:-1]) + 1:
        tokens = event_tokens(events.iloc[k])
        by_autonomy = MODE_SWITCH_AUTONOMY in tokens or (MODE_SWITCH_HUMAN not in tokens
                                                         and turns[k] == AUTONOMY_TURN)
        out.append((int(k), "autonomy" if by_autonomy else "human"))
    return out


def trajectory(steps: pd.DataFrame, layout: TrialLayout, *, ax: Axes | None = None, title: str | None = None,
               legend: bool = True) -> TrajectoryArtists:
    """One trial's path through the workspace.

    The workspace ``[3, 45] x [2, 36]`` with its 10 x 10 grid of cells (4.2 x 3.4); the goals
    as discs with a tick in their heading (the true goal red, labelled); the path in black and
    solid where the human drove and gray and dashed where the autonomy drove; a marker at each
    mode change whose shape is the new mode (filled: switched by the human, open: by the
    autonomy); diamonds at nudges; the start (star) and the end (cross).

    Parameters
    ----------
    steps
        The 10 Hz steps of one trial: ``x``, ``y``, ``turn``, ``mode`` (and ``event``, ``step``).
    layout
        The trial's goals, start pose and true goal.
    ax
        Axes to draw on; default a new 7.2 x 4.3 in figure's.
    title
        Optional title.
    legend
        Add the legend to the right of the figure.

    Returns
    -------
    TrajectoryArtists
        One equal-aspect panel.
    """
    require_columns(steps, ["x", "y", "turn"], "steps table")
    if steps.empty:
        raise DataError("steps table: the trial has no steps")
    steps = sorted_steps(steps)
    x = steps["x"].to_numpy(dtype=float)
    y = steps["y"].to_numpy(dtype=float)
    theta = steps["theta"].to_numpy(dtype=float) if "theta" in steps.columns else np.zeros_like(x)
    start = layout.start_pose if layout.start_pose is not None else np.array([x[0], y[0], theta[0]])
    turns = steps["turn"].astype(str).to_numpy()
    events = steps["event"] if "event" in steps.columns else pd.Series([""] * len(steps))
    ax = axes_or_new(ax, TRAJECTORY_FIGSIZE)
    out = TrajectoryArtists(ax=ax)

    with figure_style():
        _draw_grid(ax)
        _draw_goals(ax, layout, out)
        _draw_path(ax, x, y, turns, out)
        nudged = _draw_marks(ax, steps, x, y, start, events, out)
        _style_axes(ax, title)
        out.handles = _legend_handles(layout, nudged)
        figure = ax.get_figure()
        if legend and figure is not None:
            figure.legend(handles=out.handles, loc="outside right center")
    return out


def _draw_grid(ax: Axes) -> None:
    """The workspace's cell grid, in light gray under everything."""
    for gx in np.arange(world.N_CELLS_X + 1) * world.CELL_WIDTH + world.X_MIN:
        ax.axvline(gx, color="#D0D0D0", linewidth=0.5, zorder=0)
    for gy in np.arange(world.N_CELLS_Y + 1) * world.CELL_HEIGHT + world.Y_MIN:
        ax.axhline(gy, color="#D0D0D0", linewidth=0.5, zorder=0)


def _draw_goals(ax: Axes, layout: TrialLayout, out: TrajectoryArtists) -> None:
    """Each goal as a disc with a tick in its heading, and its label (the true goal's says so)."""
    tick_len = 0.55 * world.CELL_HEIGHT
    for g, (gx, gy, gth) in enumerate(layout.goal_poses):
        colour, _ = goal_style(g, layout.true_goal)
        ax.plot([gx, gx + tick_len * np.cos(gth)], [gy, gy + tick_len * np.sin(gth)], color=colour,
                linewidth=2.0, solid_capstyle="butt", zorder=4)
        (disc,) = ax.plot([gx], [gy], marker="o", markersize=10, color=colour, markeredgecolor="black",
                          markeredgewidth=0.6, zorder=5, linestyle="none")
        out.goals.append(disc)
        out.goal_labels.append(ax.annotate(
            f"g{g}" + (" (true)" if g == layout.true_goal else ""), (gx, gy), xytext=(0, -9),
            textcoords="offset points", ha="center", va="top", fontsize=8, color="black", zorder=6))


def _draw_path(ax: Axes, x: np.ndarray, y: np.ndarray, turns: np.ndarray, out: TrajectoryArtists) -> None:
    """The path: solid black where the human drove, dashed gray where the autonomy drove."""
    # Path, one segment per turn (each joined to the next turn's first point).
    for turn, first, last in runs(turns):
        end = min(last + 1, len(x) - 1)
        who = "autonomy" if turn == AUTONOMY_TURN else "human"
        human = who == "human"
        (line,) = ax.plot(x[first:end + 1], y[first:end + 1],
                          color=HUMAN_COLOUR if human else AUTONOMY_COLOUR,
                          linestyle="-" if human else (0, (3, 1.5)), linewidth=1.6 if human else 1.8,
                          solid_capstyle="round", zorder=3)
        out.path.append((who, line))


def _draw_marks(ax: Axes, steps: pd.DataFrame, x: np.ndarray, y: np.ndarray, start: np.ndarray,
                events: pd.Series, out: TrajectoryArtists) -> bool:
    """Markers at the mode changes and nudges, the start and the end; whether there was a nudge."""
    # Mode changes.
    modes = steps["mode"].astype(str).to_numpy() if "mode" in steps.columns else np.empty(0, dtype=str)
    for k, who in mode_switch_authors(steps):
        (marker,) = ax.plot([x[k]], [y[k]], marker=MODE_MARKERS.get(modes[k], "s"), markersize=6,
                            markerfacecolor=SWITCH_FILL[who], markeredgecolor="black",
                            markeredgewidth=0.9, linestyle="none", zorder=7)
        out.switches.append((who, marker))
    nudge = has_event(events, NUDGE)
    if nudge.any():
        # Under the mode-change markers: the autonomy often switches mode as it starts a nudge.
        ax.plot(x[nudge], y[nudge], marker="D", markersize=10,
                markerfacecolor=to_rgba(NUDGE_COLOUR, 0.85), markeredgecolor="black",
                markeredgewidth=0.6, linestyle="none", zorder=6)
    ax.plot([start[0]], [start[1]], marker="*", markersize=13, color="black",
            markeredgecolor="white", markeredgewidth=0.5, linestyle="none", zorder=9)
    ax.plot([x[-1]], [y[-1]], marker="X", markersize=8, color="black", markeredgecolor="white",
            markeredgewidth=0.5, linestyle="none", zorder=9)
    return bool(nudge.any())


def _style_axes(ax: Axes, title: str | None) -> None:
    """The workspace's limits, equal aspect, labels, a closed frame and the title."""
    ax.set_xlim(world.X_MIN, world.X_MAX)
    ax.set_ylim(world.Y_MIN, world.Y_MAX)
    ax.set_aspect("equal")
    ax.set_xlabel("x (world units)")
    ax.set_ylabel("y (world units)")
    for spine in ("top", "right"):
        ax.spines[spine].set_visible(True)
    if title:
        ax.set_title(title, loc="left")


def _legend_handles(layout: TrialLayout, nudged: bool) -> list[Any]:
    """The legend: the goals, start and end, who drove, the modes, who switched, and nudges."""
    # one swatch per goal, in the colours the discs (and Fig. 5's lines) use
    handles = [
        Line2D([], [], marker="o", markersize=8, color=goal_style(g, layout.true_goal)[0],
               markeredgecolor="black", markeredgewidth=0.6, linestyle="none",
               label=f"g{g} (true goal)" if g == layout.true_goal else f"g{g}")
        for g in range(layout.n_goals)
    ]
    handles += [
        Line2D([], [], marker="*", markersize=11, color="black", linestyle="none", label="Start"),
        Line2D([], [], marker="X", markersize=7, color="black", linestyle="none", label="End"),
        Line2D([], [], color=HUMAN_COLOUR, linewidth=1.6, label="Human drove"),
        Line2D([], [], color=AUTONOMY_COLOUR, linewidth=1.8, linestyle=(0, (3, 1.5)),
               label="Autonomy drove"),
    ]
    for mode, symbol in MODE_MARKERS.items():
        handles.append(Line2D([], [], marker=symbol, markersize=6, markerfacecolor="#B0B0B0",
                              markeredgecolor="black", linestyle="none",
                              label=f"Switch to {MODE_NAMES[mode]}"))
    # squares: no mode uses them, so the fill key cannot be read as the theta marker
    for who, text in (("human", "  filled: by human"), ("autonomy", "  open: by autonomy")):
        handles.append(Line2D([], [], marker="s", markersize=6, markerfacecolor=SWITCH_FILL[who],
                              markeredgecolor="black", linestyle="none", label=text))
    if nudged:
        handles.append(Line2D([], [], marker="D", markersize=7, markerfacecolor=NUDGE_COLOUR,
                              markeredgecolor="black", markeredgewidth=0.6, linestyle="none",
                              label="Nudge"))
    return handles


__all__ = ["MODE_MARKERS", "SWITCH_FILL", "TRAJECTORY_FIGSIZE", "TrajectoryArtists", "mode_switch_authors",
           "trajectory"]
