"""How ``nudge habits`` prints its numbers beside a reference's: one owner of the decimals of a
measured value, a reference's value (as written, or as measured for a habits JSON) and a compared
row's measured median."""

from __future__ import annotations

import math
from typing import Any

import pandas as pd


def fmt(value: Any, digits: int = 2) -> str:
    """``value`` at ``digits`` decimals (2: the measured values'), ``-`` for none."""
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.{digits}f}"


#: The most decimals a reference written by hand gives (HABITS.md's 0.045); a value with more is
#: a measured one (a ``--format json`` output's 0.211864), printed as measured values are.
_WRITTEN_DIGITS = 3


def _own_digits(*values: float) -> int:
    """The fewest decimals (2 to 3) at which each of ``values`` reads as written (HABITS.md's 0.045),
    else 2: measured values (a habits JSON as the reference), printed as the measured column is."""
    return next((d for d in range(2, _WRITTEN_DIGITS + 1)
                 if all(math.isnan(v) or abs(float(f"{v:.{d}f}") - v) < 1e-12 for v in values)), 2)


def compared_digits(median: float, ref: pd.Series) -> tuple[int, int]:
    """The decimals of a compared row's reference values and of its measured values: the reference's
    own (:func:`_own_digits`), and the fewest at which the measured median reads inside the printed
    range exactly when it is (:func:`_digits_reading`); where none does (a measured reference's range
    rounded onto the median), the reference's too are given more, up to 6."""
    own = _own_digits(ref["reference_median"], ref["reference_min"], ref["reference_max"])
    if ref["inside"] is None:
        return own, 2
    for digits in range(own, 7):
        low, high = fmt(ref["reference_min"], digits), fmt(ref["reference_max"], digits)
        reading = _digits_reading(median, low, high, bool(ref["inside"]))
        if reading < 9:
            return digits, reading
    return 6, reading


def _digits_reading(median: float, low: str, high: str, inside: bool) -> int:
    """The fewest decimals (2 to 9) at which ``median`` printed reads inside the printed range
    ``low``-``high`` exactly when it is ``inside`` (0.0496 is outside 0.05-0.65, so not 0.05)."""
    reads = (d for d in range(2, 9) if (float(low) <= float(f"{median:.{d}f}") <= float(high)) == inside)
    return next(reads, 9)
