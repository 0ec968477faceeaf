"""The fit of a twin (:mod:`nudgecli.sim.twins`) from one participant's habit figures (issue 37).

How a parameter is set: by taking off what the simulator adds between the parameter and the habit
it produces. Some of that is fixed (a switch is seen the step after it:
:data:`nudgecli.sim.habit_ranges.HABIT_OFFSETS_S`), some is set by the person's other fitted
parameters (their pulse's peak and offset ramp), and some by physiology a twin draws and a habits
table does not hold (the onset ramp, the hard and soft levels and spreads, the drift): for that,
:class:`Mechanics` draws people from the population, so that the fit is right on average over the
people a twin's physiology is drawn from (and off by up to a cell for one whose onset ramp is the
range's shortest or longest). Simulation-based fitting would need each person's physiology. The
rules, one per parameter:

- ``planning_s``: the first-command latency's median (offset 0);
- ``hard_peak_s`` and ``offset_ramp_samples`` (a mode-switch pulse: onset ramp, peak, offset ramp,
  ``pulse_fractions``; the driver switches at its first sample above the hard threshold): the peak
  and offset ramp whose pulses have, on average over the draws, the participant's time in the hard
  band and samples outside it (whole hard blow less time in the band); so the peak is the band less
  the ramp samples that reach it (a ramp sample above the threshold is a hard-band cell too), at
  least one sample. A hard blows' median longer than a pulse of the population's longest offset
  ramp is no pulse (soft blows with a stray Hard cell count as hard blows, and for a person whose
  soft level is near the threshold they are most of them): their lower quartile is read. A fit
  outside ``[population]``'s offset ramps is clamped to them, and the note says so. A band longer
  than the pulses drawn hold (:meth:`Mechanics.longest_peak`) is searched as the longest they hold,
  its peak then moved by the rest: past what the simulation accepts, its note says so;
- ``event_reaction_s``: from both reactions (a stop at a waypoint -> the next switch, a switch ->
  the robot moves again; both needed: a log without its layout has no stop -> switch). From a log
  or a run folder, event by event (:func:`reaction_observations`): a reaction ends at the first
  blow after a release, which starts when the reaction ends or after the person's own pause,
  whichever is later, so a release longer than the population's longest pause gives the reaction,
  and a shorter one only bounds it (a censored observation); an event with no release is no
  reaction; the median is the censored log-normal likelihood's (:func:`censored_lognormal`). From
  a habits table (medians only), or with fewer than :data:`MIN_EVENTS_FOR_QUARTILES` reactions
  read whole: the mean over the two of the median (of the events with a release, where they are
  given) less its offset (:meth:`Mechanics.reaction_offsets`: the pulse's onset samples below
  the hard band before the switch; the step after the switch and the soft blow's samples before
  it reads input), which reads short reactions hidden by a pause as the pause (slow);
- ``event_reaction_log_sd``: switch -> motion's quartiles, less its offset, read as a
  log-normal's: ``ln(q75 / q25) / (2 z_0.75)``; it needs :data:`MIN_EVENTS_FOR_QUARTILES` events
  and a lower quartile at least a cell above the offset (quicker events are no reactions). Stop ->
  switch's quartiles read the spread 0.07 high on average over 100 simulated people (switch ->
  motion's 0.01): they hold events the offsets do not model (a switch 0.1 s after a stop);
- ``hold_on_s``: the median hold-on per stop (``hold_on_per_stop``, a row ``nudge habits``
  measures beside HABITS.md's: each soft blow that went on after the robot stopped), one for one:
  on 60 simulated people of three seeds it read 0.02 s below the parameter on average, the 0.1 s
  cells rounding it down, and within 0.1 s for every one; a table with only HABITS.md's per-trial
  hold-on falls back to it shared over the stops of a CIAA trial (:func:`stops_per_trial`: the
  waypoints where the path turns and the goal heading), which also counts stalls and surprises;
- ``deadband_share`` and ``deadband_stray_s`` (pressure control within a soft blow): the share of
  soft-blow time in the deadband and the median deadband run inside a soft blow, less their
  offsets (0: :data:`nudgecli.sim.habit_ranges.DEADBAND_PARAMETERS`, one for one).

A parameter whose habit the source lacks, whose quartiles are no reaction's, whose fitted value
lies outside what the simulation accepts, or that is read from stops (:data:`STOP_PARAMETERS`) of a
grid-world run, is left to the population's draw: the twin lists it in
:attr:`~nudgecli.sim.twins.Twin.from_population`, and its :attr:`~nudgecli.sim.twins.Twin.notes`
say why (``nudge fit-people`` prints them).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from statistics import NormalDist

import numpy as np
from scipy.optimize import minimize
from scipy.stats import norm

from nudgecli.config import BehaviourSection, PopulationSection
from nudgecli.config_people import POPULATION_RANGES
from nudgecli.model import portable_math
from nudgecli.model.interface import (
    HARD_PUFF,
    HARD_SIP,
    HARD_THRESHOLD_EARLY,
    NO_INPUT,
    SOFT_PUFF,
    SOFT_SIP,
    SOFT_THRESHOLD_EARLY,
    ZERO_THRESHOLD,
    label_pressure,
)
from nudgecli.sim.habit_ranges import DEADBAND_PARAMETERS, HABIT_OFFSETS_S
from nudgecli.sim.participants import draw_participant
from nudgecli.sim.pressure_model import LABEL_SIGN, blow_pressures, pulse_fractions
from nudgecli.sim.twins import INTEGER_PARAMETERS, TWIN_PARAMETERS, parameter_is_valid, parameter_needs

#: The habits each parameter is fitted from (all of them needed), for every parameter a twin sets.
PARAMETER_HABITS: dict[str, tuple[str, ...]] = {
    "planning_s": ("first_command_latency",),
    "event_reaction_s": ("reaction_stop_to_switch", "reaction_switch_to_motion"),
    "event_reaction_log_sd": ("reaction_switch_to_motion",),
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
#: People drawn from the population for what a twin's drawn physiology does (:class:`Mechanics`),
#: with a seed of their own: a fit is a function of the habits alone.
MECHANICS_PEOPLE = 400
MECHANICS_SEED = 20261129
#: Samples drawn of a pulse (its onset, peak and offset ramps) and of a soft blow's start.
PULSE_SAMPLES = 80
#: The longest offset ramp a fit considers, samples (``[population]``'s own limit).
MAX_OFFSET_SAMPLES = int(POPULATION_RANGES["offset_ramp_samples"][1])
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
    values, blow_after, releases
        A reaction's events one by one, s (a log or a run; a habits table gives none): each as
        measured, from its start (the stop; the step after the switch, when it is seen) to the
        first blow after a release, and that release (neutral cells before the blow; 0 where the
        event ends before any release).
    """

    n: int
    median: float
    q25: float = math.nan
    q75: float = math.nan
    values: tuple[float, ...] = ()
    blow_after: tuple[float, ...] = ()
    releases: tuple[float, ...] = ()


def stops_per_trial(waypoints: int = 5) -> int:
    """The stops of a CIAA trial a person holds on at: the path's interior waypoints (where it
    turns) and the goal heading at the turn waypoint; the goal waypoint ends the trial.

    >>> stops_per_trial(5)
    4
    """
    return waypoints - 2 + 1


# --- what the simulator does between a parameter and its habit -------------------------------


@dataclass(frozen=True)
class _Draws:
    """What :class:`Mechanics` reads of each person drawn from the population (``(J,)`` each)."""

    onset: np.ndarray  # onset ramp samples
    hard: tuple[np.ndarray, np.ndarray, np.ndarray]  # a switch's level, spread and sign
    normals: np.ndarray  # (J, PULSE_SAMPLES) a pulse's deviations (their drift)
    motion_wait: np.ndarray  # samples of a soft blow before its first that reads input


def _draw_people(population: PopulationSection, thresholds: tuple[float, float, float]) -> _Draws:
    """:data:`MECHANICS_PEOPLE` people drawn from ``population`` (``draw_participant``, a seed of the
    fit's own: a fit is a function of the habits), each with one switch pulse's deviations and one
    soft blow's first samples, as the simulator draws them (``drift_normals``, ``pressures``)."""
    rng = np.random.default_rng(MECHANICS_SEED)
    onset, hard, normals, wait = [], [], [], []
    zero, soft, hard_threshold = thresholds
    for index in range(MECHANICS_PEOPLE):
        person = draw_participant(population, index, rng)
        label = (HARD_PUFF, HARD_SIP)[index % 2]  # a switch is a puff or a sip
        onset.append(person.onset_ramp_samples)
        hard.append((abs(person.pressure_level[label]), person.pressure_spread[label], LABEL_SIGN[label]))
        normals.append(person.drift_normals(PULSE_SAMPLES, rng))
        blow = person.pressures((SOFT_PUFF, SOFT_SIP)[index % 2], PULSE_SAMPLES, rng)
        reads = label_pressure(blow, soft, hard_threshold, zero) != NO_INPUT
        wait.append(int(np.argmax(reads)) if reads.any() else PULSE_SAMPLES)
    columns = np.array(hard).T
    return _Draws(np.array(onset), (columns[0], columns[1], columns[2]), np.array(normals), np.array(wait))


@dataclass(frozen=True)
class Mechanics:
    """What the simulator adds to a parameter on the way to its habit where physiology a twin draws
    takes part (the onset ramp, the hard and soft levels and spreads, the drift): over
    :data:`MECHANICS_PEOPLE` people drawn from the population, so that a fit is right on average over
    the people a twin's physiology is drawn from.

    Attributes
    ----------
    population
        The ``[population]`` a twin's physiology is drawn from.
    thresholds
        ``(zero, soft, hard)`` of the driver the source's people used (a run folder's own
        ``[interface]``: ``twins_of_sources``; its defaults by default): it switches the mode at a
        pulse's first sample above ``hard`` (``sim/protocol.py``), and a sample below ``zero`` is no
        input.
    behaviour
        The ``[behaviour]`` a twin acts under (its ``pause_jitter``: :meth:`longest_pause_s`).
    cell_s
        The habits' cell length (one simulation step), s.
    """

    population: PopulationSection = field(default_factory=PopulationSection)
    behaviour: BehaviourSection = field(default_factory=BehaviourSection)
    thresholds: tuple[float, float, float] = (ZERO_THRESHOLD, SOFT_THRESHOLD_EARLY, HARD_THRESHOLD_EARLY)
    cell_s: float = CELL_S
    draws: _Draws = field(init=False, repr=False, compare=False)
    # the samples a pulse may take after the longest onset ramp drawn: its peak and offset ramp
    _after_onset: int = field(init=False, repr=False, compare=False)
    # (peak, offset) -> pulse(peak, offset): a fit asks for a few dozen shapes, every twin the same ones
    _pulses: dict[tuple[int, int], tuple[np.ndarray, np.ndarray, np.ndarray]] = field(
        init=False, repr=False, compare=False, default_factory=dict)

    def __post_init__(self) -> None:
        draws = _draw_people(self.population, self.thresholds)
        object.__setattr__(self, "draws", draws)
        object.__setattr__(self, "_after_onset", draws.normals.shape[1] - int(draws.onset.max()))

    def longest_peak(self) -> int:
        """The longest peak, samples, of a pulse the draws hold with any offset ramp a fit considers:
        :data:`PULSE_SAMPLES` less the longest onset ramp drawn and :data:`MAX_OFFSET_SAMPLES` (57 for
        the default population: 5.7 s, beyond the 5 s ``[population] hard_peak_s`` accepts, so that
        a fit just past that limit is found, and said, as such)."""
        return self._after_onset - MAX_OFFSET_SAMPLES

    def peak_samples(self, seconds: float) -> int:
        """The peak, whole samples (at least one), of a pulse with ``seconds`` at the level, held to
        :meth:`longest_peak`: a longer peak switches the mode as the longest the draws hold does, and
        has the same samples outside the hard band (its ramps')."""
        return min(max(1, round(seconds / self.cell_s)), self.longest_peak())

    def pulse(self, peak: int, offset: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(length, first, inside)`` per draw, ``(J,)`` each, of a pulse of ``peak`` samples at the
        level and an offset ramp of ``offset`` (``pulse_fractions``, ``blow_pressures``): its
        samples, its first in the hard band (where the mode switches; its length where none is), and
        its samples there. A pulse longer than the samples drawn is a ValueError (a fit asks for
        peaks up to :meth:`longest_peak`)."""
        if (peak, offset) not in self._pulses:
            if peak + offset > self._after_onset:
                raise ValueError(f"a pulse of a {peak}-sample peak and a {offset}-sample offset ramp is "
                                 f"longer than the {self.draws.normals.shape[1]} samples drawn (longest "
                                 f"peak: {self.longest_peak()})")
            self._pulses[peak, offset] = self._pulse(peak, offset)
        return self._pulses[peak, offset]

    def _pulse(self, peak: int, offset: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        draws, (zero, soft, hard) = self.draws, self.thresholds
        length, first, inside = (np.zeros(len(draws.onset), dtype=int) for _ in range(3))
        for onset in np.unique(draws.onset):
            rows = draws.onset == onset
            fractions = pulse_fractions(int(onset), peak, offset)
            n = len(fractions)
            level, spread, sign = (column[rows, None] for column in draws.hard)
            pressures = blow_pressures(level, spread, sign, fractions[None, :], draws.normals[rows, :n])
            labels = label_pressure(pressures, soft, hard, zero)
            above = (labels == HARD_PUFF) | (labels == HARD_SIP)
            length[rows] = n
            first[rows] = np.where(above.any(axis=1), np.argmax(above, axis=1), n)
            inside[rows] = above.sum(axis=1)
        return length, first, inside

    def longest_pause_s(self) -> float:
        """The longest release a person gives between two blows when nothing is left of a reaction,
        s: ``[population]``'s longest ``action_pause_s`` at its most jittered (``_decide``: the
        release is ``max(1, round(action_pause_s * jitter / dt))`` samples, or until the reaction
        ends if that is later). A longer release ends where the reaction does."""
        longest = self.population.action_pause_s[1] * (1.0 + self.behaviour.pause_jitter)
        return max(1, round(longest / self.cell_s)) * self.cell_s

    def blow_offsets(self) -> dict[str, float]:
        """Reaction habit -> how long after the reaction its next blow reads input, s, on average:
        after a stop it is a switch pulse, whose first sample reads input; after a switch a soft
        blow, whose first samples may read none (:meth:`reaction_offsets`)."""
        return {"reaction_stop_to_switch": 0.0,
                "reaction_switch_to_motion": float(np.mean(self.draws.motion_wait)) * self.cell_s}

    def reaction_offsets(self, peak: int, offset: int) -> dict[str, float]:
        """Reaction habit -> how long after the reaction it is measured, s, on average over the draws:

        - a stop at a waypoint -> the next switch: the reaction runs from the stop, the pulse starts
          when it ends, and the switch is the pulse's first sample in the hard band (the onset
          ramp's samples below it come first: ``_decision_due``, ``_decide``, ``sim/protocol.py``);
        - a switch -> the robot moves: the mode is seen the step after the switch
          (:data:`~nudgecli.sim.habit_ranges.HABIT_OFFSETS_S`, ``_see_mode``), and the next blow
          moves the robot from its first sample that reads input (a soft level near zero with a
          wide spread reads none for a sample or more: ``sample_pressure`` clips at 0).
        """
        length, first, _ = self.pulse(peak, offset)
        switches = first < length  # a pulse that never reaches the band switches nothing
        return {"reaction_stop_to_switch": float(np.mean(first[switches])) * self.cell_s,
                "reaction_switch_to_motion": HABIT_OFFSETS_S["reaction_switch_to_motion"]
                + self.blow_offsets()["reaction_switch_to_motion"]}


# --- the inverse -------------------------------------------------------------------------------


#: Parameter -> why it is the population's or was clamped (the words ``nudge fit-people`` prints).
Notes = dict[str, str]


def _reaction_spread(figures: HabitFigures, offset_s: float, cell_s: float) -> tuple[float | None, str]:
    """A reaction's log-normal spread from its quartiles less its offset, ``ln(q75 / q25) / (2 z)``,
    or None and why: too few events, a lower quartile within a cell of the offset (a reaction
    is at least a cell: quicker events are no reactions, and a log of them reads a spread of 1.5),
    or both quartiles in one cell (the spread is below what the cells resolve, not 0)."""
    if figures.n < MIN_EVENTS_FOR_QUARTILES:
        return None, f"{figures.n} event(s), fewer than the {MIN_EVENTS_FOR_QUARTILES} its quartiles need"
    lo, hi = figures.q25 - offset_s, figures.q75 - offset_s
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
        return None, "no quartiles"
    if lo < cell_s - 1e-9:
        return None, (f"its lower quartile ({figures.q25:g} s) is within a cell of its offset "
                      f"({offset_s:.2f} s): no reaction's")
    if hi - lo < 1e-9:  # a spread of 0 would make every reaction the median
        return None, (f"its quartiles are both {figures.q25:g} s, one {cell_s:g} s cell: its spread is not "
                      "measurable at the source's resolution")
    return math.log(hi / lo) / (2.0 * Z_QUARTILE), ""


def released_median(figures: HabitFigures) -> float:
    """A reaction's median over the events that end in a release, s (the figures' median where they
    give no events one by one: a habits table). The simulator ends every reaction with a release
    (``_decide``, ``sim/behaviour.py``: a new blow starts after at least one sample of no input);
    an event with none is no reaction: a soft blow that strays into the hard band switches the mode
    as the robot stops (a "stop -> switch" of 0-0.1 s, the pilot run's person 2's quarter)."""
    released = [value for value, release in zip(figures.values, figures.releases, strict=True) if release > 0]
    return float(np.median(released)) if released else figures.median


def reaction_observations(habits: Mapping[str, HabitFigures],
                          mechanics: Mechanics) -> tuple[np.ndarray, np.ndarray]:
    """Both reactions' events as reactions, ``(exact, bounds)``, s, as the simulator makes them
    (``_saw_event``, ``_decide``, ``sim/behaviour.py``): the next blow starts when the reaction
    ends or after the person's release, whichever is later. So a release longer than
    :meth:`Mechanics.longest_pause_s` ends with the reaction (exact: the time to that blow, less
    :meth:`Mechanics.blow_offsets`); a shorter one may be the person's own pause, which hides a
    shorter reaction: the reaction is at most the time to the release's start plus the longest
    pause and half a step (left-censored; a reaction is kept in whole steps). The reaction ends at
    the first blow after it, whatever that blow is (the switch may come after a blow that went
    nowhere and a stall, which start another reaction). An event that ends before any release is
    no reaction (:func:`released_median`)."""
    longest, offsets = mechanics.longest_pause_s(), mechanics.blow_offsets()
    exact: list[float] = []
    bounds: list[float] = []
    for habit in PARAMETER_HABITS["event_reaction_s"]:
        figures = habits[habit]
        for after, release in zip(figures.blow_after, figures.releases, strict=True):
            if release <= 0:
                continue
            if release > longest + 1e-9:
                exact.append(after - offsets[habit])
            else:
                # the reaction is drawn in seconds and kept in whole steps (``round(r / dt)``): a
                # reaction of at most k steps is one of at most k + 1/2
                bounds.append(after - release + longest + mechanics.cell_s / 2)
    return np.array(exact), np.array(bounds)


def censored_lognormal(exact: np.ndarray, bounds: np.ndarray, log_sd_range: tuple[float, float],
                       floor: float) -> tuple[float, float]:
    """``(median, log_sd)`` of the log-normal most likely to give the ``exact`` values and values
    at most ``bounds`` (left-censored), its log-sd within ``log_sd_range`` (a person whose reactions
    are nearly all hidden shows too little of them to tell a spread from a median); values below
    ``floor`` read as ``floor``."""
    logs = portable_math.log(np.maximum(exact, floor))
    log_bounds = portable_math.log(np.maximum(bounds, floor))

    def minus_log_likelihood(point: np.ndarray) -> float:
        mu, sd = float(point[0]), math.exp(float(point[1]))
        z = (logs - mu) / sd
        hidden = norm.logcdf((log_bounds - mu) / sd)
        return float(np.sum(0.5 * z * z) + len(logs) * math.log(sd) - np.sum(hidden))

    lo, hi = (math.log(bound) for bound in log_sd_range)
    start = np.array([float(np.median(logs)), (lo + hi) / 2])
    best = minimize(minus_log_likelihood, start, method="L-BFGS-B", bounds=[(-5.0, 5.0), (lo, hi)])
    return math.exp(float(best.x[0])), math.exp(float(best.x[1]))


def _fit_reactions(habits: Mapping[str, HabitFigures], mechanics: Mechanics,
                   fitted: Mapping[str, float | None], notes: Notes) -> tuple[float | None, float | None]:
    """``(event_reaction_s, event_reaction_log_sd)``: the reactions' medians less their offsets
    (:meth:`Mechanics.reaction_offsets`), averaged (both needed); the spread from the switch ->
    motion quartiles."""
    peak, offset = fitted.get("hard_peak_s"), fitted.get("offset_ramp_samples")
    population, cell_s = mechanics.population, mechanics.cell_s
    # a peak longer than the draws hold switches the mode as the longest they hold does: at the
    # pulse's first sample in the band, on its onset ramp or at its peak's start
    offsets = mechanics.reaction_offsets(
        mechanics.peak_samples(_middle(population.hard_peak_s) if peak is None else peak),
        round(_middle(population.offset_ramp_samples)) if offset is None else int(offset))
    log_sd = None
    spread_habit = PARAMETER_HABITS["event_reaction_log_sd"][0]
    if spread_habit in habits:
        log_sd, why = _reaction_spread(habits[spread_habit], offsets[spread_habit], cell_s)
        if log_sd is None:
            notes["event_reaction_log_sd"] = f"{spread_habit}: {why}"
    missing = [habit for habit in PARAMETER_HABITS["event_reaction_s"] if habit not in habits]
    if missing:
        notes["event_reaction_s"] = f"no {missing[0]} in the source (the rule is both reactions' mean)"
        return None, log_sd
    exact, bounds = reaction_observations(habits, mechanics)
    if len(exact) >= MIN_EVENTS_FOR_QUARTILES:  # events one by one: the censored likelihood's median
        return censored_lognormal(exact, bounds, population.event_reaction_log_sd, cell_s / 2)[0], log_sd
    medians = [released_median(habits[habit]) - offsets[habit]
               for habit in PARAMETER_HABITS["event_reaction_s"]]
    return sum(medians) / len(medians), log_sd


def _pulse_length(habits: Mapping[str, HabitFigures], mechanics: Mechanics, band_s: float,
                  notes: Notes) -> float | None:
    """The whole length of the participant's pulse, s: the hard blows' median, or their lower
    quartile where the median is longer than a pulse of the population's longest offset ramp with
    that time in the hard band can be (the longer "hard blows" are soft blows with a stray Hard
    cell); None without hard blows."""
    whole = habits.get("hard_blow_whole")
    if whole is None:
        notes["offset_ramp_samples"] = "no hard_blow_whole in the source"
        return None
    # a peak longer than the draws hold has the same samples outside the band (its ramps') as theirs
    peak = mechanics.peak_samples(band_s)
    length, _, inside = mechanics.pulse(peak, mechanics.population.offset_ramp_samples[1])
    longest = band_s + float(np.mean(length - inside) + 1) * mechanics.cell_s  # a cell's slack
    if whole.median > longest + 1e-9 and math.isfinite(whole.q25) and whole.q25 < whole.median:
        notes["offset_ramp_samples"] = (
            f"the hard blows' median ({whole.median:g} s) is longer than a pulse of the population's ramps "
            f"can be (soft blows with a stray Hard cell count as hard blows): read from their lower "
            f"quartile ({whole.q25:g} s)")
        return whole.q25
    return whole.median


def _fit_pulse(habits: Mapping[str, HabitFigures], mechanics: Mechanics,
               notes: Notes) -> tuple[float | None, int | None]:
    """``(hard_peak_s, offset_ramp_samples)`` of the participant's mode-switch pulse: the peak (whole
    samples) and offset ramp whose pulses, over the population's draws, come nearest the
    participant's time in the hard band and samples outside it; the peak then moved by what the
    band still lacks. Without hard blows the offset ramp is the population's middle, not fitted."""
    band = habits.get("hard_band_per_excursion")
    if band is None:
        notes["hard_peak_s"] = notes["offset_ramp_samples"] = "no hard_band_per_excursion in the source"
        return None, None
    cell_s, (lo, hi) = mechanics.cell_s, mechanics.population.offset_ramp_samples
    band_cells = band.median / cell_s
    whole = _pulse_length(habits, mechanics, band.median, notes)
    offsets = range(MAX_OFFSET_SAMPLES + 1) if whole is not None else [round(_middle((lo, hi)))]
    # the peaks searched end at the longest the draws hold (5.7 s by default, past the 5 s the
    # simulation accepts): a longer band is searched as one that long, with the same samples outside
    # it (a long pulse's ramps, not its peak, set those), and its peak moved by the rest below, as
    # by what any band still lacks; so a fit past the limit is found and said as for one just past it
    searched_cells = min(band_cells, mechanics.longest_peak() - 1)

    def distance(shape: tuple[int, int]) -> float:
        length, _, inside = mechanics.pulse(*shape)
        outside = 0.0 if whole is None else float(np.mean(length - inside)) - (whole - band.median) / cell_s
        return (float(np.mean(inside)) - searched_cells) ** 2 + outside ** 2

    peak, offset = min(((p, o) for o in offsets for p in range(1, round(searched_cells) + 2)), key=distance)
    # a peak is at least one sample (``SimulatedPerson._start_hold``)
    peak_s = max(peak + band_cells - float(np.mean(mechanics.pulse(peak, offset)[2])), 1.0) * cell_s
    if whole is None:
        return peak_s, None
    if not lo <= offset <= hi:
        clamped = min(max(offset, lo), hi)
        clamp = (f"fitted {offset} samples, outside [population] offset_ramp_samples {lo}-{hi}: "
                 f"clamped to {clamped}")
        notes["offset_ramp_samples"] = "; ".join(filter(None, (notes.get("offset_ramp_samples"), clamp)))
        offset = clamped
    return peak_s, offset


def default_mechanics() -> Mechanics:
    """The :class:`Mechanics` of the default population, interface and behaviour: drawn once (a few
    hundred people) and shared by every fit given no ``mechanics`` (a fit only reads it; its pulses
    are memoised, the same for every fit)."""
    return _default_mechanics(PULSE_SAMPLES)


@functools.cache
def _default_mechanics(samples: int) -> Mechanics:
    """:func:`default_mechanics` of pulses of ``samples`` samples (:data:`PULSE_SAMPLES` when it is
    called, which the draws are made of): a cache keyed by it hands no caller draws of another
    length."""
    return Mechanics()


def _middle(bounds: tuple[float, float]) -> float:
    return (bounds[0] + bounds[1]) / 2


def fit_twin_with_notes(habits: Mapping[str, HabitFigures], *, mechanics: Mechanics | None = None,
                        stops: int | None = None, waypoints: bool = True) -> tuple[dict[str, float], Notes]:
    """The parameters one participant's habits set (the rules of the module's docstring), and why
    each of the others is left to the population's draw (or a fit was clamped).

    Parameters
    ----------
    habits
        Habit key -> the participant's figures (the habits they have events of).
    mechanics
        What the simulator does between a parameter and its habit (the default population's).
    stops
        Stops per trial (:func:`stops_per_trial` by default).
    waypoints
        Whether the source's robot stops at the CIAA task's waypoints (a real log, a CIAA run);
        False (a grid-world run) leaves :data:`STOP_PARAMETERS` to the population.

    Returns
    -------
    tuple
        Parameter -> value for the parameters whose habits are all there and whose value the
        simulation accepts (:func:`parameter_is_valid`), and parameter -> the note on it.
    """
    mechanics = default_mechanics() if mechanics is None else mechanics
    stops = stops_per_trial() if stops is None else stops
    notes: Notes = {}
    fitted: dict[str, float | None] = dict.fromkeys(TWIN_PARAMETERS)
    if "first_command_latency" in habits:
        latency = habits["first_command_latency"].median
        fitted["planning_s"] = latency - HABIT_OFFSETS_S["first_command_latency"]
    if "hold_on_per_stop" in habits:  # a log measured by nudge habits
        fitted["hold_on_s"] = habits["hold_on_per_stop"].median  # one for one (see the module's rules)
    elif "hold_on_per_trial" in habits:  # a table of HABITS.md's rows only
        fitted["hold_on_s"] = habits["hold_on_per_trial"].median / stops
    fitted["hard_peak_s"], fitted["offset_ramp_samples"] = _fit_pulse(habits, mechanics, notes)
    if waypoints:
        fitted["event_reaction_s"], fitted["event_reaction_log_sd"] = _fit_reactions(
            habits, mechanics, fitted, notes)
    for parameter, habit in DEADBAND_PARAMETERS.items():
        if habit in habits:
            fitted[parameter] = habits[habit].median - HABIT_OFFSETS_S[habit]
    kept = {}
    for name, value in fitted.items():
        if not waypoints and name in STOP_PARAMETERS:
            notes[name] = "a grid-world run: its robot stops in any cell, not at the CIAA task's waypoints"
        elif value is None:
            notes.setdefault(name, f"no {' or '.join(PARAMETER_HABITS[name])} in the source")
        elif not parameter_is_valid(name, value):
            notes[name] = f"fitted {value:.6g}, but the simulation needs {parameter_needs(name)}"
        else:
            kept[name] = round(value, 6) if name not in INTEGER_PARAMETERS else int(value)
    return kept, notes


def fit_twin(habits: Mapping[str, HabitFigures], *, mechanics: Mechanics | None = None,
             stops: int | None = None, waypoints: bool = True) -> dict[str, float]:
    """The parameters one participant's habits set: :func:`fit_twin_with_notes` without its notes."""
    return fit_twin_with_notes(habits, mechanics=mechanics, stops=stops, waypoints=waypoints)[0]
