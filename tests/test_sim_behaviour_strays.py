"""Pressure control within a soft blow (sim/behaviour_strays.py, ``[behaviour] deadband_strays``): the
rules by hand, the mean stray against scipy, the schedule's long-run share, a person's soft blow
step by step, and the switch off reproducing the earlier person's runs exactly."""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.model.interface import MOVE_N, NO_INPUT, SIP_DEADBAND, SOFT_SIP, label_of_pressure
from nudgecli.model.world import N_MODES, N_STATES, discretise, state_index
from nudgecli.sim import behaviour, behaviour_strays
from nudgecli.sim.behaviour import SimulatedPerson
from nudgecli.sim.behaviour_settings import BehaviourSettings
from nudgecli.sim.behaviour_strays import (
    STRAY_LOG_SD,
    STRAY_RELEASE_SHARE,
    controlled_pressure,
    mean_stray_samples,
    stray_hazard,
    stray_schedule,
)
from nudgecli.sim.participants import Participant, mapping_with_error

THRESHOLDS = (0.05, 0.3, 0.5)


@pytest.mark.parametrize(("pressure", "sign", "straying", "returning", "expected"), [
    (0.42, 1.0, False, False, 0.3),  # a deadband reading outside a stray: the soft band's edge
    (-0.42, -1.0, False, False, -0.3),
    (0.3, 1.0, False, False, 0.3),  # the soft threshold reads soft already
    (0.2, 1.0, True, False, 0.4),  # a stray reads the deadband's middle
    (0.0, -1.0, True, False, -0.4),  # even from no input, on the label's side
    (0.7, 1.0, True, False, 0.7),  # past the hard threshold: the drawn pressure, stray or not
    (-0.7, -1.0, False, True, -0.7),
    (0.01, 1.0, False, True, 0.3),  # the sample after a stray comes down into the soft band
    (0.0, -1.0, False, True, -0.3),
    (0.01, 1.0, False, False, 0.01),  # elsewhere a dip to no input stays one
    (0.2, 1.0, False, True, 0.2),
])
def test_the_pressure_rules_by_hand(pressure: float, sign: float, straying: bool, returning: bool,
                                    expected: float) -> None:
    assert controlled_pressure(pressure, sign, straying, returning, THRESHOLDS) == pytest.approx(expected)


@pytest.mark.parametrize(("median", "log_sd"), [(2.0, STRAY_LOG_SD), (1.0, 0.5), (3.0, 1.0), (0.7, 0.3)])
def test_the_mean_stray_against_scipy(median: float, log_sd: float) -> None:
    # E[max(1, round(X))] = sum_k k P(L = k), P(L = 1) = P(X < 1.5), P(L = k) = P(k - 1/2 <= X < k + 1/2)
    x = stats.lognorm(s=log_sd, scale=median)
    k = np.arange(2, 5000)
    expected = x.cdf(1.5) + float(np.sum(k * (x.cdf(k + 0.5) - x.cdf(k - 0.5))))
    assert mean_stray_samples(median, log_sd) == pytest.approx(expected, rel=1e-9)


def _mean_stray_loop(median: float, log_sd: float) -> float:
    """The sum of :func:`mean_stray_samples` term by term in plain floats: the reference its blocks
    of numpy arguments and accumulated terms must give bit for bit."""
    if median <= 0.0:
        return 1.0
    total, k, log_median = 1.0, 2, math.log(median)
    while True:
        term = 0.5 * math.erfc((math.log(k - 0.5) - log_median) / (log_sd * math.sqrt(2.0)))
        total += term
        if term < 1e-15:
            return total
        k += 1


@settings(max_examples=60, deadline=None)
@given(median=st.floats(-0.5, 6.0), log_sd=st.one_of(st.just(STRAY_LOG_SD), st.floats(1e-3, 1.6)))
def test_the_mean_stray_is_the_plain_loops_bit_for_bit(median: float, log_sd: float) -> None:
    assert mean_stray_samples.__wrapped__(median, log_sd) == _mean_stray_loop(median, log_sd)


def test_the_mean_stray_past_its_first_block_is_the_plain_loops(monkeypatch: pytest.MonkeyPatch) -> None:
    # the first block ending far too early: the rest of the terms come in blocks of 7
    monkeypatch.setattr(behaviour_strays, "_TAIL_ARGUMENT", 0.1)
    monkeypatch.setattr(behaviour_strays, "_BLOCK", 7)
    for median in (0.05, 1.3, 2.7):
        assert mean_stray_samples.__wrapped__(median, STRAY_LOG_SD) == _mean_stray_loop(median, STRAY_LOG_SD)


@pytest.mark.parametrize(("median", "log_sd"), [(2.0, -0.5), (math.nan, 1.0), (2.0, math.inf)])
def test_a_mean_stray_whose_sum_never_ends_is_refused(median: float, log_sd: float) -> None:
    with pytest.raises(ValueError, match="log-sd"):
        mean_stray_samples.__wrapped__(median, log_sd)


def test_the_mean_stray_without_spread_and_the_hazard_by_hand() -> None:
    assert mean_stray_samples(2.4, 0.0) == 2.0 and mean_stray_samples(0.3, 0.0) == 1.0
    # share 0.2 of strays of 2 samples: a cycle of 1/h soft samples and 2 straying ones, h = 0.2 / (0.8 * 2)
    assert stray_hazard(0.2, 2.0, 0.0) == pytest.approx(0.125)
    assert stray_hazard(0.0, 2.0) == 0.0


def test_a_schedule_solved_by_hand() -> None:
    rng = np.random.default_rng(0)
    # every eligible sample starts a stray of 2: one soft sample between strays
    straying, release = stray_schedule(1.0, 2.0, 10, rng, log_sd=0.0, release_share=0.0)
    assert straying == [True, True, False, True, True, False, True, True, False, True]
    assert release == -1
    # always let go after a stray: the hold ends before its third sample
    straying, release = stray_schedule(1.0, 2.0, 10, rng, log_sd=0.0, release_share=1.0)
    assert straying == [True, True] + [False] * 8 and release == 2
    assert stray_schedule(0.0, 2.0, 10, rng) == ([False] * 10, -1)


def test_the_schedule_strays_the_share_of_a_long_hold() -> None:
    rng = np.random.default_rng(7)
    share, median = 0.12, 2.0
    hazard = stray_hazard(share, median)
    straying = np.array([stray_schedule(hazard, median, 2000, rng, release_share=0.0)[0] for _ in range(150)])
    assert straying.mean() == pytest.approx(share, abs=0.006)
    # the runs: median 2 samples, mean E[L]
    flat = np.concatenate([np.r_[False, row, False] for row in straying]).astype(int)
    edges = np.diff(flat)
    lengths = np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)
    assert np.median(lengths) == 2
    assert lengths.mean() == pytest.approx(mean_stray_samples(median, STRAY_LOG_SD), rel=0.05)


def test_a_stray_is_let_go_with_the_release_share() -> None:
    # hazard 1, strays of one sample: they follow each other until one is let go, so the number of
    # strays up to the release is geometric with mean 1 / STRAY_RELEASE_SHARE
    rng = np.random.default_rng(3)
    counts = []
    for _ in range(3000):
        straying, release = stray_schedule(1.0, 1.0, 400, rng, log_sd=0.0)
        assert 0 < release <= 400
        counts.append(sum(straying))
    assert np.mean(counts) == pytest.approx(1 / STRAY_RELEASE_SHARE, rel=0.06)


# --- a person's soft blow, step by step ------------------------------------------------------------


class Still:
    """A robot that never moves (only the labels matter here)."""

    x, y, theta, mode = 13.5, 7.1, 0.0, 0

    @property
    def state(self) -> int:
        i, j, h = discretise(self.x, self.y, self.theta)
        return int(state_index(i, j, h, self.mode))


def sipping_person(level: float, strays: bool, share: float = 0.0, stray_s: float = 0.2,
                   stall_steps: int = 0) -> SimulatedPerson:
    """A noise-free person who sips softly (move_n, the true mapping's Soft Sip) at ``level``."""
    participant = Participant(index=0, seed_key="test", pressure_level=np.array([-0.8, 0.8, -0.15, level]),
                              pressure_spread=np.zeros(4), mapping=mapping_with_error(0.0), epsilon=0.0,
                              rest_s=0.0, operate_s=30.0, action_pause_s=0.2, hard_blow_s=0.3, reaction_s=0.5,
                              deadband_share=share, deadband_stray_s=stray_s)
    settings = BehaviourSettings(dt=0.1, rest_jitter=0.0, operate_jitter=0.0, pause_jitter=0.0,
                                 hard_blow_jitter=0.0, max_hold_steps=60, stall_steps=stall_steps,
                                 deadband_strays=strays)
    goal = (40.0, 30.0, 0.0)
    i, j, h = discretise(*goal)
    person = SimulatedPerson(participant, settings, np.full(N_STATES, MOVE_N), np.array(goal),
                             int(state_index(i, j, h, 0)) // N_MODES, np.random.default_rng(0))
    person.start_turn(after_autonomy=False)
    return person


def labels_of(person: SimulatedPerson, steps: int) -> list[int]:
    return [label_of_pressure(person.next_input(Still())[1], 0.3, 0.5) for _ in range(steps)]


def test_a_level_inside_the_deadband_reads_soft_under_control_and_deadband_without() -> None:
    assert set(labels_of(sipping_person(0.42, strays=False), 30)) == {SIP_DEADBAND}
    controlled = labels_of(sipping_person(0.42, strays=True), 30)
    assert controlled[0] in (SOFT_SIP, NO_INPUT) and set(controlled) <= {SOFT_SIP, NO_INPUT}
    assert controlled.count(SOFT_SIP) >= 29


def test_a_stray_reads_deadband_then_soft_or_is_let_go(monkeypatch: pytest.MonkeyPatch) -> None:
    def fixed(release: float) -> object:  # strays of exactly 3 samples at every eligible sample
        return lambda hazard, median, n, rng: stray_schedule(1.0, 3.0, n, rng, log_sd=0.0,
                                                             release_share=release)

    monkeypatch.setattr(behaviour, "stray_schedule", fixed(0.0))
    labels = labels_of(sipping_person(0.15, strays=True, share=0.1, stall_steps=10), 12)
    assert labels == [SIP_DEADBAND] * 3 + [SOFT_SIP] + [SIP_DEADBAND] * 3 + [SOFT_SIP] + [SIP_DEADBAND] * 3 \
        + [SOFT_SIP]
    monkeypatch.setattr(behaviour, "stray_schedule", fixed(1.0))
    labels = labels_of(sipping_person(0.15, strays=True, share=0.1), 6)
    assert labels == [SIP_DEADBAND] * 3 + [NO_INPUT] * 2 + [SIP_DEADBAND]  # let go, a 0.2 s pause, again


def test_a_long_stray_is_no_stall(monkeypatch: pytest.MonkeyPatch) -> None:
    # one stray of 15 samples under a 10-step stall: the person waits for its end, then sips on
    monkeypatch.setattr(behaviour, "stray_schedule",
                        lambda hazard, median, n, rng: ([True] * 15 + [False] * (n - 15), -1))
    labels = labels_of(sipping_person(0.15, strays=True, share=0.1, stall_steps=10), 17)
    assert labels == [SIP_DEADBAND] * 15 + [SOFT_SIP] * 2


def test_the_switch_and_the_thresholds_come_from_the_experiment() -> None:
    settings = BehaviourSettings.from_config(load_experiment("ciaa-teleop"))
    assert settings.deadband_strays is True
    assert (settings.zero_threshold, settings.soft_threshold, settings.hard_threshold) == \
        pytest.approx((0.05, 0.3, 0.5), abs=0.05)
    off = BehaviourSettings.from_config(load_experiment("ciaa-teleop", ["behaviour.deadband_strays=false",
                                                                        "interface.soft_threshold=0.25"]))
    assert off.deadband_strays is False and off.soft_threshold == 0.25


# --- the switch off: the earlier person's runs, bit for bit -----------------------------------------

#: Digests of the steps and trials of `nudge simulate PRESET --participants N --seed 3` made before
#: the mechanism existed (the commit before issue 37's), with :func:`run_digests`. smoke's were made
#: again when the model's logs and products became the same on every CPU (2026-11-28,
#: ``nudgecli.model.portable_math``): against the earlier digests' run (``7295c80``, switch off) its
#: steps then differed only in the last bits of the belief, entropy and alpha, and of the
#: autonomy's command and the pose they move (at most 4e-14), its trials only in
#: ``final_entropy``; the same rows and events. ciaa-teleop has no belief, and kept its digests.
#: smoke's were made a third time the same day when a heading at a bin's edge became that bin's
#: and the handover came on time: two model fixes that change every turn-taking run, so from then
#: on they pin the switched-off person under today's model, no longer the earlier code's tables.
BEFORE = {("ciaa-teleop", 2): {"steps": "5e8c3f6da595d889", "trials": "b3bc61ccc699bc50"},
          ("smoke", 1): {"steps": "723dbd37460f6f6a", "trials": "328865047e24962b"}}


def run_digests(out: Path) -> dict[str, str]:
    """The first 16 hex digits of the sha256 of each table's CSV, rows in (participant, trial, step) order."""
    digests = {}
    for table in ("steps", "trials"):
        keys = ["participant", "trial"] + (["step"] if table == "steps" else [])
        frame = pd.read_parquet(out / table).sort_values(keys, kind="stable")
        digests[table] = hashlib.sha256(frame.to_csv(index=False).encode()).hexdigest()[:16]
    return digests


@pytest.mark.parametrize(("preset", "participants"), list(BEFORE))
def test_with_the_switch_off_a_run_is_the_earlier_persons(tmp_path: Path, preset: str,
                                                          participants: int) -> None:
    digests = {}
    for switch in ("false", "true"):
        out = tmp_path / switch
        result = CliRunner().invoke(main, ["simulate", preset, "--participants", str(participants),
                                           "--seed", "3", "--set", f"behaviour.deadband_strays={switch}",
                                           "--out", str(out)])
        assert result.exit_code == 0, result.output
        digests[switch] = run_digests(out)
    assert digests["false"] == BEFORE[(preset, participants)]
    assert digests["true"] != digests["false"]  # and on, it is another person
    assert math.isfinite(STRAY_LOG_SD)


def test_each_person_draws_their_control_inside_the_ranges_and_old_records_read_back() -> None:
    from nudgecli.config import PopulationSection
    from nudgecli.sim.participants import draw_participants

    population = PopulationSection()
    people = draw_participants(population, 200, seed=5)
    shares = np.array([p.deadband_share for p in people])
    strays = np.array([p.deadband_stray_s for p in people])
    assert population.deadband_share[0] <= shares.min() and shares.max() <= population.deadband_share[1]
    assert population.deadband_stray_s[0] <= strays.min() and strays.max() <= population.deadband_stray_s[1]
    assert np.ptp(shares) > 0.1 and np.ptp(strays) > 0.1  # spread over the ranges, not one value
    record = people[0].to_record()
    assert Participant.from_record(record) == people[0]
    # a participants table written before issue 37 has neither column: the defaults are used
    older = {k: v for k, v in record.items() if not k.startswith("deadband_")}
    assert Participant.from_record(older).deadband_share == Participant.__dataclass_fields__[
        "deadband_share"].default
    with pytest.raises(ValueError, match="deadband_share"):
        Participant(**{**{f: getattr(people[0], f) for f in ("index", "seed_key", "pressure_level",
                                                              "pressure_spread", "mapping", "epsilon",
                                                              "rest_s", "operate_s", "action_pause_s",
                                                              "hard_blow_s", "reaction_s")},
                       "deadband_share": 1.0})


def schedule_sample_by_sample(hazard: float, median: float, n: int, rng: np.random.Generator, log_sd: float,
                              release_share: float) -> tuple[list[bool], int]:
    """The module's schedule read off its docstring, one sample after another: the ``k``-th sample
    whose uniform is below the hazard is the ``k``-th candidate and owns the ``k``-th length and
    release draws, whether or not it starts a stray."""
    starts, lengths, releases = rng.random(n), rng.standard_normal(n), rng.random(n)
    straying = [False] * n
    candidate, free_from = -1, 0
    for sample in range(n):
        if not starts[sample] < hazard:
            continue
        candidate += 1
        if sample < free_from:  # inside a stray, or the sample right after it
            continue
        end = sample + max(1, round(median * math.exp(log_sd * lengths[candidate])))
        for inside in range(sample, min(end, n)):
            straying[inside] = True
        if releases[candidate] < release_share:
            return straying, end
        free_from = end + 1
    return straying, -1


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), hazard=st.sampled_from([0.0, 0.02, 0.3, 1.0]) | st.floats(0.0, 1.0),
       median=st.floats(0.2, 6.0), n=st.integers(0, 80), log_sd=st.sampled_from([STRAY_LOG_SD, 0.0, 1.3]),
       release_share=st.sampled_from([STRAY_RELEASE_SHARE, 0.0, 1.0]) | st.floats(0.0, 1.0))
def test_the_schedule_is_the_sample_by_sample_reading(seed: int, hazard: float, median: float, n: int,
                                                      log_sd: float, release_share: float) -> None:
    # the same three draws, the same flags and release, and the stream left where the reading leaves it
    rng, reference_rng = np.random.default_rng(seed), np.random.default_rng(seed)
    assert (stray_schedule(hazard, median, n, rng, log_sd, release_share)
            == schedule_sample_by_sample(hazard, median, n, reference_rng, log_sd, release_share))
    assert rng.bit_generator.state == reference_rng.bit_generator.state
