"""Simulated participants: drawing, the pressure model, records, and estimation from real logs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rng_stubs import FixedUniform

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
    ZERO_THRESHOLD,
    label_pressure,
)
from nudgecli.rng import generator
from nudgecli.sim.calibration_sessions import simulate_distortion_session
from nudgecli.sim.participant_fitting import censored_normal_fit, log_drift_correlation, participant_from_log
from nudgecli.sim.participants import (
    Participant,
    draw_participants,
    mapping_with_error,
    participants_frame,
    participants_from_frame,
)
from nudgecli.sim.pressure_model import (
    LABEL_SIGN,
    blows_drift_normals,
    drift_normals,
    lognormal_delay,
    lognormal_delays,
    pulse_fractions,
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


# --- drift within a blow ------------------------------------------------------------------------

@settings(max_examples=60, deadline=None)
@given(rho=st.floats(0.0, 0.99), n=st.integers(1, 40), seed=st.integers(0, 2**16),
       previous=st.one_of(st.none(), st.floats(-4.0, 4.0)))
def test_drift_normals_is_the_ar1_recursion(rho: float, n: int, seed: int, previous: float | None) -> None:
    e = np.random.default_rng(seed).standard_normal(n)
    expected = np.empty(n)
    scale = np.sqrt(1.0 - rho**2)
    for j in range(n):  # the recursion written out, sample by sample
        before = previous if j == 0 else expected[j - 1]
        expected[j] = e[j] if before is None else rho * before + scale * e[j]
    np.testing.assert_allclose(drift_normals(e, rho, previous), expected, rtol=1e-12, atol=1e-12)


@settings(max_examples=200, deadline=None)
@given(rho=st.floats(0.0, 0.999), n=st.integers(1, 300), seed=st.integers(0, 2**16),
       previous=st.one_of(st.none(), st.floats(-4.0, 4.0)))
def test_drift_normals_equals_scipy_lfilter_bit_for_bit(rho: float, n: int, seed: int,
                                                       previous: float | None) -> None:
    # The loop replaced scipy.signal.lfilter (same IIR filter, z_t = rho z_{t-1} + scale e_t);
    # runs recorded before the change must reproduce exactly, so equality is exact, not close.
    from scipy.signal import lfilter

    e = np.random.default_rng(seed).standard_normal(n)
    scale = np.sqrt(1.0 - rho * rho)
    first = e[0] if previous is None else rho * previous + scale * e[0]
    rest = lfilter([scale], [1.0, -rho], e[1:], zi=[rho * first])[0] if n > 1 else np.zeros(0)
    assert np.array_equal(drift_normals(e, rho, previous), np.r_[first, rest])


def test_zero_drift_leaves_the_innovations_unchanged_bit_for_bit() -> None:
    e = np.random.default_rng(1).standard_normal(50)
    assert np.array_equal(drift_normals(e, 0.0), e)
    assert np.array_equal(blows_drift_normals(e, np.array([20, 30]), 0.0), e)


def test_drift_keeps_standard_normal_samples_with_correlation_rho_to_the_k() -> None:
    rho, blows, n = 0.9, 20000, 8
    e = np.random.default_rng(2).standard_normal((blows, n))
    z = blows_drift_normals(e.ravel(), np.full(blows, n), rho).reshape(blows, n)
    # every position of the blow is N(0, 1): mean 0, variance 1 (standard errors ~0.007 and ~0.01)
    np.testing.assert_allclose(z.mean(axis=0), 0.0, atol=0.03)
    np.testing.assert_allclose(z.var(axis=0), 1.0, atol=0.04)
    for lag in (1, 3):
        corr = np.mean(z[:, :-lag] * z[:, lag:])
        assert corr == pytest.approx(rho**lag, abs=0.02), lag


def test_blows_drift_normals_start_every_blow_afresh() -> None:
    e = np.random.default_rng(3).standard_normal(12)
    lengths = np.array([5, 0, 4, 3])
    z = blows_drift_normals(e, lengths, 0.8)
    np.testing.assert_array_equal(z[[0, 5, 9]], e[[0, 5, 9]])  # each blow's first deviation is its draw
    np.testing.assert_allclose(z[5:9], drift_normals(e[5:9], 0.8))
    with pytest.raises(ValueError, match="add up to 11"):
        blows_drift_normals(e, np.array([5, 6]), 0.8)


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_blows=st.integers(0, 40), longest=st.integers(0, 45),
       rho=st.floats(0.0, 0.999))
def test_blows_advanced_together_are_each_blows_drift_bit_for_bit(seed: int, n_blows: int, longest: int,
                                                                  rho: float) -> None:
    # blows of 0 to `longest` samples, each its own drift_normals (the loop a blow), joined
    rng = np.random.default_rng(seed)
    lengths = rng.integers(0, longest + 1, size=n_blows)
    e = rng.standard_normal(int(lengths.sum()))
    ends = np.cumsum(lengths).tolist()
    expected = [drift_normals(e[end - length:end], rho)
                for end, length in zip(ends, lengths.tolist(), strict=True)]
    got = blows_drift_normals(e, lengths, rho)
    assert got.dtype == np.float64 and got.tobytes() == np.concatenate([np.zeros(0), *expected]).tobytes()


def test_blows_of_a_negative_length_are_refused() -> None:
    with pytest.raises(ValueError, match=r"add up to 3, .* one is negative"):
        blows_drift_normals(np.zeros(3), np.array([5, -2]), 0.5)


def test_log_drift_correlation_by_hand() -> None:
    levels, spreads = np.array([0.8, 0.9, 0.1, 0.2]), np.array([0.1, 0.1, 0.05, 0.1])
    blows = [[np.array([0.9, 1.0, 0.7, 0.6])], [], [], [np.array([0.3, 0.1, 0.2]), np.array([0.4])]]
    # deviations: Hard Puff 1, (saturated), -1, -2 -> the one unsaturated pair (-1, -2);
    # Soft Sip 1, -1, 0 -> pairs (1, -1), (-1, 0); the 1-sample blow has no pair
    products, squares = (-1 * -2) + (1 * -1) + (-1 * 0), 1 + 1 + 1
    import nudgecli.sim.participant_fitting as participants_module

    assert log_drift_correlation(blows, levels, spreads) is None  # 3 pairs < MIN_DRIFT_PAIRS
    original = participants_module.MIN_DRIFT_PAIRS
    try:
        participants_module.MIN_DRIFT_PAIRS = 3
        assert log_drift_correlation(blows, levels, spreads) == pytest.approx(products / squares)
        # a negative estimate is clipped to 0
        flipped = [[], [], [], [np.array([0.3, 0.1, 0.3, 0.1])]]
        assert log_drift_correlation(flipped, levels, spreads) == 0.0
    finally:
        participants_module.MIN_DRIFT_PAIRS = original


def test_participant_from_log_recovers_the_drift() -> None:
    from dataclasses import replace

    truth = replace(make_participant(ramp=2), drift_correlation=0.9)
    session = simulate_distortion_session(truth, CalibrationSection(prompts_per_label=40),
                                          InterfaceSection(), generator(8, "drift"))
    estimated = participant_from_log(session, template=truth)
    # ~4 x 40 blows of ~20 plateau samples: the lag-1 estimate's standard error is about 0.01
    assert estimated.drift_correlation == pytest.approx(0.9, abs=0.04)
    session = simulate_distortion_session(replace(truth, drift_correlation=0.0),
                                          CalibrationSection(prompts_per_label=40), InterfaceSection(),
                                          generator(8, "drift"))
    independent = participant_from_log(session, template=truth)
    assert independent.drift_correlation < 0.1


@needs_shared
def test_the_pilots_pressure_drifts() -> None:
    # PopulationSection's docstring: pooled lag-1 correlations 0.94 (andrewtest), 0.99 (deepaktest)
    found = {name: participant_from_log(SHARED_CALIBRATION / name).drift_correlation
             for name in ("andrewtest", "deepaktest")}
    assert round(found["andrewtest"], 2) == 0.94 and found["deepaktest"] == 0.99


def test_drawn_drift_lies_in_its_range_and_comes_last() -> None:
    population = PopulationSection(drift_correlation=(0.3, 0.4))
    drawn = draw_participants(population, 20, seed=4)
    assert all(0.3 <= p.drift_correlation <= 0.4 for p in drawn)
    # drawn after every other field: the rest of each participant does not depend on it
    other = draw_participants(PopulationSection(drift_correlation=(0.6, 0.7)), 20, seed=4)
    for a, b in zip(drawn, other, strict=True):
        assert replace_drift(a, 0.0) == replace_drift(b, 0.0)
    with pytest.raises(ValueError, match="drift_correlation"):
        replace_drift(drawn[0], 1.0)


def replace_drift(participant: Participant, value: float) -> Participant:
    from dataclasses import replace

    return replace(participant, drift_correlation=value)


@given(label=st.integers(0, 3), ramp=st.integers(0, 4), start=st.integers(0, 6), n=st.integers(1, 30),
       rho=st.floats(0.0, 0.99), seed=st.integers(0, 2**16),
       previous=st.one_of(st.none(), st.floats(-3.0, 3.0)),
       levels=st.lists(st.floats(0.0, 1.4), min_size=4, max_size=4),
       spreads=st.lists(st.floats(0.0, 0.6), min_size=4, max_size=4))
@settings(max_examples=200)
def test_a_blow_sample_by_sample_is_the_array_blow_bit_for_bit(
        label: int, ramp: int, start: int, n: int, rho: float, seed: int, previous: float | None,
        levels: list[float], spreads: list[float]) -> None:
    # the simulated person computes a soft hold one sample at a time (drift_step, sample_pressure);
    # the array methods (drift_normals, pressures_from_normals) are the definition
    participant = Participant(
        index=0, seed_key="test/samples", pressure_level=LABEL_SIGN * (np.array(levels) + 1e-3),
        pressure_spread=np.array(spreads), mapping=mapping_with_error(0.0), epsilon=0.1, rest_s=0.5,
        operate_s=3.0, action_pause_s=0.2, hard_blow_s=0.5, reaction_s=1.0, onset_ramp_samples=ramp,
        drift_correlation=rho)
    innovations = np.random.default_rng(seed).standard_normal(n)
    normals = drift_normals(innovations, rho, previous)
    pressures = participant.pressures_from_normals(label, normals, start=start)
    last = previous
    for k, innovation in enumerate(innovations.tolist()):
        normal = innovation if last is None else participant.drift_step(last, innovation)
        assert normal == normals[k] and np.signbit(normal) == np.signbit(normals[k])
        pressure = participant.sample_pressure(label, start + k, normal)
        assert pressure == pressures[k] and np.signbit(pressure) == np.signbit(pressures[k])
        last = normal


@pytest.mark.parametrize("rho", [1.5, -0.2])
def test_a_drift_correlation_out_of_range_is_named(rho: float) -> None:
    # checked before anything is derived from it (sqrt(1 - rho^2) fails first for |rho| > 1)
    with pytest.raises(ValueError, match="drift_correlation must lie in"):
        Participant(index=0, seed_key="test/rho", pressure_level=np.array([-0.6, 0.9, -0.12, 0.25]),
                    pressure_spread=np.full(4, 0.1), mapping=mapping_with_error(0.0), epsilon=0.1, rest_s=0.5,
                    operate_s=3.0, action_pause_s=0.2, hard_blow_s=0.5, reaction_s=1.0, drift_correlation=rho)


def test_ramp_counts_are_drawn_over_the_whole_inclusive_range() -> None:
    # integer ranges include both ends: a one-value range gives that value, and over many draws
    # every count of the default ranges occurs
    narrow = PopulationSection(onset_ramp_samples=(2, 2), offset_ramp_samples=(3, 3))
    fixed = draw_participants(narrow, 3, seed=4)
    assert [(p.onset_ramp_samples, p.offset_ramp_samples) for p in fixed] == [(2, 3)] * 3
    population = PopulationSection()
    drawn = draw_participants(population, 200, seed=1)
    for name in ("onset_ramp_samples", "offset_ramp_samples"):
        low, high = getattr(population, name)
        assert {getattr(p, name) for p in drawn} == set(range(low, high + 1)), name


def test_an_intended_label_of_probability_zero_is_never_drawn() -> None:
    # inverse-CDF sampling: label k for u in [cdf[k-1], cdf[k]); a zero-probability label has an
    # empty interval, even at u = 0 and at u exactly on a boundary
    mapping = np.zeros((3, 4, 4))
    mapping[..., 2] = 0.25
    mapping[..., 3] = 0.75
    person = Participant(index=0, seed_key="t", pressure_level=np.array([-0.8, 0.8, -0.15, 0.15]),
                         pressure_spread=np.full(4, 0.05), mapping=mapping, epsilon=0.0, rest_s=0.5,
                         operate_s=3.0, action_pause_s=0.2, hard_blow_s=0.4, reaction_s=0.5)
    assert person.intended_label(0, 0, FixedUniform(0.0)) == 2
    assert person.intended_label(1, 2, FixedUniform(0.25)) == 3
    assert person.intended_label(1, 2, FixedUniform(0.2499)) == 2


def test_drawn_levels_are_floored_at_twice_the_zero_threshold() -> None:
    # a range reaching 0 would give a level without a side (and a blow that is never an input)
    population = PopulationSection(soft_puff_level=(0.0, 0.001), soft_sip_level=(0.0, 0.0))
    for person in draw_participants(population, 5, seed=0):
        assert person.pressure_level[SOFT_PUFF] == -2 * ZERO_THRESHOLD == -0.004
        assert person.pressure_level[SOFT_SIP] == 0.004
        assert abs(person.pressure_level[HARD_PUFF]) >= population.hard_puff_level[0]


def test_participant_from_log_takes_the_reaction_from_the_positive_onsets_by_hand() -> None:
    # a hand-built stream: 8 prompts of 3 s (then 1 s blank), each blow from a known sample on;
    # one blow is already on at its prompt's first sample (onset 0: no reaction to measure)
    import math
    import statistics

    onsets = [3, 4, 6, 9, 3, 5, 0, 12]  # samples after each prompt's first
    labels = [LABELS[k % 4] for k in range(8)]
    magnitude = dict(zip(LABELS, (0.6, 0.7, 0.15, 0.2), strict=True))  # Hard/Soft Puff/Sip, in label order
    t, pressure, intended, delays = [], [], [], []
    for prompt, (onset, label) in enumerate(zip(onsets, labels, strict=True)):
        first = len(t)
        for j in range(40):
            t.append(round((first + j) * 0.1, 10))
            on = j < 30
            intended.append(label if on else "")
            blowing = on and onset <= j < 29
            sign = LABEL_SIGN[LABELS.index(label)]
            pressure.append(sign * (magnitude[label] + 0.01 * math.sin(j + prompt)) if blowing else 0.0)
        if onset > 0:
            delays.append(t[first + onset] - t[first])
    frame = pd.DataFrame({"t": t, "pressure": pressure, "intended": intended})
    person = participant_from_log(frame)
    centre = statistics.median(math.log(d) for d in delays)
    assert person.reaction_s == pytest.approx(statistics.median(delays), rel=1e-12)
    assert person.reaction_s == pytest.approx(0.5, rel=1e-9)
    assert person.reaction_log_sd == pytest.approx(
        1.4826 * statistics.median(abs(math.log(d) - centre) for d in delays), rel=1e-12)


def test_censored_normal_fit_of_all_saturated_samples_by_hand() -> None:
    # nothing below the ceiling: spread SATURATED_SPREAD (0.05) and the level that saturates
    # 1 - 0.5 / n of the time (the fraction is capped below 1)
    from statistics import NormalDist

    level, spread = censored_normal_fit(np.ones(50))
    assert spread == 0.05
    assert level == pytest.approx(1.0 + 0.05 * NormalDist().inv_cdf(1 - 0.5 / 50), rel=1e-12)


@given(label=st.integers(0, 3), onset=st.integers(0, 4), peak=st.integers(1, 4), offset=st.integers(0, 3),
       seed=st.integers(0, 2**16), levels=st.lists(st.floats(0.0, 1.4), min_size=4, max_size=4),
       spreads=st.lists(st.floats(0.0, 0.6), min_size=4, max_size=4))
@settings(max_examples=150)
def test_a_pulse_is_its_samples_in_plain_floats_bit_for_bit(label: int, onset: int, peak: int, offset: int,
                                                             seed: int, levels: list[float],
                                                             spreads: list[float]) -> None:
    # the pulse's law sample by sample: f_j * (|level| + spread z_j), clipped to [0, 1], signed; the
    # onset rises (j + 1) / (onset + 1), the offset falls (offset - j) / (offset + 1)
    participant = Participant(
        index=0, seed_key="test/pulse", pressure_level=LABEL_SIGN * (np.array(levels) + 1e-3),
        pressure_spread=np.array(spreads), mapping=mapping_with_error(0.0), epsilon=0.1, rest_s=0.5,
        operate_s=3.0, action_pause_s=0.2, hard_blow_s=0.5, reaction_s=1.0, onset_ramp_samples=onset,
        offset_ramp_samples=offset)
    normals = np.random.default_rng(seed).standard_normal(onset + peak + offset)
    fractions = ([(j + 1) / (onset + 1.0) for j in range(onset)] + [1.0] * peak
                 + [(offset - j) / (offset + 1.0) for j in range(offset)])
    level = abs(float(participant.pressure_level[label]))
    spread = float(participant.pressure_spread[label])
    sign = -1.0 if label in (HARD_PUFF, SOFT_PUFF) else 1.0
    expected = [sign * min(max(f * (level + spread * z), 0.0), 1.0)
                for f, z in zip(fractions, normals.tolist(), strict=True)]
    pressures = participant.pulse_pressures(label, normals, peak)
    assert pressures.dtype == np.float64 and pressures.tolist() == expected
    assert np.signbit(pressures).tolist() == np.signbit(expected).tolist()
    # the shape is made once and shared, so nobody may change it
    assert pulse_fractions(onset, peak, offset) is pulse_fractions(onset, peak, offset)
    assert not pulse_fractions(onset, peak, offset).flags.writeable


@given(seed=st.integers(0, 2**32 - 1), median=st.floats(0.01, 5.0), log_sd=st.floats(0.0, 1.5))
@settings(max_examples=200)
def test_one_reaction_delay_is_the_arrays_bit_for_bit(seed: int, median: float, log_sd: float) -> None:
    # a person's reaction (one delay) against the array law of size one, from the same stream
    rng, reference_rng = np.random.default_rng(seed), np.random.default_rng(seed)
    participant = Participant(
        index=0, seed_key="test/delay", pressure_level=LABEL_SIGN * 0.5, pressure_spread=np.full(4, 0.1),
        mapping=mapping_with_error(0.0), epsilon=0.1, rest_s=0.5, operate_s=3.0, action_pause_s=0.2,
        hard_blow_s=0.5, reaction_s=1.0, event_reaction_s=median, event_reaction_log_sd=log_sd)
    for _ in range(3):
        assert participant.event_reaction(rng) == float(lognormal_delays(median, log_sd, 1, reference_rng)[0])
    one = float(lognormal_delays(median, log_sd, 1, reference_rng)[0])
    assert lognormal_delay(median, log_sd, rng) == one
    assert rng.bit_generator.state == reference_rng.bit_generator.state
