"""Real sip-and-puff users as the yardstick of the simulated population (issue 14, part 3).

Eleven real people's prompt-and-produce calibrations are known: the two pilots' produce sessions
in ``../shared/data/calibration/`` (andrewtest, deepaktest; a fixed 10 Hz stream; ``deepak`` holds
a mapping session only) and nine participants of the sibling study
(2020, CIAA; an event-driven stream, ``../shared/data/ciaa-task/TASK.md``). Their fitted
``p(phi_m | phi_i)`` diagonals are the yardstick: a simulated participant calibrated the same way
should produce a diagonal inside the real people's spread, and the population as a whole should
cover it. The two stream formats weigh a blow differently (a fixed-rate stream counts time, an
event-driven one counts pressure *changes*: a saturated hard blow is silent while its ramps
through the soft band and the deadband are not), so each real value is compared with simulated
participants calibrated in its own format.

- :data:`SIBLING_DIAGONAL_SPANS`: the nine sibling-study participants' spans (event-driven).
- :data:`PILOT_DIAGONALS`: the pilots' diagonals, fitted by ``nudge fit`` from their logs (10 Hz).
- :data:`PILOT_EVENT_DIAGONALS`: the same real blows counted as the event-driven device would
  (:func:`as_event_driven`).
- :func:`expected_diagonal`: the diagonal the estimator converges to for a physiology (exact label
  probabilities for the fixed-rate stream; expected message counts, by a seeded Monte-Carlo
  average over blows, for the event-driven one).
- :func:`diagonal_image`: the range of :func:`expected_diagonal` over a population's ranges.
- :func:`simulated_diagonals`: simulated participants' fitted diagonals (their calibration
  simulated and fitted with the study's estimator), in both formats.
"""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd

from nudgecli.config import CalibrationSection, ExperimentConfig, InterfaceSection, PopulationSection
from nudgecli.model.interface import LABELS, N_LABELS
from nudgecli.rng import generator
from nudgecli.sim.calibration import estimate_distortion, merge_and_smooth, smooth_true_distortion
from nudgecli.sim.calibration_io import CIAA_VARIANT, DistortionSession
from nudgecli.sim.calibration_sessions import CALIBRATION, event_driven_stream, simulate_distortion_session
from nudgecli.sim.participants import Participant, level_range, spread_range
from nudgecli.sim.pressure_model import (
    LABEL_IS_HARD,
    LABEL_SIGN,
    blow_pressures,
    blows_drift_normals,
    ramp_fractions,
)

#: The stream formats: the pilots' fixed 10 Hz stream, the sibling study's event-driven one.
STREAMS = ("fixed_rate", "event_driven")
#: Fitted diagonal spans of nine sibling-study participants (event-driven stream; issue 14).
#: Their p(phi_i | a) answers were all correct.
SIBLING_DIAGONAL_SPANS: dict[str, tuple[float, float]] = {
    "Hard Puff": (0.53, 0.84), "Hard Sip": (0.54, 0.78), "Soft Puff": (0.80, 0.97), "Soft Sip": (0.31, 0.97),
}
#: The pilots' fitted diagonals (``nudge fit ../shared/data/calibration/<pilot>``, fixed 10 Hz stream;
#: ``deepak`` has no p(phi_m | phi_i) session), at full precision: :func:`coverage_table` compares
#: simulated diagonals with them exactly, and a simulated person at the estimator's ceiling
#: ``(1 + 0.01) / 1.04 = 0.97115...`` (deepaktest's Hard Sip and Soft Puff) is inside their range.
#: deepaktest never produced a soft sip (every Soft Sip prompt read Hard Sip: his soft-sip level is
#: 1.08; his diagonal is the floor ``0.01 / 1.04``), which no range of a "soft" level covers.
PILOT_DIAGONALS: dict[str, dict[str, float]] = {
    "andrewtest": {"Hard Puff": 0.9329886373417366, "Hard Sip": 0.9543276926023108,
                   "Soft Puff": 0.965181557572862, "Soft Sip": 0.6983950395816705},
    "deepaktest": {"Hard Puff": 0.9031329247675401, "Hard Sip": 0.9711538461538461,
                   "Soft Puff": 0.9711538461538461, "Soft Sip": 0.009615384615384616},
}
#: The pilots' own 10 Hz pressure traces turned into the sibling study's event-driven stream
#: (:func:`as_event_driven`) and fitted with the study's estimator: how the same real blows count
#: in that format. A check of the pressure model's drift, which was estimated from the same logs
#: but never fitted to these values.
PILOT_EVENT_DIAGONALS: dict[str, dict[str, float]] = {
    "andrewtest": {"Hard Puff": 0.713, "Hard Sip": 0.695, "Soft Puff": 0.965, "Soft Sip": 0.721},
    "deepaktest": {"Hard Puff": 0.608, "Hard Sip": 0.687, "Soft Puff": 0.971, "Soft Sip": 0.282},
}
#: The sibling study's prompt-and-produce protocol: 4 s prompts, 1 s blank, event-driven stream.
SIBLING_PROMPT_S, SIBLING_BLANK_S = 4.0, 1.0
#: Blows averaged by :func:`expected_diagonal` for the event-driven stream.
EVENT_BLOWS = 400


def as_event_driven(session: DistortionSession, interface: InterfaceSection,
                    event_step: float = CALIBRATION.event_step) -> DistortionSession:
    """A fixed-rate distortion session's pressures as the sibling study's event-driven stream.

    The session's pressure samples (missing ones read as zero) go through
    :func:`nudgecli.sim.calibration_sessions.event_driven_stream`, so the result holds the messages the
    sibling study's device would have sent for the same blows (with the pressure taken to move
    linearly between samples); the prompts are kept.

    Raises
    ------
    ValueError
        If the session is event-driven already.
    """
    if session.event_driven:
        raise ValueError("the session is event-driven already")
    pressure = np.nan_to_num(session.stream_pressure, nan=0.0)
    times, pressures, codes = event_driven_stream(session.stream_times, pressure, interface, event_step)
    files = {**session.files, "stream": f"{session.files.get('stream', 'stream')} (as event-driven)"}
    return DistortionSession(session.prompt_times, session.prompt_commands, times, codes, pressures, files,
                             CIAA_VARIANT)


def sibling_calibration(calibration: CalibrationSection) -> CalibrationSection:
    """``calibration`` with the sibling study's prompt timing and its event-driven stream."""
    return calibration.model_copy(update={"prompt_s": SIBLING_PROMPT_S, "blank_s": SIBLING_BLANK_S,
                                          "stream": "event_driven"})


def _probe(label: int, level: float, spread: float, ramp: int, correlation: float = 0.0) -> Participant:
    """A participant whose ``label`` has ``level``/``spread`` (the other labels are irrelevant)."""
    levels = np.array([0.9, 0.9, 0.1, 0.1])
    spreads = np.full(N_LABELS, 0.05)
    levels[label], spreads[label] = level, spread
    return Participant(index=0, seed_key="probe", pressure_level=LABEL_SIGN * levels, pressure_spread=spreads,
                       mapping=np.full((3, 4, N_LABELS), 0.25), epsilon=0.0, rest_s=0.0, operate_s=1.0,
                       action_pause_s=0.0, hard_blow_s=0.5, reaction_s=1.0, onset_ramp_samples=ramp,
                       drift_correlation=correlation)


def expected_diagonal(label: int, level: float, spread: float, interface: InterfaceSection,
                      stream: str = CALIBRATION.stream, ramp: int = 2, hold_samples: int = 25,
                      event_step: float = CALIBRATION.event_step, seed: int = 0,
                      correlation: float = 0.0) -> float:
    """The ``p(phi_m = phi_i | phi_i)`` the study's estimator converges to for one label's physiology.

    Parameters
    ----------
    label
        The intended label ``0..3``.
    level, spread
        Its pressure magnitude level and per-sample spread (the pressure model of
        :mod:`nudgecli.sim.participants`).
    interface
        The label thresholds.
    stream
        ``"fixed_rate"``: exact, the ratio of expected counts over an ``hold_samples``-tick blow
        with an onset ramp of ``ramp`` ticks (:meth:`Participant.true_distortion`), smoothed as
        the estimator smooths. ``"event_driven"``: the ratio of the expected message counts of
        such a blow (its ticks turned into messages by
        :func:`nudgecli.sim.calibration_sessions.event_driven_stream`, the release back to zero included),
        averaged over :data:`EVENT_BLOWS` blows drawn from ``generator(seed, "expected_diagonal")``.
    hold_samples
        Ticks of one blow (a 4 s prompt minus a ~1.5 s reaction at 10 Hz: 25).
    correlation
        The drift correlation within a blow (``Participant.drift_correlation``). The fixed-rate
        diagonal does not depend on it (each tick's label probabilities do not).

    Returns
    -------
    float
        The diagonal entry, after the deadbands are merged into hard and the ``+0.01`` smoothing.
    """
    if stream == "fixed_rate":
        truth = _probe(label, level, spread, ramp).true_distortion(interface, hold_samples)
        return float(smooth_true_distortion(truth)[label, label])
    if stream != "event_driven":
        raise ValueError(f"stream must be one of {STREAMS}, got {stream!r}")
    rng = generator(seed, "expected_diagonal")
    fractions = np.tile(np.r_[ramp_fractions(hold_samples, ramp), 0.0], EVENT_BLOWS)  # each blow ends at zero
    normals = rng.standard_normal(fractions.size)
    blow = fractions > 0
    deviations = blows_drift_normals(normals[blow], np.full(EVENT_BLOWS, hold_samples), correlation)
    pressure = np.zeros(fractions.size)
    pressure[blow] = blow_pressures(np.full(blow.sum(), level), np.full(blow.sum(), spread),
                                    np.full(blow.sum(), LABEL_SIGN[label]), fractions[blow], deviations)
    pressure = np.r_[0.0, pressure]
    _, _, codes = event_driven_stream(np.arange(pressure.size) * 0.1, pressure, interface, event_step)
    counted = np.array([np.sum(codes == c) for c in (0, 1, 2, 3, 4, 5)], dtype=float)
    if counted.sum() == 0:
        return float("nan")
    merged = merge_and_smooth((counted / counted.sum())[None, :])[0]
    return float(merged[label])


def diagonal_image(population: PopulationSection, interface: InterfaceSection,
                   stream: str = CALIBRATION.stream, hold_samples: int = 25,
                   event_step: float = CALIBRATION.event_step) -> pd.DataFrame:
    """The range of :func:`expected_diagonal` over a population's level, spread, ramp and drift ranges.

    Every corner of each label's (level, spread, ramp, drift correlation) box is evaluated, plus
    the midpoints of level, spread and drift (the diagonal is monotone in the level between
    thresholds, so the extremes sit at the corners; the midpoints guard against a level range
    that straddles a threshold). The fixed-rate diagonal does not depend on the drift, so it is
    evaluated at the drift range's lower end only.

    Returns
    -------
    pd.DataFrame
        One row per label: ``label``, ``stream``, ``low``, ``high`` and the (level, spread, ramp,
        drift correlation) of each extreme.
    """
    rows = []
    for label in range(N_LABELS):
        spreads = spread_range(population, label)
        lo, hi = level_range(population, label)
        drift_lo, drift_hi = population.drift_correlation
        drifts = ((drift_lo, 0.5 * (drift_lo + drift_hi), drift_hi) if stream == "event_driven"
                  else (drift_lo,))
        grid = itertools.product((lo, 0.5 * (lo + hi), hi),
                                 (spreads[0], 0.5 * sum(spreads), spreads[1]),
                                 sorted(set(population.onset_ramp_samples)), drifts)
        values = [(expected_diagonal(label, lv, sd, interface, stream, rp, hold_samples, event_step,
                                     correlation=rho), lv, sd, rp, rho) for lv, sd, rp, rho in grid]
        low, high = min(values), max(values)
        rows.append({"label": LABELS[label], "stream": stream, "low": low[0], "high": high[0],
                     "low_at": low[1:], "high_at": high[1:]})
    return pd.DataFrame(rows)


def lowest_diagonal(label: int, level: float, population: PopulationSection, interface: InterfaceSection,
                    stream: str = "event_driven") -> float:
    """The lowest :func:`expected_diagonal` at ``level`` over the population's other ranges.

    The minimum over the ends of the label's spread range, the onset ramps and the ends of the
    drift-correlation range (the diagonal is monotone in each at a fixed level).
    """
    grid = itertools.product(spread_range(population, label), sorted(set(population.onset_ramp_samples)),
                             population.drift_correlation)
    return min(expected_diagonal(label, level, spread, interface, stream, ramp, correlation=rho)
               for spread, ramp, rho in grid)


def level_range_covering(label: int, target: float, population: PopulationSection,
                         interface: InterfaceSection,
                         stream: str = "event_driven", grid: float = 0.01) -> tuple[float, float]:
    """The narrowest extension of a label's level range whose participants reach a diagonal of ``target``.

    For a soft label the diagonal falls as the level rises towards the soft threshold, so the
    range's upper end is raised; for a hard label it falls as the level drops towards the hard
    threshold (a saturated blow is silent in an event-driven stream, an unsaturated one near the
    threshold spends its changes in the soft band and the deadband), so the lower end is lowered.
    The new end is the first level on a ``grid`` (stepping outwards from the present end) at
    which :func:`lowest_diagonal` is at most ``target``; a range that reaches ``target`` already
    is returned as it is.

    Returns
    -------
    tuple[float, float]
        The label's level range.

    Raises
    ------
    ValueError
        If no level between the range and the threshold side's limit (1.5 for soft, 0 for hard)
        reaches ``target``.
    """
    lo, hi = level_range(population, label)
    end = hi if not LABEL_IS_HARD[label] else lo
    direction = -1 if LABEL_IS_HARD[label] else 1
    limit = 0.0 if LABEL_IS_HARD[label] else 1.5
    step = 0
    while True:
        level = round(end + direction * step * grid, 10)
        if (level - limit) * direction > 0:
            raise ValueError(f"no {LABELS[label]} level beyond {end} gives a diagonal of {target} or less")
        if lowest_diagonal(label, level, population, interface, stream) <= target:
            return (level, hi) if LABEL_IS_HARD[label] else (lo, level)
        step += 1


def highest_diagonal(label: int, correlation: float, population: PopulationSection,
                     interface: InterfaceSection, stream: str = "event_driven") -> float:
    """The highest :func:`expected_diagonal` at a drift ``correlation`` over the other ranges.

    The maximum over the label's level range (its ends and midpoint, as :func:`diagonal_image`),
    the ends of its spread range and the onset ramps.
    """
    levels = level_range(population, label)
    grid = itertools.product((levels[0], 0.5 * sum(levels), levels[1]), spread_range(population, label),
                             sorted(set(population.onset_ramp_samples)))
    return max(expected_diagonal(label, level, spread, interface, stream, ramp, correlation=correlation)
               for level, spread, ramp in grid)


def drift_range_covering(targets: dict[int, float], population: PopulationSection,
                         interface: InterfaceSection, stream: str = "event_driven",
                         grid: float = 0.01) -> tuple[float, float]:
    """The narrowest extension of the drift range whose participants reach the highest real diagonals.

    Less drift means more pressure changes on an unsaturated plateau, where a hard blow's
    changes count as hard, so a hard label's highest diagonal rises as the drift falls. The
    range's lower end is lowered, on a ``grid``, to the first value at which
    :func:`highest_diagonal` reaches every label's target; a range that reaches them already
    is returned as it is.

    Parameters
    ----------
    targets
        Label index -> the highest real diagonal to reach.

    Raises
    ------
    ValueError
        If even independent samples (drift 0) do not reach a target.
    """
    lo, hi = population.drift_correlation
    step = 0
    while True:
        rho = round(lo - step * grid, 10)
        if rho < 0:
            raise ValueError(f"no drift correlation down to 0 reaches {targets}")
        if all(highest_diagonal(label, rho, population, interface, stream) >= target
               for label, target in targets.items()):
            return rho, hi
        step += 1


def simulated_diagonals(config: ExperimentConfig, participants: int, seed: int) -> pd.DataFrame:
    """Simulated participants' fitted diagonals, calibrated in both stream formats.

    Participant ``i`` is the study's participant ``i`` (:func:`nudgecli.sim.study.study_participant`);
    their distortion session is simulated with the experiment's calibration (fixed-rate) and with
    the sibling study's (:func:`sibling_calibration`, event-driven), each from
    ``generator(seed, "participant", i, "calibration", stream)``, and fitted with the study's
    estimator (:func:`nudgecli.sim.calibration.estimate_distortion`).

    Returns
    -------
    pd.DataFrame
        Columns ``participant``, ``stream``, ``label``, ``diagonal``; one row per participant,
        stream and label.
    """
    from nudgecli.sim.study import study_participant

    calibrations = {"fixed_rate": config.calibration.model_copy(update={"stream": "fixed_rate"}),
                    "event_driven": sibling_calibration(config.calibration)}
    rows = []
    for index in range(participants):
        person = study_participant(config, seed, index)
        for stream, calibration in calibrations.items():
            rng = generator(seed, "participant", index, "calibration", stream)
            session = simulate_distortion_session(person, calibration, config.interface, rng)
            table = estimate_distortion(session).table
            rows += [{"participant": index, "stream": stream, "label": LABELS[k],
                      "diagonal": float(table[k, k])} for k in range(N_LABELS)]
    return pd.DataFrame(rows, columns=["participant", "stream", "label", "diagonal"])


def simulated_habits(config: ExperimentConfig, participants: int, seed: int) -> pd.DataFrame:
    """The study's participants' timing habits as their drawn parameters set them
    (:func:`nudgecli.sim.habit_ranges.drawn_habits`; participant ``i`` as in :func:`simulated_diagonals`)."""
    from nudgecli.sim.habit_ranges import drawn_habits
    from nudgecli.sim.study import study_participant

    return drawn_habits([study_participant(config, seed, index) for index in range(participants)])


def real_diagonal_ranges() -> pd.DataFrame:
    """The real people's diagonals per stream format and label, as ranges.

    Returns
    -------
    pd.DataFrame
        Columns ``stream``, ``label``, ``real_min``, ``real_max``, ``real_source``: the sibling
        study's spans (event-driven) and the pilots' values (fixed-rate; min and max over the pilots).
    """
    rows = []
    for label in LABELS:
        low, high = SIBLING_DIAGONAL_SPANS[label]
        rows.append({"stream": "event_driven", "label": label, "real_min": low, "real_max": high,
                     "real_source": "9 sibling-study participants"})
        values = [pilot[label] for pilot in PILOT_DIAGONALS.values()]
        rows.append({"stream": "fixed_rate", "label": label, "real_min": min(values), "real_max": max(values),
                     "real_source": f"{len(values)} pilots ({', '.join(PILOT_DIAGONALS)})"})
    return pd.DataFrame(rows)


def coverage_table(simulated: pd.DataFrame) -> pd.DataFrame:
    """Simulated participants' fitted diagonals against the real people's, per stream and label.

    Parameters
    ----------
    simulated
        :func:`simulated_diagonals`'s result.

    Returns
    -------
    pd.DataFrame
        Columns ``stream``, ``label``, ``participants``, ``simulated_min``, ``simulated_median``,
        ``simulated_max``, ``real_min``, ``real_max``, ``real_source``, ``covers_low`` and
        ``covers_high`` (whether the simulated extremes reach the real ones) and ``real_inside``
        (the share of simulated participants inside the real range).
    """
    grouped = simulated.groupby(["stream", "label"], sort=False)["diagonal"]
    summary = grouped.agg(participants="size", simulated_min="min", simulated_median="median",
                          simulated_max="max").reset_index()
    inside = simulated.merge(real_diagonal_ranges(), on=["stream", "label"])
    inside["inside"] = (inside["diagonal"] >= inside["real_min"]) & (inside["diagonal"] <= inside["real_max"])
    share = inside.groupby(["stream", "label"], sort=False)["inside"].mean()
    share = share.rename("real_inside").reset_index()
    table = summary.merge(real_diagonal_ranges(), on=["stream", "label"]).merge(share, on=["stream", "label"])
    table["covers_low"] = table["simulated_min"] <= table["real_min"]
    table["covers_high"] = table["simulated_max"] >= table["real_max"]
    return table
