"""One belief's entropy and Bayes update in plain floats (every belief update of a trial asks for
them) against the array rules they stand for, ``-xlogy(b, b).sum()`` and ``b l / sum(b l)``, bit for
bit."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.model import portable_math
from nudgecli.model.inference import BELIEF_FLOOR, _belief_entropy, bayes_update, normalised_entropy
from nudgecli.model.log_terms import xlogy


def array_rule(belief: np.ndarray) -> float:
    """The entropy as the array path computes it (masked log, multiply, numpy's sum)."""
    return float(-xlogy(belief, belief).sum(axis=-1))


def same_float(a: float, b: float) -> bool:
    return (np.isnan(a) and np.isnan(b)) or (a == b and np.signbit(a) == np.signbit(b))


entries = st.one_of(st.floats(0.0, 1.0), st.sampled_from([0.0, 1e-300, 5e-324, 1.0, 0.25]))
beliefs = st.integers(2, 9).flatmap(lambda n: st.lists(entries, min_size=n, max_size=n))


@settings(max_examples=400, deadline=None)
@given(beliefs, st.booleans())
def test_a_beliefs_entropy_is_the_array_rules_bit_for_bit(values: list[float], normalise: bool) -> None:
    belief = np.array(values)
    if normalise and belief.sum() > 0:
        belief = belief / belief.sum()
    assert same_float(_belief_entropy(belief), array_rule(belief))


def test_many_random_beliefs_of_every_size_match_the_array_rule() -> None:
    rng = np.random.default_rng(39)
    for n_goals in range(2, 10):
        for concentration in (0.05, 1.0, 20.0):
            for belief in rng.dirichlet(np.full(n_goals, concentration), size=3000):
                assert _belief_entropy(belief) == array_rule(belief)
    # a strided view (a column of a batch) is summed in the same order
    batch = rng.dirichlet(np.ones(4), size=50)
    for row in batch.T.copy().T:
        assert _belief_entropy(row) == array_rule(row)


def test_the_normalised_entropy_of_one_belief_is_a_batchs_row() -> None:
    # the one-belief path against the (N, G) path, which keeps xlogy and np.clip
    rng = np.random.default_rng(7)
    batch = rng.dirichlet(np.ones(4), size=2000)
    batch[0] = [1.0, 0.0, 0.0, 0.0]
    batch[1] = 0.25
    rows = [normalised_entropy(belief) for belief in batch]
    assert rows == normalised_entropy(batch).tolist()


# --- one belief's Bayes update (Eq. 7) in plain floats ---------------------------------------------

def array_update(belief: np.ndarray, likelihood: np.ndarray) -> np.ndarray:
    """Eq. 7 as the array rule computes it: numpy's product, sum and quotient, a possible goal kept
    at the floor."""
    unnormalised = belief * likelihood
    posterior = unnormalised / unnormalised.sum()
    return np.where((belief > 0) & (likelihood > 0), np.maximum(posterior, BELIEF_FLOOR), posterior)


positives = st.one_of(st.floats(1e-300, 1.0), st.sampled_from([1e-300, 5e-324, 1.0, 0.25, 0.1, 1 / 3]))
pairs = st.integers(1, 9).flatmap(lambda n: st.tuples(st.lists(positives, min_size=n, max_size=n),
                                                        st.lists(entries, min_size=n, max_size=n)))


@settings(max_examples=400, deadline=None)
@given(pairs, st.booleans())
def test_one_beliefs_update_is_the_array_rules_bit_for_bit(pair: tuple[list[float], list[float]],
                                                          normalise: bool) -> None:
    belief, likelihood = np.array(pair[0]), np.array(pair[1])
    if normalise:
        belief = belief / belief.sum()
    if not (belief * likelihood).sum() > 0.0:
        with pytest.raises(ValueError, match="zero probability"):
            bayes_update(belief, likelihood)
        return
    updated = bayes_update(belief, likelihood)
    expected = array_update(belief, likelihood)
    assert updated.dtype == expected.dtype and updated.shape == expected.shape
    assert updated.tobytes() == expected.tobytes()


def test_many_random_updates_of_every_size_match_the_array_rule() -> None:
    rng = np.random.default_rng(41)
    for n_goals in range(1, 10):
        for concentration in (0.05, 1.0, 20.0):
            beliefs = rng.dirichlet(np.full(n_goals, concentration), size=2000)
            likelihoods = rng.dirichlet(np.ones(4), size=(2000, n_goals))[:, :, 0] ** rng.integers(1, 8)
            for belief, likelihood in zip(beliefs, likelihoods, strict=True):
                expected = array_update(belief, likelihood)
                assert bayes_update(belief, likelihood).tobytes() == expected.tobytes()
    # a likelihood numpy broadcasts, and a goal transition, keep the array rule
    belief = np.array([0.5, 0.3, 0.2])
    assert bayes_update(belief, np.array([0.4])).tolist() == array_update(belief, np.array([0.4])).tolist()
    stay = np.full((3, 3), 0.05) + np.eye(3) * 0.85
    assert bayes_update(belief, np.array([0.2, 0.3, 0.5]), stay).tolist() == array_update(
        portable_math.matmul(belief, stay), np.array([0.2, 0.3, 0.5])).tolist()
