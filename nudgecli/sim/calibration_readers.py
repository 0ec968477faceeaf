"""Reading calibration logs: the study's export format (both variants, told apart by
:func:`detect_variant`) and this toolkit's tidy format, into the in-memory sessions of
:mod:`nudgecli.sim.calibration_io`.

Every problem with a file raises one :class:`~nudgecli.errors.DataError` line naming the file and
the line (line 1 is the header) and saying what to fix.
"""


from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from nudgecli.csv_rows import read_csv_whole_rows
from nudgecli.csv_text import not_utf8_message
from nudgecli.errors import DataError, did_you_mean, shell_words
from nudgecli.model.interface import LABELS, NO_INPUT_LABEL
from nudgecli.run_folder_calibration import check_calibration_logs
from nudgecli.sim.calibration_io import (
    ACTION_IMAGES,
    AUTO_VARIANT,
    BLOCK_BREAK_COMMAND,
    CIAA_DISTORTION_SUFFIX,
    CIAA_MAPPING_SUFFIX,
    CIAA_VARIANT,
    EVENT_DRIVEN_MEDIAN_GAP_S,
    LOG_VARIANTS,
    NEUTRAL_LABELS,
    PILOT_VARIANT,
    STREAM_CODES,
    STUDY_DISTORTION_FOLDER,
    STUDY_FILES,
    STUDY_MAPPING_FOLDER,
    STUDY_TIME_COLUMN,
    TIDY_FILES,
    VARIANT_STREAMS,
    ZERO_BAND_LABEL,
    DistortionSession,
    MappingSession,
)

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
    """Read a CSV as strings, checking that it exists, is not empty, has ``columns`` and no row
    with fewer or more fields than the header (a log cut off: its last prompt row, its command
    missing, would be read as a clearing row)."""
    if not path.is_file():
        raise DataError(f"{path}: no such file; {what} needs it")
    try:
        frame = read_csv_whole_rows(path, dtype=str, keep_default_na=False, skipinitialspace=False)
    except pd.errors.EmptyDataError:
        raise DataError(f"{path}: the file is empty; expected a header with columns "
                        f"{', '.join(columns)} and one row per message") from None
    except UnicodeDecodeError:
        raise DataError(not_utf8_message(path)) from None
    except pd.errors.ParserError as exc:
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


#: The largest pressure magnitude of a stream (DESIGN 2.2: p in [-1, 1], sip positive; the pilots'
#: logs peak at exactly 1.0), and what a log of each variant may add to it: rounding in the
#: fixed-rate stream; in the event-driven one a quantisation step (this toolkit's simulated
#: device steps in 0.0109 and tops out at the step nearest 1, 92 x 0.0109 = 1.0028). A log in
#: percent (100 at full scale) is beyond either.
PRESSURE_LIMIT = 1.0
PRESSURE_TOLERANCE = {PILOT_VARIANT: 1e-6, CIAA_VARIANT: 0.02}


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
    outside = np.flatnonzero(np.abs(np.nan_to_num(pressure)) > PRESSURE_LIMIT + PRESSURE_TOLERANCE[detected])
    if outside.size:  # a log in percent (x100) would fit soft levels in the hard band without a word
        row = int(outside[0])
        raise DataError(f"{path}: line {row + 2}: {pressure_column} {raw.iloc[row]!r}: pressure must lie in "
                        f"[-{PRESSURE_LIMIT:g}, {PRESSURE_LIMIT:g}] (sip positive); is it in percent? "
                        "divide the column by 100")
    pressure = np.where(np.isfinite(pressure), pressure, np.nan)
    return times, codes, pressure, detected


#: The sibling study's folder suffix for each of our session subfolders.
CIAA_SUBFOLDERS = {STUDY_MAPPING_FOLDER: CIAA_MAPPING_SUFFIX, STUDY_DISTORTION_FOLDER: CIAA_DISTORTION_SUFFIX}


def _candidates(folder: Path, subfolder: str) -> list[Path]:
    """Where a session's files may be: ``folder``, ``folder/subfolder``, or the sibling study's
    ``folder/<id>_p_ui_given_a`` / ``folder/<id>_p_um_given_ui`` (sorted; a session found in more
    than one of them is refused by :func:`_find_session`)."""
    found = [folder, folder / subfolder]
    suffix = CIAA_SUBFOLDERS.get(subfolder)
    if suffix is not None and folder.is_dir():
        sibling = sorted(child for child in folder.iterdir()
                         if child.is_dir() and (child.name == suffix or child.name.endswith("_" + suffix)))
        if len(sibling) > 1:
            names = ", ".join(child.name for child in sibling)
            fit_first = shell_words(["nudge", "fit", str(sibling[0])])
            raise DataError(f"{folder}: holds the sibling study's session folders of several participants "
                            f"({names}); fit one at a time, e.g. `{fit_first}`")
        found += sibling
    return found


def _locate(folder: Path, names: dict[str, str], keys: tuple[str, str], subfolder: str) -> list[Path]:
    """Every folder holding both files ``keys`` of a format (see :func:`_candidates`)."""
    return [candidate for candidate in _candidates(folder, subfolder)
            if all((candidate / names[k]).is_file() for k in keys)]


#: Every name a calibration folder's sessions are read under (folders and files of both formats).
_READ_NAMES = (STUDY_MAPPING_FOLDER, STUDY_DISTORTION_FOLDER, *STUDY_FILES.values(), *TIDY_FILES.values())


def _close_to_csv(suffix: str) -> bool:
    """Whether a file's suffix is a close miss of ``.csv`` (``.cvs``, ``.csvv``), not another kind."""
    from difflib import SequenceMatcher

    return SequenceMatcher(None, suffix.lower(), ".csv").ratio() >= 0.75


def _look_alike(folder: Path, keys: tuple[str, str], subfolder: str) -> tuple[Path, str] | None:
    """An entry of ``folder`` (or its ``subfolder``) whose name is not read but resembles one this
    session's folder or files take (``p_phi_given_A``, ``maping_prompts.csv``, a ``.CSV``), with
    that name; ``None`` where there is none. Names another session reads are never look-alikes, a
    folder's name is matched only by a folder, and a file's only by a ``.csv`` file (any case): a
    ``notes.txt`` or ``x.p_phi_given_a.json`` beside the logs is no misnamed session."""
    expected = {subfolder, *(names[k] for names in (STUDY_FILES, TIDY_FILES) for k in keys)}
    folders = (STUDY_MAPPING_FOLDER, STUDY_DISTORTION_FOLDER)
    for where in (folder, folder / subfolder):
        entries = sorted(where.iterdir()) if where.is_dir() else []
        for entry in entries:
            if entry.name in _READ_NAMES or entry.name.endswith(tuple(CIAA_SUBFOLDERS.values())):
                continue
            if entry.is_dir():
                read: tuple[str, ...] = folders
            elif entry.suffix.lower() == ".csv" or _close_to_csv(entry.suffix):
                read = tuple(name for name in _READ_NAMES if name not in folders)
            else:
                continue
            meant = next((name for name in read if entry.name.lower() == name.lower()), None)
            hint = did_you_mean(entry.name, read)
            meant = meant or next((name for name in read if f"{name!r}" in hint), None)
            if meant in expected:
                return entry, meant
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
    ``second_file``); more than one pair (a study export beside tidy files, or two of the places
    :func:`_candidates` looks) is an error naming them all, as several participants' folders are.
    """
    study = _locate(folder, STUDY_FILES, keys, subfolder)
    tidy = _locate(folder, TIDY_FILES, keys, subfolder)
    if not study and not tidy:
        orphan = _half_present(folder, keys, subfolder)
        alike = _look_alike(folder, keys, subfolder)
        if orphan is not None:
            partner = second_file if "prompt" in orphan.name else "prompts"
            named = f" ({alike[0].name!r} is not read: rename it {alike[1]!r})" if alike else ""
            raise DataError(f"{orphan}: the {session} session's {partner} file is missing beside it{named}")
        if alike is not None:  # else the session is left for the default table without a word
            raise DataError(f"{alike[0]}: not read as the {session} session's {alike[1]!r}, which its name "
                            f"resembles; rename it {alike[1]!r}, or move it away to fit without that session "
                            "(its default table)")
        return None
    found = [(where, STUDY_FILES) for where in study] + [(where, TIDY_FILES) for where in tidy]
    if len(found) > 1:  # which one to fit is the researcher's choice, never the first match's
        raise _several_sessions(folder, [where / names[keys[0]] for where, names in found], session)
    return (study[0] if study else None), (tidy[0] if tidy else None)


def _several_sessions(folder: Path, prompts: list[Path], session: str) -> DataError:
    """The error of a ``folder`` holding more than one ``session`` session (their ``prompts`` files):
    name them all and say how to fit one."""
    places = [path.parent for path in prompts]
    if len(set(places)) == len(places) and folder not in places:  # each alone in a folder of its own
        advice = " or ".join(f"`{shell_words(['nudge', 'fit', str(where)])}`" for where in places)
    else:  # two in one folder, or one in the folder given: that one cannot be fitted alone
        shared = next(where for where in places if where == folder or places.count(where) > 1)
        others = [where for where in places if where != shared]
        advice = f"move the files you do not mean to fit out of {shared}" + \
            (f", or fit the other with `{shell_words(['nudge', 'fit', str(others[0])])}`" if others else "")
    return DataError(f"{folder}: holds {len(prompts)} {session} sessions ({', '.join(map(str, prompts))}); "
                     f"fit one at a time: {advice}")


#: The tidy logs of each session a run writes (its manifest records their SHA-256).
_MAPPING_LOGS = (TIDY_FILES["mapping_prompts"], TIDY_FILES["mapping_responses"])
_DISTORTION_LOGS = (TIDY_FILES["distortion_prompts"], TIDY_FILES["distortion_stream"])


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
    RunFolderError
        A run's log missing or changed since the run wrote it
        (:func:`~nudgecli.run_folder_calibration.check_calibration_logs`).
    """
    # a run's logs: read only as the run wrote them
    check_calibration_logs(folder, _MAPPING_LOGS)
    return _read_mapping_session(Path(folder))


def _read_mapping_session(folder: Path) -> MappingSession | None:
    """:func:`read_mapping_session` once the run's logs were checked (by it, or by
    :func:`read_sessions` with the other session's)."""
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


#: Where :func:`distortion_session_files` finds a ``p(phi_m | phi_i)`` session in a folder, every
#: layout it reads: for the message of a folder that holds none.
DISTORTION_LAYOUTS = (
    f"{STUDY_DISTORTION_FOLDER}/{STUDY_FILES['distortion_prompts']} + {STUDY_FILES['distortion_stream']} "
    f"(the study's export), the sibling study's <id>_{CIAA_DISTORTION_SUFFIX}/ with the same files, or the "
    f"tidy {TIDY_FILES['distortion_prompts']} + {TIDY_FILES['distortion_stream']} in the folder or its "
    f"{STUDY_DISTORTION_FOLDER}/ (a simulated run's calibration/participant-NNNN)")


def distortion_session_files(folder: str | Path) -> tuple[Path, Path] | None:
    """The two files :func:`read_distortion_session` reads from ``folder``, its prompts and its
    stream (study or tidy format; never both), or ``None`` if it holds no session: all that a
    ``population.physiology_logs`` recording gives a participant, so all its digest covers
    (:func:`nudgecli.recording_digests.recording_digest`).

    Raises
    ------
    DataError
        When one file of the pair is missing (naming the other).
    """
    found = _find_session(Path(folder), ("distortion_prompts", "distortion_stream"), STUDY_DISTORTION_FOLDER,
                          "distortion", "stream")
    if found is None:
        return None
    where, names = (found[0], STUDY_FILES) if found[0] is not None else (found[1], TIDY_FILES)
    assert where is not None
    return where / names["distortion_prompts"], where / names["distortion_stream"]


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
    RunFolderError
        A run's log missing or changed since the run wrote it
        (:func:`~nudgecli.run_folder_calibration.check_calibration_logs`).
    """
    # a run's logs: read only as the run wrote them (the mapping session's are not read here)
    check_calibration_logs(folder, _DISTORTION_LOGS)
    return _read_distortion_session(folder, variant)


def _read_distortion_session(folder: str | Path, variant: str) -> DistortionSession | None:
    """:func:`read_distortion_session` once the run's logs were checked (by it, or by
    :func:`read_sessions` with the other session's)."""
    found = distortion_session_files(folder)
    if found is None:
        return None
    prompts_path, stream_path = found
    what = "the p(phi_m | phi_i) session"
    if prompts_path.name == STUDY_FILES["distortion_prompts"]:
        time_column, label_column, pressure_column = STUDY_TIME_COLUMN, "frame_id", "axes"
    else:
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
    RunFolderError
        A run's log missing or changed since the run wrote it
        (:func:`~nudgecli.run_folder_calibration.check_calibration_logs`).
    """
    folder = Path(folder)
    if not folder.is_dir():
        what = "a file, not a folder" if folder.exists() else "no such folder"
        raise DataError(f"{folder}: {what}; give one participant's calibration folder "
                        f"(with {STUDY_MAPPING_FOLDER}/ and/or {STUDY_DISTORTION_FOLDER}/)")
    # a run's logs, both sessions' at once: one reading of its manifest
    check_calibration_logs(folder, _MAPPING_LOGS + _DISTORTION_LOGS)
    mapping = _read_mapping_session(folder)
    distortion = _read_distortion_session(folder, variant)
    if mapping is None and distortion is None:
        raise _no_session(folder)
    return mapping, distortion


def _holds_session(folder: Path) -> bool:
    """Whether ``folder`` looks like one participant's calibration folder (a session's subfolder, or
    a tidy prompts file)."""
    return (folder / STUDY_MAPPING_FOLDER).is_dir() or (folder / STUDY_DISTORTION_FOLDER).is_dir() or \
        any((folder / TIDY_FILES[key]).is_file() for key in ("mapping_prompts", "distortion_prompts"))


def holds_calibration_session(folder: str | Path) -> bool:
    """Whether ``folder`` looks like one participant's calibration folder (a session's subfolder,
    or a tidy prompts file): what another command's refusal of it names."""
    return _holds_session(Path(folder))


def _no_session(folder: Path) -> DataError:
    """The error of a ``folder`` without a session: it holds several participants' folders (a run
    folder: in its ``calibration/``), fit one; else the files a session needs."""
    from nudgecli.store import RunFolder, is_run_folder

    run = is_run_folder(folder)
    where = RunFolder(folder).calibration_dir(0).parent if run else folder  # a run's calibration/
    children = where.iterdir() if where.is_dir() else ()
    participants = sorted(child.name for child in children if child.is_dir() and _holds_session(child))
    fit_first = shell_words(["nudge", "fit", str(where / participants[0])]) if participants else ""
    example = "" if not participants else f"fit it with `{fit_first}`" \
        if len(participants) == 1 else f"fit one at a time, e.g. `{fit_first}`"
    if run and participants:
        held = (f"its {len(participants)} participants' simulated calibration logs are in {where}/ "
                f"({participants[0]} to {participants[-1]})") if len(participants) > 1 else \
            f"its participant's simulated calibration logs are in {where / participants[0]}"
        return DataError(f"{folder}: a run folder; {held}; {example}")
    if participants:
        return DataError(f"{folder}: holds the calibration folders of several participants "
                         f"({', '.join(participants)}); {example}")
    which = f"a run folder without calibration logs (no {where}/participant-NNNN); " if run else ""
    return DataError(
        f"{folder}: {which}no calibration session found; expected {STUDY_MAPPING_FOLDER}/"
        f"{STUDY_FILES['mapping_prompts']} + {STUDY_FILES['mapping_responses']} and/or "
        f"{STUDY_DISTORTION_FOLDER}/{STUDY_FILES['distortion_prompts']} + "
        f"{STUDY_FILES['distortion_stream']}, the sibling study's <id>_{CIAA_MAPPING_SUFFIX}/ and/or "
        f"<id>_{CIAA_DISTORTION_SUFFIX}/ with the same files, or the tidy "
        f"{', '.join(TIDY_FILES.values())}")
