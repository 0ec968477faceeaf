"""Pressure control within a soft blow: strays into the Soft-Hard deadband (``[behaviour] deadband_strays``).

What real pressure does inside a soft blow (``shared/data/ciaa-task/HABITS.md``, "Inside a soft
blow"): every one of the ten users strays into the deadband, where the robot stops, for 4.5-21 %
of their soft-blow time; a stray lasts about a fifth of a second (people's medians 0.10-0.30 s,
pooled quartiles 0.10-0.40 s) and in four of five the pressure is back in the soft band within
the same blow, in one of five the blow ends there. The person of :mod:`nudgecli.sim.behaviour`
keeps a soft blow soft while they watch the robot move, and strays:

- outside a stray, a sample of their pressure (:meth:`Participant.sample_pressure`, the drawn
  physiology) that would read deadband reads at the soft band's edge instead: the person keeps the
  blow soft. A sample past the hard threshold stays hard (soft-to-hard confusions are the
  physiology's, and the paper's subject);
- a stray starts at a sample with probability ``h`` (at the blow's first sample, or after at least
  one soft sample), lasts ``L = max(1, round(m exp(s z)))`` samples (``m``: the person's
  ``deadband_stray_s`` in samples, ``s``: :data:`STRAY_LOG_SD`, ``z ~ N(0, 1)``) whose pressure
  reads deadband (the band's middle, or the drawn pressure where it is past the hard threshold),
  and ends back in the soft band (its next sample reads soft, at the band's edge where the drawn
  pressure would read no input), or with probability :data:`STRAY_RELEASE_SHARE` with the
  person letting go (the robot stood still under their blow, as a stall);
- ``h = share / ((1 - share) E[L])`` so that in a long hold the strays take the person's
  ``deadband_share`` of the samples: a cycle is ``1 / h`` steady samples on average and ``E[L]``
  straying ones (:func:`mean_stray_samples`).

The two constants are HABITS.md's, read from the packaged reference (:mod:`nudgecli.reference`):
``STRAY_LOG_SD`` is the log-normal spread of its pooled quartiles of a run (``ln(0.40 / 0.10) /
(2 z_0.75)``; the pooled spread includes the people's spread, so this is an upper bound on one
person's) and ``STRAY_RELEASE_SHARE`` its share of runs after which the blow ends (0.19). The
rest of what follows a run (soft again 80 %, a neutral gap 1 %) is what the physiology gives
after a stray and its return. A hold's whole schedule is drawn when the hold starts (three draws of the hold's
length), so the step loop reads one flag per sample.
"""

from __future__ import annotations

import math
from functools import cache
from statistics import NormalDist

import numpy as np

from nudgecli.reference import packaged_reference

_REFERENCE = packaged_reference("ciaa-people")["habits"]
_RUN = _REFERENCE["deadband_run_in_soft_blow"]["pooled"]
#: The log-sd of a stray's length: HABITS.md's pooled quartiles of a deadband run, read as a log-normal's.
STRAY_LOG_SD = math.log(_RUN["q75"] / _RUN["q25"]) / (2.0 * NormalDist().inv_cdf(0.75))
#: The share of strays after which the person lets go: HABITS.md's "the blow ends" after a run.
STRAY_RELEASE_SHARE = float(_REFERENCE["deadband_then_blow_ends"]["pooled"]["median"])
#: :func:`mean_stray_samples` sums ``P(L >= k)`` until a term falls below this.
_TAIL = 1e-15
#: The argument of ``erfc`` past which a term ``erfc(x) / 2`` is below :data:`_TAIL` (about 5.6):
#: where the terms are expected to end, so that they are evaluated in one block.
_TAIL_ARGUMENT = -NormalDist().inv_cdf(_TAIL) / math.sqrt(2.0)
#: Terms evaluated at once after the first block (where the expected end was too early).
_BLOCK = 1024
#: The first block's length at most (memory; a stray of median m needs about ``3,700 m`` terms).
_MAX_BLOCK = 1 << 20


@cache
def mean_stray_samples(median_samples: float, log_sd: float) -> float:
    """``E[max(1, round(m exp(s z)))]``, ``z ~ N(0, 1)``: the mean length of a stray in samples.

    ``P(L >= k) = P(m exp(s z) >= k - 1/2)`` for ``k >= 2`` (and 1 for ``k = 1``), so
    ``E[L] = 1 + sum_{k >= 2} Phi((ln m - ln(k - 1/2)) / s)``, summed until a term is below
    :data:`_TAIL` (the terms fall with ``k``). With ``s = 0``: ``max(1, round(m))``. Cached: one
    person's value is asked for once per trial.

    The terms are evaluated a block at a time: the logs are ``math.log``'s (:func:`_half_logs`),
    the arguments' subtraction and division numpy's (IEEE, the same roundings as Python's floats),
    each ``math.erfc`` called once, and the terms added one after another in ``k`` order
    (``np.add.accumulate`` adds sequentially). So the value is, bit for bit, that of the plain loop
    ``total += 0.5 * math.erfc((math.log(k - 0.5) - math.log(m)) / (s * math.sqrt(2)))`` (about
    6,000 terms a paper participant: the loop took 3-4 ms, mostly Python's per-term overhead);
    ``tests/test_sim_behaviour_strays.py`` holds the two equal.

    Raises
    ------
    ValueError
        If ``median_samples`` or ``log_sd`` is not finite, or ``log_sd < 0`` (the sum never ends).
    """
    if not (math.isfinite(median_samples) and math.isfinite(log_sd)) or log_sd < 0.0:
        raise ValueError(f"a stray's median ({median_samples}) and log-sd ({log_sd}) must be finite, "
                         "the log-sd non-negative")
    if median_samples <= 0.0:
        return 1.0
    if log_sd == 0.0:
        return float(max(1, round(median_samples)))
    log_median, scale = math.log(median_samples), log_sd * math.sqrt(2.0)
    # k - 1/2 > m exp(x s sqrt 2) past the tail's argument x: end a little after the expected end
    expected_end = 0.5 + median_samples * math.exp(1.001 * _TAIL_ARGUMENT * scale)
    start, stop = 2, 2 + min(_MAX_BLOCK, max(_BLOCK, int(expected_end)))
    total = 1.0
    while True:
        arguments = (_half_logs(stop)[start - 2:] - log_median) / scale
        terms = 0.5 * np.fromiter(map(math.erfc, arguments.tolist()), dtype=float, count=arguments.size)
        below = np.flatnonzero(terms < _TAIL)
        end = int(below[0]) + 1 if below.size else terms.size  # the first term below the tail is added
        total = float(np.add.accumulate(np.concatenate(([total], terms[:end])))[-1])
        if below.size:
            return total
        start, stop = stop, stop + _BLOCK


#: ``math.log(k - 0.5)`` for ``k = 2, 3, ...`` (the C library's: numpy's SIMD log can differ in the
#: last bit), made once per process and replaced whole when longer ones are asked for.
_HALF_LOGS = np.empty(0)


def _half_logs(stop: int) -> np.ndarray:
    """``(stop - 2,)`` ``math.log(k - 0.5)`` for ``k = 2 .. stop - 1`` (read-only)."""
    global _HALF_LOGS
    if _HALF_LOGS.size < stop - 2:
        size = max(stop - 2, 2 * _HALF_LOGS.size)
        logs = np.fromiter((math.log(k - 0.5) for k in range(2, size + 2)), dtype=float, count=size)
        logs.setflags(write=False)
        _HALF_LOGS = logs
    return _HALF_LOGS[:stop - 2]


def stray_hazard(share: float, median_samples: float, log_sd: float = STRAY_LOG_SD) -> float:
    """The probability that a stray starts at an eligible sample: ``share / ((1 - share) E[L])``."""
    if share <= 0.0:
        return 0.0
    return min(1.0, share / ((1.0 - share) * mean_stray_samples(median_samples, log_sd)))


def stray_schedule(hazard: float, median_samples: float, n: int, rng: np.random.Generator,
                   log_sd: float = STRAY_LOG_SD,
                   release_share: float = STRAY_RELEASE_SHARE) -> tuple[list[bool], int]:
    """Which samples of a soft hold of ``n`` samples stray into the deadband, and where it is let go.

    Parameters
    ----------
    hazard
        :func:`stray_hazard`.
    median_samples
        The person's median stray, in samples.
    n
        Samples of the hold (its longest: it may end earlier).
    rng
        The person's stream: three draws of ``n`` (start uniforms, length normals, release uniforms).

    Returns
    -------
    tuple
        ``(n,)`` flags (True: the sample strays) and the sample at which the person lets go, the one
        after a stray they end with the blow (``-1``: none; at or past ``n``: after the hold's end).
    """
    starts = rng.random(n)
    lengths = rng.standard_normal(n)
    releases = rng.random(n)
    straying = [False] * n
    allowed = 0  # a stray starts at the hold's first sample or after at least one soft sample
    # the candidates' samples as Python ints; nonzero() of the 1-d mask is flatnonzero's without
    # its ravel (a hold draws this once, a paper participant some 400 times)
    for k, start in enumerate((starts < hazard).nonzero()[0].tolist()):
        if start < allowed:
            continue
        # Python floats: the same IEEE product and comparison as numpy's scalars, without their overhead
        length = max(1, round(median_samples * math.exp(log_sd * float(lengths[k]))))
        end = start + length
        last = min(end, n)
        straying[start:last] = [True] * (last - start)
        if float(releases[k]) < release_share:
            return straying, end
        allowed = end + 1
    return straying, -1


def controlled_pressure(pressure: float, sign: float, straying: bool, returning: bool,
                        thresholds: tuple[float, float, float]) -> float:
    """A soft-blow sample's pressure under the person's control (the module's rules).

    Parameters
    ----------
    pressure
        The drawn sample, signed.
    sign
        Its label's sign (-1 puff, +1 sip).
    straying
        The sample is in a stray: it reads deadband (the band's middle).
    returning
        The sample follows a stray: the pressure comes down from the deadband into the soft band,
        so where the drawn one reads no input it reads soft too (the band's edge).
    thresholds
        ``(zero, soft, hard)`` of the driver.

    Returns
    -------
    float
        The pressure: past the hard threshold the drawn one always; a deadband reading outside a
        stray brought to the soft band's edge (``soft`` reads soft).

    Notes
    -----
    A known limitation (docs/people.md, "Known limitations of the operating habits", 2026-11-29):
    the edge is ``soft`` exactly, and a draw past ``hard`` is let through. On ``ciaa-teleop``'s 50
    people of seed 2020, 15.7 % of the soft-intended samples read exactly 0.300, 10.6 % of the hard
    blows are soft blows with a Hard spike (most straight after a sample at 0.300), and 0.198 of the
    hard blows move the robot against HABITS.md's "about one in nine" (0.112 of those holding an
    intended pulse alone).
    """
    zero, soft, hard = thresholds
    magnitude = abs(pressure)
    if magnitude > hard:
        return pressure
    if straying:
        return sign * 0.5 * (soft + hard)
    if magnitude > soft or (returning and magnitude < zero):
        return sign * soft
    return pressure
