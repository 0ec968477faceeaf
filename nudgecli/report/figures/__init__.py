"""The paper's figures, drawn from tidy tables: one module per figure family.

- :mod:`~nudgecli.report.figures.boxplots`: per-trial metrics (Fig. 3, Fig. 4, any metric table);
- :mod:`~nudgecli.report.figures.beliefs`: the goal probabilities of one trial (Fig. 5);
- :mod:`~nudgecli.report.figures.trajectories`: one trial's path through the workspace;
- :mod:`~nudgecli.report.figures.questionnaires`: NASA-TLX and Likert (Fig. 6);
- :mod:`~nudgecli.report.figures.replication`: replications, power curves, sweeps, sensitivity;
- :mod:`~nudgecli.report.figures.output`: writing them.

Every drawing function takes ``ax=None`` so figures compose. Which trial Fig. 5 shows is chosen
in :mod:`nudgecli.report.trial_selection`; reading a run and writing every figure is
:mod:`nudgecli.report.plotting`. Figures are :class:`~matplotlib.figure.Figure` objects (no
``pyplot``, no GUI backend) drawn inside :func:`nudgecli.report.style.figure_style`, sized for
print (a full-width figure is 7.2 in wide) with no font below 8 pt at that size.
"""

from __future__ import annotations

import pandas as pd
from matplotlib.figure import Figure

from nudgecli.report.figures.beliefs import FIGURE5_FIGSIZE, BeliefTraceArtists, belief_trace
from nudgecli.report.figures.boxplots import (
    FIGURE3_METRICS,
    FIGURE4_METRICS,
    METRIC_SPECS,
    BoxplotArtists,
    MetricSpec,
    figure_3,
    figure_4,
    metric_boxplot,
    metrics_figure,
)
from nudgecli.report.figures.common import TrialLayout, resolve_conditions, stats_by_metric
from nudgecli.report.figures.output import SUPPORTED_FORMATS, check_formats, save_figure, save_figures
from nudgecli.report.figures.questionnaires import (
    group_label,
    questionnaire_bars,
    questionnaire_figure,
    split_questionnaire_scores,
)
from nudgecli.report.figures.trajectories import TRAJECTORY_FIGSIZE, TrajectoryArtists, trajectory


def figure_5(steps: pd.DataFrame, true_goal: int, n_goals: int | None = None, *,
             title: str | None = None) -> Figure:
    """Fig. 5 as a figure of its own: :func:`~nudgecli.report.figures.beliefs.belief_trace` on new axes."""
    ax = belief_trace(steps, true_goal, n_goals, title=title).ax
    return _figure_of(ax)


def trajectory_figure(steps: pd.DataFrame, layout: TrialLayout, *, title: str | None = None) -> Figure:
    """The trajectory as a figure of its own: :func:`~nudgecli.report.figures.trajectories.trajectory`."""
    return _figure_of(trajectory(steps, layout, title=title).ax)


def _figure_of(ax: object) -> Figure:
    fig = getattr(ax, "figure", None)
    if not isinstance(fig, Figure):
        raise TypeError("the axes belong to no figure")
    return fig


__all__ = [
    "FIGURE3_METRICS",
    "FIGURE4_METRICS",
    "FIGURE5_FIGSIZE",
    "METRIC_SPECS",
    "SUPPORTED_FORMATS",
    "TRAJECTORY_FIGSIZE",
    "BeliefTraceArtists",
    "BoxplotArtists",
    "MetricSpec",
    "TrajectoryArtists",
    "TrialLayout",
    "belief_trace",
    "check_formats",
    "figure_3",
    "figure_4",
    "figure_5",
    "group_label",
    "metric_boxplot",
    "metrics_figure",
    "questionnaire_bars",
    "questionnaire_figure",
    "resolve_conditions",
    "save_figure",
    "save_figures",
    "split_questionnaire_scores",
    "stats_by_metric",
    "trajectory",
    "trajectory_figure",
]
