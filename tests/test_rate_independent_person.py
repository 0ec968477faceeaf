"""The same person at any ``study.rate_hz``: the per-sample traits drawn at 10 Hz (the onset and
offset ramps' sample counts, the drift's lag-1 correlation) describe the same durations and the
same drift over time at another rate (``Participant.at_sample_period``, sim/behaviour.py)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from nudgecli.config import PopulationSection
from nudgecli.model.interface import HARD_PUFF, TO_MODE_R
from nudgecli.sim.behaviour import SimulatedPerson
from nudgecli.sim.behaviour_settings import BehaviourSettings
from nudgecli.sim.participants import Participant, draw_participants

HARD_THRESHOLD = 0.5
PEOPLE = draw_participants(PopulationSection(), 20, seed=2020)


def _person(participant: Participant, dt: float) -> SimulatedPerson:
    settings = BehaviourSettings(dt=dt, hard_pulses=True, hard_blow_jitter=0.0, hard_threshold=HARD_THRESHOLD)
    return SimulatedPerson(participant, settings, np.zeros(1, dtype=int), np.zeros(3), 0,
                           np.random.default_rng(0))


class _View:
    mode = 0
    state = 0


def _pulse(participant: Participant, dt: float) -> tuple[float, float]:
    """``(length, rise to the hard band)`` of one mode-switch pulse of ``participant``, seconds.

    Their spreads are near zero, so the pulse is its shape: ramp, peak and ramp of the level."""
    person = _person(replace(participant, pressure_spread=np.zeros(4)), dt)
    person._start_hold(_View(), HARD_PUFF, TO_MODE_R, False, False)  # type: ignore[arg-type]
    hard = np.flatnonzero(np.abs(np.array(person.blow)) > HARD_THRESHOLD)
    return person.hold_left * dt, float(hard[0]) * dt


@pytest.mark.parametrize("rate_hz", [20.0, 40.0])
def test_a_pulse_lasts_and_rises_as_long_at_any_rate(rate_hz: float) -> None:
    for participant in PEOPLE:
        length_10, rise_10 = _pulse(participant, 1.0 / 10.0)
        length_at, rise_at = _pulse(participant, 1.0 / rate_hz)
        # within one 10 Hz sample: the peak and the ramps are each whole samples at either rate
        assert abs(length_at - length_10) <= 0.1 + 1e-9, (participant.index, length_10, length_at)
        assert abs(rise_at - rise_10) <= 0.1 + 1e-9, (participant.index, rise_10, rise_at)


def test_the_drift_keeps_its_correlation_over_a_tenth_of_a_second() -> None:
    for participant in PEOPLE:
        at_20 = _person(participant, 0.05).participant
        # two 20 Hz steps are one 10 Hz step: rho_20 ** 2 == rho_10
        assert at_20.drift_correlation ** 2 == pytest.approx(participant.drift_correlation, rel=1e-12)
        assert at_20.onset_ramp_samples == 2 * participant.onset_ramp_samples
        assert at_20.offset_ramp_samples == 2 * participant.offset_ramp_samples


def test_at_ten_hertz_the_person_is_the_same_object() -> None:
    # 1 / 10.0 / 0.1 is 1.0 exactly: every table at the default rate keeps its bits
    for participant in PEOPLE:
        assert _person(participant, 1.0 / 10.0).participant is participant


def test_a_one_sample_ramp_stays_a_ramp_at_five_hertz() -> None:
    person = replace(PEOPLE[0], onset_ramp_samples=1, offset_ramp_samples=3)
    at_5 = person.at_sample_period(0.2)
    assert (at_5.onset_ramp_samples, at_5.offset_ramp_samples) == (1, 2)  # 0.5 and 1.5 samples, half up


def _calibration_rise_s(participant: Participant, rate_hz: float) -> float:
    """Seconds from the first sample of the calibration session's first blow to its full level."""
    from nudgecli.config import CalibrationSection, InterfaceSection
    from nudgecli.sim.calibration_sessions import simulate_distortion_session

    still = replace(participant, pressure_spread=np.zeros(4))  # the blow is its ramp and level (and noise)
    session = simulate_distortion_session(still, CalibrationSection(rate_hz=rate_hz, prompts_per_label=1),
                                          InterfaceSection(), np.random.default_rng(3))
    magnitude = np.abs(np.nan_to_num(session.stream_pressure))
    first = int(np.flatnonzero(magnitude > 0)[0])
    blow = magnitude[first:first + int(rate_hz * 2)]
    return float(np.flatnonzero(blow >= 0.99 * np.median(blow))[0]) / rate_hz  # a ramp's last step: 1 - 1/n


@pytest.mark.parametrize("participant", [p for p in PEOPLE if p.onset_ramp_samples >= 2][:3])
def test_a_calibration_session_blows_with_the_same_ramp_at_any_rate(participant: Participant) -> None:
    assert _calibration_rise_s(participant, 20.0) == pytest.approx(_calibration_rise_s(participant, 10.0),
                                                                   abs=0.06)  # half a 10 Hz sample
