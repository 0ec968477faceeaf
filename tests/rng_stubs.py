"""A stand-in for ``np.random.Generator`` whose uniform draws are one fixed value.

``Generator.random`` may return exactly 0.0 or a value on a CDF step; inverse-CDF samplers must
treat those edges right, and a real generator hits them about once in 2**53 draws.
"""

from __future__ import annotations

import numpy as np


class FixedUniform:
    """``random()`` gives ``value``; ``random(size)`` an array of it."""

    def __init__(self, value: float) -> None:
        self.value = value

    def random(self, size: int | tuple[int, ...] | None = None) -> float | np.ndarray:
        return self.value if size is None else np.full(size, self.value)
