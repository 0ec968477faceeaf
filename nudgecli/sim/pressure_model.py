"""The pressure model of a sip-and-puff blow, sample by sample at 10 Hz (DESIGN.md section 2.8).

Per 10 Hz sample of a blow with intended label ``phi_i``::

    magnitude_j = clip(f_j * (level[phi_i] + spread[phi_i] * z_j), 0, 1)
    pressure_j  = sign(phi_i) * magnitude_j        (puff negative, sip positive)
    f_j = (j + 1) / (k + 1) for the first k = onset_ramp_samples samples of the blow, else 1
    z_0 = e_0,  z_j = rho * z_{j-1} + sqrt(1 - rho^2) * e_j,   e_j ~ N(0, 1) iid

so a blow never crosses to the other side (a draw past zero reads as no input), hard blows
saturate at 1 like the real sensor, and the onset ramp reproduces the ramp-through soft and
deadband samples the pilot logs show at the start of hard blows. The deviations ``z`` drift
within a blow (an AR(1) process with lag-1 correlation ``rho = drift_correlation``, one per
participant; :func:`drift_normals`): real pressure wanders slowly (the pilots' plateaus have
lag-1 correlations of 0.75-0.98 at 10 Hz), it does not jump independently from tick to tick.
Each sample's marginal is still ``N(0, 1)``, so the per-sample label probabilities, and with them
the fixed-rate calibration tables, do not depend on ``rho``; what depends on it is how often
the pressure *changes*, which is what an event-driven device counts. The driver's thresholds
(:func:`nudgecli.model.interface.label_pressure`) turn pressures into labels, so soft-to-hard
confusions, deadbands and unintended mode switches emerge from the physiology.

A participant (:class:`nudgecli.sim.participants.Participant`) holds the per-label levels and
spreads, the onset and offset ramps and ``rho``; these functions turn them into pressures. The ramps'
sample counts and ``rho`` are a person's at 10 Hz; at another ``study.rate_hz`` the person's
behaviour samples them as the same durations and the same drift over time
(:meth:`~nudgecli.sim.participants.Participant.at_sample_period`: ``rho ** (dt / 0.1)``), and these
functions take the samples they are given.
"""

from __future__ import annotations

from functools import cache

import numpy as np

from nudgecli.model import portable_math

#: Sign of each intended label's pressure: puffs negative, sips positive.
LABEL_SIGN = np.array([-1.0, 1.0, -1.0, 1.0])
#: Whether each label is a hard one.
LABEL_IS_HARD = np.array([True, True, False, False])


def ramp_fractions(n: int, ramp_samples: int) -> np.ndarray:
    """``(n,)`` fraction of the level reached at each sample of a blow of ``n`` samples.

    The first ``ramp_samples`` samples rise linearly, ``(j + 1) / (ramp_samples + 1)``; the rest are 1.
    """
    return ramp_fraction_at(np.arange(n), ramp_samples)


def ramp_fraction_at(position: np.ndarray, ramp_samples: int) -> np.ndarray:
    """The onset-ramp fraction of samples at ``position`` (``(N,)``, 0: a blow's first sample)."""
    return np.where(position < ramp_samples, (position + 1.0) / (ramp_samples + 1.0), 1.0)


@cache
def pulse_fractions(onset_samples: int, peak_samples: int, offset_samples: int) -> np.ndarray:
    """``(onset + peak + offset,)`` fraction of the level at each sample of a short hard pulse.

    The onset rises as a blow's (``(j + 1) / (onset + 1)``, :func:`ramp_fractions`), the peak holds
    the level, and the offset falls symmetrically (``(offset - j) / (offset + 1)``), so the last
    sample is still above zero and the release that follows is a full one.

    Cached and read-only: a person's pulses have a few shapes, and making one anew (four small
    arrays joined) was two thirds of a pulse's pressures in the trial loop.
    """
    onset = ramp_fractions(onset_samples, onset_samples)
    offset = (offset_samples - np.arange(offset_samples)) / (offset_samples + 1.0)
    fractions = np.concatenate([onset, np.ones(peak_samples), offset])
    fractions.setflags(write=False)
    return fractions


def lognormal_delays(median: float, log_sd: float, n: int, rng: np.random.Generator) -> np.ndarray:
    """``(n,)`` delays ``median * exp(log_sd * z)``, ``z ~ N(0, 1)``: log-normal around ``median``.

    The one delay law of a person's reactions, in calibration prompts and in the task.
    """
    return median * portable_math.exp(log_sd * rng.standard_normal(n))


def lognormal_delay(median: float, log_sd: float, rng: np.random.Generator) -> float:
    """One delay of :func:`lognormal_delays`: ``float(lognormal_delays(median, log_sd, 1, rng)[0])``
    bit for bit, from the same draw of size 1.

    The exponential is the C library's, as there (:mod:`nudgecli.model.portable_math`); the
    products are Python floats', the same IEEE multiplications without arrays (a person's reaction
    is drawn hundreds of times a trial set).
    """
    return median * portable_math.exp(log_sd * float(rng.standard_normal(1)[0]))


def drift_normals(innovations: np.ndarray, correlation: float, previous: float | None = None) -> np.ndarray:
    """The standard normal deviations of one blow's samples: an AR(1) drift with stationary marginals.

    ``z_0 = e_0`` (or ``rho * previous + sqrt(1 - rho^2) * e_0`` when the blow continues from a
    sample whose deviation was ``previous``) and ``z_j = rho * z_{j-1} + sqrt(1 - rho^2) * e_j``,
    so every ``z_j`` is ``N(0, 1)`` and ``corr(z_j, z_{j+k}) = rho^k``. With ``rho = 0`` the
    result is ``innovations`` itself.

    Parameters
    ----------
    innovations
        ``(n,)`` independent standard normal draws ``e``.
    correlation
        ``rho`` in ``[0, 1)``.
    previous
        The deviation of the sample just before this stretch of the same blow, or ``None`` for a
        new blow.

    Returns
    -------
    np.ndarray
        ``(n,)`` deviations ``z``.
    """
    e = np.asarray(innovations, dtype=float)
    if e.size == 0:
        return e.copy()
    rho = float(correlation)
    scale = np.sqrt(1.0 - rho * rho)
    first = e[0] if previous is None else rho * previous + scale * e[0]
    # The recursion z_t = rho z_{t-1} + scale e_t, step by step: blows are tens of samples, where a
    # plain loop beats scipy.signal.lfilter's call overhead and spares every worker importing
    # scipy.signal (over a second). The same operations as lfilter's direct form, so the values
    # are bit-identical to it (tests/test_sim_participants.py checks).
    out = np.empty(e.size)
    out[0] = last = float(first)
    for t, innovation in enumerate(e[1:].tolist(), start=1):
        last = scale * innovation + rho * last
        out[t] = last
    return out


def blows_drift_normals(innovations: np.ndarray, lengths: np.ndarray, correlation: float) -> np.ndarray:
    """:func:`drift_normals` of consecutive blows, each a new blow, all advanced together.

    Parameters
    ----------
    innovations
        ``(N,)`` the blows' standard normal draws, one blow after another.
    lengths
        ``(B,)`` the blows' numbers of samples (``N`` in all; a blow may have none).
    correlation
        ``rho`` in ``[0, 1)``.

    Returns
    -------
    np.ndarray
        ``(N,)`` deviations: ``[drift_normals(blow, rho) for blow in blows]`` joined, bit for bit.
        Step ``j`` of every blow longer than ``j`` is one numpy step (the same multiplications and
        addition as the loop's, elementwise), so a calibration's 50 blows take as many numpy steps
        as its longest blow has samples, not a Python loop each.
    """
    counts = np.asarray(lengths, dtype=np.int64).reshape(-1)
    e = np.asarray(innovations, dtype=float).reshape(-1)
    total = int(counts.sum())
    if total != len(e) or (counts < 0).any():
        raise ValueError(f"lengths add up to {total}, not to the {len(e)} innovations (or one is negative)")
    if correlation == 0.0 or e.size == 0:
        return e.copy()
    rho = float(correlation)
    scale = np.sqrt(1.0 - rho * rho)
    # (longest, B): sample j of blow b at [j, b], so a step of all blows is one contiguous row
    blow = np.repeat(np.arange(counts.size), counts)
    position = np.arange(e.size) - np.repeat(np.cumsum(counts) - counts, counts)
    padded = np.zeros((int(counts.max()), counts.size))
    padded[position, blow] = e
    out = np.empty_like(padded)
    out[0] = padded[0]  # a new blow: z_0 = e_0
    for j in range(1, padded.shape[0]):  # past a blow's end the rows are padding, never read back
        out[j] = scale * padded[j] + rho * out[j - 1]
    return out[position, blow]


def blow_pressures(levels: np.ndarray | float, spreads: np.ndarray | float, signs: np.ndarray | float,
                   fractions: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Signed pressures of blow samples (the module's pressure model, vectorised).

    Parameters
    ----------
    levels, spreads
        ``(N,)`` magnitude level and spread of each sample's intended label, or one for all samples
        (a scalar broadcasts: the same values as an array of it).
    signs
        ``(N,)`` ``-1`` for puffs, ``+1`` for sips, or one for all samples.
    fractions
        ``(N,)`` onset-ramp fraction of each sample (1 on the plateau).
    normals
        ``(N,)`` standard normal deviations (:func:`drift_normals`).

    Returns
    -------
    np.ndarray
        ``(N,)`` pressures in ``[-1, 1]``.
    """
    magnitude = np.clip(fractions * (levels + spreads * normals), 0.0, 1.0)
    return signs * magnitude
