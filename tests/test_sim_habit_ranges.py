"""The derivation of the population's timing ranges (sim/habit_ranges.py): the pilots' facts read
from hand-built sessions, the least covering extension, and the shipped defaults recomputed from
the real pilots' logs and HABITS.md's ranges."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nudgecli.config import PopulationSection
from nudgecli.sim.calibration_io import DistortionSession
from nudgecli.sim.calibration_readers import read_distortion_session
from nudgecli.sim.habit_ranges import (
    covering_range,
    derived_timing_ranges,
    hard_offset_samples,
    prompt_onsets,
    releases_after_clear,
)

CALIBRATION = Path(__file__).resolve().parents[2] / "shared" / "data" / "calibration"


def hand_session() -> DistortionSession:
    """Two prompts at 10 Hz: a Hard Puff shown at 1.0 s (blow from 2.3 s, plateau to 4.0 s, two
    falling samples, released before the clear at 7.0 s) and a Soft Sip shown at 9.0 s (blow from
    10.5 s, held 0.4 s past the clear at 15.0 s)."""
    t = np.round(np.arange(0.0, 17.0, 0.1), 1)
    pressure = np.zeros_like(t)
    pressure[(t >= 2.3) & (t <= 4.0)] = -1.0
    pressure[np.isclose(t, 4.1)] = -0.6
    pressure[np.isclose(t, 4.2)] = -0.3
    pressure[(t >= 10.5) & (t <= 15.4)] = 0.2
    codes = np.zeros(len(t), dtype=int)
    return DistortionSession(prompt_times=np.array([1.0, 7.0, 9.0, 15.0]),
                             prompt_commands=("Hard Puff", "", "Soft Sip", ""), stream_times=t,
                             stream_codes=codes, stream_pressure=pressure)


def test_the_pilots_facts_on_a_hand_built_session() -> None:
    session = hand_session()
    np.testing.assert_allclose(prompt_onsets(session), [1.3, 1.5])
    np.testing.assert_allclose(releases_after_clear(session), [0.4])
    np.testing.assert_array_equal(hard_offset_samples(session), [2])


@pytest.mark.parametrize(("start", "real", "offset", "expected"), [
    ((1.32, 1.45), (1.80, 2.75), 0.0, (1.32, 2.75)),  # extended up only
    ((1.32, 1.45), (0.59, 1.80), 0.1, (0.49, 1.70)),  # both ends, after the offset
    ((0.0, 5.0), (1.0, 2.0), 0.0, (0.0, 5.0)),  # already covering: unchanged
])
def test_the_least_covering_extension(start: tuple[float, float], real: tuple[float, float], offset: float,
                                      expected: tuple[float, float]) -> None:
    lo, hi = covering_range(start, real, offset)
    assert (lo, hi) == pytest.approx(expected)
    assert lo + offset <= real[0] + 1e-9 and hi + offset >= real[1] - 1e-9


@pytest.mark.skipif(not CALIBRATION.is_dir(),
                    reason="the pilots' logs (../shared/data/calibration) are absent")
def test_the_shipped_ranges_are_the_derivation_from_the_pilots_and_habits() -> None:
    pilots = [read_distortion_session(CALIBRATION / name) for name in ("andrewtest", "deepaktest")]
    derived = derived_timing_ranges([p for p in pilots if p is not None])
    population = PopulationSection()
    for name, bounds in derived.items():
        assert tuple(getattr(population, name)) == pytest.approx(bounds, abs=1e-9), name
    # the reactions' tail starts at the pilots' blow onsets' log-sd
    sds = [float(np.std(np.log(prompt_onsets(p)))) for p in pilots if p is not None]
    assert population.event_reaction_log_sd[0] == pytest.approx(min(sds), abs=0.01)
