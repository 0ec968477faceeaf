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


def one_prompt_session(label: str, shown: float, cleared: float, magnitudes: dict[float, float],
                       end: float = 8.0) -> DistortionSession:
    """One prompt of ``label`` at 10 Hz, with the given pressure magnitudes (a puff: negative)."""
    t = np.round(np.arange(0.0, end, 0.1), 1)
    pressure = np.zeros_like(t)
    for time, value in magnitudes.items():
        pressure[np.isclose(t, time)] = -value
    return DistortionSession(prompt_times=np.array([shown, cleared]), prompt_commands=(label, ""),
                             stream_times=t, stream_codes=np.zeros(len(t), dtype=int),
                             stream_pressure=pressure)


def test_a_blow_starting_as_the_prompt_clears_is_no_onset_of_that_prompt() -> None:
    # the prompt was on [1.0, 3.0): pressure from 3.0 on came after it cleared
    late = one_prompt_session("Soft Puff", 1.0, 3.0, {3.0: 0.2, 3.1: 0.2})
    assert prompt_onsets(late).size == 0
    early = one_prompt_session("Soft Puff", 1.0, 3.0, {2.9: 0.2, 3.0: 0.2})
    np.testing.assert_allclose(prompt_onsets(early), [1.9])


def test_a_sample_at_exactly_the_plateau_fraction_is_on_the_plateau() -> None:
    # magnitudes 1, 1, 1, 1, 0.8, 0.3: median 1, so 0.8 (= PLATEAU_FRACTION * 1) is the last plateau
    # sample and one sample (0.3) follows it
    blow = {2.0: 1.0, 2.1: 1.0, 2.2: 1.0, 2.3: 1.0, 2.4: 0.8, 2.5: 0.3}
    np.testing.assert_array_equal(hard_offset_samples(one_prompt_session("Hard Puff", 1.0, 4.0, blow)), [1])


@pytest.mark.parametrize(("stop", "motion", "reaction"), [
    ((1.0, 2.0), (0.5, 3.0), (0.4, 2.9)),  # both ends from the switch-to-motion reaction
    ((0.5, 3.0), (1.0, 2.0), (0.4, 2.9)),  # both ends from the stop-to-switch reaction
])
def test_derived_ranges_solved_by_hand(monkeypatch: pytest.MonkeyPatch, stop: tuple[float, float],
                                       motion: tuple[float, float], reaction: tuple[float, float]) -> None:
    import nudgecli.sim.habit_ranges as habit_ranges

    real = {"first_command_latency": (1.0, 2.0), "reaction_stop_to_switch": stop,
            "reaction_switch_to_motion": motion, "hard_band_per_excursion": (0.2, 0.6),
            "hard_blow_whole": (0.5, 1.5), "hold_on_per_stop": (0.1, 0.3)}
    monkeypatch.setattr(habit_ranges, "REAL_HABIT_RANGES", real)
    derived = derived_timing_ranges([hand_session()])
    # onsets 1.3 and 1.5: median 1.4, so every reaction starts from (1.4, 1.4); each reaction is
    # seen 0.1 s after its parameter, so its range is the real one less 0.1, joined over both
    assert derived["planning_s"] == pytest.approx((1.0, 2.0))
    assert derived["event_reaction_s"] == pytest.approx(reaction)
    # the one held blow let go 0.4 s after the clear: (0.4, 0.4) extended down to 0.1
    assert derived["hold_on_s"] == pytest.approx((0.1, 0.4))
    assert derived["hard_peak_s"] == (0.2, 0.6)
    # longest pulse 1.5 s = 15 samples = 3 onset + 6 peak + 6 offset; the pilot's offset ramp is 2
    assert derived["offset_ramp_samples"] == (2, 6)


def test_a_hard_blow_held_past_the_clear_is_measured_to_its_end() -> None:
    # plateau 2.0-3.5 s through the clear at 3.0 s, then 0.5 and 0.2: two samples after the plateau
    blow = {round(2.0 + 0.1 * k, 1): 1.0 for k in range(16)} | {3.6: 0.5, 3.7: 0.2}
    np.testing.assert_array_equal(hard_offset_samples(one_prompt_session("Hard Puff", 1.0, 3.0, blow)), [2])


def test_the_shipped_pressure_control_ranges_are_the_derivation() -> None:
    from nudgecli.sim.habit_ranges import derived_pressure_control_ranges

    derived = derived_pressure_control_ranges()
    population = PopulationSection()
    assert set(derived) == {"deadband_share", "deadband_stray_s"}
    for name, bounds in derived.items():
        assert tuple(getattr(population, name)) == pytest.approx(bounds, abs=1e-12), name
    # HABITS.md's inside-a-soft-blow table: shares 0.045-0.21, runs 0.10-0.30 s (people's medians)
    assert derived == {"deadband_share": (0.045, 0.21), "deadband_stray_s": (0.1, 0.3)}


def test_pressure_control_ranges_solved_by_hand(monkeypatch: pytest.MonkeyPatch) -> None:
    import nudgecli.sim.habit_ranges as habit_ranges

    monkeypatch.setattr(habit_ranges, "REAL_HABIT_RANGES", {"deadband_share_soft_blows": (0.0123, 0.5),
                                                            "deadband_run_in_soft_blow": (0.2, 0.7)})
    monkeypatch.setattr(habit_ranges, "HABIT_OFFSETS_S", {"deadband_share_soft_blows": 0.0,
                                                          "deadband_run_in_soft_blow": 0.1})
    derived = habit_ranges.derived_pressure_control_ranges()
    # a share to three decimals; a run measured 0.1 s after its parameter starts 0.1 s earlier
    assert derived["deadband_share"] == (0.012, 0.5)
    assert derived["deadband_stray_s"] == pytest.approx((0.1, 0.6))
