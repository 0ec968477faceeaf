"""The paper's Fig. 5: the goal probabilities of one trial over time, turns shaded, nudges marked."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from nudgecli.errors import DataError
from nudgecli.report.figures.common import axes_or_new
from nudgecli.report.style import FULL_WIDTH_IN, HUMAN_TURN_SHADE, figure_style, goal_style
from nudgecli.report.trial_steps import belief_matrix, require_columns, runs, sorted_steps
from nudgecli.steplog import HUMAN_TURN, NUDGE, has_event

FIGURE5_FIGSIZE = (FULL_WIDTH_IN, 2.6)


@dataclass
class BeliefTraceArtists:
    """What :func:`belief_trace` drew.

    Attributes
    ----------
    ax
        The axes.
    lines
        One line per goal, by goal index (``get_color()``, ``get_label()``).
    human_spans
        The shaded human turns.
    nudges
        One vertical line per nudge.
    handles
        Legend handles (goals, turn shading, nudge).
    """

    ax: Axes
    lines: list[Line2D] = field(default_factory=list)
    human_spans: list[Any] = field(default_factory=list)
    nudges: list[Line2D] = field(default_factory=list)
    handles: list[Any] = field(default_factory=list)


def turn_spans(t: np.ndarray, turns: np.ndarray) -> list[tuple[str, float, float]]:
    """``(turn, start time, end time)`` of each turn; a turn ends where the next begins.

    Parameters
    ----------
    t
        ``(T,)`` step times (s), increasing.
    turns
        ``(T,)`` turn of each step.
    """
    if t.size == 0:
        return []
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.1
    spans = []
    turn_runs = runs(turns)
    for k, (turn, first, last) in enumerate(turn_runs):
        end = float(t[turn_runs[k + 1][1]]) if k + 1 < len(turn_runs) else float(t[last]) + dt
        spans.append((str(turn), float(t[first]), end))
    return spans


def belief_trace(steps: pd.DataFrame, true_goal: int, n_goals: int | None = None, *, ax: Axes | None = None,
                 title: str | None = None, legend: bool = True) -> BeliefTraceArtists:
    """The goal probabilities of one trial over time (the paper's Fig. 5).

    The true goal is the red solid line, the other goals have their own colours and line styles
    (distinguishable in grayscale, see :func:`nudgecli.report.style.goal_style`). Human turns are
    shaded gray, autonomy turns are left white; each ``nudge`` event (the autonomy starting to
    move the robot to the disambiguating state s*) is a vertical black line.

    Parameters
    ----------
    steps
        The 10 Hz steps of one trial: ``t``, ``turn``, ``belief``, ``event`` (and ``step``).
    true_goal
        The trial's true goal index (the trials table's ``true_goal``).
    n_goals
        The trial's number of goals; default the length of the beliefs.
    ax
        Axes to draw on; default a new 7.2 x 2.6 in figure's.
    title
        Optional title (e.g. which trial this is).
    legend
        Add the legend to the right of the figure.

    Returns
    -------
    BeliefTraceArtists
        Probability (0-1) against time (s).
    """
    require_columns(steps, ["t", "turn", "belief"], "steps table")
    if steps.empty:
        raise DataError("steps table: the trial has no steps")
    steps = sorted_steps(steps)
    t = steps["t"].to_numpy(dtype=float)
    belief = belief_matrix(steps, n_goals)
    if not 0 <= true_goal < belief.shape[1]:
        raise DataError(f"true goal {true_goal} is not one of the trial's {belief.shape[1]} goals; "
                        "check the trials table's `true_goal`")
    turns = steps["turn"].astype(str).to_numpy()
    nudge_times = t[has_event(steps["event"], NUDGE)] if "event" in steps.columns else np.empty(0)
    ax = axes_or_new(ax, FIGURE5_FIGSIZE)
    out = BeliefTraceArtists(ax=ax)
    with figure_style():
        spans = turn_spans(t, turns)
        for turn, start, end in spans:
            if turn == HUMAN_TURN:
                out.human_spans.append(ax.axvspan(start, end, color=HUMAN_TURN_SHADE, linewidth=0, zorder=0))
        for g in range(belief.shape[1]):
            true = g == true_goal
            colour, style = goal_style(g, true_goal)
            (line,) = ax.plot(t, belief[:, g], color=colour, linestyle=style, linewidth=2.0 if true else 1.4,
                              zorder=3 if true else 2, label=f"Goal {g} (true)" if true else f"Goal {g}",
                              clip_on=False)
            out.lines.append(line)
        for x in nudge_times:
            out.nudges.append(ax.axvline(x, color="black", linewidth=1.1, zorder=4))
        out.handles = [*out.lines,
                       Patch(facecolor=HUMAN_TURN_SHADE, edgecolor="none", label="Human turn"),
                       Patch(facecolor="white", edgecolor="#808080", linewidth=0.6, label="Autonomy turn")]
        if nudge_times.size:
            out.handles.append(Line2D([], [], color="black", linewidth=1.1, label="Nudge (to s*)"))
        ax.set_xlim(float(t[0]), spans[-1][2])
        ax.set_ylim(0.0, 1.0)
        ax.set_yticks(np.linspace(0.0, 1.0, 6))
        ax.set_xlabel("Time (s)")
        ax.set_ylabel("Goal probability")
        if title:
            ax.set_title(title, loc="left")
        figure = ax.get_figure()
        if legend and figure is not None:
            figure.legend(handles=out.handles, loc="outside right center")
    return out


__all__ = ["FIGURE5_FIGSIZE", "BeliefTraceArtists", "belief_trace", "turn_spans"]
