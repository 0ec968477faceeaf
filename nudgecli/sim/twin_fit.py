"""The fit of a twin (:mod:`nudgecli.sim.twins`) from one participant's habit medians (issue 37).

How a parameter is set: by the documented offsets between a parameter and the habit it
produces (:data:`nudgecli.sim.habit_ranges.HABIT_OFFSETS_S`), inverted (:func:`fit_twin`). The
offsets are the model's mechanics at 10 Hz, the same ones the population's ranges were derived
with, so a twin and the population read the habits alike; simulation-based fitting would need a
person's physiology, which a habits table does not hold. The rules, one per parameter:

- ``planning_s``: the first-command latency's median, less its offset (0 s);
- ``event_reaction_s``: the mean over the two reactions (a stop at a waypoint -> the next switch,
  a switch -> the robot moves again) of the median less its offset (0.1 s each); both are needed
  (a log without its layout has no stop -> switch);
- ``event_reaction_log_sd``: the same reactions' quartiles, less the offset, read as a log-normal's:
  ``ln(q75 / q25) / (2 z_0.75)``, averaged over the two; both need at least
  :data:`MIN_EVENTS_FOR_QUARTILES` events;
- ``hard_peak_s``: the median time in the hard band per excursion (offset 0: the peak is the
  time in the hard band);
- ``offset_ramp_samples``: the hard blow's samples outside its hard band (whole less hard band, in
  cells) less the onset ramp, which is physiology and drawn: the population's middle onset ramp
  is assumed (:func:`assumed_onset_samples`), and fewer ramp samples than that give 0;
- ``hold_on_s``: the median hold-on per stop (``hold_on_per_stop``, a row ``nudge habits``
  measures beside HABITS.md's: each soft blow that went on after the robot stopped), one for one:
  on 60 simulated people of three seeds it read 0.02 s below the parameter on average, the 0.1 s
  cells rounding it down, and within 0.1 s for every one; a table with only HABITS.md's per-trial
  hold-on falls back to it shared over the stops of a CIAA trial (:func:`stops_per_trial`: the
  waypoints where the path turns and the goal heading), which also counts stalls and surprises;
- ``deadband_share`` and ``deadband_stray_s`` (pressure control within a soft blow): the share of
  soft-blow time in the deadband and the median deadband run inside a soft blow, less their
  offsets (0: :data:`nudgecli.sim.habit_ranges.DEADBAND_PARAMETERS`, one for one).

A parameter whose habit the source lacks, whose fitted value lies outside what the simulation
accepts, or that is read from stops (:data:`STOP_PARAMETERS`) of a grid-world run, is left to the
population's draw, and the twin lists it in
:attr:`~nudgecli.sim.twins.Twin.from_population`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from statistics import NormalDist

from nudgecli.config import PopulationSection
from nudgecli.sim.habit_ranges import DEADBAND_PARAMETERS, HABIT_OFFSETS_S
from nudgecli.sim.twins import INTEGER_PARAMETERS, TWIN_PARAMETERS, parameter_is_valid

#: The habits each parameter is fitted from (all of them needed), for every parameter a twin sets.
PARAMETER_HABITS: dict[str, tuple[str, ...]] = {
    "planning_s": ("first_command_latency",),
    "event_reaction_s": ("reaction_stop_to_switch", "reaction_switch_to_motion"),
    "event_reaction_log_sd": ("reaction_stop_to_switch", "reaction_switch_to_motion"),
    "hold_on_s": ("hold_on_per_stop",),  # else the per-trial hold-on shared over the trial's stops
    "hard_peak_s": ("hard_band_per_excursion",),
    "offset_ramp_samples": ("hard_blow_whole", "hard_band_per_excursion"),
    **{parameter: (habit,) for parameter, habit in DEADBAND_PARAMETERS.items()},
}
#: The parameters read from the robot's stops (the reactions to a stop and to a switch, the hold-on
#: after a stop), whose offsets are the CIAA task's, where the robot stops at its layout's waypoints.
#: A grid-world run has none: its robot stops in any cell (a hard blow's soft onset moves it a cell
#: right before its own switch), and these read 0.3-0.8 s off there, so they are the population's.
STOP_PARAMETERS = ("event_reaction_s", "event_reaction_log_sd", "hold_on_s")
#: Fewer events than this give no quartiles worth reading a spread from.
MIN_EVENTS_FOR_QUARTILES = 4
#: The habits' cell length, s (HABITS.md's 10 Hz view).
CELL_S = 0.1
#: ``z`` of a standard normal's upper quartile: a log-normal's ``ln(q75 / q25) = 2 z sd``.
Z_QUARTILE = NormalDist().inv_cdf(0.75)


@dataclass(frozen=True)
class HabitFigures:
    """One participant's summary of one habit (a row of ``nudge habits --by participant``).

    Attributes
    ----------
    n
        Events measured.
    median, q25, q75
        Seconds (``q25``/``q75`` NaN where not given).
    """

    n: int
    median: float
    q25: float = math.nan
    q75: float = math.nan


def stops_per_trial(waypoints: int = 5) -> int:
    """The stops of a CIAA trial a person holds on at: the path's interior waypoints (where it
    turns) and the goal heading at the turn waypoint; the goal waypoint ends the trial.

    >>> stops_per_trial(5)
    4
    """
    return waypoints - 2 + 1


def assumed_onset_samples(population: PopulationSection) -> int:
    """The onset ramp a twin's hard pulse is fitted with: the middle of the population's range
    (the person's own is physiology, drawn)."""
    lo, hi = population.onset_ramp_samples
    return math.floor((lo + hi) / 2 + 0.5)


def _reaction_median(habits: Mapping[str, HabitFigures]) -> float | None:
    """The mean of both reactions' medians less their offsets; None without both (one reaction
    alone is not the documented rule's figure)."""
    needed = PARAMETER_HABITS["event_reaction_s"]
    if not all(h in habits for h in needed):
        return None
    return sum(habits[h].median - HABIT_OFFSETS_S[h] for h in needed) / len(needed)


def _reaction_log_sd(habits: Mapping[str, HabitFigures]) -> float | None:
    """The mean of both reactions' log-normal spreads; None unless both have quartiles to read
    (:data:`MIN_EVENTS_FOR_QUARTILES` events, quartiles above their offset)."""
    spreads = []
    for habit in PARAMETER_HABITS["event_reaction_log_sd"]:
        figures = habits.get(habit)
        if figures is None or figures.n < MIN_EVENTS_FOR_QUARTILES:
            return None
        lo, hi = figures.q25 - HABIT_OFFSETS_S[habit], figures.q75 - HABIT_OFFSETS_S[habit]
        if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 < lo <= hi):
            return None
        spreads.append(math.log(hi / lo) / (2.0 * Z_QUARTILE))
    return sum(spreads) / len(spreads)


def fit_twin(habits: Mapping[str, HabitFigures], *, onset_samples: int, stops: int | None = None,
             cell_s: float = CELL_S, waypoints: bool = True) -> dict[str, float]:
    """The parameters one participant's habits set (the rules of the module's docstring).

    Parameters
    ----------
    habits
        Habit key -> the participant's figures (the habits they have events of).
    onset_samples
        The onset ramp assumed for their hard pulses (:func:`assumed_onset_samples`).
    stops
        Stops per trial (:func:`stops_per_trial` by default).
    cell_s
        The habits' cell length, s.
    waypoints
        Whether the source's robot stops at the CIAA task's waypoints (a real log, a CIAA run);
        False (a grid-world run) leaves :data:`STOP_PARAMETERS` to the population.

    Returns
    -------
    dict
        Parameter -> value for the parameters whose habits are all there and whose value the
        simulation accepts (:func:`parameter_is_valid`); the others are left out (the population's).
    """
    stops = stops_per_trial() if stops is None else stops
    fitted: dict[str, float | None] = {name: None for name in TWIN_PARAMETERS}
    if "first_command_latency" in habits:
        latency = habits["first_command_latency"].median
        fitted["planning_s"] = latency - HABIT_OFFSETS_S["first_command_latency"]
    fitted["event_reaction_s"] = _reaction_median(habits)
    fitted["event_reaction_log_sd"] = _reaction_log_sd(habits)
    if "hold_on_per_stop" in habits:  # a log measured by nudge habits
        fitted["hold_on_s"] = habits["hold_on_per_stop"].median  # one for one (see the module's rules)
    elif "hold_on_per_trial" in habits:  # a table of HABITS.md's rows only
        fitted["hold_on_s"] = habits["hold_on_per_trial"].median / stops
    band = habits.get("hard_band_per_excursion")
    if band is not None:
        fitted["hard_peak_s"] = band.median - HABIT_OFFSETS_S.get("hard_band_per_excursion", 0.0)
        if "hard_blow_whole" in habits:
            ramps = round((habits["hard_blow_whole"].median - band.median) / cell_s)
            # fewer ramp samples than the assumed onset: the person's onset is shorter, their offset none
            fitted["offset_ramp_samples"] = max(0, ramps - onset_samples)
    for parameter, habit in DEADBAND_PARAMETERS.items():
        if habit in habits:
            fitted[parameter] = habits[habit].median - HABIT_OFFSETS_S[habit]
    if not waypoints:
        fitted.update(dict.fromkeys(STOP_PARAMETERS))
    return {name: round(value, 6) if name not in INTEGER_PARAMETERS else int(value)
            for name, value in fitted.items() if value is not None and parameter_is_valid(name, value)}


