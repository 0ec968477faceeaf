"""Calibration: simulated sessions, the study's two estimators, and participant profiles.

- :func:`simulate_mapping_session` and :func:`simulate_distortion_session` run the study's
  calibration protocol (paper Phases 1-2, DESIGN.md section 2.8) with a simulated participant and
  return the same in-memory logs the readers of :mod:`nudgecli.sim.calibration_io` return for
  real logs.
- :func:`estimate_mapping` and :func:`estimate_distortion` are the study's estimators of
  ``p(phi_i | a, m)`` and ``p(phi_m | phi_i)``, following DESIGN.md section 2.9 to the letter; they
  reproduce the study's published pilot tables from its raw logs.
- :func:`fit_participant_tables` simulates both sessions and fits them (the agent then uses the
  fitted tables while the participant acts from their true physiology).
- :func:`fit_calibration_dir` fits a real or simulated participant's calibration folder into a
  profile (what ``nudge fit`` writes).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from nudgecli.config import CalibrationSection, InterfaceSection
from nudgecli.errors import DataError
from nudgecli.model.interface import (
    ACTIONS,
    LABELS,
    MOVE_N,
    MOVE_P,
    N_ACTIONS,
    N_LABELS,
    PUFF_DEADBAND,
    SIP_DEADBAND,
    TO_MODE_L,
    TO_MODE_R,
    TRUE_MAPPING,
    default_distortion_table,
    default_mapping_table,
    distortion_table_to_dict,
    label_pressure,
    mapping_table_to_dict,
)
from nudgecli.model.world import MODE_NAMES, N_MODES
from nudgecli.sim.calibration_io import (
    ACTION_IMAGES,
    AUTO_VARIANT,
    BLOCK_BREAK_COMMAND,
    CIAA_VARIANT,
    INPUT_STOPPED,
    VARIANT_STREAMS,
    DistortionSession,
    MappingSession,
    distortion_windows,
    nearest_indices,
    read_sessions,
    requeue_consistent,
    silent_prompts,
)
from nudgecli.sim.participant_fitting import participant_from_log
from nudgecli.sim.participants import (
    LABEL_SIGN,
    Participant,
    blow_pressures,
    blows_drift_normals,
    lognormal_delays,
    ramp_fraction_at,
)
from nudgecli.store import write_json_atomic

#: Action image -> (mode, task action), the study's table (DESIGN.md section 2.9).
IMAGE_TO_MODE_ACTION: dict[str, tuple[int, int]] = {
    "right": (0, MOVE_P), "left": (0, MOVE_N),
    "up": (1, MOVE_P), "down": (1, MOVE_N),
    "clockwise": (2, MOVE_P), "counterclockwise": (2, MOVE_N),
    **{f"mode_switch_right_{k}": (k - 1, TO_MODE_R) for k in (1, 2, 3)},
    **{f"mode_switch_left_{k}": (k - 1, TO_MODE_L) for k in (1, 2, 3)},
}
#: Smoothing added to each ``p(phi_i | a)`` entry before renormalising (study).
MAPPING_SMOOTHING = 1e-4
#: Smoothing added to each ``p(phi_m | phi_i)`` entry before renormalising (study).
DISTORTION_SMOOTHING = 0.01
#: The study's "needs more training" threshold: L2 distance of a row from the true one-hot row.
NEEDS_TRAINING_DISTANCE = 0.22
#: Prompt rows per showing of each action: (shown + cleared) x 12 actions.
PROMPT_ROWS_PER_SHOWING = 2 * len(ACTION_IMAGES)
#: Time of the first prompt of a simulated session, seconds (the pilot logs: about 4-6 s).
SESSION_START_S = 2.0
#: Gap between a prompt being cleared and the next one shown (pilot logs: 0.015-0.017 s).
PROMPT_GAP_S = 0.017
#: Stream codes the distortion estimator counts, in its column order (labels, then deadbands).
COUNTED_CODES = (0, 1, 2, 3, PUFF_DEADBAND, SIP_DEADBAND)
#: How often a prompt that got no input is appended again before the session gives up.
MAX_REPEAT_ROUNDS = 10


# --- estimators -------------------------------------------------------------------------------

@dataclass(frozen=True)
class MappingEstimate:
    """``p(phi_i | a, m)`` fitted from a mapping session, and what went into it.

    Attributes
    ----------
    table
        ``(M, A, F)`` fitted ``p(phi_i | a, m)``; rows without any answer hold the default row.
    counts
        ``(12, F)`` answers per action image (order ``ACTION_IMAGES``) and label.
    showings
        ``(12,)`` showings per image the study divides by: prompt rows / 24, minus its missed answers.
    missed
        ``(12,)`` showings counted as "no answer" per image.
    unanswered
        Images without any counted answer (their rows fall back to the default table).
    """

    table: np.ndarray
    counts: np.ndarray
    showings: np.ndarray
    missed: np.ndarray
    unanswered: tuple[str, ...]


def estimate_mapping(session: MappingSession, fallback: np.ndarray | None = None) -> MappingEstimate:
    """The study's ``p(phi_i | a)`` estimator (DESIGN.md section 2.9).

    Prompt rows are taken in (shown, cleared) pairs. For each pair the responses nearest in time to
    the shown and to the cleared moment are found; the same response is counted; if both lie
    before their moments the one nearest the cleared moment is counted; if both lie after, the one
    nearest the shown moment; otherwise no answer is counted and that action's number of showings
    is lowered by one. Probabilities are counts divided by the showings per action
    (``prompt rows / 24``), plus ``1e-4``, renormalised, and placed at the (mode, action) of each
    image (``IMAGE_TO_MODE_ACTION``).

    Parameters
    ----------
    fallback
        ``(M, A, F)`` rows used for images without any counted answer (default: the 0.85/0.05
        default table); the study would divide by zero there.
    """
    n_images = len(ACTION_IMAGES)
    counts = np.zeros((n_images, N_LABELS))
    missed = np.zeros(n_images)
    image_index = {name: i for i, name in enumerate(ACTION_IMAGES)}
    shown_times = session.prompt_times[0::2]
    cleared_times = session.prompt_times[1::2]
    images = np.array([image_index[c] for c in session.prompt_commands[0::2]], dtype=int)
    responses = session.response_times
    if len(responses) == 0:
        np.add.at(missed, images, 1)
    else:
        near_shown = nearest_indices(responses, shown_times)
        near_cleared = nearest_indices(responses, cleared_times)
        pairs = zip(images, shown_times, cleared_times, near_shown, near_cleared, strict=True)
        for image, shown, cleared, i_s, i_c in pairs:
            if i_s == i_c:
                counted = i_s
            elif responses[i_s] < shown and responses[i_c] < cleared:
                counted = i_c
            elif responses[i_s] > shown and responses[i_c] > cleared:
                counted = i_s
            else:
                missed[image] += 1
                continue
            counts[image, session.response_labels[counted]] += 1
    showings = len(session.prompt_commands) / PROMPT_ROWS_PER_SHOWING - missed
    table = default_mapping_table() if fallback is None else np.array(fallback, dtype=float)
    unanswered = []
    for image, name in enumerate(ACTION_IMAGES):
        mode, action = IMAGE_TO_MODE_ACTION[name]
        if counts[image].sum() == 0 or showings[image] <= 0:
            unanswered.append(name)
            continue
        row = counts[image] / showings[image] + MAPPING_SMOOTHING
        table[mode, action] = row / row.sum()
    return MappingEstimate(table, counts, showings, missed, tuple(unanswered))


@dataclass(frozen=True)
class DistortionEstimate:
    """``p(phi_m | phi_i)`` fitted from a distortion session, and what went into it.

    Attributes
    ----------
    table
        ``(F, F)`` fitted ``p(phi_m | phi_i)``; rows without data hold the default row.
    mean_fractions
        ``(F, 6)`` per intended label, the renormalised mean of the per-prompt fractions over
        ``COUNTED_CODES`` (before merging deadbands and smoothing); zeros for rows without data.
    prompts
        ``(F,)`` prompts per intended label.
    prompts_used
        ``(F,)`` prompts with at least one counted sample.
    counted_samples
        ``(F,)`` counted samples (labels and deadbands) per intended label.
    rows_without_data
        Labels never prompted, or whose prompts had no counted sample.
    """

    table: np.ndarray
    mean_fractions: np.ndarray
    prompts: np.ndarray
    prompts_used: np.ndarray
    counted_samples: np.ndarray
    rows_without_data: tuple[str, ...]


def prompt_code_counts(session: DistortionSession) -> np.ndarray:
    """``(n_prompts, 6)`` counts of each counted code (``COUNTED_CODES``) in each prompt's window.

    Windows are ``[nearest sample to the prompt, nearest sample to its blank)``
    (:func:`nudgecli.sim.calibration_io.distortion_windows`).
    """
    starts, ends = distortion_windows(session)
    onehot = (session.stream_codes[:, None] == np.array(COUNTED_CODES)[None, :]).astype(np.int64)
    cumulative = np.vstack([np.zeros((1, len(COUNTED_CODES)), dtype=np.int64), np.cumsum(onehot, axis=0)])
    return np.maximum(cumulative[ends] - cumulative[starts], 0)


def merge_and_smooth(mean_fractions: np.ndarray, smoothing: float = DISTORTION_SMOOTHING) -> np.ndarray:
    """``(F, 6)`` mean code fractions -> ``(F, F)``: deadbands into hard, ``+smoothing``, renormalised."""
    merged = mean_fractions[:, :N_LABELS].copy()
    merged[:, 0] += mean_fractions[:, COUNTED_CODES.index(PUFF_DEADBAND)]
    merged[:, 1] += mean_fractions[:, COUNTED_CODES.index(SIP_DEADBAND)]
    merged += smoothing
    return merged / merged.sum(axis=1, keepdims=True)


def estimate_distortion(session: DistortionSession, fallback: np.ndarray | None = None) -> DistortionEstimate:
    """The study's ``p(phi_m | phi_i)`` estimator (DESIGN.md section 2.9).

    For each prompt, the stream samples from the one nearest in time to the prompt's start up to
    (not including) the one nearest to its end are counted by code (the four labels and the two
    deadbands; no-input and "input stopped" samples are ignored) and turned into fractions of that
    prompt. The fractions are averaged over the prompts of each intended label that had at least
    one counted sample and renormalised; the puff deadband is added to Hard Puff and the sip
    deadband to Hard Sip; ``0.01`` is added to each of the four and the row renormalised.

    The "samples" are the stream's messages, whatever the stream's variant. In the pilots' fixed
    10 Hz stream a message is a time sample, so a fraction is a share of the prompt's time. In the
    sibling study's event-driven stream (``session.event_driven``) a message is sent only while the
    pressure changes, so a fraction is a share of the *changes*: a steady (e.g. saturated hard)
    pressure adds nothing, and the ramps of a hard blow through the soft band and the deadband
    weigh as much as its plateau; the study's own estimator counted them the same way, so its
    tables carry this weighting and are not comparable with fixed-rate ones label for label.
    A prompt that got no message (re-queued by the protocol, :func:`~nudgecli.sim.calibration_io.
    silent_prompts`) has an empty or uncounted window and is not used; its repeat is.

    Parameters
    ----------
    fallback
        ``(F, F)`` rows used for labels without data (default: the 0.85/0.05 default table).
    """
    counts = prompt_code_counts(session)
    totals = counts.sum(axis=1)
    labels = session.prompt_labels
    mean_fractions = np.zeros((N_LABELS, len(COUNTED_CODES)))
    prompts = np.bincount(labels, minlength=N_LABELS)
    used = np.bincount(labels[totals > 0], minlength=N_LABELS)
    counted = np.bincount(labels, weights=totals, minlength=N_LABELS).astype(int)
    table = default_distortion_table() if fallback is None else np.array(fallback, dtype=float)
    missing = []
    for label in range(N_LABELS):
        rows = (labels == label) & (totals > 0)
        if not rows.any():
            missing.append(LABELS[label])
            continue
        mean = (counts[rows] / totals[rows, None]).mean(axis=0)
        mean_fractions[label] = mean / mean.sum()
    has_data = mean_fractions.sum(axis=1) > 0
    smoothed = merge_and_smooth(np.where(has_data[:, None], mean_fractions, 1.0))
    table[has_data] = smoothed[has_data]
    return DistortionEstimate(table, mean_fractions, prompts, used, counted, tuple(missing))


def smooth_true_distortion(true_distortion: np.ndarray,
                           smoothing: float = DISTORTION_SMOOTHING) -> np.ndarray:
    """``(F, F)``: what the estimator converges to for a physiology's unsmoothed ``true_distortion``."""
    table = np.asarray(true_distortion, dtype=float) + smoothing
    return table / table.sum(axis=1, keepdims=True)


def smooth_true_mapping(mapping: np.ndarray, smoothing: float = MAPPING_SMOOTHING) -> np.ndarray:
    """``(M, A, F)``: what the mapping estimator converges to for a true ``p(phi_i | a, m)``."""
    table = np.asarray(mapping, dtype=float) + smoothing
    return table / table.sum(axis=-1, keepdims=True)


# --- simulated sessions -----------------------------------------------------------------------

def _reaction_delays(participant: Participant, n: int, rng: np.random.Generator) -> np.ndarray:
    """``(n,)`` per-prompt delays ``reaction_s * exp(reaction_log_sd * z)``: log-normal around the median."""
    return lognormal_delays(participant.reaction_s, participant.reaction_log_sd, n, rng)


def simulate_mapping_session(participant: Participant, calibration: CalibrationSection,
                             rng: np.random.Generator) -> MappingSession:
    """The study's ``p(phi_i | a)`` session with a simulated participant.

    ``mapping_blocks`` blocks of the 12 action images, each block in a fresh random order. Each
    image stands for (mode, task action) (``IMAGE_TO_MODE_ACTION``); the participant answers with
    the label their internal mapping draws for it, after a log-normal reaction delay. An answer
    clears the prompt ``answer_clear_s`` later; no answer within ``answer_timeout_s`` clears it
    unanswered. The last prompt of each block but the final one is cleared by
    ``hard_puff_training`` and the next block starts ``block_break_s`` later; otherwise the next
    prompt follows ``PROMPT_GAP_S`` after the clearing.

    Draws, in order: the block orders ``(B, 12)``, one uniform per answer (the label), one normal
    per answer (the delay).

    Returns
    -------
    MappingSession
        ``2 * 12 * mapping_blocks`` prompt rows and one response per answered prompt.
    """
    blocks = calibration.mapping_blocks
    n_images = len(ACTION_IMAGES)
    orders = rng.permuted(np.tile(np.arange(n_images), (blocks, 1)), axis=1)
    modes_actions = [IMAGE_TO_MODE_ACTION[ACTION_IMAGES[i]] for i in orders.ravel()]
    answers = [participant.intended_label(action, mode, rng) for mode, action in modes_actions]
    delays = _reaction_delays(participant, blocks * n_images, rng)
    prompt_times: list[float] = []
    commands: list[str] = []
    response_times: list[float] = []
    response_labels: list[int] = []
    t = SESSION_START_S
    for k, image in enumerate(orders.ravel()):
        prompt_times.append(t)
        commands.append(ACTION_IMAGES[image])
        if delays[k] < calibration.answer_timeout_s:
            response_times.append(t + delays[k])
            response_labels.append(answers[k])
            cleared = t + delays[k] + calibration.answer_clear_s
        else:
            cleared = t + calibration.answer_timeout_s
        block_end = (k + 1) % n_images == 0 and k + 1 < blocks * n_images
        prompt_times.append(cleared)
        commands.append(BLOCK_BREAK_COMMAND if block_end else "")
        t = cleared + (calibration.block_break_s if block_end else PROMPT_GAP_S)
    return MappingSession(np.array(prompt_times), tuple(commands), np.array(response_times),
                          np.array(response_labels, dtype=int),
                          {"source": f"simulated {participant.seed_key}"})


def event_driven_stream(times: np.ndarray, pressure: np.ndarray, interface: InterfaceSection,
                        step: float = 0.0109) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The event-driven label stream a device sends for a pressure trace sampled at fixed ticks.

    The device's pressure is quantised in ``step`` increments and it sends one message each time
    the quantised value changes, none while it is steady. Between two ticks the pressure is taken
    to move linearly, so it passes every quantisation level in between, one message each (at the
    time of the crossing, labelled by its pressure); a saturated or constant stretch sends nothing.
    When the pressure comes back to zero (a blow ends) the zero-level message is the neutral label
    and an ``input stopped`` message follows it, 0.1 ms later, as the sibling study's driver did.

    Parameters
    ----------
    times
        ``(N,)`` tick times, increasing.
    pressure
        ``(N,)`` pressures at the ticks (sip positive).
    interface
        The label thresholds.
    step
        The quantisation step (the sibling study's device: about 0.0109, ``../shared/data/ciaa-task/
        TASK.md`` section 5).

    Returns
    -------
    tuple[np.ndarray, np.ndarray, np.ndarray]
        ``(M,)`` message times, ``(M,)`` pressures and ``(M,)`` stream codes (labels, deadbands,
        ``NO_INPUT`` for the zero level, ``INPUT_STOPPED``).
    """
    levels = np.round(np.asarray(pressure, dtype=float) / step).astype(np.int64)
    times = np.asarray(times, dtype=float)
    moves = np.diff(levels)
    counts = np.abs(moves)
    interval = np.repeat(np.arange(len(moves)), counts)
    # position of each message within its interval: 1..count
    offsets = np.arange(interval.size) - np.repeat(np.cumsum(counts) - counts, counts) + 1
    direction = np.sign(moves)[interval]
    message_level = levels[interval] + direction * offsets
    fraction = offsets / counts[interval]
    message_time = times[interval] + fraction * (times[interval + 1] - times[interval])
    message_pressure = message_level * step
    codes = label_pressure(message_pressure, interface.soft_threshold, interface.hard_threshold,
                           interface.zero_threshold)
    stops = np.flatnonzero(message_level == 0) + 1
    message_time = np.insert(message_time, stops, message_time[stops - 1] + 1e-4)
    message_pressure = np.insert(message_pressure, stops, 0.0)
    codes = np.insert(codes, stops, INPUT_STOPPED)
    return message_time, message_pressure, codes


def _first_sample_at_or_after(t: np.ndarray, phase: float, rate: float) -> np.ndarray:
    """Index of the first stream sample (at ``phase + j / rate``) at or after each time ``t``."""
    return np.ceil(np.round((t - phase) * rate, 9)).astype(int)


def simulate_distortion_session(participant: Participant, calibration: CalibrationSection,
                                interface: InterfaceSection, rng: np.random.Generator) -> DistortionSession:
    """The study's ``p(phi_m | phi_i)`` session with a simulated participant, vectorised.

    ``prompts_per_label`` rounds of the four labels, each round in a random order; each prompt is
    shown ``prompt_s`` and followed by ``blank_s`` blank. The participant starts blowing the
    prompted label a log-normal reaction delay after the prompt and blows until it is cleared
    (resting in the blank). The stream is sampled at ``rate_hz`` from a random phase; a blow's
    samples follow the participant's pressure model (onset ramp, level, spread, drift within each
    blow; one normal draw for the whole stream) and are labelled by the interface thresholds. As
    in the study, a prompt that got no input (the delay outlasted it) is appended again at the end.

    Draws, in order: the rounds' orders ``(R, 4)``, one normal per prompt (delays; again for
    repeated prompts), the stream phase, one normal per stream sample.

    With ``calibration.stream = "event_driven"`` the ticks' pressures become the sibling study's
    event-driven stream (:func:`event_driven_stream`, variant ``ciaa``); a prompt the participant
    never blew in then gets no message at all, which is the study's re-queue test.

    Returns
    -------
    DistortionSession
        Prompt rows alternate label / blank; the stream holds every sample with its pressure
        and code.
    """
    rate = calibration.rate_hz
    period = calibration.prompt_s + calibration.blank_s
    labels = rng.permuted(np.tile(np.arange(N_LABELS), (calibration.prompts_per_label, 1)), axis=1).ravel()
    delays = _reaction_delays(participant, len(labels), rng)
    phase = float(rng.uniform(0.0, 1.0 / rate))
    pending = np.arange(len(labels))
    for _ in range(MAX_REPEAT_ROUNDS):
        starts = SESSION_START_S + np.arange(len(labels)) * period
        first = _first_sample_at_or_after(starts[pending] + delays[pending], phase, rate)
        stop = _first_sample_at_or_after(starts[pending] + calibration.prompt_s, phase, rate)
        no_input = pending[stop <= first]
        if no_input.size == 0:
            break
        pending = len(labels) + np.arange(no_input.size)
        labels = np.concatenate([labels, labels[no_input]])
        delays = np.concatenate([delays, _reaction_delays(participant, no_input.size, rng)])
    starts = SESSION_START_S + np.arange(len(labels)) * period
    blank_starts = starts + calibration.prompt_s
    session_end = np.array([blank_starts[-1] + calibration.blank_s])
    n_samples = int(_first_sample_at_or_after(session_end, phase, rate)[0])
    times = phase + np.arange(n_samples) / rate
    first = _first_sample_at_or_after(starts + delays, phase, rate)
    stop = np.minimum(_first_sample_at_or_after(blank_starts, phase, rate), n_samples)
    lengths = np.maximum(stop - first, 0)
    sample_index = np.concatenate([np.arange(f, f + n) for f, n in zip(first, lengths, strict=True)])
    sample_label = np.repeat(labels, lengths)
    position = np.concatenate([np.arange(n) for n in lengths])
    fractions = ramp_fraction_at(position, participant.onset_ramp_samples)
    normals = rng.standard_normal(n_samples)
    deviations = blows_drift_normals(normals[sample_index], lengths, participant.drift_correlation)
    pressure = np.zeros(n_samples)
    pressure[sample_index] = blow_pressures(np.abs(participant.pressure_level[sample_label]),
                                            participant.pressure_spread[sample_label],
                                            LABEL_SIGN[sample_label], fractions, deviations)
    codes = label_pressure(pressure, interface.soft_threshold, interface.hard_threshold,
                           interface.zero_threshold)
    prompt_times = np.column_stack([starts, blank_starts]).ravel()
    commands = tuple(c for label in labels for c in (LABELS[label], ""))
    source = {"source": f"simulated {participant.seed_key}"}
    if calibration.stream == "event_driven":
        times, pressure, codes = event_driven_stream(times, pressure, interface, calibration.event_step)
        return DistortionSession(prompt_times, commands, times, codes, pressure, source, CIAA_VARIANT)
    return DistortionSession(prompt_times, commands, times, codes, pressure, source)


@dataclass(frozen=True)
class FittedTables:
    """The tables the agent uses for one participant, fitted from their (simulated) calibration.

    Attributes
    ----------
    mapping
        ``(M, A, F)`` fitted ``p(phi_i | a, m)``.
    distortion
        ``(F, F)`` fitted ``p(phi_m | phi_i)``.
    provenance
        JSON-ready description: prompts, answers missed, counted samples, rows without data.
    sessions
        The simulated logs ``(mapping, distortion)`` (write them with
        :func:`nudgecli.sim.calibration_io.write_sessions`).
    """

    mapping: np.ndarray
    distortion: np.ndarray
    provenance: dict[str, Any]
    sessions: tuple[MappingSession, DistortionSession] | None = field(default=None, repr=False, compare=False)


def fit_participant_tables(participant: Participant, calibration: CalibrationSection,
                           interface: InterfaceSection, rng: np.random.Generator) -> FittedTables:
    """Simulate both calibration sessions with ``participant`` and fit the study's tables.

    The mapping and distortion sessions use independent children of ``rng`` (``rng.spawn(2)``),
    so changing one session's settings does not change the other's draws.

    Parameters
    ----------
    participant
        Who is calibrated (their true physiology produces the logs).
    calibration
        The protocol (blocks, prompts, durations, rate).
    interface
        The label thresholds the stream is labelled with.
    rng
        E.g. ``generator(seed, "participant", i, "calibration")``.
    """
    mapping_rng, distortion_rng = rng.spawn(2)
    mapping_session = simulate_mapping_session(participant, calibration, mapping_rng)
    distortion_session = simulate_distortion_session(participant, calibration, interface, distortion_rng)
    mapping = estimate_mapping(mapping_session)
    distortion = estimate_distortion(distortion_session)
    provenance = {
        "source": "simulated calibration",
        "participant": participant.seed_key,
        "p_phi_given_a": _mapping_provenance(mapping_session, mapping),
        "p_phm_given_phi": _distortion_provenance(distortion_session, distortion),
    }
    return FittedTables(mapping.table, distortion.table, provenance, (mapping_session, distortion_session))


def _mapping_provenance(session: MappingSession, estimate: MappingEstimate) -> dict[str, Any]:
    return {
        "files": dict(session.files),
        "prompts": session.n_showings,
        "answered": int(estimate.counts.sum()),
        "answers_missed": int(estimate.missed.sum()),
        "missed_by_action": {name: int(m) for name, m in zip(ACTION_IMAGES, estimate.missed, strict=True)
                             if m},
        "showings_per_action": len(session.prompt_commands) / PROMPT_ROWS_PER_SHOWING,
        "smoothing": MAPPING_SMOOTHING,
        "rows_from_default": list(estimate.unanswered),
    }


def _distortion_provenance(session: DistortionSession, estimate: DistortionEstimate) -> dict[str, Any]:
    return {
        "files": dict(session.files),
        "variant": session.variant,
        "stream": VARIANT_STREAMS[session.variant],
        "prompts_without_input": int(silent_prompts(session).sum()),
        "requeue_consistent": requeue_consistent(session),
        "prompts": {label: int(n) for label, n in zip(LABELS, estimate.prompts, strict=True)},
        "prompts_used": {label: int(n) for label, n in zip(LABELS, estimate.prompts_used, strict=True)},
        "counted_samples": {label: int(n) for label, n in zip(LABELS, estimate.counted_samples, strict=True)},
        "smoothing": DISTORTION_SMOOTHING,
        "rows_from_default": list(estimate.rows_without_data),
    }


# --- profiles (`nudge fit`) -------------------------------------------------------------------

@dataclass(frozen=True)
class CalibrationProfile:
    """What ``nudge fit`` produces for one calibration folder.

    Attributes
    ----------
    profile
        JSON-ready: ``participant``, ``p_phi_given_a`` ``{mode: {action: {label: p}}}`` (modes
        ``x``, ``y``, ``theta``), ``p_phm_given_phi`` ``{intended: {measured: p}}``, ``provenance``.
    summary
        Readable text for stdout: diagonals, worst confusions, the "needs more training" check.
    warnings
        One line each (missing sessions, rows from the default table), for stderr.
    """

    profile: dict[str, Any]
    summary: str
    warnings: tuple[str, ...]


def needs_more_training(mapping: np.ndarray, distortion: np.ndarray) -> dict[str, dict[str, float]]:
    """Rows farther than ``NEEDS_TRAINING_DISTANCE`` (L2) from the true one-hot row.

    Returns
    -------
    dict
        ``{"p_phi_given_a": {"mode/action": distance}, "p_phm_given_phi": {"intended": distance}}``.
        The study ran this check on ``p(phi_i | a)`` only; here it is applied to both tables.
    """
    truth = np.eye(N_LABELS)[TRUE_MAPPING]
    mapping_distance = np.linalg.norm(mapping - truth[None], axis=-1)
    distortion_distance = np.linalg.norm(distortion - np.eye(N_LABELS), axis=-1)
    return {
        "p_phi_given_a": {f"{MODE_NAMES[m]}/{ACTIONS[a]}": float(mapping_distance[m, a])
                          for m in range(N_MODES) for a in range(N_ACTIONS)
                          if mapping_distance[m, a] > NEEDS_TRAINING_DISTANCE},
        "p_phm_given_phi": {LABELS[i]: float(distortion_distance[i]) for i in range(N_LABELS)
                            if distortion_distance[i] > NEEDS_TRAINING_DISTANCE},
    }


def fit_calibration_dir(calibration_dir: str | Path, variant: str = AUTO_VARIANT) -> CalibrationProfile:
    """Fit the tables of one participant's calibration folder (study or tidy format).

    Reads whichever sessions the folder holds; a missing session falls back to the default table
    with a warning. When a fixed-rate pressure stream exists, the participant's pressure physiology
    is estimated too (:func:`nudgecli.sim.participant_fitting.participant_from_log`) and recorded in the
    provenance; an event-driven stream's messages are not samples of the blow (steady pressure
    sends none), so no physiology is estimated from it.

    Parameters
    ----------
    calibration_dir
        One participant's folder.
    variant
        The distortion log's variant: ``"auto"`` (detect), ``"pilot"`` or ``"ciaa"``
        (:data:`nudgecli.sim.calibration_io.LOG_VARIANTS`).

    Raises
    ------
    DataError
        If the folder does not exist, holds no session, or a log is malformed.
    """
    folder = Path(calibration_dir)
    mapping_session, distortion_session = read_sessions(folder, variant)
    warnings: list[str] = []
    provenance: dict[str, Any] = {"tool": "nudge fit", "folder": str(folder)}
    if mapping_session is not None:
        mapping_estimate = estimate_mapping(mapping_session)
        mapping = mapping_estimate.table
        provenance["p_phi_given_a"] = {"source": "fitted",
                                       **_mapping_provenance(mapping_session, mapping_estimate)}
        if mapping_estimate.unanswered:
            warnings.append(f"p(phi_i | a): no answer for {', '.join(mapping_estimate.unanswered)}; "
                            "those rows use the default table")
    else:
        mapping = default_mapping_table()
        provenance["p_phi_given_a"] = {"source": "default (no p_phi_given_a session)"}
        warnings.append(f"{folder}: no p(phi_i | a) session; using the default table (0.85 / 0.05)")
    if distortion_session is not None:
        distortion_estimate = estimate_distortion(distortion_session)
        distortion = distortion_estimate.table
        provenance["p_phm_given_phi"] = {"source": "fitted",
                                         **_distortion_provenance(distortion_session, distortion_estimate)}
        if distortion_estimate.rows_without_data:
            missing = ", ".join(distortion_estimate.rows_without_data)
            warnings.append(f"p(phi_m | phi_i): no counted input for {missing}; "
                            "those rows use the default table")
        if not requeue_consistent(distortion_session):
            silent = int(silent_prompts(distortion_session).sum())
            warnings.append(f"p(phi_m | phi_i): {silent} prompt(s) got no input but the prompt log does "
                            "not end with their repeats (the protocol shows such a prompt again at the end); "
                            "the session may have been cut short")
        if distortion_session.event_driven:
            provenance["pressure_physiology"] = None
            provenance["pressure_physiology_note"] = (
                "not estimated: the event-driven stream sends messages only while the pressure changes, "
                "so its pressures are not samples of the blow")
        else:
            shortfall = stream_shortfall(distortion_session)
            if shortfall is not None:
                warnings.append(shortfall)
            provenance["pressure_physiology"] = _physiology(distortion_session, warnings)
    else:
        distortion = default_distortion_table()
        provenance["p_phm_given_phi"] = {"source": "default (no p_phm_given_phi session)"}
        warnings.append(f"{folder}: no p(phi_m | phi_i) session; using the default table (0.85 / 0.05)")
    flagged = needs_more_training(mapping, distortion)
    provenance["needs_more_training"] = flagged
    participant = folder.resolve().name
    profile = {
        "participant": participant,
        "p_phi_given_a": mapping_table_to_dict(mapping),
        "p_phm_given_phi": distortion_table_to_dict(distortion),
        "provenance": provenance,
    }
    summary = profile_summary(participant, mapping, distortion, provenance)
    return CalibrationProfile(profile, summary, tuple(warnings))


#: A stream with fewer than this fraction of the samples its rate implies over the prompts is reported.
STREAM_COVERAGE = 0.9


def stream_shortfall(session: DistortionSession) -> str | None:
    """A warning when the label stream holds fewer samples during the prompts than its rate implies.

    The rate is the stream's own (the median interval between samples: 10 Hz in simulated logs,
    about 15 Hz in the pilot logs); over the span from the first prompt to the last blank it
    implies ``span / interval`` samples. A stream cut short (a truncated file, a recording that
    stopped) or with long gaps holds fewer, and the prompts it misses add nothing to the fit.

    Returns
    -------
    str or None
        The warning, or ``None`` when the stream covers the prompts (or is too short to tell).
    """
    times = session.stream_times
    if times.size < 2 or session.prompt_times.size < 2:
        return None
    interval = float(np.median(np.diff(times)))
    first, last = float(session.prompt_times[0]), float(session.prompt_times[-1])
    if interval <= 0 or last <= first:
        return None
    expected = int((last - first) / interval)
    inside = int(np.count_nonzero((times >= first) & (times <= last)))
    if inside >= STREAM_COVERAGE * expected:
        return None
    where = session.files.get("stream", "the label stream")
    return (f"{where}: {inside} samples during the prompts ({last - first:.1f} s), fewer than the "
            f"{expected} its own rate ({1 / interval:.1f} Hz) implies; the stream looks truncated or has "
            f"gaps (it ends at {float(times[-1]):.1f} s, the last prompt at {last:.1f} s), so prompts "
            "without samples add nothing to p(phi_m | phi_i)")


def _physiology(session: DistortionSession, warnings: list[str]) -> dict[str, Any] | None:
    """The pressure physiology of a real log, or ``None`` (with a warning) if it cannot be estimated."""
    try:
        person = participant_from_log(session)
    except DataError as exc:
        warnings.append(f"pressure physiology not estimated: {exc}")
        return None
    return {
        "method": "censored-normal quantile fit of the plateau samples per prompted label "
                  "(nudgecli.sim.participant_fitting.participant_from_log)",
        "level": {label: float(v) for label, v in zip(LABELS, person.pressure_level, strict=True)},
        "spread": {label: float(v) for label, v in zip(LABELS, person.pressure_spread, strict=True)},
        "reaction_s": person.reaction_s,
        "reaction_log_sd": person.reaction_log_sd,
    }


def profile_summary(participant: str, mapping: np.ndarray, distortion: np.ndarray,
                    provenance: dict[str, Any]) -> str:
    """Readable summary: each table's source, its diagonal, worst confusions, the training check."""
    lines = [f"Calibration profile of {participant}"]
    mapping_info = provenance.get("p_phi_given_a", {})
    if mapping_info.get("source") == "fitted":
        lines.append(f"p(phi_i | a): fitted from {mapping_info['prompts']} prompts "
                     f"({mapping_info['answered']} answered, {mapping_info['answers_missed']} missed)")
    else:
        lines.append("p(phi_i | a): default table (no session)")
    header = "  p(true label)  " + "".join(f"{a:>11}" for a in ACTIONS)
    lines.append(header)
    truth = TRUE_MAPPING
    for m, mode in enumerate(MODE_NAMES):
        lines.append(f"  {mode:<15}" + "".join(f"{mapping[m, a, truth[a]]:>11.4f}" for a in range(N_ACTIONS)))
    confusions = [(mapping[m, a, f], f"{MODE_NAMES[m]}/{ACTIONS[a]} -> {LABELS[f]}")
                  for m in range(N_MODES) for a in range(N_ACTIONS) for f in range(N_LABELS) if f != truth[a]]
    lines.append("  worst confusions: " + _worst(confusions))
    distortion_info = provenance.get("p_phm_given_phi", {})
    if distortion_info.get("source") == "fitted":
        used = sum(distortion_info["prompts_used"].values())
        total = sum(distortion_info["prompts"].values())
        unit = "messages" if distortion_info.get("variant") == "ciaa" else "samples"
        lines.append(f"p(phi_m | phi_i): fitted from {total} prompts ({used} with input, "
                     f"{sum(distortion_info['counted_samples'].values())} counted {unit}; "
                     f"{distortion_info.get('stream', 'fixed-rate stream')})")
    else:
        lines.append("p(phi_m | phi_i): default table (no session)")
    lines.append("  diagonal: " + ", ".join(f"{LABELS[i]} {distortion[i, i]:.3f}" for i in range(N_LABELS)))
    confusions = [(distortion[i, j], f"{LABELS[i]} -> {LABELS[j]}")
                  for i in range(N_LABELS) for j in range(N_LABELS) if i != j]
    lines.append("  worst confusions: " + _worst(confusions))
    flagged = provenance.get("needs_more_training", {})
    rows = [f"p(phi_i | a) {k} ({v:.2f})" for k, v in flagged.get("p_phi_given_a", {}).items()]
    rows += [f"p(phi_m | phi_i) {k} ({v:.2f})" for k, v in flagged.get("p_phm_given_phi", {}).items()]
    check = "; ".join(rows) if rows else "none"
    lines.append(f"Needs more training (row more than {NEEDS_TRAINING_DISTANCE} from one-hot, L2): {check}")
    return "\n".join(lines)


def _worst(confusions: list[tuple[float, str]], count: int = 3, floor: float = 0.011) -> str:
    """The ``count`` largest confusions above ``floor`` (just above the smoothing floors), or "none"."""
    ranked = [item for item in sorted(confusions, key=lambda item: -item[0]) if item[0] > floor][:count]
    return ", ".join(f"{name} {p:.3f}" for p, name in ranked) if ranked else "none above the smoothing floor"



def write_profile(profile: dict[str, Any], path: str | Path) -> Path:
    """Write a profile as JSON atomically; return its path."""
    target = Path(path)
    write_json_atomic(target, profile)
    return target
