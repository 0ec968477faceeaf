"""Parameter recovery of twins (issue 37): how well :func:`~nudgecli.sim.twins.fit_twin` gives back
known parameters, and how near the twins' own habits come to their sources'.

The comparison only; the simulation and the measuring are the caller's
(``experiments/twins_recovery.py``, ``tests/test_twins_recovery.py``): simulate people with known
parameters, measure their habits, fit twins, simulate the twins with the same seed (so the
physiology the habits do not determine is the same draw), measure them again, and hand the four
tables here.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from nudgecli.sim.participants import Participant
from nudgecli.sim.twin_fit import PARAMETER_HABITS, HabitFigures
from nudgecli.sim.twins import TWIN_PARAMETERS, Twin

#: How far a fitted parameter may lie from the truth and count as recovered, set from how
#: precisely a habit's median can show it: a time two 0.1 s cells (a median is read in whole cells,
#: and over a dozen trials the person's per-trial jitter moves it by about a cell), the reactions'
#: log-sd 0.15 (their quartiles are whole cells too: one cell on a quartile of 0.6 s moves the
#: log-sd by 0.12), the per-stop hold-on one cell (the per-trial sum is shared over four stops),
#: the offset ramp one sample (the onset ramp it is told from is assumed), the deadband share 0.03
#: (a fifth of the real people's span, about the sampling error of a share of some 300 soft-blow
#: cells' runs), a deadband stray one cell.
TOLERANCES: dict[str, float] = {
    "planning_s": 0.20,
    "event_reaction_s": 0.20,
    "event_reaction_log_sd": 0.15,
    "hold_on_s": 0.10,
    "hard_peak_s": 0.20,
    "offset_ramp_samples": 1.0,
    "deadband_share": 0.03,
    "deadband_stray_s": 0.10,
}
#: The recovery targets: a parameter recovered for at least this share of people ...
PARAMETER_TARGET = 0.90
#: ... and a twin's habit near its source's for at least this share of (person, habit) pairs,
HABIT_TARGET = 0.80
#: near meaning within this many seconds ...
HABIT_ABSOLUTE_S = 0.10
#: ... or this share of the source's median.
HABIT_RELATIVE = 0.20
#: The habits a twin is fitted from (and is compared on).
FITTED_HABITS = tuple(dict.fromkeys(h for habits in PARAMETER_HABITS.values() for h in habits))


@dataclass(frozen=True)
class ParameterRecovery:
    """One parameter over the people: how many were fitted and how many within its tolerance."""

    parameter: str
    tolerance: float
    fitted: int
    within: int
    people: int
    worst: float

    @property
    def share(self) -> float:
        """Share of all people recovered within the tolerance (a parameter not fitted is not)."""
        return self.within / self.people if self.people else 0.0

    @property
    def met(self) -> bool:
        return self.share >= PARAMETER_TARGET


def parameter_recovery(truth: Sequence[Participant], twins: Sequence[Twin],
                       tolerances: Mapping[str, float] | None = None) -> list[ParameterRecovery]:
    """Per parameter of :data:`TWIN_PARAMETERS`: the twins' fitted values against the truth.

    Parameters
    ----------
    truth
        ``(P,)`` the simulated people, in the twins' order.
    twins
        ``(P,)`` their twins.
    tolerances
        Parameter -> the largest error that counts as recovered (:data:`TOLERANCES`).
    """
    if len(truth) != len(twins):
        raise ValueError(f"{len(truth)} people and {len(twins)} twins")
    tolerances = TOLERANCES if tolerances is None else tolerances
    rows = []
    for name in TWIN_PARAMETERS:
        errors = [abs(float(twin.parameters[name]) - float(getattr(person, name)))
                  for person, twin in zip(truth, twins, strict=True) if name in twin.parameters]
        tolerance = float(tolerances[name])
        # a float's last bit (2.3 - 2.2) must not turn an error of exactly the tolerance into a miss
        within = sum(error <= tolerance + 1e-9 for error in errors)
        rows.append(ParameterRecovery(name, tolerance, len(errors), within, len(truth),
                                      max(errors, default=float("nan"))))
    return rows


def habit_is_near(twin: float, source: float) -> bool:
    """Whether a twin's habit median is within :data:`HABIT_ABSOLUTE_S` or :data:`HABIT_RELATIVE` of
    its source's."""
    gap = abs(twin - source)
    return gap <= HABIT_ABSOLUTE_S + 1e-9 or gap <= HABIT_RELATIVE * abs(source) + 1e-9


def habit_agreement(sources: Sequence[Mapping[str, HabitFigures]],
                    twins: Sequence[Mapping[str, HabitFigures]],
                    habits: Sequence[str] = FITTED_HABITS) -> dict[str, tuple[int, int]]:
    """Per habit: (pairs near, pairs compared) over the people who have it in both.

    ``sources[i]`` and ``twins[i]`` are person ``i``'s habits and their twin's.
    """
    if len(sources) != len(twins):
        raise ValueError(f"{len(sources)} sources and {len(twins)} twins")
    counts: dict[str, tuple[int, int]] = {}
    for habit in habits:
        pairs = [(twin[habit].median, source[habit].median)
                 for source, twin in zip(sources, twins, strict=True) if habit in source and habit in twin]
        counts[habit] = (sum(habit_is_near(t, s) for t, s in pairs), len(pairs))
    return counts
