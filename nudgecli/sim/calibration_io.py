'''Calibration logs on disk: the study's export format, this toolkit's tidy format, the in-memory
sessions both are read into, the tidy writer, and the prompt windows of a session. The readers
are in :mod:`nudgecli.sim.calibration_readers`.

Two sessions make one participant's calibration (paper Phases 1-2, DESIGN.md section 2.9):

- the **mapping session** for ``p(phi_i | a)``: action images shown then cleared, and the keys the
  participant pressed (``1`` Hard Puff, ``2`` Hard Sip, ``3`` Soft Puff, ``4`` Soft Sip);
- the **distortion session** for ``p(phi_m | phi_i)``: interface actions prompted for a few seconds
  then cleared, and the 10 Hz labelled pressure stream.

Both formats are read into the same in-memory structures (:class:`MappingSession`,
:class:`DistortionSession`), which the estimators in :mod:`nudgecli.sim.calibration` consume.

Study export format (``shared/data/calibration/<pilot>/``), one CSV per ROS topic, times in the
``rosbagTimestamp`` column (seconds since the recording started) and strings quoted the way the
export wrote them (``"""Soft Sip"""`` is ``Soft Sip``, ``''`` is blank):

- ``p_phi_given_a/_action_prompt.csv`` (``rosbagTimestamp``, ``command``),
- ``p_phi_given_a/_user_response.csv`` (``rosbagTimestamp``, ``command`` in ``"1".."4"``),
- ``p_phm_given_phi/_command_prompt.csv`` (``rosbagTimestamp``, ``command``),
- ``p_phm_given_phi/_joy_sip_puff.csv`` (``rosbagTimestamp``, ``frame_id`` = label,
  ``axes`` = ``[pressure]``).

Tidy format (what simulated sessions are written as; plain CSV, a header row, times in seconds):

- ``mapping_prompts.csv``: ``t, command`` -- an action image name when shown, an empty field when
  cleared, ``hard_puff_training`` when cleared at a block boundary;
- ``mapping_responses.csv``: ``t, key`` -- the key pressed, ``1..4``;
- ``distortion_prompts.csv``: ``t, command`` -- an interface label when shown, empty when cleared;
- ``distortion_stream.csv``: ``t, pressure, label`` -- the 10 Hz stream, ``label`` one of the
  stream labels (``None``, the four interface labels, the two deadbands, ``input stopped``).

The tidy files may sit directly in a folder or in ``p_phi_given_a/`` and ``p_phm_given_phi/``
subfolders, like the study's files.

Two variants of the study export exist (:data:`LOG_VARIANTS`), told apart by
:func:`~nudgecli.sim.calibration_readers.detect_variant`:

- ``pilot``: the pilots' logs above. The label stream is sampled at a fixed 10 Hz and its neutral
  label is ``None``.
- ``ciaa``: the sibling study's prompt-and-produce logs (2020, "Customized Handling of
  Unintended Interface Operation in Assistive Robots", ``../shared/data/ciaa-task/TASK.md``). Same
  file names and columns (its folders are named ``<id>_p_ui_given_a/`` and
  ``<id>_p_um_given_ui/``, which are found too), but the neutral label is ``Zero Band``, and the
  stream is **event-driven**: a message every few milliseconds while the pressure changes, none
  while it is steady (e.g. saturated at 1 or held still), and one ``input stopped`` after the
  ``Zero Band`` message that ends each blow. Prompts were shown 4 s with 1 s blank, and a prompt
  that got no stream message at all (by the end of its blank) was shown again at the end of the
  session. Its folders also hold ``_keyboard_entry.csv`` and ``_mode_switches.csv``, which are
  not read.

The variant is recorded on the :class:`DistortionSession`; the estimators treat both the same way
(in an event-driven stream the "samples" they count are messages, see
:func:`nudgecli.sim.calibration.estimate_distortion`).

Every problem with a file raises one :class:`~nudgecli.errors.DataError` line naming the file and
the line (line 1 is the header) and saying what to fix (see the readers).
'''

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from nudgecli import command_defaults as defaults
from nudgecli.errors import DataError
from nudgecli.model.interface import INPUT_STOPPED_LABEL, LABELS, NO_INPUT, NO_INPUT_LABEL, STREAM_LABELS

if TYPE_CHECKING:  # pandas (and the run folder's store) load where sessions are written, not in a worker
    import pandas as pd

#: The 12 action images of the mapping session, in the study's naming.
ACTION_IMAGES = (
    "up", "down", "left", "right", "clockwise", "counterclockwise",
    "mode_switch_right_1", "mode_switch_right_2", "mode_switch_right_3",
    "mode_switch_left_1", "mode_switch_left_2", "mode_switch_left_3",
)
#: The clearing row of the last prompt of a block (the start of the hard-puff refresher).
BLOCK_BREAK_COMMAND = "hard_puff_training"
#: Stream code of the driver's "input stopped" frames (ignored like no-input samples).
INPUT_STOPPED = -2
#: The pilots' logs (a fixed-rate 10 Hz stream whose neutral label is ``None``), the sibling
#: study's (an event-driven stream whose neutral label is ``Zero Band``), and ``auto`` to detect
#: them: the names ``nudge fit --variant`` offers, written once in the click layer's defaults.
PILOT_VARIANT, CIAA_VARIANT = defaults.PILOT_VARIANT, defaults.CIAA_VARIANT
AUTO_VARIANT = defaults.AUTO_VARIANT
#: The log variants ``nudge fit`` reads (``--variant``).
LOG_VARIANTS = (PILOT_VARIANT, CIAA_VARIANT)
#: The sibling study's neutral label (the pilots' is ``None``).
ZERO_BAND_LABEL = "Zero Band"
#: Each variant's neutral (no-input) label.
NEUTRAL_LABELS = {PILOT_VARIANT: NO_INPUT_LABEL, CIAA_VARIANT: ZERO_BAND_LABEL}
#: Each variant's stream, in words (for summaries and errors).
VARIANT_STREAMS = {PILOT_VARIANT: "fixed-rate 10 Hz stream, neutral label 'None'",
                   CIAA_VARIANT: "event-driven stream, neutral label 'Zero Band'"}
#: A stream whose median gap between messages is below this is event-driven (10 Hz is 0.1 s;
#: the sibling study's messages came every 2-7 ms while the pressure changed).
EVENT_DRIVEN_MEDIAN_GAP_S = 0.05
#: Stream label name -> code (interface labels 0..3, deadbands 4/5, no input -1, input stopped -2);
#: both variants' neutral labels are no input.
STREAM_CODES = {**STREAM_LABELS, ZERO_BAND_LABEL: NO_INPUT, INPUT_STOPPED_LABEL: INPUT_STOPPED}
#: Stream code -> label name written to tidy files (the pilot variant's names).
STREAM_NAMES = {code: name for name, code in {**STREAM_LABELS, INPUT_STOPPED_LABEL: INPUT_STOPPED}.items()}


def stream_names(variant: str) -> dict[int, str]:
    """Stream code -> label name in ``variant``'s spelling (its neutral label differs)."""
    return {**STREAM_NAMES, NO_INPUT: NEUTRAL_LABELS[variant]}

STUDY_MAPPING_FOLDER = "p_phi_given_a"
STUDY_DISTORTION_FOLDER = "p_phm_given_phi"
#: The sibling study's names of the two session folders (``<id>_p_ui_given_a`` etc.).
CIAA_MAPPING_SUFFIX = "p_ui_given_a"
CIAA_DISTORTION_SUFFIX = "p_um_given_ui"
STUDY_FILES = {
    "mapping_prompts": "_action_prompt.csv",
    "mapping_responses": "_user_response.csv",
    "distortion_prompts": "_command_prompt.csv",
    "distortion_stream": "_joy_sip_puff.csv",
}
TIDY_FILES = {
    "mapping_prompts": "mapping_prompts.csv",
    "mapping_responses": "mapping_responses.csv",
    "distortion_prompts": "distortion_prompts.csv",
    "distortion_stream": "distortion_stream.csv",
}
STUDY_TIME_COLUMN = "rosbagTimestamp"


@dataclass(frozen=True)
class MappingSession:
    """One ``p(phi_i | a)`` session, whatever format it was read from.

    Attributes
    ----------
    prompt_times
        ``(P,)`` seconds, non-decreasing; rows alternate shown / cleared, so ``P`` is even.
    prompt_commands
        ``P`` strings: an action image (even rows), ``""`` or ``"hard_puff_training"`` (odd rows).
    response_times
        ``(R,)`` seconds, non-decreasing.
    response_labels
        ``(R,)`` interface label codes ``0..3`` (key ``k`` is label ``k - 1``).
    files
        Where the two logs came from (``prompts``, ``responses``).
    """

    prompt_times: np.ndarray
    prompt_commands: tuple[str, ...]
    response_times: np.ndarray
    response_labels: np.ndarray
    files: dict[str, str] = field(default_factory=dict)

    @property
    def n_showings(self) -> int:
        """Number of (shown, cleared) pairs."""
        return len(self.prompt_commands) // 2


@dataclass(frozen=True)
class DistortionSession:
    """One ``p(phi_m | phi_i)`` session, whatever format it was read from.

    Attributes
    ----------
    prompt_times
        ``(P,)`` seconds, non-decreasing; rows alternate prompt / blank, so ``P`` is even.
    prompt_commands
        ``P`` strings: an interface label (even rows) or ``""`` (odd rows).
    stream_times
        ``(N,)`` seconds of the labelled stream, non-decreasing.
    stream_codes
        ``(N,)`` codes: ``0..3`` labels, ``PUFF_DEADBAND``/``SIP_DEADBAND``, ``NO_INPUT``,
        ``INPUT_STOPPED``.
    stream_pressure
        ``(N,)`` raw pressures (sip positive); ``nan`` where the log holds none.
    files
        Where the two logs came from (``prompts``, ``stream``).
    variant
        ``"pilot"`` (fixed-rate stream) or ``"ciaa"`` (event-driven stream), see
        :data:`LOG_VARIANTS`.
    """

    prompt_times: np.ndarray
    prompt_commands: tuple[str, ...]
    stream_times: np.ndarray
    stream_codes: np.ndarray
    stream_pressure: np.ndarray
    files: dict[str, str] = field(default_factory=dict)
    variant: str = PILOT_VARIANT

    @property
    def event_driven(self) -> bool:
        """Whether the stream sends messages only while the pressure changes (the ``ciaa`` variant)."""
        return self.variant == CIAA_VARIANT

    @property
    def n_prompts(self) -> int:
        """Number of (prompt, blank) pairs."""
        return len(self.prompt_commands) // 2

    @property
    def prompt_labels(self) -> np.ndarray:
        """``(n_prompts,)`` intended label code of each prompt."""
        return np.array([LABELS.index(c) for c in self.prompt_commands[0::2]], dtype=int)


# --- writers (tidy format) --------------------------------------------------------------------

def _write_csv_atomic(frame: pd.DataFrame, path: Path) -> None:
    from nudgecli.store import atomic_path

    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False)


def mapping_session_frames(session: MappingSession) -> dict[str, pd.DataFrame]:
    """The tidy tables of a mapping session: ``mapping_prompts`` (t, command), ``mapping_responses``
    (t, key)."""
    import pandas as pd

    return {
        "mapping_prompts": pd.DataFrame({"t": session.prompt_times,
                                         "command": list(session.prompt_commands)}),
        "mapping_responses": pd.DataFrame({"t": session.response_times, "key": session.response_labels + 1}),
    }


def distortion_session_frames(session: DistortionSession) -> dict[str, pd.DataFrame]:
    """The tidy tables of a distortion session: ``distortion_prompts`` (t, command) and
    ``distortion_stream`` (t, pressure, label)."""
    import pandas as pd

    names = stream_names(session.variant)
    return {
        "distortion_prompts": pd.DataFrame({"t": session.prompt_times,
                                            "command": list(session.prompt_commands)}),
        "distortion_stream": pd.DataFrame({
            "t": session.stream_times, "pressure": session.stream_pressure,
            "label": [names[code] for code in np.asarray(session.stream_codes).astype(np.int64).tolist()]}),
    }


def write_sessions(folder: str | Path, mapping: MappingSession | None = None,
                   distortion: DistortionSession | None = None) -> list[Path]:
    """Write sessions in the tidy format into ``folder`` (created if needed); returns the files written.

    Each file is written atomically (temporary file, then rename).
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    frames: dict[str, pd.DataFrame] = {}
    if mapping is not None:
        frames.update(mapping_session_frames(mapping))
    if distortion is not None:
        frames.update(distortion_session_frames(distortion))
    written = []
    for key, frame in frames.items():
        path = folder / TIDY_FILES[key]
        _write_csv_atomic(frame, path)
        written.append(path)
    return written


def is_counted_code(codes: np.ndarray) -> np.ndarray:
    """``(N,)`` bool: the stream codes the distortion estimator counts (labels and deadbands)."""
    return (codes != NO_INPUT) & (codes != INPUT_STOPPED)


def nearest_indices(times: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Index of the time nearest each target, ties to the earlier one (what ``np.argmin`` picks).

    Parameters
    ----------
    times
        ``(N,)`` non-decreasing, ``N >= 1``.
    targets
        ``(K,)``.

    Returns
    -------
    np.ndarray
        ``(K,)`` integer indices into ``times``; among equal times, the first.
    """
    times = np.asarray(times, dtype=float)
    targets = np.asarray(targets, dtype=float)
    right = np.clip(np.searchsorted(times, targets, side="left"), 0, len(times) - 1)
    left = np.clip(right - 1, 0, len(times) - 1)
    take_left = np.abs(times[left] - targets) <= np.abs(times[right] - targets)
    nearest = np.where(take_left, left, right)
    return np.searchsorted(times, times[nearest], side="left")


def distortion_windows(session: DistortionSession) -> tuple[np.ndarray, np.ndarray]:
    """Each prompt's stream window ``[start, end)``: the samples nearest its start and its blank.

    Returns
    -------
    tuple[np.ndarray, np.ndarray]
        ``(n_prompts,)`` start indices and ``(n_prompts,)`` end indices (exclusive) into the stream.
    """
    if len(session.stream_times) == 0:
        raise DataError(f"{session.files.get('stream', 'stream')}: the stream has no samples")
    starts = nearest_indices(session.stream_times, session.prompt_times[0::2])
    ends = nearest_indices(session.stream_times, session.prompt_times[1::2])
    return starts, ends


def silent_prompts(session: DistortionSession) -> np.ndarray:
    """``(n_prompts,)`` bool: the prompts that got no input, which the protocol shows again.

    Event-driven stream (``ciaa``): no stream message at all (of any label, ``Zero Band`` and
    ``input stopped`` included) from the prompt's showing up to the next prompt's showing (the
    last prompt: up to the end of the stream). This is the sibling study's re-queue test (after the
    blank it compared the time of the last stream message with the prompt's time). Fixed-rate
    stream (``pilot``): the stream never falls silent, so "no input" means no message other than
    the neutral label in that interval (the rule of this toolkit's simulated sessions).
    """
    shown = session.prompt_times[0::2]
    until = np.append(shown[1:], np.inf)
    times = session.stream_times
    if not session.event_driven:
        times = times[session.stream_codes != NO_INPUT]
    return np.searchsorted(times, shown, side="left") == np.searchsorted(times, until, side="left")


def requeue_consistent(session: DistortionSession) -> bool:
    """Whether the prompt log follows the re-queue rule of the prompt-and-produce protocol.

    The protocol shows each label equally often (rounds of the four labels), then appends each
    prompt without input (:func:`silent_prompts`) to the end of the session, in the order they
    occurred (a repeat that again gets no input is appended again). So with ``k`` silent prompts,
    the first ``n - k`` prompts hold each label equally often and the last ``k`` have the labels of
    the silent prompts, in order. ``False`` means the session was cut short, or the log is not a
    complete prompt-and-produce session.
    """
    silent = silent_prompts(session)
    labels = session.prompt_labels
    k = int(silent.sum())
    planned = np.bincount(labels[:len(labels) - k], minlength=len(LABELS))
    balanced = bool(np.all(planned == planned[0]))
    return balanced and bool(np.array_equal(labels[len(labels) - k:], labels[silent]))
