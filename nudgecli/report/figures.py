"""The paper's figures, drawn from tidy tables: data in, :class:`matplotlib.figure.Figure` out.

- :func:`figure_3` / :func:`figure_4`: box plots of the per-trial metrics, every trial a dot,
  significance brackets from our own Kruskal-Wallis / Conover p-values (``stats.json``).
- :func:`figure_5`: the goal probabilities of one trial over time, turns shaded, nudges marked;
  :func:`choose_figure5_trial` picks the trial the paper would show.
- :func:`trajectory_figure`: one trial's path in the workspace (who drove, mode switches, goals).
- :func:`questionnaire_figure`: NASA-TLX and Likert items, mean with SD per condition.
- :func:`plot_run` writes all of them; :func:`save_figure` writes one figure atomically.

Figures are built on :class:`~matplotlib.figure.Figure` objects (no ``pyplot``, no GUI backend)
inside :func:`nudgecli.report.style.figure_style`, so nothing leaks into global ``rcParams``.
They are sized for print (a full-width figure is 7.2 in wide) with no font below 8 pt at
that size. Conditions are drawn in a stable order: an explicit ``conditions`` argument, else
``stats["conditions"]``, else Disambiguation, Control, then any others alphabetically.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import textwrap
import zlib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.collections import PathCollection
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.layout_engine import ConstrainedLayoutEngine
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import MaxNLocator

from nudgecli.errors import ConfigError, DataError
from nudgecli.model import world
from nudgecli.report.brackets import Bracket, brackets_from_stats, draw_brackets
from nudgecli.report.style import (
    AUTONOMY_COLOUR,
    FULL_WIDTH_IN,
    HUMAN_COLOUR,
    HUMAN_TURN_SHADE,
    PANEL_LETTER_PT,
    TICK_FONT_PT,
    condition_colours,
    condition_display_name,
    condition_hatches,
    figure_style,
    goal_colour,
    goal_linestyle,
)
from nudgecli.steplog import (
    AUTONOMY_TURN,
    HUMAN_TURN,
    MODE_SWITCH_AUTONOMY,
    MODE_SWITCH_HUMAN,
    NUDGE,
    event_tokens,
    has_event,
)

TrialKey = tuple[int, int]
"""A trial's identity: ``(participant, trial)``."""

SUPPORTED_FORMATS = ("png", "pdf", "svg")
PNG_DPI = 300
METRIC_FIGSIZE = (FULL_WIDTH_IN, 2.6)
FIGURE5_FIGSIZE = (FULL_WIDTH_IN, 2.6)
TRAJECTORY_FIGSIZE = (FULL_WIDTH_IN, 4.3)

#: Jitter half-width of the trial dots, in units of the box spacing.
JITTER_HALF_WIDTH = 0.17
BOX_WIDTH = 0.55


@dataclass(frozen=True)
class MetricSpec:
    """How one metric column is shown.

    Attributes
    ----------
    column
        Column of the metrics table.
    label
        y-axis label, with its unit.
    scale
        Factor from the stored value to the shown value (fractions shown as percent: 100).
    integer
        A count: y ticks only at whole numbers.
    """

    column: str
    label: str
    scale: float = 1.0
    integer: bool = False


METRIC_SPECS: dict[str, MetricSpec] = {
    "assistance_engagement": MetricSpec("assistance_engagement", "Assistance engagement (% of human turn)",
                                        100.0),
    "assistance_strength": MetricSpec("assistance_strength", "Strength of assistance (mean α)"),
    "human_turns": MetricSpec("human_turns", "Human turns per trial", integer=True),
    "mode_switches": MetricSpec("mode_switches", "Mode switches per trial", integer=True),
    "human_effort": MetricSpec("human_effort", "Human effort (fraction of trial time)"),
    "completion_time": MetricSpec("completion_time", "Completion time (s)"),
}
FIGURE3_METRICS = ("assistance_engagement", "assistance_strength", "human_turns")
FIGURE4_METRICS = ("mode_switches", "human_effort", "completion_time")

#: Known NASA-TLX scale names (column or ``scale`` values, without a ``tlx_`` prefix) and how
#: they are shown; ``tlx_raw`` and ``tlx_weighted`` are the scores of
#: :func:`nudgecli.report.questionnaires.questionnaire_scores`.
TLX_SCALE_NAMES: dict[str, str] = {
    "raw_tlx": "Raw TLX",
    "weighted_tlx": "Weighted TLX",
    "raw": "Raw TLX",
    "weighted": "Weighted TLX",
    "mental": "Mental",
    "physical": "Physical",
    "temporal": "Temporal",
    "performance": "Performance",
    "effort": "Effort",
    "frustration": "Frustration",
}
#: The study's Likert statements (notes section 7), short forms for the axis; looked up
#: case-insensitively and without a ``likert_`` prefix.
LIKERT_ITEM_LABELS: dict[str, str] = {
    "Q3": "Q3: figured out my goal more easily",
    "Q4": "Q4: helped me move towards the goal",
    "Q7": "Q7: helped me complete the task efficiently",
    "Q10": "Q10: helped reduce unwanted mode switches",
}
_ID_COLUMNS = {"participant", "condition", "block", "trial", "id", "subject"}


# --- helpers ---------------------------------------------------------------------------------


def _require_columns(df: pd.DataFrame, columns: Iterable[str], what: str) -> None:
    missing = [c for c in columns if c not in df.columns]
    if missing:
        raise DataError(
            f"{what}: missing column(s) {', '.join(missing)} (has: {', '.join(map(str, df.columns))}); "
            "produce it with `nudge analyze` or add the columns"
        )


def resolve_conditions(metrics: pd.DataFrame | None = None, stats: Mapping[str, Any] | None = None,
                       conditions: Sequence[str] | None = None) -> list[str]:
    """The conditions to draw, in a stable order.

    Parameters
    ----------
    metrics
        A table with a ``condition`` column (its conditions are used when nothing else says).
    stats
        A ``stats.json`` dict; its ``"conditions"`` list fixes the order.
    conditions
        An explicit order, which wins.

    Returns
    -------
    list[str]
        Explicit order, else the stats' order (plus any condition only in ``metrics``, sorted),
        else Disambiguation, Control, then the others alphabetically.
    """
    if conditions is not None:
        return [str(c) for c in conditions]
    present = [] if metrics is None else [str(c) for c in pd.unique(metrics["condition"].dropna())]
    if stats and stats.get("conditions"):
        order = [str(c) for c in stats["conditions"]]
        return order + sorted(c for c in present if c not in order)
    preferred = {"disambiguation": 0, "control": 1}
    return sorted(present, key=lambda c: (preferred.get(c.lower(), 2), c.lower(), c))


def stats_entry_for(stats: Mapping[str, Any] | None, metric: str) -> Mapping[str, Any] | None:
    """The ``stats["metrics"]`` element of ``metric`` (``None`` if absent)."""
    if not stats:
        return None
    for entry in stats.get("metrics") or []:
        if entry.get("metric") == metric:
            return entry
    return None


def wrap_label(label: str, width: int = 26) -> str:
    """Break a long axis label into lines, preferring a break before its parenthesised unit."""
    if len(label) <= width:
        return label
    head, sep, unit = label.partition(" (")
    if sep and len(head) <= width and len(unit) + 1 <= width:
        return f"{head}\n({unit}"
    return "\n".join(textwrap.wrap(label, width))


def _jitter(seed: int, key: str, n: int) -> np.ndarray:
    """Deterministic uniform jitter in ``[-JITTER_HALF_WIDTH, JITTER_HALF_WIDTH]`` for one group."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), zlib.crc32(key.encode("utf-8"))]))
    return rng.uniform(-JITTER_HALF_WIDTH, JITTER_HALF_WIDTH, size=n)


def _panel_letter(ax: Axes, index: int) -> None:
    ax.set_title(f"({chr(ord('a') + index)})", loc="left", fontweight="bold", fontsize=PANEL_LETTER_PT)


def _runs(labels: np.ndarray) -> list[tuple[Any, int, int]]:
    """Maximal runs of equal labels: ``(label, first index, last index)``."""
    runs: list[tuple[Any, int, int]] = []
    start = 0
    for i in range(1, len(labels) + 1):
        if i == len(labels) or labels[i] != labels[start]:
            runs.append((labels[start], start, i - 1))
            start = i
    return runs


def _sorted_steps(steps: pd.DataFrame) -> pd.DataFrame:
    if "step" in steps.columns:
        return steps.sort_values("step", kind="stable").reset_index(drop=True)
    return steps.sort_values("t", kind="stable").reset_index(drop=True)


def _as_vector(value: Any) -> np.ndarray:
    if isinstance(value, str):
        value = json.loads(value) if value.strip() else []
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return np.empty(0)
    return np.asarray(value, dtype=float).ravel()


def belief_matrix(steps: pd.DataFrame, n_goals: int | None = None) -> np.ndarray:
    """The goal beliefs of a trial's steps as one array.

    Parameters
    ----------
    steps
        Steps of one trial, in order, with a ``belief`` column of per-row sequences (lists,
        arrays or JSON strings).
    n_goals
        Expected number of goals; default the longest belief.

    Returns
    -------
    np.ndarray
        ``(T, G)``; rows with no belief are NaN.

    Raises
    ------
    DataError
        A belief has another length than ``n_goals``.
    """
    _require_columns(steps, ["belief"], "steps table")
    rows = [_as_vector(v) for v in steps["belief"]]
    lengths = {r.size for r in rows if r.size}
    if n_goals is None:
        n_goals = max(lengths) if lengths else 0
    bad = sorted(n for n in lengths if n != n_goals)
    if bad:
        raise DataError(f"steps table: belief vectors of length {bad[0]} but the trial has {n_goals} goals; "
                        "pass the trial's own layout")
    out = np.full((len(rows), n_goals), np.nan)
    for i, r in enumerate(rows):
        if r.size:
            out[i] = r
    return out


def _goal_count(layout_or_goal_count: Any) -> int | None:
    if layout_or_goal_count is None:
        return None
    if isinstance(layout_or_goal_count, (int, np.integer)):
        return int(layout_or_goal_count)
    goal_poses, _ = layout_poses(layout_or_goal_count)
    return int(goal_poses.shape[0])


def layout_poses(layout: Any) -> tuple[np.ndarray, np.ndarray | None]:
    """Goal poses ``(G, 3)`` and start pose ``(3,)`` (or ``None``) of a layout-like object.

    Accepted: a :class:`nudgecli.model.world.Layout` (or anything with ``goal_poses`` and
    ``start_pose`` attributes), a mapping with keys ``goal_poses``/``goals`` and
    ``start_pose``/``start``, a ``(goal_poses, start_pose)`` tuple, or a ``(G, 3)`` array.
    """
    if hasattr(layout, "goal_poses"):
        goals, start = layout.goal_poses, getattr(layout, "start_pose", None)
    elif isinstance(layout, Mapping):
        goals = layout.get("goal_poses", layout.get("goals"))
        start = layout.get("start_pose", layout.get("start"))
    elif isinstance(layout, tuple) and len(layout) == 2:
        goals, start = layout
    else:
        goals, start = layout, None
    if goals is None:
        raise DataError("layout: no goal poses (expected `goal_poses` or `goals`)")
    goals_arr = np.asarray([_as_vector(g) for g in goals] if isinstance(goals, (list, tuple)) else goals,
                           dtype=float)
    goals_arr = np.atleast_2d(goals_arr)
    if goals_arr.ndim != 2 or goals_arr.shape[1] != 3:
        raise DataError(f"layout: goal poses must have shape (G, 3), got {goals_arr.shape}")
    start_arr = None if start is None else _as_vector(start)
    if start_arr is not None and start_arr.shape != (3,):
        raise DataError(f"layout: start pose must have shape (3,), got {start_arr.shape}")
    return goals_arr, start_arr


# --- box plots (Figures 3 and 4) ---------------------------------------------------------------


@dataclass
class BoxplotArtists:
    """What :func:`metric_boxplot` drew.

    Attributes
    ----------
    conditions
        The conditions, left to right.
    positions
        x position of each condition.
    points
        The trial dots of each condition (``get_offsets()`` gives their ``(x, y)``).
    brackets
        Significance bracket artists (lines and star texts).
    n
        Number of trials with a value, per condition.
    """

    conditions: list[str]
    positions: dict[str, float]
    points: dict[str, PathCollection] = field(default_factory=dict)
    brackets: list[Any] = field(default_factory=list)
    n: dict[str, int] = field(default_factory=dict)


def metric_boxplot(ax: Axes, metrics: pd.DataFrame, metric: str, stats_entry: Mapping[str, Any] | None = None,
                   *, conditions: Sequence[str] | None = None, seed: int = 0, show_points: bool = True,
                   show_n: bool = True, label: str | None = None) -> BoxplotArtists:
    """A box plot per condition with every trial as a jittered dot and significance brackets.

    Boxes show the median and quartiles, whiskers reach the furthest trial within 1.5 IQR of
    the box; no separate outlier markers are drawn because every trial is a dot. NaN values
    (e.g. strength of assistance in a trial without assistance) are left out and the number
    of trials drawn is printed under each condition.

    Parameters
    ----------
    ax
        Axes to draw on.
    metrics
        One row per trial with ``condition`` and the ``metric`` column.
    metric
        The metric column (a key of :data:`METRIC_SPECS` gets its label and unit scaling).
    stats_entry
        The metric's element of ``stats["metrics"]``; brackets are drawn for its significant
        comparisons only. ``None``: no brackets.
    conditions
        Conditions in drawing order; default :func:`resolve_conditions`.
    seed
        Seed of the horizontal jitter (the same seed gives the same dot positions).
    show_points
        Draw every trial as a dot.
    show_n
        Add ``n = ...`` under each condition name.
    label
        y-axis label; default from :data:`METRIC_SPECS`.

    Returns
    -------
    BoxplotArtists
        Positions, dots and brackets drawn.
    """
    _require_columns(metrics, ["condition", metric], "metrics table")
    spec = METRIC_SPECS.get(metric, MetricSpec(metric, metric.replace("_", " ").capitalize()))
    order = resolve_conditions(metrics, None, conditions)
    if len(order) == 0:
        raise DataError("metrics table: no conditions to plot")
    values = pd.to_numeric(metrics[metric], errors="coerce").astype(float) * spec.scale
    condition_col = metrics["condition"].astype(str)
    colours = condition_colours(order)
    positions = {c: float(i) for i, c in enumerate(order)}
    out = BoxplotArtists(conditions=list(order), positions=positions)

    data = []
    for c in order:
        v = values[condition_col == c].to_numpy()
        v = v[np.isfinite(v)]
        data.append(v)
        out.n[c] = int(v.size)
    drawable = [i for i, v in enumerate(data) if v.size]
    if drawable:
        bp = ax.boxplot([data[i] for i in drawable], positions=[positions[order[i]] for i in drawable],
                        widths=BOX_WIDTH, patch_artist=True, showfliers=False, whis=1.5,
                        medianprops={"color": "black", "linewidth": 1.8, "zorder": 4},
                        whiskerprops={"color": "black", "linewidth": 0.9},
                        capprops={"color": "black", "linewidth": 0.9},
                        boxprops={"edgecolor": "black", "linewidth": 0.9}, manage_ticks=False, zorder=2)
        for patch, i in zip(bp["boxes"], drawable, strict=True):
            patch.set_facecolor(to_rgba(colours[order[i]], 0.45))
    if show_points:
        for i, c in enumerate(order):
            v = data[i]
            if not v.size:
                continue
            x = positions[c] + _jitter(seed, c, v.size)
            out.points[c] = ax.scatter(x, v, s=6, color="black", alpha=0.5, linewidths=0, zorder=3,
                                       label=None)
    ax.set_xticks([positions[c] for c in order])
    names = [condition_display_name(c) for c in order]
    if len(order) <= 2:
        if show_n:
            names = [f"{name}\n(n = {out.n[c]})" for name, c in zip(names, order, strict=True)]
        ax.set_xticklabels(names)
    else:
        # Too narrow for horizontal names: rotate them, and keep the counts horizontal in a
        # row of their own just under the axis.
        ax.set_xticklabels(names, rotation=30, ha="right", rotation_mode="anchor")
        if show_n and len(order) <= 4:
            ax.tick_params(axis="x", pad=12)
            for c in order:
                ax.annotate(f"n={out.n[c]}", (positions[c], 0.0), xycoords=("data", "axes fraction"),
                            xytext=(0, -2), textcoords="offset points", ha="center", va="top",
                            fontsize=TICK_FONT_PT)
    ax.set_xlim(-0.6, len(order) - 0.4)
    ax.set_ylabel(wrap_label(label if label is not None else spec.label))
    if spec.integer:
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.tick_params(axis="x", length=0)
    ax.margins(y=0.05)
    ax.autoscale_view()
    out.brackets = draw_brackets(ax, positions, brackets_from_stats(stats_entry))
    return out


def _metric_figure(metrics: pd.DataFrame, stats: Mapping[str, Any] | None, metric_names: Sequence[str],
                   conditions: Sequence[str] | None, seed: int) -> Figure:
    order = resolve_conditions(metrics, stats, conditions)
    with figure_style():
        layout = ConstrainedLayoutEngine(w_pad=0.04, h_pad=0.03, wspace=0.06)
        fig = Figure(figsize=METRIC_FIGSIZE, layout=layout)
        axes = fig.subplots(1, len(metric_names))
        for i, (ax, metric) in enumerate(zip(np.atleast_1d(axes), metric_names, strict=True)):
            metric_boxplot(ax, metrics, metric, stats_entry_for(stats, metric), conditions=order, seed=seed)
            _panel_letter(ax, i)
    return fig


def figure_3(metrics: pd.DataFrame, stats: Mapping[str, Any] | None = None, *,
             conditions: Sequence[str] | None = None, seed: int = 0) -> Figure:
    """Fig. 3: (a) assistance engagement, (b) strength of assistance, (c) human turns.

    Parameters
    ----------
    metrics
        One row per trial (``condition`` and the three metric columns).
    stats
        ``stats.json`` dict; its significant Conover comparisons become brackets.
    conditions
        Drawing order of the conditions; default :func:`resolve_conditions`.
    seed
        Jitter seed.

    Returns
    -------
    Figure
        1 x 3 panels, 7.2 x 2.6 in.
    """
    return _metric_figure(metrics, stats, FIGURE3_METRICS, conditions, seed)


def figure_4(metrics: pd.DataFrame, stats: Mapping[str, Any] | None = None, *,
             conditions: Sequence[str] | None = None, seed: int = 0) -> Figure:
    """Fig. 4: (a) mode switches, (b) human effort, (c) completion time.

    Parameters are those of :func:`figure_3`.

    Returns
    -------
    Figure
        1 x 3 panels, 7.2 x 2.6 in.
    """
    return _metric_figure(metrics, stats, FIGURE4_METRICS, conditions, seed)


# --- Figure 5: goal probabilities of one trial -------------------------------------------------


def _turn_spans(t: np.ndarray, turns: np.ndarray) -> list[tuple[str, float, float]]:
    """``(turn, start time, end time)`` of each turn; a turn ends where the next begins."""
    if t.size == 0:
        return []
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.1
    spans = []
    runs = _runs(turns)
    for k, (turn, first, last) in enumerate(runs):
        end = float(t[runs[k + 1][1]]) if k + 1 < len(runs) else float(t[last]) + dt
        spans.append((str(turn), float(t[first]), end))
    return spans


def figure_5(steps: pd.DataFrame, layout_or_goal_count: Any = None, *, title: str | None = None,
             figsize: tuple[float, float] = FIGURE5_FIGSIZE) -> Figure:
    """Fig. 5: the goal probabilities of one trial over time.

    The true goal (goal 0) is the red solid line, the other goals have their own colours and
    line styles (distinguishable in grayscale). Human turns are shaded gray, autonomy turns
    are left white; each ``nudge`` event (the autonomy starting to move the robot to the
    disambiguating state s*) is a vertical black line.

    Parameters
    ----------
    steps
        The 10 Hz steps of one trial: ``t``, ``turn``, ``belief``, ``event`` (and ``step``).
    layout_or_goal_count
        The trial's layout (see :func:`layout_poses`) or its number of goals; default the
        length of the beliefs.
    title
        Optional title (e.g. which trial this is).
    figsize
        Figure size in inches.

    Returns
    -------
    Figure
        One panel: probability (0-1) against time (s), legend on the right.
    """
    _require_columns(steps, ["t", "turn", "belief"], "steps table")
    if steps.empty:
        raise DataError("steps table: the trial has no steps")
    steps = _sorted_steps(steps)
    t = steps["t"].to_numpy(dtype=float)
    belief = belief_matrix(steps, _goal_count(layout_or_goal_count))
    turns = steps["turn"].astype(str).to_numpy()
    nudges = t[has_event(steps["event"], NUDGE)] if "event" in steps.columns else np.empty(0)
    with figure_style():
        fig = Figure(figsize=figsize, layout="constrained")
        ax = fig.subplots()
        spans = _turn_spans(t, turns)
        for turn, start, end in spans:
            if turn == HUMAN_TURN:
                ax.axvspan(start, end, color=HUMAN_TURN_SHADE, linewidth=0, zorder=0)
        handles: list[Any] = []
        for g in range(belief.shape[1]):
            name = "Goal 0 (true)" if g == 0 else f"Goal {g}"
            (line,) = ax.plot(t, belief[:, g], color=goal_colour(g), linestyle=goal_linestyle(g),
                              linewidth=2.0 if g == 0 else 1.4, zorder=3 if g == 0 else 2, label=name,
                              clip_on=False)
            handles.append(line)
        for x in nudges:
            ax.axvline(x, color="black", linewidth=1.1, zorder=4)
        handles.append(Patch(facecolor=HUMAN_TURN_SHADE, edgecolor="none", label="Human turn"))
        handles.append(Patch(facecolor="white", edgecolor="#808080", linewidth=0.6, label="Autonomy turn"))
        if nudges.size:
            handles.append(Line2D([], [], color="black", linewidth=1.1, label="Nudge (to s*)"))
        ax.set_xlim(float(t[0]), spans[-1][2])
        ax.set_ylim(0.0, 1.0)
        ax.set_yticks(np.linspace(0.0, 1.0, 6))
        ax.set_xlabel("Time (s)")
        ax.set_ylabel("Goal probability")
        if title:
            ax.set_title(title, loc="left")
        fig.legend(handles=handles, loc="outside right center")
    return fig


def nudge_followup_changes(steps: pd.DataFrame, goal: int = 0) -> list[float]:
    """The change in a goal's belief over the human turn that follows each nudge.

    For each step whose event contains ``nudge``, take the first human turn that starts after
    it; the change is the goal's belief at the last step of that turn minus its belief at the
    step just before the turn began (the belief handed over by the autonomy). Nudges with no
    human turn after them (or no belief) contribute nothing.

    Parameters
    ----------
    steps
        Steps of one trial (``turn``, ``belief``, ``event``).
    goal
        Goal index (0 = the true goal).

    Returns
    -------
    list[float]
        One signed change per nudge that has a following human turn, in time order.
    """
    if steps.empty or "event" not in steps.columns:
        return []
    steps = _sorted_steps(steps)
    nudge_idx = np.flatnonzero(has_event(steps["event"], NUDGE))
    if nudge_idx.size == 0:
        return []
    p = belief_matrix(steps)
    if p.shape[1] <= goal:
        return []
    p = p[:, goal]
    human_runs = [(first, last) for turn, first, last in _runs(steps["turn"].astype(str).to_numpy())
                  if turn == HUMAN_TURN]
    changes = []
    for k in nudge_idx:
        following = next(((f, la) for f, la in human_runs if f > k), None)
        if following is None:
            continue
        first, last = following
        before = p[first - 1] if first > 0 else p[first]
        change = p[last] - before
        if np.isfinite(change):
            changes.append(float(change))
    return changes


def _trial_groups(steps_all: pd.DataFrame | Mapping[TrialKey, pd.DataFrame]) -> Iterable[tuple[TrialKey,
                                                                                                 pd.DataFrame]]:
    if isinstance(steps_all, Mapping):
        for key, df in steps_all.items():
            yield (int(key[0]), int(key[1])), df
        return
    _require_columns(steps_all, ["participant", "trial"], "steps table")
    for (p, tr), df in steps_all.groupby(["participant", "trial"], sort=True):
        yield (int(p), int(tr)), df


def choose_figure5_trial(steps_all: pd.DataFrame | Mapping[TrialKey, pd.DataFrame], trials: pd.DataFrame,
                         *, condition: str = "disambiguation") -> TrialKey:
    """The trial Fig. 5 shows by default.

    Definition: among the trials of ``condition`` (Disambiguation), the one whose true-goal
    belief rose most over a human turn that followed a nudge, i.e. the largest value of
    :func:`nudge_followup_changes` (goal 0) over the trial's nudges. When ``trials`` has a
    ``success`` column and any candidate succeeded, only successful trials are considered.
    Ties go to the smallest ``(participant, trial)``. If no trial of the condition has a nudge
    followed by a human turn, the same rule is applied to every human turn of those trials
    (change over the turn, no nudge required); if the condition has no trials with steps, the
    first trial with steps of any condition is returned.

    Parameters
    ----------
    steps_all
        All steps (``participant``, ``trial``, ``turn``, ``belief``, ``event``), or a mapping
        ``(participant, trial) -> steps of that trial``.
    trials
        One row per trial with ``participant``, ``trial``, ``condition`` (the trials table or
        the metrics table), optionally ``success``.
    condition
        Condition to choose from (case-insensitive).

    Returns
    -------
    tuple[int, int]
        ``(participant, trial)``.

    Raises
    ------
    DataError
        There are no steps at all.
    """
    _require_columns(trials, ["participant", "trial", "condition"], "trials table")
    cond_of = {(int(p), int(tr)): str(c) for p, tr, c in
               zip(trials["participant"], trials["trial"], trials["condition"], strict=True)}
    success_of: dict[TrialKey, bool] = {}
    if "success" in trials.columns:
        success_of = {(int(p), int(tr)): bool(s) for p, tr, s in
                      zip(trials["participant"], trials["trial"], trials["success"], strict=True)
                      if not pd.isna(s)}
    groups = dict(_trial_groups(steps_all))
    if not groups:
        raise DataError("steps table: no steps to choose a Fig. 5 trial from; simulate a run first")
    candidates = sorted(k for k in groups if cond_of.get(k, "").lower() == condition.lower())
    if not candidates:
        return min(groups)
    if success_of and any(success_of.get(k, False) for k in candidates):
        candidates = [k for k in candidates if success_of.get(k, False)]

    best: tuple[float, TrialKey] | None = None
    for key in candidates:
        changes = nudge_followup_changes(groups[key])
        if changes and (best is None or max(changes) > best[0]):
            best = (max(changes), key)
    if best is not None:
        return best[1]
    for key in candidates:
        df = _sorted_steps(groups[key])
        p = belief_matrix(df)
        if p.shape[1] == 0:
            continue
        for turn, first, last in _runs(df["turn"].astype(str).to_numpy()):
            if turn != HUMAN_TURN:
                continue
            change = p[last, 0] - (p[first - 1, 0] if first > 0 else p[first, 0])
            if np.isfinite(change) and (best is None or change > best[0]):
                best = (float(change), key)
    return best[1] if best is not None else candidates[0]


# --- trajectory --------------------------------------------------------------------------------

_MODE_MARKERS = {"x": ">", "y": "^", "theta": "o"}
_MODE_NAMES = {"x": "x (Horizontal)", "y": "y (Vertical)", "theta": "θ (Rotational)"}


def trajectory_figure(steps: pd.DataFrame, goal_poses: np.ndarray, start_pose: np.ndarray | None = None, *,
                      title: str | None = None, figsize: tuple[float, float] = TRAJECTORY_FIGSIZE) -> Figure:
    """One trial's path through the workspace.

    The workspace ``[3, 45] x [2, 36]`` with its 10 x 10 grid of cells (4.2 x 3.4); the goals
    as discs with a tick in their heading (goal 0, the true goal, red, labelled); the path in
    black and solid where the human drove and gray and dashed where the autonomy drove; a
    marker at each mode change whose shape is the new mode (filled: switched by the human,
    open: by the autonomy); diamonds at nudges; the start (star) and the end (cross).

    Parameters
    ----------
    steps
        The 10 Hz steps of one trial: ``x``, ``y``, ``turn``, ``mode`` (and ``event``, ``step``).
    goal_poses
        ``(G, 3)`` goal poses ``(x, y, theta)``; goal 0 is the true goal.
    start_pose
        ``(3,)`` start pose; default the first step's pose.
    title
        Optional title.
    figsize
        Figure size in inches.

    Returns
    -------
    Figure
        One equal-aspect panel with the legend on the right.
    """
    _require_columns(steps, ["x", "y", "turn"], "steps table")
    if steps.empty:
        raise DataError("steps table: the trial has no steps")
    steps = _sorted_steps(steps)
    goal_poses = np.atleast_2d(np.asarray(goal_poses, dtype=float))
    if goal_poses.ndim != 2 or goal_poses.shape[1] != 3:
        raise DataError(f"layout: goal poses must have shape (G, 3), got {goal_poses.shape}")
    x = steps["x"].to_numpy(dtype=float)
    y = steps["y"].to_numpy(dtype=float)
    theta = steps["theta"].to_numpy(dtype=float) if "theta" in steps.columns else np.zeros_like(x)
    if start_pose is None:
        start_pose = np.array([x[0], y[0], theta[0]])
    start_pose = np.asarray(start_pose, dtype=float)
    turns = steps["turn"].astype(str).to_numpy()
    events = steps["event"] if "event" in steps.columns else pd.Series([""] * len(steps))
    tick_len = 0.55 * world.CELL_HEIGHT

    with figure_style():
        fig = Figure(figsize=figsize, layout="constrained")
        ax = fig.subplots()
        for gx in np.arange(world.N_CELLS_X + 1) * world.CELL_WIDTH + world.X_MIN:
            ax.axvline(gx, color="#D0D0D0", linewidth=0.5, zorder=0)
        for gy in np.arange(world.N_CELLS_Y + 1) * world.CELL_HEIGHT + world.Y_MIN:
            ax.axhline(gy, color="#D0D0D0", linewidth=0.5, zorder=0)

        # Goals: disc, heading tick, label.
        for g, (gx, gy, gth) in enumerate(goal_poses):
            colour = goal_colour(g)
            ax.plot([gx, gx + tick_len * np.cos(gth)], [gy, gy + tick_len * np.sin(gth)], color=colour,
                    linewidth=2.0, solid_capstyle="butt", zorder=4)
            ax.plot([gx], [gy], marker="o", markersize=10, color=colour, markeredgecolor="black",
                    markeredgewidth=0.6, zorder=5, linestyle="none")
            ax.annotate(f"g{g}" + (" (true)" if g == 0 else ""), (gx, gy), xytext=(0, -9),
                        textcoords="offset points", ha="center", va="top", fontsize=8, color="black",
                        zorder=6)

        # Path, one segment per turn (each joined to the next turn's first point).
        for turn, first, last in _runs(turns):
            end = min(last + 1, len(x) - 1)
            human = turn == HUMAN_TURN
            ax.plot(x[first:end + 1], y[first:end + 1], color=HUMAN_COLOUR if human else AUTONOMY_COLOUR,
                    linestyle="-" if human else (0, (3, 1.5)), linewidth=1.6 if human else 1.8,
                    solid_capstyle="round", zorder=3)

        # Mode changes.
        if "mode" in steps.columns:
            modes = steps["mode"].astype(str).to_numpy()
            for k in range(1, len(modes)):
                if modes[k] == modes[k - 1]:
                    continue
                tokens = event_tokens(events.iloc[k])
                by_autonomy = MODE_SWITCH_AUTONOMY in tokens or (
                    MODE_SWITCH_HUMAN not in tokens and turns[k] == AUTONOMY_TURN)
                ax.plot([x[k]], [y[k]], marker=_MODE_MARKERS.get(modes[k], "s"), markersize=6,
                        markerfacecolor="white" if by_autonomy else "black", markeredgecolor="black",
                        markeredgewidth=0.9, linestyle="none", zorder=7)
        nudge = has_event(events, NUDGE)
        if nudge.any():
            # Under the mode-change markers: the autonomy often switches mode as it starts a nudge.
            ax.plot(x[nudge], y[nudge], marker="D", markersize=10, markerfacecolor=to_rgba("#CC79A7", 0.85),
                    markeredgecolor="black", markeredgewidth=0.6, linestyle="none", zorder=6)
        ax.plot([start_pose[0]], [start_pose[1]], marker="*", markersize=13, color="black",
                markeredgecolor="white", markeredgewidth=0.5, linestyle="none", zorder=9)
        ax.plot([x[-1]], [y[-1]], marker="X", markersize=8, color="black", markeredgecolor="white",
                markeredgewidth=0.5, linestyle="none", zorder=9)

        ax.set_xlim(world.X_MIN, world.X_MAX)
        ax.set_ylim(world.Y_MIN, world.Y_MAX)
        ax.set_aspect("equal")
        ax.set_xlabel("x (world units)")
        ax.set_ylabel("y (world units)")
        for spine in ("top", "right"):
            ax.spines[spine].set_visible(True)
        if title:
            ax.set_title(title, loc="left")

        # one swatch per goal, in the colours the discs (and Fig. 5's lines) use
        handles: list[Any] = [
            Line2D([], [], marker="o", markersize=8, color=goal_colour(g), markeredgecolor="black",
                   markeredgewidth=0.6, linestyle="none", label="g0 (true goal)" if g == 0 else f"g{g}")
            for g in range(len(goal_poses))
        ]
        handles += [
            Line2D([], [], marker="*", markersize=11, color="black", linestyle="none", label="Start"),
            Line2D([], [], marker="X", markersize=7, color="black", linestyle="none", label="End"),
            Line2D([], [], color=HUMAN_COLOUR, linewidth=1.6, label="Human drove"),
            Line2D([], [], color=AUTONOMY_COLOUR, linewidth=1.8, linestyle=(0, (3, 1.5)),
                   label="Autonomy drove"),
        ]
        for mode, marker in _MODE_MARKERS.items():
            handles.append(Line2D([], [], marker=marker, markersize=6, markerfacecolor="#B0B0B0",
                                  markeredgecolor="black", linestyle="none",
                                  label=f"Switch to {_MODE_NAMES[mode]}"))
        # squares: no mode uses them, so the fill key cannot be read as the theta marker
        for fill, who in (("black", "  filled: by human"), ("white", "  open: by autonomy")):
            handles.append(Line2D([], [], marker="s", markersize=6, markerfacecolor=fill,
                                  markeredgecolor="black", linestyle="none", label=who))
        if nudge.any():
            handles.append(Line2D([], [], marker="D", markersize=7, markerfacecolor="#CC79A7",
                                  markeredgecolor="black", markeredgewidth=0.6, linestyle="none",
                                  label="Nudge"))
        fig.legend(handles=handles, loc="outside right center")
    return fig


# --- questionnaires (Figure 6) -----------------------------------------------------------------


def _long_scores(df: pd.DataFrame, name_col: str, value_col: str, what: str) -> pd.DataFrame:
    """``condition, <name_col>, <value_col>`` rows from a long or a wide questionnaire table."""
    _require_columns(df, ["condition"], what)
    if name_col in df.columns and value_col in df.columns:
        out = df[["condition", name_col, value_col]].copy()
    else:
        value_cols = [c for c in df.columns if str(c).lower() not in _ID_COLUMNS
                      and pd.api.types.is_numeric_dtype(df[c])]
        if not value_cols:
            raise DataError(f"{what}: no score columns (expected `{name_col}` and `{value_col}` columns, "
                            "or one numeric column per scale/item)")
        out = df.melt(id_vars=["condition"], value_vars=value_cols, var_name=name_col, value_name=value_col)
    out[value_col] = pd.to_numeric(out[value_col], errors="coerce")
    out[name_col] = out[name_col].astype(str)
    out["condition"] = out["condition"].astype(str)
    return out.dropna(subset=[value_col])


def group_label(name: str, item_labels: Mapping[str, str] | None = None) -> str:
    """How a questionnaire scale or item is named on the axis.

    ``item_labels`` (exact name) wins; then the known TLX scales and Likert items (case-
    insensitive, without a ``tlx_``/``likert_`` prefix); otherwise the name without its prefix.
    """
    if item_labels and name in item_labels:
        return item_labels[name]
    key = name.lower()
    for prefix in ("tlx_", "likert_"):
        if key.startswith(prefix):
            key = key[len(prefix):]
            break
    if key in TLX_SCALE_NAMES:
        return TLX_SCALE_NAMES[key]
    likert = {k.lower(): v for k, v in LIKERT_ITEM_LABELS.items()}
    if key in likert:
        return likert[key]
    bare = name[len(name) - len(key):]
    return bare.replace("_", " ") if not bare.isupper() else bare


def split_questionnaire_scores(scores: pd.DataFrame) -> tuple[pd.DataFrame | None, pd.DataFrame | None]:
    """Split a questionnaire scores table into its TLX and its Likert part.

    Parameters
    ----------
    scores
        The table of :func:`nudgecli.report.questionnaires.questionnaire_scores`:
        ``participant, condition`` (``block``), ``tlx_*`` and ``likert_*`` columns.

    Returns
    -------
    tuple
        ``(tlx, likert)`` wide tables with the id columns, ``None`` for a part without columns.
    """
    _require_columns(scores, ["condition"], "questionnaire scores")
    ids = [c for c in scores.columns if str(c).lower() in _ID_COLUMNS]
    tlx = [c for c in scores.columns if str(c).lower().startswith("tlx_")]
    likert = [c for c in scores.columns if str(c).lower().startswith("likert_")]
    return (scores[ids + tlx] if tlx else None, scores[ids + likert] if likert else None)


def _stats_by_name(stats: Mapping[str, Any] | None) -> dict[str, Mapping[str, Any]] | None:
    """``name -> entry`` from a ``stats.json`` dict or an already keyed mapping."""
    if not stats:
        return None
    if "metrics" in stats and isinstance(stats["metrics"], list):
        return {str(e["metric"]): e for e in stats["metrics"] if "metric" in e}
    return dict(stats)


def _wrap_group_label(label: str, width: int = 13) -> str:
    """A group label on short lines; an item code (``Q3:``) gets a line of its own."""
    code, sep, text = label.partition(": ")
    if sep and len(code) <= 4:
        return code + "\n" + "\n".join(textwrap.wrap(text, width))
    return "\n".join(textwrap.wrap(label, width))


def _grouped_bars(ax: Axes, scores: pd.DataFrame, name_col: str, value_col: str, order: Sequence[str],
                  group_labels: Mapping[str, str], baseline: float,
                  stats: Mapping[str, Mapping[str, Any]] | None) -> list[Any]:
    """Bars of mean with SD error bars, one group per scale/item, one bar per condition."""
    groups = list(pd.unique(scores[name_col]))
    n_cond = len(order)
    width = 0.8 / n_cond
    colours, hatches = condition_colours(order), condition_hatches(order)
    summary = scores.groupby([name_col, "condition"])[value_col].agg(["mean", "std", "count"])
    artists: list[Any] = []
    tops: dict[str, float] = {}
    for j, c in enumerate(order):
        xs, means, sds = [], [], []
        for i, g in enumerate(groups):
            if (g, c) not in summary.index:
                continue
            row = summary.loc[(g, c)]
            xs.append(i + (j - (n_cond - 1) / 2) * width)
            means.append(float(row["mean"]))
            sds.append(float(row["std"]) if row["count"] > 1 else 0.0)
            tops[g] = max(tops.get(g, baseline), means[-1] + sds[-1])
        if not xs:
            continue
        bars = ax.bar(xs, np.asarray(means) - baseline, width=width * 0.92, bottom=baseline,
                      color=to_rgba(colours[c], 0.75), edgecolor="black", linewidth=0.7, hatch=hatches[c],
                      label=condition_display_name(c), zorder=2)
        ax.errorbar(xs, means, yerr=sds, fmt="none", ecolor="black", elinewidth=0.9, capsize=2.5,
                    capthick=0.9, zorder=3)
        artists.append(bars)
    ax.set_xticks(range(len(groups)))
    ax.set_xticklabels([group_labels.get(g, g) for g in groups])
    ax.tick_params(axis="x", length=0)
    ax.set_xlim(-0.5, len(groups) - 0.5)
    if stats:
        for i, g in enumerate(groups):
            positions = {c: i + (j - (n_cond - 1) / 2) * width for j, c in enumerate(order)}
            entry = stats.get(g)
            if entry:
                artists.extend(draw_brackets(ax, positions, brackets_from_stats(entry),
                                             data_top=tops.get(g)))
    return artists


def questionnaire_figure(tlx_df: pd.DataFrame | None = None, likert_df: pd.DataFrame | None = None, *,
                         conditions: Sequence[str] | None = None,
                         stats: Mapping[str, Any] | None = None,
                         item_labels: Mapping[str, str] | None = None) -> Figure:
    """Questionnaires: NASA-TLX and Likert items, mean with SD per condition (the paper's Fig. 6).

    Tables may be long (``participant, condition, scale, score`` for the TLX and
    ``participant, condition, item, response`` for Likert) or wide (one numeric column per
    TLX scale or Likert item beside ``participant`` and ``condition``). Bars are the mean,
    error bars one standard deviation (n - 1); conditions differ in colour and hatching.
    Likert responses on 1..7 are drawn from 1 (strongly disagree); responses on -3..+3 (the
    study software's coding) from 0 (neutral).

    Parameters
    ----------
    tlx_df
        NASA-TLX scores (0-100), e.g. ``raw_tlx`` per participant and condition.
    likert_df
        Likert responses per participant, condition and item.
    conditions
        Drawing order; default :func:`resolve_conditions` of the tables.
    stats
        Optional statistics of the scores: a ``stats.json`` dict whose metrics are named like
        the scales/items, or ``name -> stats entry``; significant comparisons get brackets.
    item_labels
        Axis labels of scales/items; defaults cover the study's TLX scales and Likert items
        (see :func:`group_label`).

    Returns
    -------
    Figure
        One panel per given table, full width.

    Raises
    ------
    DataError
        Neither table is given, or a table lacks ``condition`` or scores.
    """
    tables = []
    if tlx_df is not None:
        tables.append(("tlx", _long_scores(tlx_df, "scale", "score", "NASA-TLX table")))
    if likert_df is not None:
        tables.append(("likert", _long_scores(likert_df, "item", "response", "Likert table")))
    if not tables:
        raise DataError("questionnaires: give a NASA-TLX table, a Likert table or both")
    by_name = _stats_by_name(stats)
    all_conditions = pd.concat([df[["condition"]] for _, df in tables], ignore_index=True)
    order = resolve_conditions(all_conditions, None, conditions)
    names = pd.concat([df.iloc[:, 1] for _, df in tables], ignore_index=True).unique()
    wrapped = {str(n): _wrap_group_label(group_label(str(n), item_labels)) for n in names}

    widths = [max(2, df.iloc[:, 1].nunique()) for _, df in tables]
    with figure_style():
        fig = Figure(figsize=(FULL_WIDTH_IN, 3.0), layout="constrained")
        axes = np.atleast_1d(fig.subplots(1, len(tables), width_ratios=widths))
        for i, (ax, (kind, df)) in enumerate(zip(axes, tables, strict=True)):
            if kind == "tlx":
                _grouped_bars(ax, df, "scale", "score", order, wrapped, 0.0, by_name)
                ax.set_ylabel("NASA-TLX score (0-100)")
                ax.set_ylim(0.0, max(ax.get_ylim()[1], 100.0))
            else:
                coded = float(df["response"].min()) < 1.0
                baseline = 0.0 if coded else 1.0
                _grouped_bars(ax, df, "item", "response", order, wrapped, baseline, by_name)
                hi = ax.get_ylim()[1]
                ax.set_ylim(-3.0 if coded else 1.0, max(hi, 3.0 if coded else 7.0))
                ax.set_yticks(range(-3, 4) if coded else range(1, 8))
                if coded:
                    ax.axhline(0.0, color="black", linewidth=0.8)
                low, high = ("-3", "+3") if coded else ("1", "7")
                ax.set_ylabel(f"Rating ({low} = strongly disagree,\n{high} = strongly agree)")
            if len(tables) > 1:
                _panel_letter(ax, i)
        fig.legend(handles=[Patch(facecolor=to_rgba(condition_colours(order)[c], 0.75), edgecolor="black",
                                  hatch=condition_hatches(order)[c], label=condition_display_name(c))
                            for c in order], loc="outside upper center", ncols=len(order))
    return fig


# --- writing -------------------------------------------------------------------------------------

_METADATA: dict[str, dict[str, Any]] = {
    "png": {"Software": None},
    "pdf": {"CreationDate": None, "Producer": None},
    "svg": {"Date": None},
}


def save_figure(fig: Figure, out_dir: str | os.PathLike[str], stem: str,
                formats: Sequence[str] = ("png", "pdf"), *, dpi: int = PNG_DPI) -> list[Path]:
    """Write a figure in each format, atomically (temporary file in the folder, then rename).

    Parameters
    ----------
    fig
        The figure.
    out_dir
        Folder (created if missing).
    stem
        File name without suffix.
    formats
        Any of ``png``, ``pdf``, ``svg``.
    dpi
        Resolution of raster output.

    Returns
    -------
    list[Path]
        The written files, in the order of ``formats``.

    Raises
    ------
    ConfigError
        An unsupported format.
    """
    fmts = [f.strip().lower().lstrip(".") for f in formats]
    bad = [f for f in fmts if f not in SUPPORTED_FORMATS]
    if bad:
        raise ConfigError(f"figure format {bad[0]!r} is not supported; use one or more of "
                          f"{', '.join(SUPPORTED_FORMATS)} (e.g. --formats png,pdf)")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    with figure_style():
        for fmt in fmts:
            target = out / f"{stem}.{fmt}"
            fd, tmp_name = tempfile.mkstemp(dir=out, prefix=f".{stem}.", suffix=f".{fmt}.tmp")
            try:
                with os.fdopen(fd, "wb") as handle:
                    fig.savefig(handle, format=fmt, dpi=dpi, metadata=_METADATA[fmt])
                os.replace(tmp_name, target)
            except BaseException:
                Path(tmp_name).unlink(missing_ok=True)
                raise
            written.append(target)
    return written


def _lookup_steps(steps_by_trial: pd.DataFrame | Mapping[TrialKey, pd.DataFrame],
                  key: TrialKey) -> pd.DataFrame:
    if isinstance(steps_by_trial, Mapping):
        for k, df in steps_by_trial.items():
            if (int(k[0]), int(k[1])) == key:
                return df
        found = pd.DataFrame()
    else:
        mask = (steps_by_trial["participant"] == key[0]) & (steps_by_trial["trial"] == key[1])
        found = steps_by_trial[mask]
    if found.empty:
        raise DataError(f"no steps for participant {key[0]}, trial {key[1]}; pick a trial of the run "
                        "(--trial PARTICIPANT:TRIAL)")
    return found


def _has_steps(steps_by_trial: pd.DataFrame | Mapping[TrialKey, pd.DataFrame] | None) -> bool:
    if steps_by_trial is None:
        return False
    return len(steps_by_trial) > 0


def plot_run(metrics: pd.DataFrame, stats: Mapping[str, Any] | None,
             steps_by_trial: pd.DataFrame | Mapping[TrialKey, pd.DataFrame] | None,
             layouts: Mapping[TrialKey, Any] | None, out_dir: str | os.PathLike[str],
             formats: Sequence[str] = ("png", "pdf"), trial: TrialKey | None = None, *,
             trials: pd.DataFrame | None = None, questionnaires: pd.DataFrame | None = None,
             tlx: pd.DataFrame | None = None, likert: pd.DataFrame | None = None,
             questionnaire_stats: Mapping[str, Any] | None = None, seed: int = 0) -> list[Path]:
    """Draw and write every figure of a run.

    Writes ``fig3``, ``fig4`` always; ``fig5`` and ``trajectory`` when steps are given (the
    trajectory also needs the trial's layout); ``questionnaires`` when a TLX or Likert table is
    given (``questionnaires``, or ``tlx``/``likert``). Each in every format of ``formats``.

    Parameters
    ----------
    metrics
        One row per trial (``participant``, ``condition``, ``trial`` and the metric columns).
    stats
        ``stats.json`` dict (brackets; condition order), or ``None``.
    steps_by_trial
        All steps as one table, or ``(participant, trial) -> steps``; ``None`` (a metrics-only
        source) skips Fig. 5 and the trajectory.
    layouts
        ``(participant, trial) -> layout`` (see :func:`layout_poses`); ``None`` or a missing
        trial skips the trajectory (Fig. 5 then takes the goal count from the beliefs).
    out_dir
        Output folder (created if missing).
    formats
        File formats (``png``, ``pdf``, ``svg``).
    trial
        ``(participant, trial)`` for Fig. 5 and the trajectory; default
        :func:`choose_figure5_trial`.
    trials
        Table naming each trial's condition (and success) for the default trial choice;
        default ``metrics``.
    questionnaires
        The scores of :func:`nudgecli.report.questionnaires.questionnaire_scores` (``tlx_*``
        and ``likert_*`` columns); split with :func:`split_questionnaire_scores`.
    tlx, likert
        Questionnaire tables given separately, see :func:`questionnaire_figure`; they take
        precedence over the parts of ``questionnaires``.
    questionnaire_stats
        Statistics of the questionnaire scores (``stats.json`` dict or ``name -> entry``) for
        brackets.
    seed
        Jitter seed of the box plots.

    Returns
    -------
    list[Path]
        Every file written.
    """
    written: list[Path] = []
    written += save_figure(figure_3(metrics, stats, seed=seed), out_dir, "fig3", formats)
    written += save_figure(figure_4(metrics, stats, seed=seed), out_dir, "fig4", formats)

    if _has_steps(steps_by_trial):
        assert steps_by_trial is not None
        table = trials if trials is not None else metrics
        key = trial if trial is not None else choose_figure5_trial(steps_by_trial, table)
        key = (int(key[0]), int(key[1]))
        steps = _lookup_steps(steps_by_trial, key)
        layout = None
        if layouts is not None:
            layout = next((v for k, v in layouts.items() if (int(k[0]), int(k[1])) == key), None)
        cond = table.loc[(table["participant"] == key[0]) & (table["trial"] == key[1]), "condition"] \
            if {"participant", "trial", "condition"} <= set(table.columns) else pd.Series(dtype=str)
        label = f"Participant {key[0]}, trial {key[1]}"
        if not cond.empty:
            label += f" ({condition_display_name(str(cond.iloc[0]))})"
        written += save_figure(figure_5(steps, layout, title=label), out_dir, "fig5", formats)
        if layout is not None:
            goals, start = layout_poses(layout)
            written += save_figure(trajectory_figure(steps, goals, start, title=label), out_dir, "trajectory",
                                   formats)

    if questionnaires is not None:
        tlx_part, likert_part = split_questionnaire_scores(questionnaires)
        tlx = tlx if tlx is not None else tlx_part
        likert = likert if likert is not None else likert_part
    if tlx is not None or likert is not None:
        fig = questionnaire_figure(tlx, likert, conditions=resolve_conditions(metrics, stats),
                                   stats=questionnaire_stats)
        written += save_figure(fig, out_dir, "questionnaires", formats)
    return written


__all__ = [
    "METRIC_SPECS",
    "BoxplotArtists",
    "Bracket",
    "MetricSpec",
    "belief_matrix",
    "choose_figure5_trial",
    "figure_3",
    "figure_4",
    "figure_5",
    "group_label",
    "layout_poses",
    "metric_boxplot",
    "nudge_followup_changes",
    "plot_run",
    "questionnaire_figure",
    "resolve_conditions",
    "save_figure",
    "split_questionnaire_scores",
    "stats_entry_for",
    "trajectory_figure",
]
