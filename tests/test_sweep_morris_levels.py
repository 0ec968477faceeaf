"""A Morris design maps each exact grid level j / (L - 1) by the documented rule (docs/batches.md):
a set of k values to value number floor(u k), an integer range to ceil(low) + floor(u n), u = 1 the
last. SALib returns the levels in floats (4 as 3.9999999999999996), which a floor of the float
took one value too low at some levels."""

from __future__ import annotations

import math
from fractions import Fraction

import pytest

from nudgecli.runs.sweep import Design, Range, SweepFile, Values, design_values, map_sample, salib_problem


def _expected(level: int, levels: int, count: int) -> int:
    """The documented choice at level j, computed exactly: floor(u count), u = j / (L - 1)."""
    return min(math.floor(Fraction(level, levels - 1) * count), count - 1)


@pytest.mark.parametrize("levels", [2, 4, 6, 8, 10, 12, 16, 18, 20, 24, 32])
def test_every_morris_level_maps_to_the_documented_choice(levels: int) -> None:
    # brute force over grid levels and counts, SALib's own float scaling of u: the exact rule each time
    for count in range(2, 40):
        for first in (-7, 0, 1, 4):
            whole = Range(low=first, high=first + count - 1, integer=True)
            mapped: list[tuple[Range | Values, int]] = [(whole, first)]
            if count <= levels:  # a set of more values than levels is refused (test_sweep_refusals.py)
                mapped.append((Values(values=list(range(count))), 0))
            for value, offset in mapped:
                spec = SweepFile(experiment="unused", design=Design(method="morris", levels=levels),
                                 parameters={"a.b": value})
                (lo, hi), = salib_problem(spec)["bounds"]
                for level in range(levels):
                    x = (level / (levels - 1)) * (hi - lo) + lo  # SALib's scale_samples
                    got = map_sample(value, x, (lo, hi), levels)
                    assert got == offset + _expected(level, levels, count), (count, first, level)


def test_the_morris_design_of_17_values_and_integers_takes_the_exact_levels() -> None:
    kappas = [round(0.50 + i / 100, 2) for i in range(17)]
    spec = SweepFile(experiment="unused", design=Design(method="morris", samples=6, levels=18, seed=0),
                     parameters={"inference.kappa": Values(values=kappas),
                                 "study.participants": Range(low=1, high=17, integer=True)})
    points, problem, samples = design_values(spec)
    assert samples is not None and problem is not None
    for point, row in zip(points, samples, strict=True):
        for k, (name, offset) in enumerate((("inference.kappa", 0), ("study.participants", 1))):
            lo, hi = problem["bounds"][k]
            level = round((row[k] - lo) / (hi - lo) * 17)
            index = _expected(level, 18, 17)
            assert point[name] == (kappas[index] if offset == 0 else offset + index)


def test_a_continuous_range_and_a_sobol_coordinate_keep_their_mapping() -> None:
    assert map_sample(Range(low=0.5, high=0.8), 0.65, (0.5, 0.8), 4) == 0.65
    assert map_sample(Range(low=1, high=5, integer=True), 3.9999999999999996) == 3  # sobol: no grid


@pytest.mark.parametrize("levels", [4, 10, 18])
def test_a_morris_design_over_any_count_of_integers_takes_the_exact_levels(levels: int) -> None:
    for count in range(2, 26):
        design = Design(method="morris", samples=8, levels=levels, seed=3)
        spec = SweepFile(experiment="unused", design=design,
                         parameters={"study.participants": Range(low=1, high=count, integer=True)})
        points, _, samples = design_values(spec)
        assert samples is not None
        for point, (x,) in zip(points, samples, strict=True):
            level = round((x - 1) / count * (levels - 1))
            assert point["study.participants"] == 1 + _expected(level, levels, count), (count, x)
