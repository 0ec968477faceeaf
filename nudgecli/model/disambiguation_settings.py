"""How D(s) is computed and where s* is searched (:class:`DisambiguationSettings`), apart from
:mod:`nudgecli.model.disambiguation` so that reading its defaults (``nudgecli.config`` does)
loads neither numpy nor scipy."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

#: How the Monte-Carlo estimate averages the per-goal KL (:mod:`nudgecli.model.information`).
Weighting = Literal["unweighted", "belief"]


@dataclass(frozen=True)
class DisambiguationSettings:
    """How D(s) is computed and where s* is searched.

    Defaults follow the paper; :meth:`study` gives the original study software's choices.

    Attributes
    ----------
    estimator
        ``"exact"`` (Eq. 13 by enumeration) or ``"monte_carlo"`` (the study's sampling scheme).
    samples
        Monte-Carlo samples per candidate state.
    weighting
        How the Monte-Carlo estimate averages the per-goal KL: ``"belief"`` (Eq. 13/14) or
        ``"unweighted"`` (the study). The exact estimator is always belief-weighted.
    mi_weight
        ``w_I`` in ``D(s) = w_I I(s) - lambda R(s)``.
    distance_weight
        ``lambda``.
    distance
        ``"expected"``: ``R(s) = sum_g b_g ||g - q(s)||`` (Eq. 15); ``"to_mean"``:
        ``R(s) = ||q(s) - sum_g b_g g||`` (the study).
    distance_unit
        ``"cells"``: positions are cell indices ``(i, j)`` (one step along x or y is 1 whatever
        the cell's 4.2 x 3.4 size); ``"world"``: world units (see
        :func:`~nudgecli.model.candidates.window_candidates`).
    window
        Side of the square window of cells around the current cell (odd: 3 or 5).
    domain
        ``"window"`` or ``"global"`` (every state off the goals' cells, all headings).
    rotation_gate
        Drop theta-mode candidates farther than this (world units) from the unweighted mean goal
        position; ``None`` keeps them all.
    scope
        ``"domain"``: the states of ``domain``; ``"mode-only"``: the states that differ from the
        current one in mode alone (:func:`mode_candidates`; the mode-switch policy's).
    """

    estimator: Literal["exact", "monte_carlo"] = "exact"
    samples: int = 250
    weighting: Weighting = "belief"
    mi_weight: float = 1.0
    distance_weight: float = 1.0
    distance: Literal["expected", "to_mean"] = "expected"
    distance_unit: Literal["cells", "world"] = "cells"
    window: int = 3
    domain: Literal["window", "global"] = "window"
    rotation_gate: float | None = None
    scope: Literal["domain", "mode-only"] = "domain"

    def __post_init__(self) -> None:
        choices = {"estimator": ("exact", "monte_carlo"), "weighting": ("unweighted", "belief"),
                   "distance": ("expected", "to_mean"), "distance_unit": ("cells", "world"),
                   "domain": ("window", "global"), "scope": ("domain", "mode-only")}
        for field_name, allowed in choices.items():
            if getattr(self, field_name) not in allowed:
                raise ValueError(f"{field_name} must be one of {allowed}, got {getattr(self, field_name)!r}")
        if self.window < 1 or self.window % 2 == 0:
            raise ValueError(f"window must be a positive odd number of cells (3 or 5), got {self.window}")
        if self.samples < 1:
            raise ValueError(f"samples must be at least 1, got {self.samples}")
        if self.rotation_gate is not None and self.rotation_gate < 0:
            raise ValueError(f"rotation_gate must be non-negative or None, got {self.rotation_gate}")

    @classmethod
    def study(cls) -> DisambiguationSettings:
        """The study software: MC 250 unweighted, 0.5 / 0.5, distance to the belief-weighted
        mean goal in world units, 5 x 5 window, theta candidates within 12 units of the goals."""
        return cls(estimator="monte_carlo", samples=250, weighting="unweighted", mi_weight=0.5,
                   distance_weight=0.5, distance="to_mean", distance_unit="world", window=5,
                   domain="window", rotation_gate=12.0)
