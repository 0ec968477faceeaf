"""Simulated participants: drawing, the pressure model, records, and estimation from real logs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from nudgecli.config import CalibrationSection, InterfaceSection, PopulationSection
from nudgecli.errors import DataError
from nudgecli.model.interface import (
    HARD_PUFF,
    HARD_SIP,
    LABELS,
    N_LABELS,
    NO_INPUT,
    PUFF_DEADBAND,
    SIP_DEADBAND,
    SOFT_PUFF,
    SOFT_SIP,
    TRUE_MAPPING,
    label_pressure,
)
from nudgecli.rng import generator
from nudgecli.sim.calibration import simulate_distortion_session
from nudgecli.sim.participants import (
    LABEL_SIGN,
    Participant,
    censored_normal_fit,
    draw_participants,
    mapping_with_error,
    participant_from_log,
    participants_frame,
    participants_from_frame,
)

SHARED_CALIBRATION = Path(__file__).resolve().parents[2] / "shared" / "data" / "calibration"
needs_shared = pytest.mark.skipif(
    not SHARED_CALIBRATION.is_dir(),
    reason=f"the real pilot logs are not checked out beside the repository ({SHARED_CALIBRATION})")

THRESHOLDS = (0.3, 0.5, 0.002)


def make_participant(ramp: int = 0, error_rate: float = 0.1) -> Participant:
    """A participant with a known physiology and visible confusions at the 0.3 / 0.5 thresholds."""
    return Participant(
        index=0, seed_key="test/known", pressure_level=np.array([-0.6, 0.9, -0.12, 0.25]),
        pressure_spread=np.array([0.12, 0.1, 0.06, 0.08]), mapping=mapping_with_error(error_rate),
        epsilon=0.1, rest_s=0.5, operate_s=3.0, action_pause_s=0.2, hard_blow_s=0.5, reaction_s=1.0,
        reaction_log_sd=0.0, onset_ramp_samples=ramp, mapping_error=error_rate)


def test_same_seed_same_participants_different_seed_different() -> None:
    population = PopulationSection()
    first = draw_participants(population, 5, seed=7)
    again = draw_participants(population, 5, seed=7)
    other = draw_participants(population, 5, seed=8)
    assert first == again
    assert [p.to_record() for p in first] == [p.to_record() for p in again]
    assert all(a != b for a, b in zip(first, other, strict=True))
    # participant i does not depend on how many are drawn
    assert draw_participants(population, 2, seed=7) == first[:2]
    assert first[3].seed_key == "participant/3"


def test_draws_stay_in_population_ranges() -> None:
    population = PopulationSection()
    participants = draw_participants(population, 200, seed=1)
    level = np.array([p.pressure_level for p in participants])
    spread = np.array([p.pressure_spread for p in participants])
    assert np.all(np.sign(level) == LABEL_SIGN)
    for label, bounds in ((HARD_PUFF, population.hard_puff_level), (HARD_SIP, population.hard_sip_level),
                          (SOFT_PUFF, population.soft_puff_level), (SOFT_SIP, population.soft_sip_level)):
        assert bounds[0] <= np.abs(level[:, label]).min() and np.abs(level[:, label]).max() <= bounds[1]
    hard, soft = population.hard_spread, population.soft_spread
    assert hard[0] <= spread[:, :2].min() and spread[:, :2].max() <= hard[1]
    assert soft[0] <= spread[:, 2:].min() and spread[:, 2:].max() <= soft[1]
    for name in ("epsilon", "rest_s", "operate_s", "action_pause_s", "hard_blow_s", "reaction_s",
                 "mapping_error", "onset_ramp_samples"):
        values = np.array([getattr(p, name) for p in participants])
        low, high = getattr(population, name)
        assert low <= values.min() and values.max() <= high, name
    for p in participants:
        np.testing.assert_allclose(p.mapping.sum(axis=-1), 1.0)
        assert np.all(p.mapping[:, np.arange(4), TRUE_MAPPING] == pytest.approx(1 - p.mapping_error))


def test_population_ranges_are_validated() -> None:
    with pytest.raises(ValueError, match="soft_sip_level"):
        PopulationSection(soft_sip_level=(0.3, 0.1))
    with pytest.raises(ValueError, match="mapping_error"):
        PopulationSection(mapping_error=(0.0, 0.9))


def test_records_round_trip_through_parquet(tmp_path: Path) -> None:
    participants = draw_participants(PopulationSection(), 3, seed=11)
    frame = participants_frame(participants)
    assert list(frame["index"]) == [0, 1, 2]
    path = tmp_path / "participants.parquet"
    frame.to_parquet(path)
    assert participants_from_frame(pd.read_parquet(path)) == participants


def test_bad_record_is_a_data_error() -> None:
    record = draw_participants(PopulationSection(), 1, seed=3)[0].to_record()
    del record["mapping"]
    with pytest.raises(DataError, match="mapping"):
        Participant.from_record(record)


def test_intended_label_follows_the_internal_mapping() -> None:
    participant = make_participant(error_rate=0.3)
    rng = generator(5, "test")
    draws = np.array([participant.intended_label(1, 2, rng) for _ in range(20_000)])
    frequencies = np.bincount(draws, minlength=N_LABELS) / draws.size
    # binomial standard error at p = 0.7 with 20 000 draws is 0.0032; allow 5 of them
    np.testing.assert_allclose(frequencies, participant.mapping[2, 1], atol=0.017)


def test_pressures_keep_the_side_clip_and_ramp() -> None:
    participant = make_participant(ramp=2)
    rng = generator(9, "test")
    for label in range(N_LABELS):
        p = participant.pressures(label, 400, rng)
        assert p.shape == (400,)
        assert np.all(np.abs(p) <= 1.0)
        assert np.all(p * LABEL_SIGN[label] >= 0)
    ramped = participant.pressures(HARD_SIP, 3, generator(1, "ramp"))
    # level 0.9: the ramp samples sit near 0.3 and 0.6, the third on the plateau
    assert ramped[0] < ramped[1] < 0.8
    # a blow produced one sample at a time ramps only at its start
    rng = generator(2, "one-by-one")
    held = np.array([participant.pressures(HARD_SIP, 1, rng, start=k)[0] for k in range(50)])
    assert held[:2].max() < 0.75 and np.median(held[2:]) == pytest.approx(0.9, abs=0.05)


def test_true_distortion_matches_monte_carlo_of_the_pressure_model() -> None:
    participant = make_participant(ramp=2)
    rng = generator(4, "mc")
    n_blows, hold = 400, 20
    for label in range(N_LABELS):
        codes = np.concatenate([label_pressure(participant.pressures(label, hold, rng), *THRESHOLDS)
                                for _ in range(n_blows)])
        counts = np.array([np.sum(codes == c) for c in range(N_LABELS)], dtype=float)
        counts[HARD_PUFF] += np.sum(codes == PUFF_DEADBAND)
        counts[HARD_SIP] += np.sum(codes == SIP_DEADBAND)
        empirical = counts / counts.sum()
        counted = np.sum(codes != NO_INPUT)
        # worst-case binomial standard error 0.5 / sqrt(counted) (8000 samples -> 0.0056); 5 of them
        np.testing.assert_allclose(empirical, participant.true_distortion(THRESHOLDS, hold)[label],
                                   atol=5 * 0.5 / np.sqrt(counted))


def test_true_distortion_shape_rows_and_plateau() -> None:
    participant = make_participant()
    table = participant.true_distortion(InterfaceSection())
    assert table.shape == (N_LABELS, N_LABELS)
    np.testing.assert_allclose(table.sum(axis=1), 1.0)
    # Soft Sip at 0.25 +- 0.08 crosses 0.3 with probability 1 - Phi(0.625) = 0.266 (deadband merged)
    assert table[SOFT_SIP, HARD_SIP] == pytest.approx(0.266, abs=0.002)
    # without an onset ramp, the plateau and any hold length agree
    np.testing.assert_allclose(participant.true_distortion(THRESHOLDS, 7),
                               participant.true_distortion(THRESHOLDS))
    # stricter thresholds (the study's later 0.4 / 0.6) turn fewer soft sips hard
    assert participant.true_distortion((0.4, 0.6))[SOFT_SIP, HARD_SIP] < table[SOFT_SIP, HARD_SIP]


def test_censored_normal_fit_recovers_level_and_spread_under_saturation() -> None:
    rng = generator(3, "fit")
    for level, spread in ((0.2, 0.05), (0.95, 0.1), (1.1, 0.15)):
        x = np.clip(level + spread * rng.standard_normal(4000), 0, 1)
        got_level, got_spread = censored_normal_fit(x)
        assert got_level == pytest.approx(level, abs=0.02)
        assert got_spread == pytest.approx(spread, abs=0.02)
    level, spread = censored_normal_fit(np.ones(50))
    assert level > 1.0 and spread > 0


@needs_shared
def test_participant_from_the_real_pilot_logs() -> None:
    andrew = participant_from_log(SHARED_CALIBRATION / "andrewtest")
    deepak = participant_from_log(SHARED_CALIBRATION / "deepaktest" / "p_phm_given_phi")
    population = PopulationSection()
    # andrewtest is inside the default population ranges (they were set from these logs)
    for label, bounds in ((HARD_PUFF, population.hard_puff_level), (HARD_SIP, population.hard_sip_level),
                          (SOFT_PUFF, population.soft_puff_level), (SOFT_SIP, population.soft_sip_level)):
        assert bounds[0] <= abs(andrew.pressure_level[label]) <= bounds[1], LABELS[label]
    assert population.reaction_s[0] <= andrew.reaction_s <= population.reaction_s[1]
    # the physiology implies andrewtest's Soft Sip -> Hard Sip confusion (0.28 in the study's table)
    assert andrew.true_distortion((0.3, 0.5))[SOFT_SIP, HARD_SIP] == pytest.approx(0.28, abs=0.06)
    # deepaktest never produced a soft sip: his "soft" sip saturates like a hard one
    assert deepak.pressure_level[SOFT_SIP] > 1.0
    assert deepak.true_distortion((0.3, 0.5))[SOFT_SIP, HARD_SIP] > 0.95


def test_participant_from_log_without_session_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(DataError, match="no p\\(phi_m \\| phi_i\\) session"):
        participant_from_log(tmp_path)


def test_participant_from_log_recovers_a_simulated_physiology() -> None:
    truth = make_participant(ramp=2)
    session = simulate_distortion_session(truth, CalibrationSection(prompts_per_label=40),
                                          InterfaceSection(), generator(8, "log"))
    # the same session given as one stream table with the prompt of each sample
    prompt_of_sample = np.searchsorted(session.prompt_times, session.stream_times, side="right") - 1
    intended = [session.prompt_commands[k] if k >= 0 else "" for k in prompt_of_sample]
    frame = pd.DataFrame({"t": session.stream_times, "pressure": session.stream_pressure,
                          "intended": intended})
    for source in (session, frame):
        estimated = participant_from_log(source, template=truth)
        # ~40 prompts x ~45 plateau samples per label: the quantile fit's standard error is < 0.005
        np.testing.assert_allclose(estimated.pressure_level, truth.pressure_level, atol=0.02)
        np.testing.assert_allclose(estimated.pressure_spread, truth.pressure_spread, atol=0.02)
        # the first non-zero sample comes 0-0.1 s after the reaction delay
        assert truth.reaction_s <= estimated.reaction_s <= truth.reaction_s + 0.1
        np.testing.assert_array_equal(estimated.mapping, truth.mapping)
    with pytest.raises(DataError, match="missing column"):
        participant_from_log(frame.drop(columns="intended"))
