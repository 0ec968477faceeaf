"""Calibration: the study's calibration protocol constants and its two estimators.

- :func:`estimate_mapping` and :func:`estimate_distortion` are the study's estimators of
  ``p(phi_i | a, m)`` and ``p(phi_m | phi_i)``, following DESIGN.md section 2.9 to the letter; they
  reproduce the study's published pilot tables from its raw logs.
- :func:`mapping_provenance` and :func:`distortion_provenance` record how an estimate was made.

Simulated sessions are in :mod:`nudgecli.sim.calibration_sessions`, profiles (``nudge fit``) in
:mod:`nudgecli.sim.calibration_profile`, the log formats in :mod:`nudgecli.sim.calibration_io`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from nudgecli.errors import DataError
from nudgecli.model.interface import (
    LABELS,
    MOVE_N,
    MOVE_P,
    N_LABELS,
    PUFF_DEADBAND,
    SIP_DEADBAND,
    TO_MODE_L,
    TO_MODE_R,
    default_distortion_table,
    default_mapping_table,
)
from nudgecli.sim.calibration_io import (
    ACTION_IMAGES,
    VARIANT_STREAMS,
    DistortionSession,
    MappingSession,
    distortion_windows,
    nearest_indices,
    requeue_consistent,
    silent_prompts,
)

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

def check_same_clock(prompt_times: np.ndarray, times: np.ndarray, files: dict[str, str], log: str,
                     event: str) -> None:
    """Refuse a response log or stream on another clock than its prompts.

    Both estimators pair each prompt with the events nearest in time, so a log on another clock
    (epoch seconds beside relative prompts) still gives a table: every prompt takes the same
    event. The pilots' logs share one clock, and each of their prompts holds its own events.

    Parameters
    ----------
    prompt_times
        ``(2K,)`` the prompts' (shown, cleared) times.
    times
        ``(N,)`` the events' times, non-decreasing (nothing is checked when ``N == 0``).
    files
        The session's files (``"prompts"`` and ``log``), for the message.
    log, event
        The events' file key (``"responses"``, ``"stream"``) and what one event is called
        (``"response"``, ``"stream sample"``).

    Raises
    ------
    DataError
        When the events' span does not overlap the prompts', or no event falls inside a prompt.
    """
    if len(times) == 0 or len(prompt_times) == 0:
        return
    where, prompts = files.get(log, f"the {log} log"), files.get("prompts", "the prompt log")
    logs = f"the prompt and {event.split()[0]} logs"  # "the prompt and response logs"
    first, last = float(prompt_times[0]), float(prompt_times[-1])
    if float(times[-1]) < first or float(times[0]) > last:
        raise DataError(f"{where}: {logs} are on different clocks: its times run from "
                        f"{float(times[0]):.9g} to {float(times[-1]):.9g} s, the prompts' ({prompts}) from "
                        f"{first:.9g} to {last:.9g} s; export both with the same time base")
    shown, cleared = prompt_times[0::2], prompt_times[1::2]
    inside = np.searchsorted(times, shown, side="left") < np.searchsorted(times, cleared, side="right")
    if not inside.any():
        raise DataError(f"{where}: no {event} falls inside any prompt (between its showing and its clearing "
                        f"in {prompts}); {logs} are on different clocks or from different "
                        "sessions; export both of one session with the same time base")


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
    reused_responses
        Responses counted for more than one showing. The study's pairing rule does this when a
        showing got no answer of its own (it takes the nearest one, a neighbour's); the pilots'
        logs have none (each response counted once), so a fit reports them.
    """

    table: np.ndarray
    counts: np.ndarray
    showings: np.ndarray
    missed: np.ndarray
    unanswered: tuple[str, ...]
    reused_responses: int = 0

    @property
    def reuse_warning(self) -> str:
        """What a fit says of :attr:`reused_responses` (when there are any)."""
        return (f"p(phi_i | a): {self.reused_responses} response(s) counted for more than one prompt (a "
                "prompt without its own answer took a neighbour's, as the study's pairing rule does); "
                "check that the response log is complete")


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
    times_used = np.zeros(len(responses), dtype=int)
    if len(responses) == 0:
        np.add.at(missed, images, 1)
    else:
        check_same_clock(session.prompt_times, responses, session.files, "responses", "response")
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
            times_used[counted] += 1
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
    return MappingEstimate(table, counts, showings, missed, tuple(unanswered), int(np.sum(times_used > 1)))


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
    check_same_clock(session.prompt_times, session.stream_times, session.files, "stream", "stream sample")
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


# --- provenance -------------------------------------------------------------------------------

def mapping_provenance(session: MappingSession, estimate: MappingEstimate) -> dict[str, Any]:
    """How a ``p(phi_i | a, m)`` estimate was made (a profile's provenance): files, prompts,
    answers, smoothing."""
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


def distortion_provenance(session: DistortionSession, estimate: DistortionEstimate) -> dict[str, Any]:
    """How a ``p(phi_m | phi_i)`` estimate was made (a profile's provenance): files, stream,
    prompts used, smoothing."""
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
