"""Simulated calibration sessions: the study's calibration protocol run with a simulated participant.

- :func:`simulate_mapping_session` and :func:`simulate_distortion_session` run the study's
  calibration protocol (paper Phases 1-2, DESIGN.md section 2.8) with a simulated participant and
  return the same in-memory logs the readers of :mod:`nudgecli.sim.calibration_io` return for
  real logs.
- :func:`fit_participant_tables` simulates both sessions and fits them with the estimators of
  :mod:`nudgecli.sim.calibration` (the agent then uses the fitted tables while the participant
  acts from their true physiology).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from nudgecli.config import CalibrationSection, InterfaceSection, section_defaults
from nudgecli.model.interface import (
    LABELS,
    N_LABELS,
    label_pressure,
)
from nudgecli.sim.calibration import (
    IMAGE_TO_MODE_ACTION,
    MAX_REPEAT_ROUNDS,
    PROMPT_GAP_S,
    SESSION_START_S,
    distortion_provenance,
    estimate_distortion,
    estimate_mapping,
    mapping_provenance,
)
from nudgecli.sim.calibration_io import (
    ACTION_IMAGES,
    BLOCK_BREAK_COMMAND,
    CIAA_VARIANT,
    INPUT_STOPPED,
    DistortionSession,
    MappingSession,
)
from nudgecli.sim.participants import Participant
from nudgecli.sim.pressure_model import (
    LABEL_SIGN,
    blow_pressures,
    blows_drift_normals,
    lognormal_delays,
    ramp_fraction_at,
)

#: The ``[calibration]`` defaults (the device's event step).
CALIBRATION = section_defaults(CalibrationSection)

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
                        step: float = CALIBRATION.event_step) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The event-driven label stream a device sends for a pressure trace sampled at fixed ticks.

    The device's pressure is quantised in ``step`` increments and it sends one message each time
    the quantised value changes, none while it is steady; a message reads at most full scale,
    ``[-1, 1]`` (the level nearest 1 may lie past it, 92 x 0.0109 = 1.0028, and reads 1). Between
    two ticks the pressure is taken to move linearly, so it passes every quantisation level in
    between, one message each (at the time of the crossing, labelled by its pressure); a saturated
    or constant stretch sends nothing.
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
    # the device reads at most full scale: a level past +-1 (round(1 / 0.0109) = 92 steps is 1.0028)
    # reads +-1, as the study's saturated device did (TASK.md section 5: pressure in [-1, 1])
    message_pressure = np.clip(message_level * step, -1.0, 1.0)
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
    participant = participant.at_sample_period(1.0 / rate)  # the same ramps and drift in seconds
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
        "p_phi_given_a": mapping_provenance(mapping_session, mapping),
        "p_phm_given_phi": distortion_provenance(distortion_session, distortion),
    }
    return FittedTables(mapping.table, distortion.table, provenance, (mapping_session, distortion_session))
