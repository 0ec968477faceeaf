"""Goal inference: Eq. 6/7 against brute-force sums, entropy, the study's decay."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from nudgecli.config import InferenceSection
from nudgecli.model.inference import (
    DecayCounters,
    DecaySettings,
    bayes_update,
    decay_on_empty_sample,
    decay_weight,
    normalised_entropy,
)

#: The study's forgetting: the ``[inference]`` defaults (delay 10, rate 0.008, cap 1000).
_INFERENCE = InferenceSection()
STUDY = DecaySettings(_INFERENCE.decay_delay, _INFERENCE.decay_rate, _INFERENCE.decay_cap)
RATE = {"rate": STUDY.rate, "cap": STUDY.cap}

def brute_force_update(belief: list[float], likelihood: list[float],
                       transition: list[list[float]] | None) -> list[float]:
    """Eq. 6 (Eq. 7 without a transition) with explicit loops."""
    n = len(belief)
    posterior = []
    for g in range(n):
        prior = belief[g] if transition is None else sum(belief[k] * transition[k][g] for k in range(n))
        posterior.append(prior * likelihood[g])
    total = sum(posterior)
    return [p / total for p in posterior]


def _random_problem(rng: np.random.Generator, n_goals: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    belief = rng.dirichlet(np.ones(n_goals))
    likelihood = rng.random(n_goals)
    likelihood[rng.random(n_goals) < 0.3] = 0.0  # exact zeros
    likelihood[rng.integers(n_goals)] = rng.random() + 0.1  # but not all of them
    transition = rng.dirichlet(np.ones(n_goals), size=n_goals)
    return belief, likelihood, transition


@pytest.mark.parametrize("seed", range(20))
def test_bayes_update_equals_brute_force(seed: int) -> None:
    rng = np.random.default_rng(seed)
    belief, likelihood, transition = _random_problem(rng, int(rng.integers(2, 7)))
    np.testing.assert_allclose(bayes_update(belief, likelihood),
                               brute_force_update(belief.tolist(), likelihood.tolist(), None),
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(bayes_update(belief, likelihood, transition),
                               brute_force_update(belief.tolist(), likelihood.tolist(), transition.tolist()),
                               rtol=0, atol=1e-12)


def test_bayes_update_certain_belief_and_impossible_observation() -> None:
    certain = np.array([0.0, 1.0, 0.0])
    np.testing.assert_array_equal(bayes_update(certain, np.array([0.9, 0.2, 0.5])), certain)
    with pytest.raises(ValueError, match="zero probability"):
        bayes_update(certain, np.array([0.9, 0.0, 0.5]))


@settings(max_examples=60, deadline=None)
@given(arrays(float, st.integers(2, 8), elements=st.floats(0.0, 1.0)),
       arrays(float, 8, elements=st.floats(0.0, 1.0)))
def test_posterior_sums_to_one(raw_belief: np.ndarray, raw_likelihood: np.ndarray) -> None:
    likelihood = raw_likelihood[: raw_belief.size]
    if not (raw_belief * likelihood).sum() > 1e-300:
        return
    posterior = bayes_update(raw_belief / raw_belief.sum(), likelihood)
    assert posterior.sum() == pytest.approx(1.0, abs=1e-12)
    assert np.all(posterior >= 0)


def test_normalised_entropy_values() -> None:
    assert normalised_entropy(np.full(4, 0.25)) == pytest.approx(1.0)
    assert normalised_entropy(np.array([0.0, 1.0, 0.0])) == 0.0
    assert normalised_entropy(np.array([1.0])) == 0.0
    b = np.array([0.5, 0.25, 0.25, 0.0])
    base2 = -sum(p * math.log2(p) for p in b if p > 0) / math.log2(4)  # the study's base-2 form
    assert normalised_entropy(b) == pytest.approx(base2, abs=1e-12)
    batch = normalised_entropy(np.array([[0.25] * 4, [1.0, 0, 0, 0]]))
    np.testing.assert_allclose(batch, [1.0, 0.0])


def test_decay_weight_formula() -> None:
    assert decay_weight(0, **RATE) == 0.0
    assert decay_weight(5, **RATE) == pytest.approx(1 - math.exp(-0.04))
    assert decay_weight(5000, **RATE) == pytest.approx(1 - math.exp(-0.008 * 1000))  # capped


def test_decay_sequence() -> None:
    belief = np.array([0.7, 0.2, 0.1])
    uniform = np.full(3, 1 / 3)
    counters = DecayCounters()
    b = belief
    for n in range(1, 11):  # the first 10 empty samples change nothing
        b, counters = decay_on_empty_sample(b, counters, STUDY)
        np.testing.assert_array_equal(b, belief)
        assert counters == DecayCounters(empty_samples=n, decay_steps=0)
    n_decaying = 25
    for _ in range(n_decaying):
        b, counters = decay_on_empty_sample(b, counters, STUDY)
    assert counters == DecayCounters(empty_samples=10 + n_decaying, decay_steps=n_decaying)
    # b - U shrinks by prod_k (1 - f_k) = exp(-0.008 * sum_{k<n} k) = exp(-0.008 n (n - 1) / 2)
    residual = math.exp(-0.008 * n_decaying * (n_decaying - 1) / 2)
    np.testing.assert_allclose(b - uniform, residual * (belief - uniform), atol=1e-12)
    assert b.sum() == pytest.approx(1.0)


def test_decay_first_mix_is_zero_and_cap_applies() -> None:
    belief = np.array([0.9, 0.1])
    b, counters = decay_on_empty_sample(belief, DecayCounters(empty_samples=10), STUDY)
    np.testing.assert_array_equal(b, belief)  # k = 0: f = 0
    assert counters.decay_steps == 1
    custom = DecaySettings(delay=0, rate=0.5, cap=2)
    b, _ = decay_on_empty_sample(belief, DecayCounters(empty_samples=3, decay_steps=7), custom)
    f = 1 - math.exp(-0.5 * 2)
    np.testing.assert_allclose(b, (1 - f) * belief + f * 0.5)


def _beliefs(g: int) -> st.SearchStrategy[np.ndarray]:
    drawn = arrays(np.float64, g, elements=st.floats(0.0, 1.0)).filter(lambda b: b.sum() > 0)
    return st.one_of(drawn.map(lambda b: b / b.sum()), st.integers(0, g - 1).map(lambda k: np.eye(g)[k]))


@given(st.integers(2, 8).flatmap(_beliefs))
def test_one_belief_has_the_entropy_of_a_batch_bit_for_bit(belief: np.ndarray) -> None:
    # a single belief takes a plain-float path; a batch row is the definition (np.clip, np.log)
    single = normalised_entropy(belief)
    batch = normalised_entropy(np.stack([belief, belief]))[0]
    assert isinstance(single, float)
    assert single == batch and math.copysign(1.0, single) == math.copysign(1.0, batch)
