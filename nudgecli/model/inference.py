"""Recursive Bayesian goal inference (paper Eq. 6 and 7), entropy and the optional decay."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from nudgecli.model import portable_math
from nudgecli.model.log_terms import xlogy

#: The least posterior a goal keeps while its prior and the observation's likelihood under it are
#: positive. Without it a run of inputs against a goal multiplied its belief down to exactly 0 (past
#: the smallest float, about 1e-308: some 200 updates at a likelihood ratio of 37, or seconds of
#: one-sided input under ``inference.update = "sample"``), and a goal at 0 never came back whatever
#: the person did next. 1e-300 lies far below any belief the presets reach (their smallest is about
#: 1e-70), whose updates it leaves bit for bit as they were, and far enough above the smallest
#: normal float that a floored goal's next product is no subnormal.
BELIEF_FLOOR = 1e-300


def predict_belief(belief: np.ndarray, goal_transition: np.ndarray | None = None) -> np.ndarray:
    """The prior for the next step, ``sum_g' b(g') p(g | g')`` (the bracket of Eq. 6).

    Parameters
    ----------
    belief
        ``(G,)`` current belief.
    goal_transition
        ``(G, G)`` row-stochastic ``p(g_t | g_{t-1})`` (row = previous goal), or ``None`` for
        the identity (Eq. 7).

    Returns
    -------
    np.ndarray
        ``(G,)``.
    """
    b = np.asarray(belief, dtype=float)
    return b if goal_transition is None else portable_math.matmul(b, np.asarray(goal_transition, dtype=float))


def bayes_update(belief: np.ndarray, likelihood: np.ndarray,
                 goal_transition: np.ndarray | None = None) -> np.ndarray:
    """One step of Eq. 6 (Eq. 7 when ``goal_transition`` is ``None``).

    Parameters
    ----------
    belief
        ``(G,)`` belief before the observation.
    likelihood
        ``(G,)`` ``p(phi_m | g, s)`` of the observed label at the current state.
    goal_transition
        ``(G, G)`` row-stochastic goal transition, or ``None`` for the identity.

    Returns
    -------
    np.ndarray
        ``(G,)`` the normalised posterior, in which a goal whose prior and likelihood are positive
        keeps at least :data:`BELIEF_FLOOR` (so it can recover; the sum stays 1 to the last bit).

    Raises
    ------
    ValueError
        If every goal has zero posterior mass (the observation is impossible under the model).
    """
    likelihood = np.asarray(likelihood, dtype=float)
    # one belief of a few goals and a likelihood of its shape (numpy would broadcast any other)
    if (goal_transition is None and isinstance(belief, np.ndarray) and belief.dtype == np.float64
            and belief.ndim == 1 and 0 < belief.size <= _SEQUENTIAL_SUM_MAX
            and likelihood.shape == belief.shape):
        return _bayes_update_one(belief, likelihood)
    prior = predict_belief(belief, goal_transition)
    unnormalised = prior * likelihood
    total = unnormalised.sum()
    if not total > 0.0:
        raise ValueError("the observation has zero probability under every goal")
    posterior = unnormalised / total
    if posterior.min() < BELIEF_FLOOR:  # rare: a goal nearly ruled out, or one prior or likelihood rules out
        possible = (prior > 0.0) & (likelihood > 0.0)
        posterior = np.where(possible, np.maximum(posterior, BELIEF_FLOOR), posterior)
    return posterior


def _bayes_update_one(belief: np.ndarray, likelihood: np.ndarray) -> np.ndarray:
    """Eq. 7 for one ``(G,)`` belief of at most :data:`_SEQUENTIAL_SUM_MAX` goals in plain floats:
    :func:`bayes_update`'s array rule bit for bit, its floor included (every new label of a trial
    asks for it).

    Each product and quotient is one IEEE operation as numpy's, and the products are added in
    numpy's order for fewer than 8 elements (the first, then the others in turn), so only the
    per-call overhead of four array operations on four numbers goes (``likelihood``: ``(G,)`` too).
    """
    products = [b * p for b, p in zip(belief.tolist(), likelihood.tolist(), strict=True)]
    total = products[0]
    for product in products[1:]:
        total += product
    if not total > 0.0:
        raise ValueError("the observation has zero probability under every goal")
    posterior = [product / total for product in products]
    if min(posterior) < BELIEF_FLOOR:  # rare (see bayes_update): the common update pays one min()
        posterior = [max(value, BELIEF_FLOOR) if b > 0.0 and p > 0.0 else value
                     for value, b, p in zip(posterior, belief.tolist(), likelihood.tolist(), strict=True)]
    return np.array(posterior)


def normalised_entropy(belief: np.ndarray) -> np.ndarray | float:
    """Shannon entropy of the belief divided by ``log |G|``: 0 when certain, 1 when uniform.

    The ratio does not depend on the logarithm's base, so it equals the study's base-2 value.
    Zero entries contribute 0 (``0 log 0 = 0``); a single goal has normalised entropy 0.

    Parameters
    ----------
    belief
        ``(..., G)`` beliefs (each normalised over the last axis).

    Returns
    -------
    np.ndarray or float
        ``(...)`` values in ``[0, 1]``.
    """
    b = np.asarray(belief, dtype=float)
    n_goals = b.shape[-1]
    if n_goals <= 1:
        return np.zeros(b.shape[:-1]) if b.ndim > 1 else 0.0
    if b.ndim == 1:  # one belief, after every update of a trial: np.clip's rule on plain floats
        ratio = _belief_entropy(b) / _log_goals(n_goals)
        return 0.0 if ratio < 0.0 else 1.0 if ratio > 1.0 else ratio
    entropy = -xlogy(b, b).sum(axis=-1)
    return np.clip(entropy / _log_goals(n_goals), 0.0, 1.0)


#: Beliefs of up to this many goals are summed as numpy sums them, element after element (its
#: pairwise sum adds 8 or more elements in another order).
_SEQUENTIAL_SUM_MAX = 7


def _belief_entropy(belief: np.ndarray) -> float:
    """``-sum_g b_g log b_g`` of one ``(G,)`` belief: ``-xlogy(b, b).sum()`` bit for bit.

    Every belief update of a trial asks for it, and xlogy's masked array calls on four numbers
    cost ten times the arithmetic. Without a zero entry (xlogy's one special case; NaN gives NaN
    either way) and for ``G <= 7``, the logs are the C library's as xlogy's
    (:mod:`nudgecli.model.portable_math`), each product one IEEE multiply as numpy's, and the
    terms are added in numpy's order for fewer than 8 elements (the first, then the others in
    turn). ``tests/test_model_inference_fast.py`` holds it to the array rule.
    """
    values = belief.tolist()
    if len(values) > _SEQUENTIAL_SUM_MAX or 0.0 in values:
        return float(-xlogy(belief, belief).sum())
    log = math.log  # every entry is positive here
    total = values[0] * log(values[0])
    for value in values[1:]:
        total += value * log(value)
    return -total


@functools.cache
def _log_goals(n_goals: int) -> float:
    """``log |G|`` from the C library, shared by one belief's ratio and a batch's."""
    return math.log(n_goals)


@dataclass(frozen=True)
class DecaySettings:
    """The study's forgetting of the belief during input pauses (not in the paper).

    Attributes
    ----------
    delay
        Decay starts after more than this many consecutive empty samples.
    rate
        ``f_k = 1 - exp(-rate * min(k, cap))`` for the ``k``-th decaying sample (``k = 0, 1, ...``).
    cap
        Upper bound on ``k`` in the exponent.
    """

    delay: int
    rate: float
    cap: int


@dataclass(frozen=True)
class DecayCounters:
    """The two counters of the decay, reset by any real observation.

    Attributes
    ----------
    empty_samples
        Consecutive samples without an observation so far.
    decay_steps
        Decaying samples so far (the ``k`` of the next one).
    """

    empty_samples: int = 0
    decay_steps: int = 0


def decay_weight(k: int | np.ndarray, rate: float, cap: int) -> float | np.ndarray:
    """Mixing weight towards uniform of the ``k``-th decaying sample: ``1 - exp(-rate min(k, cap))``."""
    return -portable_math.expm1(-rate * np.minimum(k, cap))


def decay_on_empty_sample(belief: np.ndarray, counters: DecayCounters,
                          settings: DecaySettings) -> tuple[np.ndarray, DecayCounters]:
    """Apply one sample without an observation (no input or a deadband label).

    The first ``settings.delay`` empty samples leave the belief unchanged; each further one mixes
    ``b <- (1 - f) b + f U`` with ``f = decay_weight(k)``, ``k = 0, 1, 2, ...`` (so the first mix
    has ``f = 0``). After ``n`` decaying samples the old belief keeps weight
    ``exp(-rate n (n - 1) / 2)`` (below the cap). A real observation restarts both counters:
    pass ``DecayCounters()`` afterwards.

    Parameters
    ----------
    belief
        ``(G,)`` current belief.
    counters
        The counters before this sample.
    settings
        Delay, rate and cap (``[inference] decay_delay``, ``decay_rate``, ``decay_cap``).

    Returns
    -------
    belief : np.ndarray
        ``(G,)`` the belief after this sample.
    counters : DecayCounters
        The counters after this sample.
    """
    b = np.asarray(belief, dtype=float)
    empty = counters.empty_samples + 1
    if empty <= settings.delay:
        return b, DecayCounters(empty_samples=empty, decay_steps=counters.decay_steps)
    f = decay_weight(counters.decay_steps, settings.rate, settings.cap)
    mixed = (1.0 - f) * b + f / b.shape[-1]
    return mixed, DecayCounters(empty_samples=empty, decay_steps=counters.decay_steps + 1)
