"""``[policies.NAME]``: a condition that runs a researcher's own policy (docs/policies.md): its
factory named ``module:attribute`` and its parameters: finite numbers, text, true/false and lists
or tables of them, which JSON holds unchanged (no dates or times)."""

from __future__ import annotations

import datetime
import math
import re
from collections.abc import Iterator
from typing import Any

from pydantic import Field, field_validator

from nudgecli.config_base import Section
from nudgecli.config_files import toml_value


class CustomPolicySection(Section):
    """``[policies.NAME]``: a condition ``NAME`` that runs a researcher's own policy.

    ``factory`` names it as ``module:attribute`` (the module is imported from the experiment file's
    folder, then from ``sys.path``); the attribute is called with ``params`` as keyword arguments
    once per trial and returns an object with the policy interface
    (``nudgecli.sim.policy_interface.Policy``; docs/policies.md).
    """

    factory: str
    params: dict[str, Any] = Field(default_factory=dict)

    @field_validator("factory")
    @classmethod
    def _module_and_attribute(cls, factory: str) -> str:
        if _FACTORY.fullmatch(factory):
            return factory
        # the likeliest meaning of what was written: a path, a .py name or a dotted name
        module, _, name = factory.replace("/", ".").removesuffix(".py").rpartition(":")
        if not module and "." in name:
            module, _, name = name.rpartition(".")
        guess = f"{module.removesuffix('.py')}:{name}"
        example = guess if _FACTORY.fullmatch(guess) else "mypolicies:Mine"
        raise ValueError(f"{factory!r} does not name a policy as module:attribute (the module's dotted "
                         f"import name, a colon, the class or function); e.g. {example!r}")

    @field_validator("params")
    @classmethod
    def _finite_numbers(cls, params: dict[str, Any]) -> dict[str, Any]:
        # a run folder records them in config.toml and manifest.json, whose JSON has no nan or inf,
        # nor dates or times: recorded, a date became its text, and that config.toml did not rerun
        # or resume the run (the policy given "2026-01-31" where it was given a date)
        for name, value in params.items():
            leaves = list(_leaves(value))  # one walk of the value's lists and tables for both checks
            if any(isinstance(leaf, datetime.date | datetime.time) for leaf in leaves):  # a datetime: a date
                raise ValueError(f"{name} = {_toml_text(value)}: give text in quotes, not a date or time, "
                                 f"e.g. {name} = {_toml_text(value, dates_quoted=True)} (the run folder "
                                 "records a policy's parameters as JSON, which has no dates or times; the "
                                 "policy reads the text)")
            if not all(math.isfinite(leaf) for leaf in leaves if isinstance(leaf, float)):
                raise ValueError(f"{name} = {value}: a policy's parameters are finite numbers (the run "
                                 "folder records them as JSON, which has no nan or inf); give a number")
        return params


#: A policy's factory: ``module:attribute``, the module's dotted import name.
_FACTORY = re.compile(r"[A-Za-z_][\w.]*:[A-Za-z_][\w.]*")


def _leaves(value: Any) -> Iterator[Any]:
    """The values of a TOML value that are no list or table: itself, or those its lists and tables
    hold, at any depth."""
    if isinstance(value, list | tuple):
        for item in value:
            yield from _leaves(item)
    elif isinstance(value, dict):
        for item in value.values():
            yield from _leaves(item)
    else:
        yield value


def _toml_text(value: Any, *, dates_quoted: bool = False) -> str:
    """A parameter's value as TOML writes it (a date ``2026-01-31``, text in quotes:
    :func:`~nudgecli.config_files.toml_value`), for a message; ``dates_quoted``: its dates and times
    as text (``"2026-01-31"``), what to write instead."""
    return toml_value(_dates_as_text(value) if dates_quoted else value)


def _dates_as_text(value: Any) -> Any:
    """A TOML value with its dates and times (in its lists and tables too) as their ISO text."""
    if isinstance(value, datetime.date | datetime.time):
        return value.isoformat()
    if isinstance(value, list | tuple):
        return [_dates_as_text(item) for item in value]
    if isinstance(value, dict):
        return {key: _dates_as_text(item) for key, item in value.items()}
    return value
