'''Calibration logs on disk: the study's export format, this toolkit's tidy format, and readers of both.

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

Two variants of the study export exist (:data:`LOG_VARIANTS`), told apart by :func:`detect_variant`:

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
the line (line 1 is the header) and saying what to fix.
'''

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from nudgecli.errors import DataError
from nudgecli.model.interface import INPUT_STOPPED_LABEL, LABELS, NO_INPUT, NO_INPUT_LABEL, STREAM_LABELS
from nudgecli.store import atomic_path

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
#: The pilots' logs: a fixed-rate (10 Hz) stream whose neutral label is ``None``.
PILOT_VARIANT = "pilot"
#: The sibling study's logs: an event-driven stream whose neutral label is ``Zero Band``.
CIAA_VARIANT = "ciaa"
#: The log variants ``nudge fit`` reads (``--variant``), and ``auto`` to detect them.
LOG_VARIANTS = (PILOT_VARIANT, CIAA_VARIANT)
AUTO_VARIANT = "auto"
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


# --- low-level parsing ------------------------------------------------------------------------

def unquote(value: object) -> str:
    """An exported string -> its text (``'"Soft Sip"'`` -> ``Soft Sip``, ``''`` -> ``""``).

    pandas has already removed the CSV quoting (``\"\"\"Soft Sip\"\"\"`` is read as ``"Soft Sip"``);
    this strips the remaining layer of ``"`` or ``'`` quotes.
    """
    if value is None or (isinstance(value, float) and np.isnan(value)):
        return ""
    text = str(value).strip()
    while len(text) >= 2 and text[0] == text[-1] and text[0] in "\"'":
        text = text[1:-1].strip()
    return text


def _read_csv(path: Path, columns: tuple[str, ...], what: str) -> pd.DataFrame:
    """Read a CSV as strings, checking that it exists, is not empty and has ``columns``."""
    if not path.is_file():
        raise DataError(f"{path}: no such file; {what} needs it")
    try:
        frame = pd.read_csv(path, dtype=str, keep_default_na=False, skipinitialspace=False)
    except pd.errors.EmptyDataError:
        raise DataError(f"{path}: the file is empty; expected a header with columns "
                        f"{', '.join(columns)} and one row per message") from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: not a readable CSV file ({str(exc).splitlines()[0]})") from None
    frame.columns = [str(c).strip() for c in frame.columns]
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise DataError(f"{path}: missing column(s) {', '.join(missing)}; found {', '.join(frame.columns)}; "
                        f"{what} needs {', '.join(columns)}")
    if frame.empty:
        raise DataError(f"{path}: the file has a header but no rows; record the session again")
    return frame


def _times(frame: pd.DataFrame, column: str, path: Path) -> np.ndarray:
    """The time column as floats, checked to be finite and non-decreasing."""
    raw = frame[column].to_numpy(dtype=object)
    values = pd.to_numeric(pd.Series(raw).str.strip(), errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        row = int(bad[0])
        raise DataError(f"{path}: line {row + 2}: {column} {raw[row]!r} is not a time in seconds")
    back = np.flatnonzero(np.diff(values) < 0)
    if back.size:
        row = int(back[0]) + 1
        raise DataError(f"{path}: line {row + 2}: time runs backwards ({column} {values[row]:g} after "
                        f"{values[row - 1]:g}); rows must be in recording order")
    return values


def _check_alternation(commands: list[str], path: Path, shown: set[str], cleared: set[str],
                       shown_what: str, cleared_what: str) -> None:
    """Rows must alternate shown (even) / cleared (odd) and end with a clearing row."""
    if not any(c in shown for c in commands):
        raise DataError(f"{path}: no prompts: no row shows {shown_what}; record the session again")
    for row, command in enumerate(commands):
        allowed, what = (shown, shown_what) if row % 2 == 0 else (cleared, cleared_what)
        if command not in allowed:
            if row % 2 == 0 and command in cleared:
                raise DataError(f"{path}: line {row + 2}: expected {what} (rows alternate shown / cleared), "
                                f"got a clearing row {command!r}")
            if row % 2 == 1 and command in shown:
                raise DataError(f"{path}: line {row + 2}: {command!r} is shown before the previous prompt "
                                "was cleared; rows must alternate shown / cleared")
            raise DataError(f"{path}: line {row + 2}: unknown command {command!r}; expected {what}")
    if len(commands) % 2:
        raise DataError(f"{path}: line {len(commands) + 1}: the last prompt is never cleared; "
                        "add its clearing row or drop the prompt")


# --- readers ----------------------------------------------------------------------------------

def _parse_prompts(frame: pd.DataFrame, path: Path, time_column: str,
                   kind: str) -> tuple[np.ndarray, list[str]]:
    times = _times(frame, time_column, path)
    commands = [unquote(c) for c in frame["command"].to_numpy(dtype=object)]
    if kind == "mapping":
        _check_alternation(commands, path, set(ACTION_IMAGES), {"", BLOCK_BREAK_COMMAND},
                           f"an action image ({', '.join(ACTION_IMAGES)})",
                           f"a clearing row ('' or {BLOCK_BREAK_COMMAND})")
    else:
        _check_alternation(commands, path, set(LABELS), {""},
                           f"an interface label ({', '.join(LABELS)})", "a blank row ('')")
    return times, commands


def _parse_responses(frame: pd.DataFrame, path: Path, time_column: str,
                     key_column: str) -> tuple[np.ndarray, np.ndarray]:
    times = _times(frame, time_column, path)
    keys = [unquote(k) for k in frame[key_column].to_numpy(dtype=object)]
    labels = np.empty(len(keys), dtype=int)
    for row, key in enumerate(keys):
        if key not in ("1", "2", "3", "4"):
            raise DataError(f"{path}: line {row + 2}: unknown key {key!r}; answers are 1 Hard Puff, "
                            "2 Hard Sip, 3 Soft Puff, 4 Soft Sip")
        labels[row] = int(key) - 1
    return times, labels


def detect_variant(labels: list[str], times: np.ndarray, path: Path | str,
                   requested: str = AUTO_VARIANT) -> str:
    """The log variant of a label stream (``"pilot"`` or ``"ciaa"``), checked against ``requested``.

    The neutral label decides: ``None`` is the pilots' format, ``Zero Band`` the sibling study's.
    A stream without any neutral label is told apart by its timing: a median gap between messages
    below :data:`EVENT_DRIVEN_MEDIAN_GAP_S` is event-driven (``ciaa``), else fixed-rate (``pilot``).

    Parameters
    ----------
    labels
        ``N`` unquoted stream labels, in file order.
    times
        ``(N,)`` their times in seconds.
    path
        The stream file (for messages).
    requested
        ``"auto"`` to detect, or the variant the caller expects.

    Raises
    ------
    DataError
        When the stream mixes both neutral labels, or ``requested`` contradicts its neutral label
        (naming the line and the option that fixes it).
    """
    if requested != AUTO_VARIANT and requested not in LOG_VARIANTS:
        raise DataError(f"unknown log variant {requested!r}; choose auto, {', '.join(LOG_VARIANTS)}")
    first_line = {variant: next((row + 2 for row, name in enumerate(labels) if name == neutral), None)
                  for variant, neutral in NEUTRAL_LABELS.items()}
    found = [variant for variant, line in first_line.items() if line is not None]
    if len(found) == 2:
        pilot_line, ciaa_line = first_line[PILOT_VARIANT], first_line[CIAA_VARIANT]
        raise DataError(f"{path}: mixes the pilots' neutral label {NO_INPUT_LABEL!r} (line {pilot_line}) and "
                        f"the sibling study's {ZERO_BAND_LABEL!r} (line {ciaa_line}); one stream holds one "
                        "session of one format: split the file")
    if found:
        detected = found[0]
        if requested not in (AUTO_VARIANT, detected):
            line = first_line[detected]
            raise DataError(f"{path}: line {line}: label {NEUTRAL_LABELS[detected]!r} belongs to the "
                            f"{detected!r} log format ({VARIANT_STREAMS[detected]}), but --variant "
                            f"{requested} was given; use --variant {detected} or auto")
        return detected
    if requested != AUTO_VARIANT:
        return requested
    gaps = np.diff(np.asarray(times, dtype=float))
    if gaps.size and float(np.median(gaps)) < EVENT_DRIVEN_MEDIAN_GAP_S:
        return CIAA_VARIANT
    return PILOT_VARIANT


def _parse_stream(frame: pd.DataFrame, path: Path, time_column: str, label_column: str,
                  pressure_column: str, variant: str = AUTO_VARIANT
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    times = _times(frame, time_column, path)
    names = [unquote(v) for v in frame[label_column].to_numpy(dtype=object)]
    detected = detect_variant(names, times, path, variant)
    codes = np.empty(len(names), dtype=int)
    for row, name in enumerate(names):
        code = STREAM_CODES.get(name)
        if code is None:
            other = next(v for v in LOG_VARIANTS if v != detected)
            known = [n for n in STREAM_CODES if n != NEUTRAL_LABELS[other]]
            raise DataError(f"{path}: line {row + 2}: unknown label {name!r}; stream labels are "
                            f"{', '.join(known)}")
        codes[row] = code
    raw = pd.Series(frame[pressure_column].to_numpy(dtype=object)).astype(str).str.strip()
    text = raw.str.strip("[]").str.split(",").str[0].str.strip()
    pressure = pd.to_numeric(text, errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(~np.isfinite(pressure) & (text != "").to_numpy())
    if bad.size:
        row = int(bad[0])
        raise DataError(f"{path}: line {row + 2}: {pressure_column} {raw.iloc[row]!r} is not a pressure")
    pressure = np.where(np.isfinite(pressure), pressure, np.nan)
    return times, codes, pressure, detected


#: The sibling study's folder suffix for each of our session subfolders.
CIAA_SUBFOLDERS = {STUDY_MAPPING_FOLDER: CIAA_MAPPING_SUFFIX, STUDY_DISTORTION_FOLDER: CIAA_DISTORTION_SUFFIX}


def _candidates(folder: Path, subfolder: str) -> list[Path]:
    """Where a session's files may be: ``folder``, ``folder/subfolder``, or the sibling study's
    ``folder/<id>_p_ui_given_a`` / ``folder/<id>_p_um_given_ui`` (sorted, first match wins)."""
    found = [folder, folder / subfolder]
    suffix = CIAA_SUBFOLDERS.get(subfolder)
    if suffix is not None and folder.is_dir():
        sibling = sorted(child for child in folder.iterdir()
                         if child.is_dir() and (child.name == suffix or child.name.endswith("_" + suffix)))
        if len(sibling) > 1:
            names = ", ".join(child.name for child in sibling)
            raise DataError(f"{folder}: holds the sibling study's session folders of several participants "
                            f"({names}); fit one at a time, e.g. `nudge fit {sibling[0]}`")
        found += sibling
    return found


def _locate(folder: Path, names: dict[str, str], keys: tuple[str, str], subfolder: str) -> Path | None:
    """The folder holding both files ``keys`` of a format (see :func:`_candidates`)."""
    for candidate in _candidates(folder, subfolder):
        if all((candidate / names[k]).is_file() for k in keys):
            return candidate
    return None


def _half_present(folder: Path, keys: tuple[str, str], subfolder: str) -> Path | None:
    """A file of the pair that exists while its partner does not (to name it in the error)."""
    for names in (STUDY_FILES, TIDY_FILES):
        for candidate in _candidates(folder, subfolder):
            present = [candidate / names[k] for k in keys if (candidate / names[k]).is_file()]
            if len(present) == 1:
                return present[0]
    return None


def _find_session(folder: Path, keys: tuple[str, str], subfolder: str, session: str,
                  second_file: str) -> tuple[Path | None, Path | None] | None:
    """The folder of a session's file pair in study and in tidy format, ``None`` if it has neither.

    A lone file of the pair is an error naming the missing partner (``prompts`` or
    ``second_file``).
    """
    study = _locate(folder, STUDY_FILES, keys, subfolder)
    tidy = _locate(folder, TIDY_FILES, keys, subfolder)
    if study is None and tidy is None:
        orphan = _half_present(folder, keys, subfolder)
        if orphan is not None:
            partner = second_file if "prompt" in orphan.name else "prompts"
            raise DataError(f"{orphan}: the {session} session's {partner} file is missing beside it")
        return None
    return study, tidy


def read_mapping_session(folder: str | Path) -> MappingSession | None:
    """Read the ``p(phi_i | a)`` session in ``folder`` (study or tidy format), or ``None`` if absent.

    Parameters
    ----------
    folder
        A participant's calibration folder, its ``p_phi_given_a/`` subfolder, or a folder holding
        the tidy ``mapping_prompts.csv`` and ``mapping_responses.csv``.

    Raises
    ------
    DataError
        When one file of the pair is missing or a file is malformed (one line naming file and line).
    """
    folder = Path(folder)
    found = _find_session(folder, ("mapping_prompts", "mapping_responses"), STUDY_MAPPING_FOLDER, "mapping",
                          "responses")
    if found is None:
        return None
    study, tidy = found
    if study is not None:
        prompts_path = study / STUDY_FILES["mapping_prompts"]
        responses_path = study / STUDY_FILES["mapping_responses"]
        time_column, key_column = STUDY_TIME_COLUMN, "command"
    else:
        assert tidy is not None
        prompts_path = tidy / TIDY_FILES["mapping_prompts"]
        responses_path = tidy / TIDY_FILES["mapping_responses"]
        time_column, key_column = "t", "key"
    what = "the p(phi_i | a) session"
    prompts = _read_csv(prompts_path, (time_column, "command"), what)
    prompt_times, commands = _parse_prompts(prompts, prompts_path, time_column, "mapping")
    responses = _read_csv(responses_path, (time_column, key_column), what)
    response_times, labels = _parse_responses(responses, responses_path, time_column, key_column)
    return MappingSession(prompt_times, tuple(commands), response_times, labels,
                          {"prompts": str(prompts_path), "responses": str(responses_path)})


def read_distortion_session(folder: str | Path, variant: str = AUTO_VARIANT) -> DistortionSession | None:
    """Read the ``p(phi_m | phi_i)`` session in ``folder`` (study or tidy format), or ``None`` if absent.

    Parameters
    ----------
    folder
        A participant's calibration folder, its ``p_phm_given_phi/`` (or the sibling study's
        ``<id>_p_um_given_ui/``) subfolder, or a folder holding the tidy ``distortion_prompts.csv``
        and ``distortion_stream.csv``.
    variant
        ``"auto"`` (detect, :func:`detect_variant`), ``"pilot"`` or ``"ciaa"``.

    Raises
    ------
    DataError
        When one file of the pair is missing or a file is malformed (one line naming file and line).
    """
    folder = Path(folder)
    found = _find_session(folder, ("distortion_prompts", "distortion_stream"), STUDY_DISTORTION_FOLDER,
                          "distortion", "stream")
    if found is None:
        return None
    study, tidy = found
    what = "the p(phi_m | phi_i) session"
    if study is not None:
        prompts_path = study / STUDY_FILES["distortion_prompts"]
        stream_path = study / STUDY_FILES["distortion_stream"]
        time_column, label_column, pressure_column = STUDY_TIME_COLUMN, "frame_id", "axes"
    else:
        assert tidy is not None
        prompts_path = tidy / TIDY_FILES["distortion_prompts"]
        stream_path = tidy / TIDY_FILES["distortion_stream"]
        time_column, label_column, pressure_column = "t", "label", "pressure"
    prompts = _read_csv(prompts_path, (time_column, "command"), what)
    prompt_times, commands = _parse_prompts(prompts, prompts_path, time_column, "distortion")
    stream = _read_csv(stream_path, (time_column, label_column, pressure_column), what)
    times, codes, pressure, detected = _parse_stream(stream, stream_path, time_column, label_column,
                                                     pressure_column, variant)
    return DistortionSession(prompt_times, tuple(commands), times, codes, pressure,
                             {"prompts": str(prompts_path), "stream": str(stream_path)}, detected)


def read_sessions(folder: str | Path, variant: str = AUTO_VARIANT
                  ) -> tuple[MappingSession | None, DistortionSession | None]:
    """Both sessions of one participant's calibration folder; at least one must be present.

    ``variant`` is the distortion stream's log variant (``"auto"``, ``"pilot"`` or ``"ciaa"``).

    Raises
    ------
    DataError
        If ``folder`` does not exist or holds neither session, or a log is malformed.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise DataError(f"{folder}: no such folder; give one participant's calibration folder "
                        f"(with {STUDY_MAPPING_FOLDER}/ and/or {STUDY_DISTORTION_FOLDER}/)")
    mapping = read_mapping_session(folder)
    distortion = read_distortion_session(folder, variant)
    if mapping is None and distortion is None:
        participants = sorted(child.name for child in folder.iterdir() if child.is_dir() and (
            (child / STUDY_MAPPING_FOLDER).is_dir() or (child / STUDY_DISTORTION_FOLDER).is_dir()))
        if participants:
            raise DataError(f"{folder}: holds the calibration folders of several participants "
                            f"({', '.join(participants)}); fit one at a time, e.g. "
                            f"`nudge fit {folder / participants[0]}`")
        raise DataError(
            f"{folder}: no calibration session found; expected {STUDY_MAPPING_FOLDER}/"
            f"{STUDY_FILES['mapping_prompts']} + {STUDY_FILES['mapping_responses']} and/or "
            f"{STUDY_DISTORTION_FOLDER}/{STUDY_FILES['distortion_prompts']} + "
            f"{STUDY_FILES['distortion_stream']}, the sibling study's <id>_{CIAA_MAPPING_SUFFIX}/ and/or "
            f"<id>_{CIAA_DISTORTION_SUFFIX}/ with the same files, or the tidy "
            f"{', '.join(TIDY_FILES.values())}")
    return mapping, distortion


# --- writers (tidy format) --------------------------------------------------------------------

def _write_csv_atomic(frame: pd.DataFrame, path: Path) -> None:
    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False)


def mapping_session_frames(session: MappingSession) -> dict[str, pd.DataFrame]:
    """The tidy tables of a mapping session: ``mapping_prompts`` (t, command), ``mapping_responses``
    (t, key)."""
    return {
        "mapping_prompts": pd.DataFrame({"t": session.prompt_times,
                                         "command": list(session.prompt_commands)}),
        "mapping_responses": pd.DataFrame({"t": session.response_times, "key": session.response_labels + 1}),
    }


def distortion_session_frames(session: DistortionSession) -> dict[str, pd.DataFrame]:
    """The tidy tables of a distortion session: ``distortion_prompts`` (t, command) and
    ``distortion_stream`` (t, pressure, label)."""
    return {
        "distortion_prompts": pd.DataFrame({"t": session.prompt_times,
                                            "command": list(session.prompt_commands)}),
        "distortion_stream": pd.DataFrame({
            "t": session.stream_times, "pressure": session.stream_pressure,
            "label": [stream_names(session.variant)[int(c)] for c in session.stream_codes]}),
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
