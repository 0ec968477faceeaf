"""Simulated participants: each one's true physiology and habits (DESIGN.md section 2.8).

A :class:`Participant` is drawn from the ``[population]`` ranges (see
:class:`nudgecli.config.PopulationSection` for the ranges and the pilot logs they come from), or
estimated from a real person's calibration log
(:func:`nudgecli.sim.participant_fitting.participant_from_log`).

The pressure model of a blow's samples is :mod:`nudgecli.sim.pressure_model`'s.

Index conventions: labels ``F = 4`` (Hard Puff, Hard Sip, Soft Puff, Soft Sip), actions ``A = 4``,
modes ``M = 3`` (see :mod:`nudgecli.model.interface`).
"""

from __future__ import annotations

import json
import math
from bisect import bisect_right
from collections.abc import Mapping, Sequence
from dataclasses import MISSING, dataclass, field, fields, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from nudgecli.config import InterfaceSection, PopulationSection
from nudgecli.errors import DataError
from nudgecli.model.interface import (
    HARD_PUFF,
    HARD_SIP,
    N_ACTIONS,
    N_LABELS,
    NO_INPUT,
    PUFF_DEADBAND,
    SIP_DEADBAND,
    SOFT_PUFF,
    SOFT_SIP,
    TRUE_MAPPING,
    ZERO_THRESHOLD,
)
from nudgecli.model.world import N_MODES
from nudgecli.rng import generator, seed_key
from nudgecli.sim.pressure_model import (
    LABEL_IS_HARD,
    LABEL_SIGN,
    blow_pressures,
    drift_normals,
    lognormal_delay,
    pulse_fractions,
    ramp_fractions,
)

if TYPE_CHECKING:  # pandas loads in the functions that read or build tables: a study's worker runs without it
    import pandas as pd

#: Columns of :meth:`Participant.sample_code_probabilities`: the 4 labels, the 2 deadbands, no input.
CODE_COLUMNS = (HARD_PUFF, HARD_SIP, SOFT_PUFF, SOFT_SIP, PUFF_DEADBAND, SIP_DEADBAND, NO_INPUT)
#: Smallest spread a participant may have (keeps the normal CDF defined).
MIN_SPREAD = 1e-4
#: Largest drift correlation (1 would freeze the pressure for the whole blow).
MAX_DRIFT_CORRELATION = 0.99
#: The sample period a person's per-sample traits are drawn and fitted at, s: the ramps' sample
#: counts and the drift's lag-1 correlation are the pilots' 10 Hz logs'
#: (:meth:`Participant.at_sample_period`).
TRAIT_SAMPLE_S = 0.1

Thresholds = InterfaceSection | tuple[float, float] | tuple[float, float, float]


def threshold_triple(thresholds: Thresholds) -> tuple[float, float, float]:
    """``(soft, hard, zero)`` from an ``InterfaceSection`` or a ``(soft, hard[, zero])`` tuple."""
    if isinstance(thresholds, InterfaceSection):
        return thresholds.soft_threshold, thresholds.hard_threshold, thresholds.zero_threshold
    values = tuple(float(v) for v in thresholds)
    if len(values) == 2:
        return values[0], values[1], ZERO_THRESHOLD
    if len(values) == 3:
        return values[0], values[1], values[2]
    raise ValueError(f"thresholds must be (soft, hard) or (soft, hard, zero), got {thresholds!r}")


#: :data:`LABEL_SIGN` as plain floats (one sample's pressure, :meth:`Participant.sample_pressure`).
_SIGNS = tuple(LABEL_SIGN.tolist())

@dataclass(frozen=True, eq=False)
class Participant:
    """One participant's true physiology and habits.

    Attributes
    ----------
    index
        Position in the study (0-based).
    seed_key
        The seed-tree branch it was drawn from (e.g. ``participant/3``), or its source log.
    pressure_level
        ``(F,)`` signed mean pressure per intended label (puff negative, sip positive); a
        magnitude above 1 saturates the sensor.
    pressure_spread
        ``(F,)`` per-sample standard deviation per intended label.
    mapping
        ``(M, A, F)`` the participant's true ``p(phi_i | a, m)`` (their internal mapping).
    epsilon
        Task-level sub-optimality of their epsilon-greedy policy.
    rest_s
        Rest before the first input of a turn, seconds.
    operate_s
        How long they operate before handing the turn over, seconds.
    action_pause_s
        Pause between consecutive actions within a turn, seconds.
    hard_blow_s
        How long they hold a hard (mode-switch) blow, seconds.
    reaction_s
        Median delay between a calibration prompt and their response, seconds.
    reaction_log_sd
        Standard deviation of the log of the per-prompt delay (0: always ``reaction_s``).
    onset_ramp_samples
        Samples a blow takes to reach its level (see :func:`ramp_fractions`), at 10 Hz
        (:data:`TRAIT_SAMPLE_S`): a duration of ``onset_ramp_samples x 0.1`` s, which
        :meth:`at_sample_period` turns into samples at another rate.
    mapping_error
        The error rate their ``mapping`` was built with (spread evenly over the wrong labels).
    handover_idle_s
        Idle time after the first input of a turn with which they hand the turn over, seconds.
    drift_correlation
        Lag-1 correlation of their pressure's deviations from tick to tick within a blow
        (:func:`~nudgecli.sim.pressure_model.drift_normals`; 0: independent samples), at 10 Hz:
        ``rho ** (dt / 0.1)`` per sample at another rate (:meth:`at_sample_period`).
    planning_s
        Time spent looking at the layout and the mode before a trial's first command, seconds.
    event_reaction_s
        Median delay from something they see (the robot stopped at a mark, the mode changed, the
        turn handed back, a surprise) to acting on it, seconds.
    event_reaction_log_sd
        Standard deviation of the log of that delay (:func:`lognormal_delays`): how long the
        tail of their pauses is.
    hold_on_s
        How long they keep blowing after the robot stopped under their soft command, seconds.
    hard_peak_s
        How long a mode-switch pulse stays at its peak, between its onset and offset ramps, seconds.
    offset_ramp_samples
        Samples a hard pulse takes to fall from its peak (see :func:`pulse_fractions`), at 10 Hz,
        as ``onset_ramp_samples``.
    deadband_share
        The share of their soft blows' time their pressure strays into the Soft-Hard deadband
        (``behaviour.deadband_strays``, :mod:`nudgecli.sim.behaviour_strays`). Produces HABITS.md's
        "share of soft-blow time in the deadband" one for one (offset 0): a stray's samples are
        the blow's deadband cells; the blows a stray ends are shorter by their unused rest, which
        raises the measured share a little.
    deadband_stray_s
        The median time a stray stays in the deadband before the pressure is back in the soft band,
        seconds (each stray's length log-normal around it, rounded to whole samples). Produces
        HABITS.md's "a deadband run inside a soft blow" (the person's median) one for one (offset 0).
    """

    index: int
    seed_key: str
    pressure_level: np.ndarray
    pressure_spread: np.ndarray
    mapping: np.ndarray
    epsilon: float
    rest_s: float
    operate_s: float
    action_pause_s: float
    hard_blow_s: float
    reaction_s: float
    reaction_log_sd: float = 0.0
    onset_ramp_samples: int = 0
    mapping_error: float = 0.0
    handover_idle_s: float = 1.5
    drift_correlation: float = 0.0
    planning_s: float = 2.0
    event_reaction_s: float = 1.0
    event_reaction_log_sd: float = 0.35
    hold_on_s: float = 0.2
    hard_peak_s: float = 0.2
    offset_ramp_samples: int = 1
    deadband_share: float = 0.07
    deadband_stray_s: float = 0.2
    # the mapping's cumulative rows as plain floats, (M, A, F): a label is drawn at every decision
    _mapping_cdf: tuple[tuple[tuple[float, ...], ...], ...] = field(init=False, repr=False, compare=False)
    # Plain floats of one sample's pressure model (sample_pressure, drift_step), read every step:
    # the labels' level magnitudes and spreads, and the drift's innovation scale sqrt(1 - rho^2).
    _levels: tuple[float, ...] = field(init=False, repr=False, compare=False)
    _spreads: tuple[float, ...] = field(init=False, repr=False, compare=False)
    _drift_scale: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        level = np.array(self.pressure_level, dtype=float)
        spread = np.maximum(np.array(self.pressure_spread, dtype=float), MIN_SPREAD)
        mapping = np.array(self.mapping, dtype=float)
        if level.shape != (N_LABELS,) or spread.shape != (N_LABELS,):
            raise ValueError(f"pressure_level and pressure_spread must have shape ({N_LABELS},)")
        if mapping.shape != (N_MODES, N_ACTIONS, N_LABELS):
            raise ValueError(f"mapping must have shape {(N_MODES, N_ACTIONS, N_LABELS)}, got {mapping.shape}")
        if np.any(np.sign(level) != LABEL_SIGN):
            raise ValueError("pressure_level must be negative for puffs and positive for sips")
        cdf = np.cumsum(mapping, axis=-1)
        cdf[..., -1] = 1.0
        for name, value in (("pressure_level", level), ("pressure_spread", spread), ("mapping", mapping)):
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        object.__setattr__(self, "_mapping_cdf", tuple(tuple(map(tuple, rows)) for rows in cdf.tolist()))
        object.__setattr__(self, "onset_ramp_samples", int(self.onset_ramp_samples))
        object.__setattr__(self, "offset_ramp_samples", int(self.offset_ramp_samples))
        if not 0.0 <= self.drift_correlation <= MAX_DRIFT_CORRELATION:
            raise ValueError(f"drift_correlation must lie in [0, {MAX_DRIFT_CORRELATION}], "
                             f"got {self.drift_correlation}")
        if not 0.0 <= self.deadband_share < 1.0 or self.deadband_stray_s < 0.0:
            raise ValueError(f"deadband_share must lie in [0, 1) and deadband_stray_s be at least 0, got "
                             f"{self.deadband_share} and {self.deadband_stray_s}")
        rho = float(self.drift_correlation)
        object.__setattr__(self, "_levels", tuple(abs(v) for v in level.tolist()))
        object.__setattr__(self, "_spreads", tuple(spread.tolist()))
        object.__setattr__(self, "_drift_scale", math.sqrt(1.0 - rho * rho))

    def at_sample_period(self, dt_s: float) -> Participant:
        """The same person sampled every ``dt_s`` seconds: ``self`` at 10 Hz, otherwise a copy whose
        per-sample traits (drawn at 10 Hz, :data:`TRAIT_SAMPLE_S`) describe the same durations and drift.

        - the onset and offset ramps keep their durations: ``samples x 0.1`` s is
          ``round_half_up(samples x 0.1 / dt_s)`` samples, so a blow reaches its level (and a pulse
          falls from its peak) at the same time within half a sample, and a pulse lasts as long
          within a sample. Half rounds up so that a one-sample ramp read at 5 Hz stays a ramp, not
          a jump to the level (both are within a sample of it; a ramp is what the person has).
        - the drift keeps its correlation over time: a lag of 0.1 s is ``0.1 / dt_s`` samples, so
          the lag-1 correlation is ``rho ** (dt_s / 0.1)`` (an AR(1) process' correlation over
          ``k`` steps is ``rho ** k``). At a faster rate it may exceed :data:`MAX_DRIFT_CORRELATION`,
          the bound of a 10 Hz trait; it stays below 1 for every ``rho`` below 1.

        At 10 Hz ``dt_s / 0.1`` is 1.0 exactly (``1 / 10.0`` is the float ``0.1``), and the person
        is returned as is: every table at the study's default rate keeps its values bit for bit.
        """
        periods = dt_s / TRAIT_SAMPLE_S  # samples of 0.1 s per sample of dt_s
        if periods == 1.0:
            return self
        if not periods > 0.0:
            raise ValueError(f"dt_s must be positive, got {dt_s}")

        def samples(count: int) -> int:
            return math.floor(count / periods + 0.5)

        rescaled = replace(self, onset_ramp_samples=samples(self.onset_ramp_samples),
                           offset_ramp_samples=samples(self.offset_ramp_samples))
        rho = float(self.drift_correlation) ** periods  # Python's float power: the C library's pow
        object.__setattr__(rescaled, "drift_correlation", rho)
        object.__setattr__(rescaled, "_drift_scale", math.sqrt(1.0 - rho * rho))
        return rescaled

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Participant):
            return NotImplemented
        return all(np.array_equal(getattr(self, f.name), getattr(other, f.name))
                   for f in fields(self) if f.compare)

    __hash__ = None  # type: ignore[assignment]

    # --- behaviour ---------------------------------------------------------------------------

    def intended_label(self, action: int, mode: int, rng: np.random.Generator) -> int:
        """Draw ``phi_i ~ p(phi_i | a, m)`` from the participant's internal mapping (one uniform draw)."""
        # bisect_right is np.searchsorted(side="right") on the same floats, without numpy's call
        return bisect_right(self._mapping_cdf[mode][action], rng.random())

    def drift_normals(self, n: int, rng: np.random.Generator, previous: float | None = None) -> np.ndarray:
        """``(n,)`` deviations of ``n`` samples of a blow (one normal draw of size ``n``; module function).

        ``previous`` is the deviation of the blow's sample before these, or ``None`` for a new blow.
        """
        return drift_normals(rng.standard_normal(n), self.drift_correlation, previous)

    def drift_step(self, previous: float, innovation: float) -> float:
        """The deviation of a blow's next sample after one of deviation ``previous``: one step of
        :func:`~nudgecli.sim.pressure_model.drift_normals`'s recursion, bit for bit
        (``tests/test_sim_participants.py``)."""
        # scale e + rho z: the same two products and one sum as the array recursion (a sum commutes exactly)
        return self._drift_scale * innovation + self.drift_correlation * previous

    def sample_pressure(self, label: int, position: int, normal: float) -> float:
        """The signed pressure of one sample of a blow of ``label``: the sample at ``position`` of
        the blow (0: its first), with deviation ``normal``.

        One element of :meth:`pressures_from_normals`, bit for bit, in plain floats: a person's
        soft blow is computed sample by sample as it is held (most holds end after a few of the
        ``max_hold_s`` samples drawn for them).
        """
        ramp = self.onset_ramp_samples
        fraction = (position + 1.0) / (ramp + 1.0) if position < ramp else 1.0
        magnitude = fraction * (self._levels[label] + self._spreads[label] * normal)
        return _SIGNS[label] * (0.0 if magnitude < 0.0 else 1.0 if magnitude > 1.0 else magnitude)

    def pressures_from_normals(self, label: int, normals: np.ndarray, start: int = 0) -> np.ndarray:
        """The pressures of holding ``label`` with the given deviations (:meth:`drift_normals`).

        Parameters
        ----------
        label
            Intended interface label ``0..3``.
        normals
            ``(n,)`` the samples' deviations.
        start
            Position of the first of these samples within the blow: 0 starts a new blow with the
            onset ramp; a caller producing a blow in pieces passes the number of samples already
            held, so only the blow's first ``onset_ramp_samples`` are ramped.

        Returns
        -------
        np.ndarray
            ``(n,)`` signed pressures in ``[-1, 1]``.
        """
        n = len(normals)
        fractions = ramp_fractions(start + n, self.onset_ramp_samples)[start:]
        ones = np.ones(n)
        return blow_pressures(abs(self.pressure_level[label]) * ones, self.pressure_spread[label] * ones,
                              LABEL_SIGN[label] * ones, fractions, normals)

    def pulse_pressures(self, label: int, normals: np.ndarray, peak_samples: int) -> np.ndarray:
        """The pressures of a short hard pulse of ``label``: the person's onset ramp, ``peak_samples``
        at the level, and their offset ramp (:func:`pulse_fractions`); ``normals`` holds one
        deviation per sample (``onset_ramp_samples + peak_samples + offset_ramp_samples``)."""
        fractions = pulse_fractions(self.onset_ramp_samples, peak_samples, self.offset_ramp_samples)
        if len(normals) != len(fractions):
            raise ValueError(f"a pulse of {len(fractions)} samples needs as many deviations, "
                             f"got {len(normals)}")
        # the label's level, spread and sign as scalars: broadcast, the same products and sums
        # element for element as arrays of them (a pulse is a handful of samples, drawn in the loop)
        return blow_pressures(abs(self.pressure_level[label]), self.pressure_spread[label], LABEL_SIGN[label],
                              fractions, normals)

    def event_reaction(self, rng: np.random.Generator) -> float:
        """One reaction delay to something they see, seconds (:func:`lognormal_delay`)."""
        return lognormal_delay(self.event_reaction_s, self.event_reaction_log_sd, rng)

    def pressures(self, label: int, n: int, rng: np.random.Generator, start: int = 0) -> np.ndarray:
        """The pressures of a new blow of ``label`` held ``n`` samples (one normal draw of size ``n``).

        A shorthand for :meth:`pressures_from_normals` of :meth:`drift_normals`; ``start`` as there.

        Returns
        -------
        np.ndarray
            ``(n,)`` signed pressures in ``[-1, 1]``.
        """
        return self.pressures_from_normals(label, self.drift_normals(n, rng), start)

    def sample_code_probabilities(self, thresholds: Thresholds, fraction: float = 1.0) -> np.ndarray:
        """Per-sample probabilities of each stream code for a blow sample at ``fraction`` of the level.

        Parameters
        ----------
        thresholds
            The driver's label bands (an ``InterfaceSection`` or ``(soft, hard[, zero])``).
        fraction
            Onset-ramp fraction (1 on the plateau).

        Returns
        -------
        np.ndarray
            ``(F, 7)``: row = intended label, columns :data:`CODE_COLUMNS` (Hard Puff, Hard Sip,
            Soft Puff, Soft Sip, puff deadband, sip deadband, no input); rows sum to 1. Exact under
            the normal model (the magnitude is ``N(f level, f spread)`` clipped to ``[0, 1]``).
        """
        # imported here: only a physiology's calibration tables need it, and
        # a worker that never gets here loads no scipy (0.2 s)
        from scipy.special import ndtr

        soft, hard, zero = threshold_triple(thresholds)
        mean = fraction * np.abs(self.pressure_level)
        sd = fraction * self.pressure_spread
        below_zero = ndtr((zero - mean) / sd)
        below_soft = np.maximum(ndtr((soft - mean) / sd), below_zero)
        below_hard = np.maximum(ndtr((hard - mean) / sd), below_soft)
        probs = np.zeros((N_LABELS, len(CODE_COLUMNS)))
        for label in range(N_LABELS):
            sip = LABEL_SIGN[label] > 0
            columns = ((HARD_SIP, SOFT_SIP, SIP_DEADBAND) if sip else (HARD_PUFF, SOFT_PUFF, PUFF_DEADBAND))
            hard_col, soft_col, dead_col = (CODE_COLUMNS.index(c) for c in columns)
            probs[label, hard_col] = 1.0 - below_hard[label]
            probs[label, soft_col] = below_soft[label] - below_zero[label]
            probs[label, dead_col] = below_hard[label] - below_soft[label]
            probs[label, -1] = below_zero[label]
        return probs

    def true_distortion(self, thresholds: Thresholds, hold_samples: int | None = None) -> np.ndarray:
        """The ``p(phi_m | phi_i)`` this physiology implies, in the estimator's terms, unsmoothed.

        For each intended label: the per-sample probability of each measured code (from the normal
        CDF, :meth:`sample_code_probabilities`), averaged over the samples of a blow, conditioned on
        the sample being counted (no-input samples dropped, as the estimator ignores them), with the
        puff deadband added to Hard Puff and the sip deadband to Hard Sip. No ``+0.01`` smoothing.

        With ``hold_samples=None`` this is the plateau (the limit of a long blow, no onset ramp).
        With ``hold_samples=n`` the first ``onset_ramp_samples`` of an ``n``-sample blow are the
        ramp, and the result is the ratio ``E[count of phi_m] / E[counted samples]`` over the blow,
        which the estimator's average of per-prompt fractions approaches up to an ``O(1/n)`` ratio
        bias. A label that never produces a counted sample gets a uniform row.

        Returns
        -------
        np.ndarray
            ``(F, F)``: row ``phi_i``, column ``phi_m``; rows sum to 1.
        """
        if hold_samples is None:
            probs = self.sample_code_probabilities(thresholds, 1.0)
        else:
            if hold_samples < 1:
                raise ValueError(f"hold_samples must be at least 1, got {hold_samples}")
            fractions = ramp_fractions(hold_samples, self.onset_ramp_samples)
            unique, counts = np.unique(fractions, return_counts=True)
            probs = sum(c * self.sample_code_probabilities(thresholds, float(f))
                        for f, c in zip(unique, counts, strict=True)) / hold_samples
        counted = probs[:, :6]
        merged = counted[:, :N_LABELS].copy()
        merged[:, HARD_PUFF] += counted[:, CODE_COLUMNS.index(PUFF_DEADBAND)]
        merged[:, HARD_SIP] += counted[:, CODE_COLUMNS.index(SIP_DEADBAND)]
        totals = merged.sum(axis=1, keepdims=True)
        uniform = np.full_like(merged, 1.0 / N_LABELS)
        return np.where(totals > 0, merged / np.where(totals > 0, totals, 1.0), uniform)

    # --- records -----------------------------------------------------------------------------

    def to_record(self) -> dict[str, Any]:
        """One row of the participants table: scalars, plus JSON strings for the arrays."""
        record: dict[str, Any] = {}
        for f in fields(self):
            if not f.compare:
                continue
            value = getattr(self, f.name)
            if isinstance(value, np.ndarray):
                record[f.name] = json.dumps(value.tolist())
            elif isinstance(value, str):
                record[f.name] = value
            elif isinstance(value, int | np.integer):
                record[f.name] = int(value)
            else:
                record[f.name] = float(value)
        return record

    @classmethod
    def from_record(cls, record: Mapping[str, Any]) -> Participant:
        """Inverse of :meth:`to_record` (e.g. one row of a participants parquet table).

        Raises
        ------
        DataError
            If a field is missing or malformed.
        """
        values: dict[str, Any] = {}
        for f in fields(cls):
            if not f.compare:
                continue
            if f.name not in record:
                if f.default is not MISSING:
                    continue
                raise DataError(f"participant record: missing field {f.name!r}")
            raw = record[f.name]
            try:
                if f.name in ("pressure_level", "pressure_spread", "mapping"):
                    values[f.name] = np.array(json.loads(raw), dtype=float)
                elif f.name == "seed_key":
                    values[f.name] = str(raw)
                elif f.name in ("index", "onset_ramp_samples", "offset_ramp_samples"):
                    values[f.name] = int(raw)
                else:
                    values[f.name] = float(raw)
            except (TypeError, ValueError) as exc:
                raise DataError(f"participant record: field {f.name!r} is malformed ({exc})") from None
        try:
            return cls(**values)
        except ValueError as exc:
            raise DataError(f"participant record {values.get('index')}: {exc}") from None


def participants_frame(participants: Sequence[Participant]) -> pd.DataFrame:
    """The one-row-per-participant table (scalars and JSON strings), ready for parquet."""
    import pandas as pd

    return pd.DataFrame([p.to_record() for p in participants])


def participants_from_frame(frame: pd.DataFrame) -> list[Participant]:
    """Inverse of :func:`participants_frame`."""
    return [Participant.from_record(row) for row in frame.to_dict(orient="records")]


# --- drawing from the population ---------------------------------------------------------------

def _uniform(rng: np.random.Generator, bounds: tuple[float, float]) -> float:
    return float(rng.uniform(bounds[0], bounds[1]))


def mapping_with_error(error_rate: float) -> np.ndarray:
    """``(M, A, F)`` internal mapping: ``1 - error_rate`` on the true label, the rest spread evenly."""
    off = error_rate / (N_LABELS - 1)
    row_table = np.full((N_ACTIONS, N_LABELS), off)
    row_table[np.arange(N_ACTIONS), TRUE_MAPPING] = 1.0 - error_rate
    return np.broadcast_to(row_table, (N_MODES, N_ACTIONS, N_LABELS)).copy()


def level_range(population: PopulationSection, label: int) -> tuple[float, float]:
    """The population's range of the pressure level of intended ``label``."""
    return {HARD_PUFF: population.hard_puff_level, HARD_SIP: population.hard_sip_level,
            SOFT_PUFF: population.soft_puff_level, SOFT_SIP: population.soft_sip_level}[label]


def spread_range(population: PopulationSection, label: int) -> tuple[float, float]:
    """The population's range of the per-sample spread of intended ``label`` (hard or soft)."""
    return population.hard_spread if LABEL_IS_HARD[label] else population.soft_spread


def draw_participant(population: PopulationSection, index: int, rng: np.random.Generator,
                     key: str | None = None) -> Participant:
    """Draw one participant from the population ranges (a fixed sequence of draws from ``rng``)."""
    magnitudes = np.array([_uniform(rng, level_range(population, label)) for label in range(N_LABELS)])
    spreads = np.array([_uniform(rng, spread_range(population, label)) for label in range(N_LABELS)])
    error_rate = _uniform(rng, population.mapping_error)
    lo, hi = population.onset_ramp_samples
    ramp = int(rng.integers(lo, hi + 1))
    return Participant(
        index=index,
        seed_key=key or seed_key("participant", index),
        pressure_level=LABEL_SIGN * np.maximum(magnitudes, 2 * ZERO_THRESHOLD),
        pressure_spread=spreads,
        mapping=mapping_with_error(error_rate),
        epsilon=_uniform(rng, population.epsilon),
        rest_s=_uniform(rng, population.rest_s),
        operate_s=_uniform(rng, population.operate_s),
        action_pause_s=_uniform(rng, population.action_pause_s),
        hard_blow_s=_uniform(rng, population.hard_blow_s),
        reaction_s=_uniform(rng, population.reaction_s),
        reaction_log_sd=population.reaction_log_sd,
        onset_ramp_samples=ramp,
        mapping_error=error_rate,
        handover_idle_s=_uniform(rng, population.handover_idle_s),
        # last: the earlier draws keep the values they had before these fields existed
        drift_correlation=_uniform(rng, population.drift_correlation),
        # the operating habits of issue 19, after the fields above so those keep their draws
        planning_s=_uniform(rng, population.planning_s),
        event_reaction_s=_uniform(rng, population.event_reaction_s),
        event_reaction_log_sd=_uniform(rng, population.event_reaction_log_sd),
        hold_on_s=_uniform(rng, population.hold_on_s),
        hard_peak_s=_uniform(rng, population.hard_peak_s),
        offset_ramp_samples=int(rng.integers(population.offset_ramp_samples[0],
                                             population.offset_ramp_samples[1] + 1)),
        # pressure control within a soft blow (issue 37), last: every draw above keeps its value
        deadband_share=_uniform(rng, population.deadband_share),
        deadband_stray_s=_uniform(rng, population.deadband_stray_s),
    )


def draw_participants(population: PopulationSection, n: int, seed: int) -> list[Participant]:
    """``n`` participants, participant ``i`` drawn from ``generator(seed, "participant", i, "physiology")``.

    Participant ``i`` is the same whatever ``n`` is, so studies of different sizes share participants.
    """
    if n < 0:
        raise ValueError(f"n must be non-negative, got {n}")
    return [draw_participant(population, i, generator(seed, "participant", i, "physiology"))
            for i in range(n)]
