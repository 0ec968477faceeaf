"""The equations of the prior-work assistance policies (arrays in, arrays out).

The policies themselves, one object per trial behind one interface, are
:mod:`nudgecli.sim.builtin_policies`; this module holds the mathematics they share with tests
and other callers: the confidence gap of ADA's arbitration.
"""

from __future__ import annotations

import numpy as np


def confidence_gap(belief: np.ndarray) -> float:
    """``p1 - p2``: the highest belief minus the second highest (a single goal's belief is its gap)."""
    b = np.asarray(belief, dtype=float)
    if b.size < 2:
        return float(b.max()) if b.size else 0.0
    top2 = np.partition(b, b.size - 2)[-2:]
    return float(top2[1] - top2[0])


def gap_gated_alpha(alpha: float, belief: np.ndarray, gap: float) -> float:
    """alpha, or 0 unless the confidence gap ``p1 - p2`` exceeds ``gap``.

    The arbitration gate of ADA's blend condition (personalrobotics/ada_assistance_policy,
    ``AdaAssistancePolicy.get_blend_action``: assist only when the most likely goal leads the
    second by more than 0.4), applied to policy blending's alpha
    (Dragan & Srinivasa 2013, Eq. 1: ``u = alpha u_r + (1 - alpha) u_h``, alpha a function of the
    prediction's confidence).
    """
    return alpha if confidence_gap(belief) > gap else 0.0
