"""Calibration profiles: :func:`fit_calibration_dir` fits a real or simulated participant's
calibration folder into a profile (what ``nudge fit`` writes), with its summary and warnings.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from nudgecli.errors import DataError
from nudgecli.model.interface import (
    ACTIONS,
    LABELS,
    N_ACTIONS,
    N_LABELS,
    TRUE_MAPPING,
    default_distortion_table,
    default_mapping_table,
    distortion_table_to_dict,
    mapping_table_to_dict,
)
from nudgecli.model.world import MODE_NAMES, N_MODES
from nudgecli.sim.calibration import (
    distortion_provenance,
    estimate_distortion,
    estimate_mapping,
    mapping_provenance,
)
from nudgecli.sim.calibration_io import (
    AUTO_VARIANT,
    DistortionSession,
    requeue_consistent,
    silent_prompts,
)
from nudgecli.sim.calibration_readers import read_sessions
from nudgecli.sim.participant_fitting import participant_from_log
from nudgecli.store import write_json_atomic

#: The study's "needs more training" threshold: L2 distance of a row from the true one-hot row.
NEEDS_TRAINING_DISTANCE = 0.22


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
                                       **mapping_provenance(mapping_session, mapping_estimate)}
        if mapping_estimate.unanswered:
            warnings.append(f"p(phi_i | a): no answer for {', '.join(mapping_estimate.unanswered)}; "
                            "those rows use the default table")
        warnings += [mapping_estimate.reuse_warning] if mapping_estimate.reused_responses else []
    else:
        mapping = default_mapping_table()
        provenance["p_phi_given_a"] = {"source": "default (no p_phi_given_a session)"}
        warnings.append(f"{folder}: no p(phi_i | a) session; using the default table (0.85 / 0.05)")
    if distortion_session is not None:
        distortion_estimate = estimate_distortion(distortion_session)
        distortion = distortion_estimate.table
        provenance["p_phm_given_phi"] = {"source": "fitted",
                                         **distortion_provenance(distortion_session, distortion_estimate)}
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
