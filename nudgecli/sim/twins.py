"""Twins of real people: a simulated person whose habits are one participant's own (issue 37).

A twin is a set of :class:`~nudgecli.sim.participants.Participant` parameters fitted from one
participant's habit medians (HABITS.md's definitions, as ``nudge habits`` measures them), laid
over the participant the study draws at that position (:func:`apply_twin`): the physiology the
habits do not determine (pressure levels and spreads, onset ramp, drift, mapping error, epsilon)
is drawn from the seed tree as for any participant.

The fit of a twin from the habits is :mod:`nudgecli.sim.twin_fit`'s; this module is what a
study's worker needs (no pandas).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from nudgecli.config import PopulationSection
from nudgecli.config_base import plain
from nudgecli.config_people import POPULATION_RANGES
from nudgecli.errors import ConfigError
from nudgecli.sim.participants import Participant

#: The parameters a twin sets, in the people file's column order: issue 19's timing, then the
#: pressure control within a soft blow (``nudgecli.sim.habit_ranges.DEADBAND_PARAMETERS``).
TWIN_PARAMETERS = ("planning_s", "event_reaction_s", "event_reaction_log_sd", "hold_on_s", "hard_peak_s",
                   "offset_ramp_samples", "deadband_share", "deadband_stray_s")
#: Parameters that count samples (integers).
INTEGER_PARAMETERS = frozenset({"offset_ramp_samples"})


@dataclass(frozen=True)
class Twin:
    """One participant's twin: the parameters their habits set.

    Attributes
    ----------
    participant
        The participant's label in the source.
    source
        The source's name (a file or folder name).
    parameters
        Parameter -> value, for the parameters of :data:`TWIN_PARAMETERS` fitted from the habits.
    notes
        Parameter -> why it is left to the population's draw, or how its fit was bounded (what
        ``nudge fit-people`` prints; not kept in the people file, so not compared).
    """

    participant: str
    source: str
    parameters: Mapping[str, float]
    notes: Mapping[str, str] = field(default_factory=dict, compare=False)

    @property
    def from_population(self) -> tuple[str, ...]:
        """The parameters of :data:`TWIN_PARAMETERS` left to the population's draw, in column order."""
        return tuple(name for name in TWIN_PARAMETERS if name not in self.parameters)


def parameter_is_valid(name: str, value: float) -> bool:
    """Whether ``value`` is one the simulation accepts for ``name``: the ``[population]`` check of
    :class:`~nudgecli.config.PopulationSection` for a range of that one value (its one owner)."""
    if not math.isfinite(value) or (name in INTEGER_PARAMETERS and value != int(value)):
        return False
    one = int(value) if name in INTEGER_PARAMETERS else float(value)
    try:
        PopulationSection.model_validate({name: (one, one)})
    except (ValueError, ConfigError):  # pydantic's ValidationError is a ValueError
        return False
    return True


def parameter_needs(name: str) -> str:
    """What a value of ``name`` must be, for a message about one the simulation refuses
    (:func:`parameter_is_valid`): ``"a value with 0.0 <= deadband_share <= 0.9"``, the limits of
    ``[population]``'s check (:data:`~nudgecli.config_people.POPULATION_RANGES`)."""
    kind = "a whole number of samples" if name in INTEGER_PARAMETERS else "a value"
    lo, hi = POPULATION_RANGES[name]
    return f"{kind} with {plain(lo)} <= {name} <= {plain(hi)}, as [population] {name} accepts"


def apply_twin(drawn: Participant, twin: Twin) -> Participant:
    """The participant ``drawn`` with the twin's parameters: their habits, the rest as drawn."""
    values: dict[str, Any] = {name: int(value) if name in INTEGER_PARAMETERS else float(value)
                              for name, value in twin.parameters.items()}
    return dataclasses.replace(drawn, **values)


def twin_at(people: Sequence[Twin], index: int) -> Twin:
    """The twin participant ``index`` of a study is: the people in order, cycled."""
    if not people:
        raise ValueError("no people to take a twin from")
    return people[index % len(people)]
