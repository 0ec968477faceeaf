"""The experiment's switches and the keys only they make the model read (:data:`SWITCHES`), and the
one rule of them (:func:`check_switched_keys`): a dependent key given a value other than its default
while its switch is off is an error where it is given, never a setting silently ignored (as
``[blending] gap`` beside ``gate = "none"``).

Each dependency is the model's: ``nudgecli.sim.protocol`` hands the decay's delay, rate and cap
to the inference only with ``decay = true``; ``nudgecli.model.disambiguation`` reads ``samples`` and
``weighting`` in the Monte-Carlo estimator only (the exact one is always belief-weighted);
``nudgecli.model.assistance`` reads the knee and the drop only with ``distance_weighting = true``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from pydantic import model_validator

from nudgecli.config_base import Section
from nudgecli.config_files import as_written, parse_override
from nudgecli.config_world import same_as_default


@dataclass(frozen=True)
class Switch:
    """A key that turns a part of the model on or off, and the keys only that part reads.

    Attributes
    ----------
    section, key
        Where the switch is (``inference``, ``decay``).
    off, on
        The switch's value that turns the part off, and the one to set to turn it on.
    dependents
        The section's keys the model reads only with the switch on.
    does
        What the part does when on (the end of the Error line's fix).
    """

    section: str
    key: str
    off: Any
    on: Any
    dependents: tuple[str, ...]
    does: str


#: Every switch of the experiment and the keys only it makes read.
SWITCHES: tuple[Switch, ...] = (
    Switch("inference", "decay", False, True, ("decay_delay", "decay_rate", "decay_cap"),
           "let the belief forget towards uniform while no input is measured"),
    Switch("disambiguation", "estimator", "exact", "monte_carlo", ("samples", "weighting"),
           "estimate I(s) by sampling (the exact estimator is always belief-weighted)"),
    Switch("assistance", "distance_weighting", False, True, ("distance_knee", "distance_drop"),
           "scale alpha by the distance to the goal"),
)

#: Switches whose section refuses their dependents itself (``[blending]``: ``gap`` beside ``gate =
#: "none"``, ``BlendingPolicySection``); only the dropping of a file's dependents by a ``--set`` that
#: turns the switch off (:func:`dependents_off_with_their_switch`) is shared with :data:`SWITCHES`.
SELF_CHECKED_SWITCHES: tuple[Switch, ...] = (
    Switch("blending", "gate", "none", "gap", ("gap",),
           "blend only while the two highest beliefs differ by more than gap"),
)


def check_switched_keys(section_name: str, data: Any, section: type[Section]) -> None:
    """Raise ``ValueError`` (one line, the first dependent key its field) where a section's raw
    ``data`` gives a key of :data:`SWITCHES` a value other than its default while its switch is off.

    ``section``: the section's class, whose defaults are compared. A value at its default passes: a
    run folder's ``config.toml`` writes every key, and the default changes nothing the model does.
    """
    if not isinstance(data, Mapping):
        return
    defaults = {name: field.default for name, field in section.model_fields.items()}
    for switch in SWITCHES:
        if switch.section != section_name:
            continue
        if not same_as_default(data.get(switch.key, defaults[switch.key]), switch.off):
            continue
        given = [key for key in switch.dependents
                 if key in data and not same_as_default(data[key], defaults[key])]
        if not given:
            continue
        first, others = given[0], given[1:]
        nor = "".join(f", nor is {key} = {as_written(data[key])}" for key in others)
        them = " and ".join(given)
        off, on = as_written(switch.off), as_written(switch.on)
        raise ValueError(f"{first}: {as_written(data[first])} is not used with {switch.key} = {off}{nor}; "
                         f"remove {them}, or set {section_name}.{switch.key} = {on} to {switch.does}")


def switches_checked(section_name: str) -> Any:
    """A before-validator of the section ``section_name`` applying :func:`check_switched_keys` to
    its raw data (``_keys_of_its_switches = switches_checked("inference")`` in its class)."""

    def check(cls: type[Section], data: Any) -> Any:
        check_switched_keys(section_name, data, cls)
        return data

    return model_validator(mode="before")(classmethod(check))  # type: ignore[arg-type]


def dependents_off_with_their_switch(data: dict[str, Any], overrides: list[str] | tuple[str, ...]
                                     ) -> dict[str, Any]:
    """``data`` (an experiment file) without the dependent keys of a switch that a ``--set`` turns
    off (a sweep over the estimator, or a preset's Monte-Carlo weighting): they go with the switch
    they belong to. One also given by ``--set`` is kept, and so still refused."""
    given = {tuple(path): value for path, value in map(parse_override, overrides)}
    result = data
    for switch in (*SWITCHES, *SELF_CHECKED_SWITCHES):
        place = (switch.section, switch.key)
        if place not in given or not same_as_default(given[place], switch.off):
            continue
        section = result.get(switch.section)
        if not isinstance(section, dict):
            continue
        kept = {key: value for key, value in section.items()
                if key not in switch.dependents or (switch.section, key) in given}
        result = {**result, switch.section: kept}
    return result
