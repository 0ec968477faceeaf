"""Figures of a run in the CIAA path world (``nudge plot`` of a ``ciaa-teleop`` run).

- ``trajectory``: one trial. (a) The 30 x 20 world with the drawn corridor, the waypoints (the
  turn waypoint ringed), the goal with its heading, the robot's track, a marker at each mode
  switch (its shape the new mode) and the start and end; (b) progress along the path over time
  (distance travelled along the polyline, and the heading turned at the turn waypoint on a
  second axis), with the mode as a band under it and the time limit as a line.
- ``measures``: box plots (every trial a dot) of the measures compared with real people that the
  run's ``metrics.csv`` holds: completion time, mode switches, first-input latency and the
  fraction of time with active input; the success rate in the title.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.layout_engine import ConstrainedLayoutEngine
from matplotlib.lines import Line2D

from nudgecli.errors import DataError
from nudgecli.report.figures.boxplots import METRIC_FIGSIZE, MetricSpec, metric_boxplot
from nudgecli.report.figures.common import axes_or_new, panel_letter, stats_by_metric
from nudgecli.report.not_applicable import not_applicable_of
from nudgecli.report.style import FULL_WIDTH_IN, HUMAN_COLOUR, figure_style, goal_style
from nudgecli.steplog import MODE_SWITCH_HUMAN, has_event

#: The CIAA task's world (TASK.md section 1) and its drawn corridor half-width (decoration only).
WORLD_SIZE = (30.0, 20.0)
CORRIDOR_HALF_WIDTH = 0.84
PATH_TRAJECTORY_FIGSIZE = (FULL_WIDTH_IN, 3.0)
#: Size in inches of one of its two panels drawn alone.
PATH_PANEL_FIGSIZE = (PATH_TRAJECTORY_FIGSIZE[0] / 2, PATH_TRAJECTORY_FIGSIZE[1])
#: The measures drawn by :func:`measures_figure`, in order, with their labels.
MEASURE_SPECS: dict[str, MetricSpec] = {
    "completion_time": MetricSpec("completion_time", "Completion time (s)"),
    "mode_switches": MetricSpec("mode_switches", "Mode switches per trial", integer=True),
    "first_input_latency": MetricSpec("first_input_latency", "Latency to first command (s)"),
    "active_input_fraction": MetricSpec("active_input_fraction", "Time with active input (%)", 100.0),
}
_MODE_MARKERS = {"x": ">", "y": "^", "theta": "o"}
_MODE_COLOURS = {"x": "#0072B2", "y": "#E69F00", "theta": "#009E73"}


def path_progress(x: np.ndarray, y: np.ndarray, waypoints: np.ndarray) -> np.ndarray:
    """Distance travelled along the polyline at each position (positions lie on the path).

    Parameters
    ----------
    x, y
        ``(N,)`` positions.
    waypoints
        ``(W, 2)`` the path.

    Returns
    -------
    np.ndarray
        ``(N,)`` the arc length from the start of the nearest point of the path.
    """
    a, b = waypoints[:-1], waypoints[1:]
    lengths = np.linalg.norm(b - a, axis=1)
    before = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    points = np.column_stack([x, y])[:, None, :]
    seg = (b - a)[None]
    u = np.clip(((points - a[None]) * seg).sum(-1) / np.maximum(lengths ** 2, 1e-12)[None], 0.0, 1.0)
    nearest = a[None] + u[..., None] * seg
    distance = np.linalg.norm(points - nearest, axis=-1)
    best = distance.argmin(axis=1)
    return before[best] + u[np.arange(len(x)), best] * lengths[best]


@dataclass(frozen=True)
class _Trial:
    """One trial's steps as arrays (``(T,)`` each), in step order."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    turned: np.ndarray
    modes: np.ndarray
    switches: np.ndarray


def _trial(steps: pd.DataFrame) -> _Trial:
    """The arrays a trial's panels draw; a ``DataError`` when a column is missing or no step."""
    for column in ("t", "x", "y", "theta", "mode"):
        if column not in steps.columns:
            raise DataError(f"steps table: no {column!r} column; re-run `nudge simulate`")
    if steps.empty:
        raise DataError("steps table: the trial has no steps")
    steps = steps.sort_values("step", kind="stable") if "step" in steps.columns else steps
    theta = steps["theta"].to_numpy(float)
    events = steps["event"] if "event" in steps.columns else pd.Series([""] * len(steps))
    return _Trial(t=steps["t"].to_numpy(float), x=steps["x"].to_numpy(float), y=steps["y"].to_numpy(float),
                  turned=np.abs((theta + np.pi) % (2 * np.pi) - np.pi),
                  modes=steps["mode"].astype(str).to_numpy(),
                  switches=np.asarray(has_event(events, MODE_SWITCH_HUMAN), dtype=bool))


def path_panel(steps: pd.DataFrame, waypoints: np.ndarray, turn_waypoint: int, goal_pose: np.ndarray, *,
               ax: Axes | None = None) -> Axes:
    """Panel (a): the world, the corridor and waypoints (the turn waypoint ringed), the goal with
    its heading, the robot's track, a marker per mode switch (shape and fill: the new mode), start
    and end.

    Parameters
    ----------
    steps
        The trial's steps: ``step``, ``t``, ``x``, ``y``, ``theta``, ``mode``, ``event``.
    waypoints
        ``(W, 2)`` the path.
    turn_waypoint
        Index of the turn waypoint.
    goal_pose
        ``(3,)`` the goal pose.
    ax
        Axes to draw on; default a new figure's.
    """
    trial, ax = _trial(steps), axes_or_new(ax, PATH_PANEL_FIGSIZE)
    waypoints = np.asarray(waypoints, dtype=float).reshape(-1, 2)
    x, y, modes = trial.x, trial.y, trial.modes
    gx, gy, gth = (float(v) for v in goal_pose)
    ax.plot(waypoints[:, 0], waypoints[:, 1], color="#DDDDDD", linewidth=2 * CORRIDOR_HALF_WIDTH * 6,
            solid_capstyle="round", solid_joinstyle="round", zorder=0)
    ax.plot(waypoints[:, 0], waypoints[:, 1], color="#999999", linewidth=0.8, linestyle=":", zorder=1)
    ax.plot(waypoints[:, 0], waypoints[:, 1], marker="o", markersize=3, color="#666666", linestyle="none",
            zorder=2)
    tx, ty = waypoints[turn_waypoint]
    ax.plot([tx], [ty], marker="o", markersize=11, markerfacecolor="none", markeredgecolor="black",
            markeredgewidth=1.0, linestyle="none", zorder=5)
    tick = 1.4
    ax.plot([gx, gx + tick * np.cos(gth)], [gy, gy + tick * np.sin(gth)], color=goal_style(0, 0)[0],
            linewidth=2.0, zorder=4)
    ax.plot([gx], [gy], marker="o", markersize=10, color=goal_style(0, 0)[0], markeredgecolor="black",
            markeredgewidth=0.6, linestyle="none", zorder=4)
    ax.plot(x, y, color=HUMAN_COLOUR, linewidth=1.4, zorder=3)
    for k in np.flatnonzero(trial.switches):
        new_mode = str(modes[min(int(k) + 1, len(modes) - 1)])
        ax.plot([x[k]], [y[k]], marker=_MODE_MARKERS.get(new_mode, "s"), markersize=6,
                markerfacecolor=_MODE_COLOURS.get(new_mode, "white"), markeredgecolor="black",
                markeredgewidth=0.7, linestyle="none", zorder=7)
    ax.plot([x[0]], [y[0]], marker="*", markersize=12, color="black", markeredgecolor="white",
            linestyle="none", zorder=8)
    ax.plot([x[-1]], [y[-1]], marker="X", markersize=7, color="black", markeredgecolor="white",
            linestyle="none", zorder=8)
    ax.set_xlim(0, WORLD_SIZE[0])
    ax.set_ylim(0, WORLD_SIZE[1])
    ax.set_aspect("equal")
    ax.set_xlabel("x (world units)")
    ax.set_ylabel("y (world units)")
    return ax


def progress_panel(steps: pd.DataFrame, waypoints: np.ndarray, *, time_limit_s: float | None = None,
                   ax: Axes | None = None) -> Axes:
    """Panel (b): distance along the path over time, the heading turned on a second axis, the mode
    as a band under the curves, a line per mode switch and the time limit.

    Parameters
    ----------
    steps
        The trial's steps (as :func:`path_panel`).
    waypoints
        ``(W, 2)`` the path.
    time_limit_s
        The trial's time limit (a line), or ``None``.
    ax
        Axes to draw on (the heading's axis is its twin); default a new figure's.

    Returns
    -------
    Axes
        ``ax`` (the progress axis).
    """
    trial, progress_ax = _trial(steps), axes_or_new(ax, PATH_PANEL_FIGSIZE)
    waypoints = np.asarray(waypoints, dtype=float).reshape(-1, 2)
    t, modes = trial.t, trial.modes
    along = path_progress(trial.x, trial.y, waypoints)
    progress_ax.plot(t, along, color=HUMAN_COLOUR, linewidth=1.3, label="along the path")
    progress_ax.set_xlabel("time (s)")
    progress_ax.set_ylabel("distance along the path (units)")
    total = float(np.linalg.norm(np.diff(waypoints, axis=0), axis=1).sum())
    progress_ax.set_ylim(-0.12 * total, 1.05 * total)
    turn_ax = progress_ax.twinx()
    turn_ax.plot(t, np.degrees(trial.turned), color=_MODE_COLOURS["theta"], linewidth=1.1, linestyle="--",
                 label="heading turned")
    turn_ax.set_ylim(-0.12 * 90, 1.05 * 90)
    turn_ax.set_ylabel("heading turned (deg)")
    # the mode as a band under the curves
    band = -0.07 * total
    for mode, colour in _MODE_COLOURS.items():
        mask = modes == mode
        if mask.any():
            progress_ax.scatter(t[mask], np.full(mask.sum(), band), marker="|", s=14, color=colour,
                                linewidths=1.0)
    for k in np.flatnonzero(trial.switches):
        progress_ax.axvline(t[k], color="#BBBBBB", linewidth=0.6, zorder=0)
    if time_limit_s is not None:
        progress_ax.axvline(time_limit_s, color="#D55E00", linewidth=1.0, linestyle="-.")
    return progress_ax


def path_trajectory_figure(steps: pd.DataFrame, waypoints: np.ndarray, turn_waypoint: int,
                           goal_pose: np.ndarray, *, time_limit_s: float | None = None,
                           title: str | None = None) -> Figure:
    """One trial of the path world (see the module docstring): :func:`path_panel` beside
    :func:`progress_panel`, with the legend.

    Parameters
    ----------
    steps
        The trial's steps: ``step``, ``t``, ``x``, ``y``, ``theta``, ``mode``, ``event``.
    waypoints
        ``(W, 2)`` the path.
    turn_waypoint
        Index of the turn waypoint.
    goal_pose
        ``(3,)`` the goal pose.
    time_limit_s
        The trial's time limit (a line in panel b), or ``None``.
    title
        Optional title.
    """
    _trial(steps)  # a DataError before any drawing
    with figure_style():
        fig = Figure(figsize=PATH_TRAJECTORY_FIGSIZE, layout="constrained")
        ax, progress_ax = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.1, 1.0]})
        path_panel(steps, waypoints, turn_waypoint, goal_pose, ax=ax)
        panel_letter(ax, 0)
        progress_panel(steps, waypoints, time_limit_s=time_limit_s, ax=progress_ax)
        panel_letter(progress_ax, 1)
        handles: list[Any] = [
            Line2D([], [], color=HUMAN_COLOUR, linewidth=1.3, label="Robot (along the path)"),
            Line2D([], [], color=_MODE_COLOURS["theta"], linestyle="--", label="Heading turned"),
            Line2D([], [], marker="o", markersize=8, markerfacecolor="none", markeredgecolor="black",
                   linestyle="none", label="Turn waypoint"),
            Line2D([], [], marker="o", markersize=8, color=goal_style(0, 0)[0], markeredgecolor="black",
                   linestyle="none", label="Goal (tick: heading)"),
            Line2D([], [], marker="*", markersize=10, color="black", linestyle="none", label="Start"),
            Line2D([], [], marker="X", markersize=7, color="black", linestyle="none", label="End"),
        ]
        handles += [Line2D([], [], marker=_MODE_MARKERS[m], markersize=6, markerfacecolor=c,
                           markeredgecolor="black", linestyle="none", label=f"Mode {m} (switch / band)")
                    for m, c in _MODE_COLOURS.items()]
        if time_limit_s is not None:
            handles.append(Line2D([], [], color="#D55E00", linestyle="-.", label="Time limit"))
        fig.legend(handles=handles, loc="outside lower center", ncols=4)
        if title:
            fig.suptitle(title, x=0.01, ha="left")
    return fig


def measures_figure(metrics: pd.DataFrame, stats: Mapping[str, Any] | None = None, *,
                    metric_names: Sequence[str] | None = None, seed: int = 0) -> Figure:
    """Box plots of the teleoperation measures present in ``metrics`` (one panel each).

    Parameters
    ----------
    metrics
        One row per trial with ``condition`` and metric columns.
    stats
        ``stats.json`` (brackets where tests exist), or ``None``.
    metric_names
        The measures to draw; default those of :data:`MEASURE_SPECS` the table holds.
    seed
        Jitter seed.
    """
    names = [m for m in (metric_names or MEASURE_SPECS) if m in metrics.columns]
    if not names:
        raise DataError("metrics table: none of the measures " + ", ".join(MEASURE_SPECS) + " to draw")
    order = list(dict.fromkeys(metrics["condition"].astype(str)))
    with figure_style():
        engine = ConstrainedLayoutEngine(w_pad=0.04, h_pad=0.03, wspace=0.06)
        fig = Figure(figsize=METRIC_FIGSIZE, layout=engine)
        axes = np.atleast_1d(fig.subplots(1, len(names)))
        for i, (ax, metric) in enumerate(zip(axes, names, strict=True)):
            spec = MEASURE_SPECS.get(metric)
            scaled = metrics
            if spec is not None and spec.scale != 1.0:
                values = pd.to_numeric(metrics[metric], errors="coerce") * spec.scale
                scaled = metrics.assign(**{metric: values})
            metric_boxplot(scaled, metric, stats_by_metric(stats).get(metric), ax=ax, conditions=order,
                           seed=seed, label=spec.label if spec is not None else None)
            panel_letter(ax, i)
        if "success" in metrics.columns:
            rates = metrics.groupby(metrics["condition"].astype(str), sort=False)["success"].apply(
                lambda s: pd.to_numeric(s.astype("Float64"), errors="coerce").mean())
            left_out = not_applicable_of(stats_by_metric(stats).get("success"))  # e.g. an inferred-goal
            fig.suptitle("Success rate: " + ", ".join(  # success in a condition without inference
                f"{c} {'n/a' if c in left_out else f'{rates[c]:.0%}'}" for c in order if c in rates),
                x=0.01, ha="left")
    return fig
