"""Goal inference keeps a goal it has evidence against at a floor, never at exactly 0
(nudgecli.model.inference.bayes_update): a linear product of many small likelihoods underflowed to
0, and a goal at 0 never came back. Above the floor every update is the plain rule, bit for bit."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.model.inference import bayes_update

#: The floor the brief of the fix names (nudgecli.model.inference.BELIEF_FLOOR).
FLOOR = 1e-300
FOR_GOAL_0 = np.array([0.89, 0.024])
FOR_GOAL_1 = FOR_GOAL_0[::-1].copy()
#: An identity goal transition: the same update by the array rule (goal_stay = 1).
STAY = np.eye(2)


def _run(belief: np.ndarray, likelihood: np.ndarray, updates: int, transition: np.ndarray | None = None,
         ) -> np.ndarray:
    for _ in range(updates):
        belief = bayes_update(belief, likelihood, transition)
    return belief


def test_a_goal_driven_past_the_smallest_float_comes_back():
    for transition in (None, STAY):
        # 250 updates at a ratio of 37 are 392 decades: the old belief of goal 1 was exactly 0, for good
        away = _run(np.array([0.5, 0.5]), FOR_GOAL_0, 250, transition)
        assert away[1] == FLOOR and away[0] == 1.0
        back = _run(away, FOR_GOAL_1, 250, transition)
        assert back[1] > 0.999999 and back.sum() == 1.0  # old: [1, 0]
        # from the floor, 300 decades of evidence bring it back to even: 191 updates leave it near 1/3
        assert 0.3 < _run(away, FOR_GOAL_1, 191, transition)[1] < 0.4


@settings(max_examples=60, deadline=None)
@given(st.floats(0.02, 0.98), st.floats(0.02, 0.98), st.integers(1, 150))
def test_a_round_trip_within_the_floor_returns_to_where_it_started(p, q, updates):
    # one way and back by the same likelihoods: within the floor's range nothing is lost
    likelihood = np.array([p, q])
    decades = updates * abs(np.log10(p / q))
    if decades > 290:
        return
    for transition in (None, STAY):
        away = _run(np.array([0.5, 0.5]), likelihood, updates, transition)
        back = _run(away, likelihood[::-1].copy(), updates, transition)
        assert np.allclose(back, [0.5, 0.5], atol=1e-6, rtol=0)


finite = st.floats(1e-290, 1.0)


@settings(max_examples=80, deadline=None)
@given(st.lists(st.tuples(finite, finite), min_size=2, max_size=8))
def test_above_the_floor_an_update_is_the_plain_rule_bit_for_bit(pairs):
    belief = np.array([b for b, _ in pairs])
    belief /= belief.sum()
    likelihood = np.array([p for _, p in pairs])
    plain = belief * likelihood / (belief * likelihood).sum()
    if plain.min() < FLOOR:
        return
    assert bayes_update(belief, likelihood).tobytes() == plain.tobytes()


@settings(max_examples=80, deadline=None)
@given(st.lists(st.tuples(st.sampled_from([0.0, 1e-305, 1e-200, 0.3, 1.0]),
                          st.sampled_from([0.0, 1e-250, 1e-120, 0.5, 1.0])), min_size=2, max_size=8))
def test_a_possible_goal_keeps_the_floor_and_an_impossible_one_stays_at_zero(pairs):
    belief = np.array([b for b, _ in pairs])
    likelihood = np.array([p for _, p in pairs])
    if not (belief * likelihood).sum() > 0:
        return
    for transition in (None, np.eye(len(pairs))):
        posterior = bayes_update(belief, likelihood, transition)
        possible = (belief > 0) & (likelihood > 0)
        assert (posterior[possible] >= FLOOR).all()
        assert (posterior[~possible] == 0.0).all()
        assert abs(posterior.sum() - 1.0) < 1e-12
