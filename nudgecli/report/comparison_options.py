"""The settings of a comparison of conditions (an analysis plan's ``[stats]`` and ``[bootstrap]``).

Apart from :mod:`nudgecli.report.stats` so that reading a plan (:mod:`nudgecli.report.plans`, which
a batch does before its workers start) loads neither pandas nor the statistics.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal


@dataclass(frozen=True)
class ComparisonOptions:
    """Settings of :func:`~nudgecli.report.stats_document.compare_conditions` (an analysis plan's
    ``[stats]`` and ``[bootstrap]``).

    Attributes
    ----------
    kruskal_alpha
        Significance level of the Kruskal-Wallis gate for the stars.
    p_adjust
        Adjustment of the Conover p-values (a ``statsmodels`` ``multipletests`` method, or
        ``"none"``).
    star_thresholds
        Strictly decreasing thresholds; one star per threshold met.
    star_comparison
        ``"<"`` (the paper) or ``"<="`` (the study software); also used for the gate.
    participant_aggregate
        How trials are summarised per participant and condition (``"median"`` or ``"mean"``).
    bootstrap_resamples, bootstrap_level, seed
        The cluster bootstrap.
    """

    kruskal_alpha: float = 0.05
    p_adjust: str = "holm"
    star_thresholds: tuple[float, ...] = (0.05, 0.01, 0.001)
    star_comparison: Literal["<", "<="] = "<"
    participant_aggregate: Literal["median", "mean"] = "median"
    bootstrap_resamples: int = 2000
    bootstrap_level: float = 0.95
    seed: int = 0


__all__ = ["ComparisonOptions"]
