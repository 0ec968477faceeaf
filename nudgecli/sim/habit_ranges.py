"""Where the population's timing ranges come from (issue 19, part 3).

The simulated person's timing habits (``planning_s``, ``event_reaction_s``,
``event_reaction_log_sd``, ``hold_on_s``, ``hard_peak_s``, ``offset_ramp_samples`` of
:class:`nudgecli.config.PopulationSection`) are derived the way issue 14 derived the pressure
ranges: each range starts where the pilots' calibration logs put it, and where the real people's
medians of ``shared/data/ciaa-task/HABITS.md`` lie outside, it is extended by the least amount
that covers them (:func:`covering_range`). A habit is measured a fixed mechanical offset after
the parameter that sets it (:data:`HABIT_OFFSETS_S`), so the real span is moved by that offset
first.

What the pilots' logs say (their ``p(phi_m | phi_i)`` sessions, prompts of 6 s):

- :func:`prompt_onsets`: prompt shown -> first sample with pressure: looking at a display and
  starting a blow (the trial's planning, a reaction);
- :func:`releases_after_clear`: a blow still held when its prompt cleared -> its last sample:
  letting go once what they watched has changed (blowing on after the robot stops);
- :func:`hard_offset_samples`: samples from a hard blow's last plateau sample to its end (its
  offset ramp).

Pressure control within a soft blow (issue 37: ``deadband_share``, ``deadband_stray_s``,
:func:`derived_pressure_control_ranges`): the pilots' prompts showed a label and no robot, so
nothing in them stops when the pressure strays into the deadband and nothing shows a correction:
like ``hard_peak_s``, these ranges are the real people's, moved by the offset between parameter
and habit (0 for both: a stray of n samples is a deadband run of n cells, and the stray share is
the deadband share of the soft blows' cells).

``hard_peak_s``'s offset of 0 is the peak's alone: a pulse's ramp samples read Hard too where their
fraction of a high level passes the hard threshold, so the measured time in the hard band is the
peak + 0.09 s on average, and ``planning_s`` and ``event_reaction_s``, extended from the pilots'
onsets to cover the real medians, also reach below them (docs/people.md, "Known limitations of the
operating habits", 2026-11-29). The ranges are left as derived: changing them changes every table.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from nudgecli.model.interface import HARD_PUFF, HARD_SIP, LABELS, ZERO_THRESHOLD
from nudgecli.reference import people_ranges
from nudgecli.sim.calibration_io import DistortionSession
from nudgecli.sim.participants import Participant

if TYPE_CHECKING:  # pandas loads in drawn_habits: a study's worker reads the offsets without it
    import pandas as pd

#: Real people's ranges of per-person medians (HABITS.md, the ten sibling-study users), seconds: read
#: from the packaged reference (:mod:`nudgecli.reference`), the one owner of HABITS.md's numbers.
#: ``hold_on_per_stop`` is HABITS.md's words ("about 0.1-0.3 s each time"), not its table.
REAL_HABIT_RANGES: dict[str, tuple[float, float]] = {
    name: bounds for name, bounds in people_ranges("ciaa-people").items()
    if name in ("first_command_latency", "reaction_stop_to_switch", "reaction_switch_to_motion",
                "hard_band_per_excursion", "hard_blow_whole", "hold_on_per_stop",
                "deadband_share_soft_blows", "deadband_run_in_soft_blow")
}
#: How long after its parameter each habit is measured (the model's mechanics, at 10 Hz), as the
#: population's ranges were derived: the first command cell is the blow's first sample (0); a
#: switch is seen the step after it (0.1); a pulse after a stop reaches the hard band after one
#: onset sample (0.1). A twin's fit takes off more exactly what the simulator adds, with the
#: population's onset ramps, levels and spreads (:class:`nudgecli.sim.twin_fit.Mechanics`: on
#: average 0.14 s for stop -> switch and 0.15 s for switch -> motion, whose soft blow may read no
#: input for its first samples); the ranges keep these round offsets, within a cell of those.
HABIT_OFFSETS_S: dict[str, float] = {
    "first_command_latency": 0.0,
    "reaction_stop_to_switch": 0.1,
    "reaction_switch_to_motion": 0.1,
    # a share, not seconds: the stray share is the deadband share of soft blows' cells
    "deadband_share_soft_blows": 0.0,
    # a stray of n samples is a run of n deadband cells
    "deadband_run_in_soft_blow": 0.0,
}
#: A plateau sample of a hard blow: at least this fraction of the blow's median magnitude.
PLATEAU_FRACTION = 0.8


def covering_range(start: tuple[float, float], real: tuple[float, float],
                   offset: float = 0.0, digits: int = 2) -> tuple[float, float]:
    """The least extension of ``start`` whose image ``[lo + offset, hi + offset]`` covers ``real``,
    rounded to ``digits`` decimals.

    >>> covering_range((1.32, 1.45), (1.80, 2.75))
    (1.32, 2.75)
    >>> covering_range((1.32, 1.45), (0.59, 1.80), offset=0.1)
    (0.49, 1.7)
    """
    lo = min(start[0], real[0] - offset)
    hi = max(start[1], real[1] - offset)
    return round(lo, digits), round(hi, digits)


def _windows(session: DistortionSession) -> list[tuple[float, float, str]]:
    """``(shown, cleared, label)`` of each prompt (rows alternate prompt / blank)."""
    times, commands = session.prompt_times, session.prompt_commands
    return [(float(times[i]), float(times[i + 1]), commands[i]) for i in range(0, len(times) - 1, 2)
            if commands[i] in LABELS]


def _active(session: DistortionSession) -> np.ndarray:
    return np.abs(np.nan_to_num(session.stream_pressure)) > ZERO_THRESHOLD


def prompt_onsets(session: DistortionSession) -> np.ndarray:
    """``(P,)`` seconds from each prompt to the first sample with pressure before it cleared."""
    t, active = session.stream_times, _active(session)
    onsets = []
    for shown, cleared, _ in _windows(session):
        inside = np.flatnonzero(active & (t >= shown) & (t < cleared))
        if inside.size:
            onsets.append(t[inside[0]] - shown)
    return np.array(onsets)


def releases_after_clear(session: DistortionSession) -> np.ndarray:
    """``(B,)`` seconds from a prompt's clearing to the last sample of a blow still held then."""
    t, active = session.stream_times, _active(session)
    releases = []
    for _, cleared, _ in _windows(session):
        after = np.flatnonzero(t >= cleared)
        if after.size == 0 or not active[after[0]]:
            continue
        end = after[0]
        while end + 1 < len(t) and active[end + 1]:
            end += 1
        releases.append(t[end] - cleared)
    return np.array(releases)


def hard_offset_samples(session: DistortionSession) -> np.ndarray:
    """``(H,)`` samples from each hard prompt's last plateau sample to its blow's last sample."""
    t, active = session.stream_times, _active(session)
    magnitude = np.abs(np.nan_to_num(session.stream_pressure))
    offsets = []
    for shown, cleared, label in _windows(session):
        if LABELS.index(label) not in (HARD_PUFF, HARD_SIP):
            continue
        inside = np.flatnonzero(active & (t >= shown) & (t < cleared + 3.0))
        if inside.size == 0:
            continue
        blow = magnitude[inside]
        plateau = np.flatnonzero(blow >= PLATEAU_FRACTION * np.median(blow))
        offsets.append(len(blow) - 1 - plateau[-1])
    return np.array(offsets, dtype=int)


def derived_timing_ranges(pilots: list[DistortionSession]) -> dict[str, tuple[float, float]]:
    """The population's timing ranges from the pilots' sessions and :data:`REAL_HABIT_RANGES`.

    Returns
    -------
    dict
        ``planning_s``, ``event_reaction_s``, ``hold_on_s``, ``hard_peak_s`` and
        ``offset_ramp_samples`` ranges, as :class:`~nudgecli.config.PopulationSection` holds them.
    """
    onset_medians = [float(np.median(prompt_onsets(s))) for s in pilots]
    start = (min(onset_medians), max(onset_medians))
    planning = covering_range(start, REAL_HABIT_RANGES["first_command_latency"],
                              HABIT_OFFSETS_S["first_command_latency"])
    stop = covering_range(start, REAL_HABIT_RANGES["reaction_stop_to_switch"],
                          HABIT_OFFSETS_S["reaction_stop_to_switch"])
    motion = covering_range(start, REAL_HABIT_RANGES["reaction_switch_to_motion"],
                            HABIT_OFFSETS_S["reaction_switch_to_motion"])
    reaction = (min(stop[0], motion[0]), max(stop[1], motion[1]))
    held = [float(np.median(r)) for r in (releases_after_clear(s) for s in pilots) if r.size]
    hold_on = covering_range((min(held), max(held)), REAL_HABIT_RANGES["hold_on_per_stop"])
    # the pilots held prompted hard blows for seconds: nothing on a switch pulse's peak
    peak = REAL_HABIT_RANGES["hard_band_per_excursion"]
    offsets = [int(np.median(o)) for o in (hard_offset_samples(s) for s in pilots) if o.size]
    # a pulse is onset (1-3 samples) + peak + offset: its longest reaches the real longest hard blow
    longest_onset, longest_peak = 3, round(peak[1] / 0.1)
    needed = round(REAL_HABIT_RANGES["hard_blow_whole"][1] / 0.1) - longest_onset - longest_peak
    offset = (min(offsets), max(max(offsets), needed))
    return {"planning_s": planning, "event_reaction_s": reaction, "hold_on_s": hold_on, "hard_peak_s": peak,
            "offset_ramp_samples": offset}


def derived_pressure_control_ranges() -> dict[str, tuple[float, float]]:
    """The population's ranges of pressure control within a soft blow, from :data:`REAL_HABIT_RANGES`.

    Nothing in the pilots' prompts starts them (no robot stopped, nothing was corrected), so each is
    the real people's range moved by its offset (:data:`HABIT_OFFSETS_S`, 0), the share to three
    decimals (HABITS.md gives 0.045).

    Returns
    -------
    dict
        ``deadband_share`` and ``deadband_stray_s``, as :class:`~nudgecli.config.PopulationSection`
        holds them.
    """
    ranges = {}
    for parameter, habit in DEADBAND_PARAMETERS.items():
        real = REAL_HABIT_RANGES[habit]
        # no pilots' start: the least range is the real one moved by the offset
        ranges[parameter] = covering_range((math.inf, -math.inf), real, HABIT_OFFSETS_S[habit], digits=3)
    return ranges


#: The drawn parameter of pressure control within a soft blow -> the habit it produces (issue 37),
#: measured the parameter plus :data:`HABIT_OFFSETS_S` (0).
DEADBAND_PARAMETERS: dict[str, str] = {
    "deadband_share": "deadband_share_soft_blows",
    "deadband_stray_s": "deadband_run_in_soft_blow",
}


#: The drawn parameter behind each real habit (``nudge plot-population``'s habits panel): the
#: habit is measured the parameter plus :data:`HABIT_OFFSETS_S` later.
HABIT_PARAMETERS: dict[str, str] = {
    "first_command_latency": "planning_s",
    "reaction_stop_to_switch": "event_reaction_s",
    "reaction_switch_to_motion": "event_reaction_s",
    "hard_band_per_excursion": "hard_peak_s",
    "hold_on_per_stop": "hold_on_s",
}


def drawn_habits(people: Sequence[Participant]) -> pd.DataFrame:
    """Each person's habits as their drawn parameters set them (parameter + mechanical offset).

    Returns
    -------
    pd.DataFrame
        Columns ``participant``, ``habit``, ``parameter``, ``value`` (seconds); one row per person
        and habit of :data:`HABIT_PARAMETERS`.
    """
    import pandas as pd

    rows = [{"participant": person.index, "habit": habit, "parameter": parameter,
             "value": round(float(getattr(person, parameter)) + HABIT_OFFSETS_S.get(habit, 0.0), 6)}
            for person in people for habit, parameter in HABIT_PARAMETERS.items()]
    return pd.DataFrame(rows, columns=["participant", "habit", "parameter", "value"])
