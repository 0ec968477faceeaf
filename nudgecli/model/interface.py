"""The sip-and-puff interface: actions, the task <-> interface mapping, label bands, noise tables.

Index conventions used by every table in the toolkit:

- interface labels ``Phi``: ``0 Hard Puff, 1 Hard Sip, 2 Soft Puff, 3 Soft Sip`` (``LABELS``);
- task actions: ``0 move_p, 1 move_n, 2 to_mode_r, 3 to_mode_l`` (``ACTIONS``), also the
  argmax tie-break order of the MDP;
- ``p(phi_i | a, m)``: array ``(M, A, F) = (3, 4, 4)``, rows over ``phi_i`` sum to 1;
- ``p(phi_m | phi_i)``: array ``(F, F) = (4, 4)``, row ``phi_i``, column ``phi_m``.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from nudgecli.errors import ProbabilityTableError
from nudgecli.model import portable_math
from nudgecli.model.world import MODE_NAMES, N_MODES

LABELS = ("Hard Puff", "Hard Sip", "Soft Puff", "Soft Sip")
HARD_PUFF, HARD_SIP, SOFT_PUFF, SOFT_SIP = range(4)
N_LABELS = len(LABELS)

#: Codes of the labelled stream that are not observations for inference.
NO_INPUT = -1
PUFF_DEADBAND = 4
SIP_DEADBAND = 5
NO_INPUT_LABEL = "None"
PUFF_DEADBAND_LABEL = "Soft-Hard Puff Deadband"
SIP_DEADBAND_LABEL = "Soft-Hard Sip Deadband"
INPUT_STOPPED_LABEL = "input stopped"
STREAM_LABELS = {
    **{name: code for code, name in enumerate(LABELS)},
    NO_INPUT_LABEL: NO_INPUT,
    PUFF_DEADBAND_LABEL: PUFF_DEADBAND,
    SIP_DEADBAND_LABEL: SIP_DEADBAND,
}

ACTIONS = ("move_p", "move_n", "to_mode_r", "to_mode_l")
MOVE_P, MOVE_N, TO_MODE_R, TO_MODE_L = range(4)
N_ACTIONS = len(ACTIONS)

#: The true mapping f: task action -> interface label, the same in every mode.
TRUE_MAPPING = np.array([SOFT_PUFF, SOFT_SIP, HARD_PUFF, HARD_SIP])

#: Default noise of both tables when nothing is fitted: 0.8 * one-hot + 0.2 * uniform.
DEFAULT_TABLE_NOISE = 0.2

SOFT_THRESHOLD_STUDY, HARD_THRESHOLD_STUDY = 0.4, 0.6
SOFT_THRESHOLD_EARLY, HARD_THRESHOLD_EARLY = 0.3, 0.5
ZERO_THRESHOLD = 0.002


def switch_mode(mode: int, label: int) -> int:
    """The mode after a hard blow (``Delta``): Hard Puff cycles x -> y -> theta -> x, Hard Sip back.

    Any other label leaves the mode unchanged.
    """
    if label == HARD_PUFF:
        return (mode + 1) % N_MODES
    if label == HARD_SIP:
        return (mode - 1) % N_MODES
    return mode


def label_pressure(pressure: np.ndarray | float, soft_threshold: float = SOFT_THRESHOLD_EARLY,
                   hard_threshold: float = HARD_THRESHOLD_EARLY,
                   zero_threshold: float = ZERO_THRESHOLD) -> np.ndarray:
    """Label raw pressures the way the device driver did (sip positive, puff negative).

    ``|p| < zero`` -> ``NO_INPUT``; ``|p| <= soft`` -> Soft; ``|p| > hard`` -> Hard; in between
    -> the puff or sip deadband code.

    ``|p| > 1`` is Hard too, where the sibling study's mapping (TASK.md section 5) has a deadband
    row: its band edges, which no reading reaches. The device reads full scale at most (the real
    logs never pass +-1; the pressure model and the event-driven device are clipped at it), so the
    row labels nothing, and a pressure past full scale is more than hard, not between bands.

    Parameters
    ----------
    pressure
        ``(...)`` raw pressures in ``[-1, 1]``.

    Returns
    -------
    np.ndarray
        ``(...)`` integer codes (``0..3`` labels, ``PUFF_DEADBAND``, ``SIP_DEADBAND``, ``NO_INPUT``).
    """
    p = np.asarray(pressure, dtype=float)
    mag = np.abs(p)
    sip = p > 0
    out = np.where(sip, SIP_DEADBAND, PUFF_DEADBAND)
    out = np.where(mag <= soft_threshold, np.where(sip, SOFT_SIP, SOFT_PUFF), out)
    out = np.where(mag > hard_threshold, np.where(sip, HARD_SIP, HARD_PUFF), out)
    return np.where(mag < zero_threshold, NO_INPUT, out).astype(int)


def label_of_pressure(pressure: float, soft_threshold: float = SOFT_THRESHOLD_EARLY,
                      hard_threshold: float = HARD_THRESHOLD_EARLY,
                      zero_threshold: float = ZERO_THRESHOLD) -> int:
    """The label code of one pressure sample; the scalar twin of :func:`label_pressure`."""
    magnitude = abs(pressure)
    if magnitude < zero_threshold:
        return NO_INPUT
    sip = pressure > 0
    if magnitude <= soft_threshold:
        return SOFT_SIP if sip else SOFT_PUFF
    if magnitude > hard_threshold:
        return HARD_SIP if sip else HARD_PUFF
    return SIP_DEADBAND if sip else PUFF_DEADBAND


def human_velocity(label: int, mode: int, speed: float, turn_rate: float) -> np.ndarray:
    """``Upsilon``: the robot command ``u_h`` of one measured label.

    A Soft Puff moves ``+speed`` along x or y, or turns clockwise (negative omega) at
    ``turn_rate`` in the theta mode; a Soft Sip the opposite way; hard labels do not move.

    Returns
    -------
    np.ndarray
        ``(3,)`` ``(vx, vy, omega)``: :func:`human_command` as an array.
    """
    return np.array(human_command(label, mode, speed, turn_rate))


#: The command of a label that does not move the robot (a hard label, a deadband, no input).
NO_COMMAND = (0.0, 0.0, 0.0)


def human_command(label: int, mode: int, speed: float, turn_rate: float) -> tuple[float, float, float]:
    """:func:`human_velocity` as a tuple of floats: the rule's one implementation (it runs on
    every simulated step, where a fresh numpy array per step cost more than the rule)."""
    if label != SOFT_PUFF and label != SOFT_SIP:
        return NO_COMMAND
    value = (1.0 if label == SOFT_PUFF else -1.0) * (speed if mode < 2 else -turn_rate)
    if mode == 0:
        return value, 0.0, 0.0
    if mode == 1:
        return 0.0, value, 0.0
    return 0.0, 0.0, value


def default_mapping_table(noise: float = DEFAULT_TABLE_NOISE) -> np.ndarray:
    """``p(phi_i | a, m)`` when nothing is fitted: ``(1 - noise) * one-hot + noise * uniform``.

    Returns
    -------
    np.ndarray
        ``(M, A, F)``.
    """
    onehot = np.eye(N_LABELS)[TRUE_MAPPING]
    table = (1.0 - noise) * onehot + noise / N_LABELS
    return np.broadcast_to(table, (N_MODES, N_ACTIONS, N_LABELS)).copy()


def default_distortion_table(noise: float = DEFAULT_TABLE_NOISE) -> np.ndarray:
    """``p(phi_m | phi_i)`` when nothing is fitted: ``(1 - noise) * I + noise * uniform``, ``(F, F)``."""
    return (1.0 - noise) * np.eye(N_LABELS) + noise / N_LABELS


def validate_probability_table(table: np.ndarray, name: str, shape: tuple[int, ...],
                               row_names: tuple[str, ...] | None = None,
                               atol: float = 1e-6) -> np.ndarray:
    """Check a conditional probability table and return it as a float array.

    The last axis is the distribution; every other index is a row that must be non-negative,
    finite and sum to 1 within ``atol``.

    Raises
    ------
    ProbabilityTableError
        Naming the table and the first bad row.
    """
    arr = np.asarray(table, dtype=float)
    if arr.shape != shape:
        raise ProbabilityTableError(f"{name}: expected shape {shape}, got {arr.shape}")
    if np.isfinite(arr).all() and (arr >= 0).all() and (np.abs(arr.sum(axis=-1) - 1.0) <= atol).all():
        return arr  # every row passes: checked at once (the row loop below only names the first bad one)
    for index in np.ndindex(*shape[:-1]):
        row = arr[index]
        where = _row_name(index, row_names)
        if not np.all(np.isfinite(row)):
            raise ProbabilityTableError(f"{name}: row {where} has a non-finite entry")
        if np.any(row < 0):
            raise ProbabilityTableError(
                f"{name}: row {where} has a negative probability ({row.min():g})")
        total = row.sum()
        if abs(total - 1.0) > atol:
            raise ProbabilityTableError(
                f"{name}: row {where} sums to {total:.10g}, not 1; renormalise it")
    return arr


def _row_name(index: tuple[int, ...], row_names: tuple[str, ...] | None) -> str:
    if row_names is not None and len(index) == 1:
        return repr(row_names[index[0]])
    if len(index) == 2 and row_names is None:
        return f"(mode {MODE_NAMES[index[0]]}, action {ACTIONS[index[1]]})"
    return str(index)


def validate_mapping_table(table: np.ndarray, name: str = "p(phi_i | a)") -> np.ndarray:
    """Validate a ``(M, A, F)`` ``p(phi_i | a, m)`` table."""
    return validate_probability_table(table, name, (N_MODES, N_ACTIONS, N_LABELS))


def validate_distortion_table(table: np.ndarray, name: str = "p(phi_m | phi_i)") -> np.ndarray:
    """Validate a ``(F, F)`` ``p(phi_m | phi_i)`` table (rows are intended labels)."""
    return validate_probability_table(table, name, (N_LABELS, N_LABELS), row_names=LABELS)


def mapping_table_from_dict(data: Mapping[str, Mapping[str, Mapping[str, float]]],
                            name: str = "p_phi_given_a") -> np.ndarray:
    """``{mode: {action: {label: p}}}`` (modes ``x``, ``y``, ``theta``) -> validated ``(M, A, F)``."""
    arr = np.zeros((N_MODES, N_ACTIONS, N_LABELS))
    for m, mode in enumerate(MODE_NAMES):
        if mode not in data:
            raise ProbabilityTableError(f"{name}: missing mode {mode!r}")
        for a, action in enumerate(ACTIONS):
            if action not in data[mode]:
                raise ProbabilityTableError(f"{name}: mode {mode!r} is missing action {action!r}")
            row = data[mode][action]
            _check_label_keys(row, f"{name}[{mode!r}][{action!r}]")
            arr[m, a] = [float(row[label]) for label in LABELS]
    return validate_mapping_table(arr, name)


def distortion_table_from_dict(data: Mapping[str, Mapping[str, float]],
                               name: str = "p_phm_given_phi") -> np.ndarray:
    """``{intended: {measured: p}}`` -> validated ``(F, F)``."""
    _check_label_keys(data, name)
    for i in LABELS:
        _check_label_keys(data[i], f"{name}[{i!r}]")
    arr = np.array([[float(data[i][m]) for m in LABELS] for i in LABELS])
    return validate_distortion_table(arr, name)


def _check_label_keys(row: Mapping[str, object], where: str) -> None:
    unknown = set(row) - set(LABELS)
    missing = set(LABELS) - set(row)
    if unknown:
        raise ProbabilityTableError(
            f"{where}: unknown label(s) {sorted(unknown)}; labels are {list(LABELS)}")
    if missing:
        raise ProbabilityTableError(f"{where}: missing label(s) {sorted(missing)}")


def mapping_table_to_dict(table: np.ndarray) -> dict[str, dict[str, dict[str, float]]]:
    """Inverse of :func:`mapping_table_from_dict`."""
    return {mode: {action: {label: float(table[m, a, f]) for f, label in enumerate(LABELS)}
                   for a, action in enumerate(ACTIONS)}
            for m, mode in enumerate(MODE_NAMES)}


def distortion_table_to_dict(table: np.ndarray) -> dict[str, dict[str, float]]:
    """Inverse of :func:`distortion_table_from_dict`."""
    return {i: {m: float(table[a, b]) for b, m in enumerate(LABELS)} for a, i in enumerate(LABELS)}


def observation_model(mapping: np.ndarray, distortion: np.ndarray) -> np.ndarray:
    """``p(phi_m | a, m) = sum_phi_i p(phi_m | phi_i) p(phi_i | a, m)``.

    Parameters
    ----------
    mapping
        ``(M, A, F)`` ``p(phi_i | a, m)``.
    distortion
        ``(F, F)`` ``p(phi_m | phi_i)``.

    Returns
    -------
    np.ndarray
        ``(M, A, F)`` over measured labels.
    """
    return portable_math.matmul(mapping, distortion)
