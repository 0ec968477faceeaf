"""One belief's entropy in plain floats (every belief update of a trial asks for it) against the
array rule it stands for, ``-xlogy(b, b).sum()``, bit for bit."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.model.inference import _belief_entropy, normalised_entropy
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
