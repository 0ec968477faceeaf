"""What every figure family shares: condition order, statistics lookup, labels, axes, a trial's layout.

Every drawing function takes ``ax=None`` (rliable's convention): given axes are drawn on, so
figures compose; without axes a new :class:`~matplotlib.figure.Figure` of the family's size is
made. Drawing happens inside :func:`nudgecli.report.style.figure_style`, so nothing leaks
into the global ``rcParams``.
"""

from __future__ import annotations

import textwrap
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from nudgecli.errors import DataError
from nudgecli.model.conditions import PAPER_CONDITIONS
from nudgecli.report.stats import order_conditions
from nudgecli.report.style import PANEL_LETTER_PT, figure_style

#: Conditions drawn first (the paper's order; :func:`nudgecli.report.stats.order_conditions` owns the rule).
DEFAULT_CONDITION_ORDER = PAPER_CONDITIONS
#: Jitter half-width of the trial dots, in units of the box spacing.
JITTER_HALF_WIDTH = 0.17


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
        The explicit order; else the stats' conditions (the analysis ordered them), then any
        other condition of ``metrics`` in :func:`nudgecli.report.stats.order_conditions`' order;
        else that order (the paper's conditions first).
    """
    if conditions is not None:
        return [str(c) for c in conditions]
    present = [] if metrics is None else [str(c) for c in pd.unique(metrics["condition"].dropna())]
    if stats and stats.get("conditions"):
        order = [str(c) for c in stats["conditions"]]
        return order + [c for c in order_conditions(present) if c not in order]
    return order_conditions(present)


def stats_by_metric(stats: Mapping[str, Any] | None) -> dict[str, Mapping[str, Any]]:
    """``metric -> entry`` of a ``stats.json`` dict (``{"metrics": [...]}``) or an already keyed mapping."""
    if not stats:
        return {}
    if isinstance(stats.get("metrics"), list):
        return {str(e["metric"]): e for e in stats["metrics"] if "metric" in e}
    return {str(k): v for k, v in stats.items()}


@dataclass(frozen=True)
class TrialLayout:
    """What a trial's figures need of its layout.

    Attributes
    ----------
    goal_poses
        ``(G, 3)`` goal poses ``(x, y, theta)``.
    start_pose
        ``(3,)`` start pose, or ``None`` (the first step's pose is used).
    true_goal
        Index of the trial's true goal among ``goal_poses``.
    """

    goal_poses: np.ndarray
    start_pose: np.ndarray | None
    true_goal: int

    def __post_init__(self) -> None:
        goals = np.atleast_2d(np.asarray(self.goal_poses, dtype=float))
        if goals.ndim != 2 or goals.shape[1] != 3:
            raise DataError(f"layout: goal poses must have shape (G, 3), got {goals.shape}")
        object.__setattr__(self, "goal_poses", goals)
        if self.start_pose is not None:
            start = np.asarray(self.start_pose, dtype=float).ravel()
            if start.shape != (3,):
                raise DataError(f"layout: start pose must have shape (3,), got {start.shape}")
            object.__setattr__(self, "start_pose", start)
        if not 0 <= int(self.true_goal) < goals.shape[0]:
            raise DataError(f"layout: true goal {self.true_goal} is not one of its {goals.shape[0]} goals")

    @property
    def n_goals(self) -> int:
        return int(self.goal_poses.shape[0])


def wrap_label(label: str, width: int = 26) -> str:
    """Break a long axis label into lines, preferring a break before its parenthesised unit."""
    if len(label) <= width:
        return label
    head, sep, unit = label.partition(" (")
    if sep and len(head) <= width and len(unit) + 1 <= width:
        return f"{head}\n({unit}"
    return "\n".join(textwrap.wrap(label, width))


def jitter(seed: int, key: str, n: int) -> np.ndarray:
    """``(n,)`` deterministic uniform jitter in ``[-JITTER_HALF_WIDTH, JITTER_HALF_WIDTH]`` of one group."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), zlib.crc32(key.encode("utf-8"))]))
    return rng.uniform(-JITTER_HALF_WIDTH, JITTER_HALF_WIDTH, size=n)


def panel_letter(ax: Axes, index: int) -> None:
    """Title a panel ``(a)``, ``(b)``, ... at its top left."""
    ax.set_title(f"({chr(ord('a') + index)})", loc="left", fontweight="bold", fontsize=PANEL_LETTER_PT)


def axes_or_new(ax: Axes | None, figsize: tuple[float, float]) -> Axes:
    """``ax``, or the single axes of a new constrained-layout figure of ``figsize`` inches."""
    if ax is not None:
        return ax
    with figure_style():
        fig = Figure(figsize=figsize, layout="constrained")
        return fig.subplots()


__all__ = ["DEFAULT_CONDITION_ORDER", "TrialLayout", "axes_or_new", "jitter", "panel_letter",
           "resolve_conditions", "stats_by_metric", "wrap_label"]
