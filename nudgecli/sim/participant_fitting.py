"""Estimating a real person's pressure physiology from a ``p(phi_m | phi_i)`` calibration log:
plateau samples, the censored-normal level and spread, the drift correlation, and the
:class:`~nudgecli.sim.participants.Participant` they make (:func:`participant_from_log`)."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from dataclasses import fields
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeGuard

import numpy as np

from nudgecli.config import PopulationSection
from nudgecli.errors import DataError
from nudgecli.model import portable_math
from nudgecli.model.interface import LABELS, N_LABELS, ZERO_THRESHOLD, label_pressure
from nudgecli.sim.calibration_io import DistortionSession, distortion_windows
from nudgecli.sim.participants import MAX_DRIFT_CORRELATION, MIN_SPREAD, Participant, mapping_with_error
from nudgecli.sim.pressure_model import LABEL_SIGN

if TYPE_CHECKING:  # pandas loads in the functions that read or build tables: a study's worker runs without it
    import pandas as pd

#: Samples dropped at the start and end of each blow when estimating a plateau from a log.
LOG_ONSET_SAMPLES, LOG_RELEASE_SAMPLES = 2, 1
#: Onset ramp given to a participant estimated from a log (the pilots' hard blows: 2-3 samples).
LOG_RAMP_SAMPLES = 2
#: Spread assumed when a label's samples are (nearly) all saturated, so no spread is observable.
SATURATED_SPREAD = 0.05
#: Fewest plateau samples a label needs for :func:`participant_from_log`.
MIN_LOG_SAMPLES = 5
#: Fewest pairs of consecutive unsaturated plateau samples to estimate a log's drift correlation.
MIN_DRIFT_PAIRS = 20


def censored_normal_fit(magnitudes: np.ndarray, ceiling: float = 1.0) -> tuple[float, float]:
    """Robust level and spread of pressure magnitudes that saturate at ``ceiling``.

    A normal-quantile fit: the empirical quantiles ``q_p`` of the samples are matched to
    ``level + spread * Phi^-1(p)`` by least squares, using the quartiles ``p = 0.25, 0.5, 0.75``
    that are below the ceiling (uncensored), or, when fewer than two are, the quantiles
    ``p = 0.05, 0.10, ..., 0.95`` below it. Quantiles ignore the few ramp and release samples
    (unlike a mean and standard deviation) and stay valid when many samples sit at the ceiling.
    When fewer than two such quantiles exist (nearly all samples saturated) the spread is unknown:
    it is set to ``SATURATED_SPREAD`` and the level to ``ceiling + spread * Phi^-1(s)``, with ``s``
    the saturated fraction (capped at ``1 - 0.5/n``), i.e. the level that saturates that often.

    Parameters
    ----------
    magnitudes
        ``(N,)`` non-negative pressure magnitudes, ``N >= 2``.

    Returns
    -------
    tuple[float, float]
        ``(level, spread)``, spread at least ``MIN_SPREAD``.
    """
    # imported here: only the fit of a real log needs it, and
    # a worker that never gets here loads no scipy (0.2 s)
    from scipy.special import ndtri

    x = np.sort(np.asarray(magnitudes, dtype=float))
    n = len(x)
    saturated = x >= ceiling - 1e-6
    for probs in (np.array([0.25, 0.5, 0.75]), np.arange(1, 20) * 0.05):
        quantiles = np.quantile(x, probs)
        usable = quantiles < ceiling - 1e-6
        if usable.sum() >= 2:
            z = ndtri(probs[usable])
            spread, level = np.polyfit(z, quantiles[usable], 1)
            if spread > 0:
                return float(level), float(max(spread, MIN_SPREAD))
            return float(np.median(x)), float(max(1.4826 * np.median(np.abs(x - np.median(x))), MIN_SPREAD))
    fraction = min(float(saturated.mean()), 1.0 - 0.5 / n)
    return float(ceiling + SATURATED_SPREAD * ndtri(fraction)), SATURATED_SPREAD


def log_plateau_samples(session: DistortionSession) -> tuple[list[list[np.ndarray]], np.ndarray]:
    """The plateau pressure magnitudes of each intended label's blows, and each prompt's onset delay.

    For each prompt window (the estimator's windows, :func:`nudgecli.sim.calibration_io.distortion_windows`)
    the samples with non-zero pressure (``|p| >= ZERO_THRESHOLD``; "input stopped" frames excluded)
    on the intended side are the blow; its first ``LOG_ONSET_SAMPLES`` and last
    ``LOG_RELEASE_SAMPLES`` are the onset and release ramps and are dropped.

    Returns
    -------
    tuple[list[list[np.ndarray]], np.ndarray]
        Per label, one array of plateau magnitudes per prompt (in stream order); ``(n_prompts,)``
        seconds from each prompt to its first non-zero sample (``nan`` if none).
    """
    if np.all(np.isnan(session.stream_pressure)):
        raise DataError(f"{session.files.get('stream', 'stream')}: the stream holds no pressures; "
                        "participant_from_log needs the raw pressure of each sample")
    starts, ends = distortion_windows(session)
    labels = session.prompt_labels
    prompt_times = session.prompt_times[0::2]
    per_label: list[list[np.ndarray]] = [[] for _ in range(N_LABELS)]
    onset = np.full(len(labels), np.nan)
    pressure = np.nan_to_num(session.stream_pressure, nan=0.0)
    for k, (start, end, label) in enumerate(zip(starts, ends, labels, strict=True)):
        window = pressure[start:end]
        active = np.abs(window) >= ZERO_THRESHOLD
        if active.any():
            onset[k] = session.stream_times[start + int(np.argmax(active))] - prompt_times[k]
        blow = window[active & (np.sign(window) == LABEL_SIGN[label])]
        plateau = blow[LOG_ONSET_SAMPLES:len(blow) - LOG_RELEASE_SAMPLES]
        per_label[label].append(np.abs(plateau))
    return per_label, onset


def log_drift_correlation(blows: Sequence[Sequence[np.ndarray]], levels: np.ndarray, spreads: np.ndarray,
                          ceiling: float = 1.0) -> float | None:
    """The lag-1 correlation of a log's pressure deviations within blows (the model's ``drift_correlation``).

    Each plateau sample's deviation is ``(magnitude - level) / spread`` with its label's fitted
    level and spread; over every pair of consecutive samples of one blow that are both below the
    ceiling (a saturated sample hides its deviation), ``rho = sum(x_j x_{j+1}) / sum(x_j^2)``,
    clipped to ``[0, MAX_DRIFT_CORRELATION]``.

    Parameters
    ----------
    blows
        Per label, the plateau magnitudes of each blow (:func:`log_plateau_samples`).
    levels, spreads
        ``(F,)`` each label's fitted level and spread.

    Returns
    -------
    float or None
        The correlation, or ``None`` with fewer than ``MIN_DRIFT_PAIRS`` usable pairs.
    """
    products, squares, pairs = 0.0, 0.0, 0
    for label, label_blows in enumerate(blows):
        for blow in label_blows:
            deviation = (np.asarray(blow, dtype=float) - levels[label]) / spreads[label]
            usable = (blow[:-1] < ceiling - 1e-6) & (blow[1:] < ceiling - 1e-6)
            products += float(np.sum(deviation[:-1][usable] * deviation[1:][usable]))
            squares += float(np.sum(deviation[:-1][usable] ** 2))
            pairs += int(usable.sum())
    if pairs < MIN_DRIFT_PAIRS or squares <= 0:
        return None
    return float(np.clip(products / squares, 0.0, MAX_DRIFT_CORRELATION))


def session_from_stream_frame(frame: pd.DataFrame) -> DistortionSession:
    """A distortion session from one labelled stream table with the prompt of each sample.

    Parameters
    ----------
    frame
        Columns ``t`` (seconds, non-decreasing), ``pressure`` (sip positive) and ``intended``
        (the prompted label shown at that sample, or ``""`` in a blank). Each run of consecutive
        samples with the same label is one prompt; it ends at the next run's first sample.

    Raises
    ------
    DataError
        On missing columns, unknown labels, time running backwards or no prompt.
    """
    missing = [c for c in ("t", "pressure", "intended") if c not in frame.columns]
    if missing:
        raise DataError(f"stream frame: missing column(s) {', '.join(missing)}; "
                        "expected t, pressure, intended")
    times = frame["t"].to_numpy(dtype=float)
    back = np.flatnonzero(np.diff(times) < 0)
    if back.size:
        raise DataError(f"stream frame: row {int(back[0]) + 1}: time runs backwards")
    import pandas as pd

    intended = ["" if pd.isna(v) else str(v) for v in frame["intended"]]
    unknown = [(row, v) for row, v in enumerate(intended) if v and v not in LABELS]
    if unknown:
        raise DataError(f"stream frame: row {unknown[0][0]}: unknown intended label {unknown[0][1]!r}; "
                        f"labels are {', '.join(LABELS)}")
    pressure = frame["pressure"].to_numpy(dtype=float)
    prompt_times: list[float] = []
    commands: list[str] = []
    row = 0
    while row < len(intended):
        end = row
        while end < len(intended) and intended[end] == intended[row]:
            end += 1
        if intended[row]:
            finish = times[end] if end < len(times) else times[-1] + 0.1
            prompt_times += [times[row], finish]
            commands += [intended[row], ""]
        row = end
    if not commands:
        raise DataError("stream frame: no prompts; the intended column names no interface label")
    codes = label_pressure(pressure)
    return DistortionSession(np.array(prompt_times), tuple(commands), times, codes, pressure,
                             {"stream": "stream frame"})


def _is_frame(source: object) -> TypeGuard[pd.DataFrame]:
    """Whether ``source`` is a pandas DataFrame, without importing pandas (a frame exists only once
    pandas is loaded; a worker reading a log folder never loads it for this)."""
    pandas = sys.modules.get("pandas")
    return pandas is not None and isinstance(source, pandas.DataFrame)


def _distortion_session(source: str | Path | DistortionSession | pd.DataFrame
                        ) -> tuple[DistortionSession, str]:
    """The distortion session of :func:`participant_from_log`'s ``source``, and where it came from.

    Raises
    ------
    DataError
        A folder without a ``p(phi_m | phi_i)`` session.
    """
    if isinstance(source, DistortionSession):
        return source, source.files.get("stream", "distortion session")
    if _is_frame(source):
        return session_from_stream_frame(source), "stream frame"
    # the log readers load with a log to read: a simulated participant's worker never needs them
    from nudgecli.sim.calibration_readers import DISTORTION_LAYOUTS, read_distortion_session

    found = read_distortion_session(source)
    if found is None:
        raise DataError(f"{source}: no p(phi_m | phi_i) session; expected {DISTORTION_LAYOUTS}")
    return found, str(source)


def participant_from_log(source: str | Path | DistortionSession | pd.DataFrame, index: int = 0,
                         template: Participant | None = None,
                         population: PopulationSection | None = None) -> Participant:
    """A participant with a real person's pressure physiology, estimated from a ``p(phi_m | phi_i)`` log.

    Per intended label, the plateau samples of :func:`log_plateau_samples` give the level and
    spread by :func:`censored_normal_fit` (robust quantile fit, valid under saturation at 1). The
    reaction delay is the median of the prompts' onset delays and ``reaction_log_sd`` the robust
    (MAD) standard deviation of their logs; the onset ramp is ``LOG_RAMP_SAMPLES`` (the pilots');
    the drift correlation is :func:`log_drift_correlation` (the population's midpoint when the log
    has too few unsaturated pairs).
    Everything else (mapping, epsilon, turn habits) comes from ``template`` if given, else from the
    midpoints of the ``population`` ranges (default population if ``None``), with the true mapping
    at the midpoint error rate.

    Parameters
    ----------
    source
        A participant's calibration folder (study or tidy format), its ``p_phm_given_phi/``
        folder, a session read by :func:`nudgecli.sim.calibration_readers.read_distortion_session`, or
        a stream table with the prompt of each sample (:func:`session_from_stream_frame`).

    Raises
    ------
    DataError
        If there is no distortion session, it has no pressures, or a label has fewer than
        ``MIN_LOG_SAMPLES`` plateau samples.
    """
    session, where = _distortion_session(source)
    blows, onset = log_plateau_samples(session)
    samples = [np.concatenate(label_blows) if label_blows else np.zeros(0) for label_blows in blows]
    levels = np.zeros(N_LABELS)
    spreads = np.zeros(N_LABELS)
    for label in range(N_LABELS):
        if len(samples[label]) < MIN_LOG_SAMPLES:
            raise DataError(f"{where}: only {len(samples[label])} plateau samples of {LABELS[label]!r}; "
                            f"at least {MIN_LOG_SAMPLES} are needed to estimate its pressure")
        levels[label], spreads[label] = censored_normal_fit(samples[label])
    delays = onset[np.isfinite(onset) & (onset > 0)]
    pop = population or PopulationSection()
    drift = log_drift_correlation(blows, levels, spreads)

    def midpoint(bounds: tuple[float, float]) -> float:
        return 0.5 * (bounds[0] + bounds[1])

    if delays.size:
        reaction = float(np.median(delays))
        log_delays = portable_math.log(delays)
        log_sd = float(1.4826 * np.median(np.abs(log_delays - np.median(log_delays))))
    else:
        reaction, log_sd = midpoint(pop.reaction_s), pop.reaction_log_sd
    base: dict[str, Any]
    if template is not None:
        base = {f.name: getattr(template, f.name) for f in fields(template) if f.compare}
    else:
        error_rate = midpoint(pop.mapping_error)
        base = {"mapping": mapping_with_error(error_rate), "mapping_error": error_rate,
                "epsilon": midpoint(pop.epsilon), "rest_s": midpoint(pop.rest_s),
                "operate_s": midpoint(pop.operate_s), "action_pause_s": midpoint(pop.action_pause_s),
                "hard_blow_s": midpoint(pop.hard_blow_s)}
    base.update(index=index, seed_key=f"log:{where}",
                pressure_level=LABEL_SIGN * np.maximum(levels, 2 * ZERO_THRESHOLD),
                pressure_spread=spreads, reaction_s=reaction, reaction_log_sd=log_sd,
                onset_ramp_samples=LOG_RAMP_SAMPLES,
                drift_correlation=midpoint(pop.drift_correlation) if drift is None else drift)
    return Participant(**base)
