"""The sweep file's format: its tables as pydantic models, each ``[parameters]`` entry read as a
:class:`Range` or a :class:`Values`, and every refusal that needs the file alone (no experiment):
the format is described in :mod:`nudgecli.runs.sweep` and docs/batches.md."""

from __future__ import annotations

import json
import math
from typing import Any, Literal

from pydantic import Field, ValidationError, model_validator

from nudgecli.config_base import Section
from nudgecli.config_files import as_written, format_validation_error, settable_path
from nudgecli.errors import did_you_mean


class _Model(Section):
    """A sweep file's table: an experiment section's rules (:class:`~nudgecli.config_base.Section`),
    unknown keys refused and values as written: pydantic's lax mode read ``replications = true`` as
    1, ``seed = 11.0`` as 11 and ``low = "0.5"`` as 0.5, which an experiment file refuses."""


class Range(_Model):
    """A continuous (or integer) range to sample."""

    low: float = Field(allow_inf_nan=False)
    high: float = Field(allow_inf_nan=False)
    integer: bool = Field(default=False, strict=True)  # true or false: "yes" and 1 were taken as true

    @model_validator(mode="after")
    def _check(self) -> Range:
        if not self.low < self.high:
            raise ValueError(f"low must be below high, got low={self.low:g}, high={self.high:g}")
        if self.integer and math.ceil(self.low) > math.floor(self.high):
            raise ValueError(f"no integer lies between low={self.low:g} and high={self.high:g}; "
                             "widen the range or drop integer = true")
        return self

    def integers(self) -> tuple[int, int]:
        """An integer range's first and last integer: ``ceil(low)`` and ``floor(high)``."""
        return math.ceil(self.low), math.floor(self.high)


class Values(_Model):
    """An explicit set of values."""

    values: list[Any] = Field(min_length=1)


#: The most grid levels of a Morris design (see :class:`Design`).
MAX_LEVELS = 100
#: The fewest base samples of a Sobol design (see :class:`Design`).
MIN_SOBOL_SAMPLES = 2
#: The fewest trajectories of a Morris design (see :class:`Design`).
MIN_MORRIS_TRAJECTORIES = 2


class Design(_Model):
    """``[design]``."""

    method: Literal["grid", "sobol", "morris"] = "grid"
    samples: int = Field(default=8, ge=1, le=100_000)
    levels: int = Field(default=4, ge=2, le=MAX_LEVELS)
    seed: int = Field(default=0, ge=0)

    @model_validator(mode="after")
    def _even_levels(self) -> Design:
        # SALib's Morris sampler wants even levels (SALib/SALib, src/SALib/sample/morris/morris.py,
        # ``sample``: "num_levels ... (should be even)"; ``_check_if_num_levels_is_even`` only warns
        # "sample may be biased"): its start points are int(L / 2) evenly spaced points of
        # [0, 1 - delta], delta = L / (2 (L - 1)), on the k / (L - 1) grid for even L only
        if self.method == "morris" and self.levels % 2:
            raise ValueError(f"levels: Morris needs an even number of levels (SALib's grid k / (levels - 1) "
                             f"holds for even levels only), got {self.levels}; use {self.levels - 1} or "
                             f"{self.levels + 1}")
        # SALib samples and analyses N = 1 (it asks for no least N), but its confidence intervals
        # bootstrap the N base samples: one resampled is always itself, and every conf came out 0
        if self.method == "sobol" and self.samples < MIN_SOBOL_SAMPLES:
            raise ValueError(f"samples: a Sobol design needs at least {MIN_SOBOL_SAMPLES} base samples (the "
                             f"intervals of its indices resample them), got {self.samples}; use a power "
                             "of 2: 4, 8 or 16")
        # SALib's Morris analysis takes sigma as the standard deviation of each elementary effect over
        # the trajectories (SALib/SALib, src/SALib/analyze/morris.py: np.std(..., ddof=1)), NaN for
        # one, and its mu_star intervals resample the trajectories: one resampled is always itself
        if self.method == "morris" and self.samples < MIN_MORRIS_TRAJECTORIES:
            raise ValueError(f"samples: a Morris design needs at least {MIN_MORRIS_TRAJECTORIES} "
                             "trajectories (sigma is the spread of the elementary effects over them, and "
                             f"the intervals of mu_star resample them), got {self.samples}; use 4 to 10")
        return self


class SweepFile(_Model):
    """A whole sweep file (see the module docstring)."""

    experiment: str
    replications: int = Field(default=4, ge=1, le=100_000)
    seed: int = Field(default=0, ge=0)
    plan: str | None = None
    set: list[str] = Field(default_factory=list)
    design: Design = Field(default_factory=Design)
    parameters: dict[str, Range | Values]

    @model_validator(mode="before")
    @classmethod
    def _shorthand(cls, data: Any) -> Any:
        if isinstance(data, dict) and isinstance(data.get("experiment"), dict):
            raise ValueError("this looks like an experiment file, not a sweep file (it has an [experiment] "
                             "table); a sweep file names its experiment, e.g. experiment = \"smoke\", and "
                             "has [design] and [parameters] (docs/batches.md)")
        if isinstance(data, dict) and not isinstance(data.get("set", []), list | str):  # a str: [str]'s
            given = data["set"]  # a table of the --set values is spelled as they are, else an example
            texts = [f"{key}={json.dumps(value, default=str)}" for key, value in given.items()] \
                if isinstance(given, dict) and given else ["study.participants=2"]
            raise ValueError(f"set: should be a list of --set values, e.g. set = {json.dumps(texts)} (got "
                             f"{'a table' if isinstance(given, dict) else json.dumps(given, default=str)})")
        if isinstance(data, dict) and isinstance(data.get("parameters"), dict):
            data = dict(data)
            data["parameters"] = {k: parameter(k, v) for k, v in data["parameters"].items()}
        return data

    @model_validator(mode="after")
    def _check(self) -> SweepFile:
        if not self.parameters:
            raise ValueError("name at least one parameter under [parameters]")
        for key in self.parameters:  # any key --set takes (one rule: config_files.settable_path)
            if settable_path(key) is None:
                raise ValueError(f"parameter {key!r}: write it as section.key (any key --set takes), e.g. "
                                 "inference.kappa or policies.NAME.params.KEY")
        swept = [set_key(key) for key in self.parameters]
        fixed = [set_key(entry) for entry in self.set]
        if SEED_KEY in swept or SEED_KEY in fixed:
            where = "under [parameters]" if SEED_KEY in swept else "in set"
            raise ValueError(f"{SEED_KEY} {where}: a sweep does not use the experiment's seed; every point "
                             "runs the same replication seeds, drawn from the sweep file's seed (seed = "
                             f"{self.seed}) or --seed; for more independent seeds raise replications")
        both = [key for key in fixed if key in swept]
        if both:
            raise ValueError(f"{both[0]} is both in set and under [parameters]; keep it in one place: set "
                             "fixes a key at every point, [parameters] varies it")
        # the points' parameters come after the set: a swept table would replace a key set inside it
        inside = [(key, table) for key in fixed for table in swept if key.startswith(table + ".")]
        if inside:
            key, table = inside[0]
            raise ValueError(f"{key} in set lies inside {table}, which [parameters] sets whole at every "
                             f"point, so the set's value would be dropped; give "
                             f"{key.removeprefix(table + '.')} in each of {table}'s values instead")
        if self.design.method == "grid":
            ranges = [k for k, v in self.parameters.items() if isinstance(v, Range)]
            if ranges:
                raise ValueError(f"a grid needs values, not ranges ({', '.join(ranges)}); list the values "
                                 "or use method = \"sobol\" or \"morris\"")
        if self.design.method == "morris":
            for key, value in self.parameters.items():
                if isinstance(value, Values):
                    _refuse_values_morris_skips(key, len(value.values), self.design.levels)
        return self


def morris_choice(level: int, levels: int, count: int) -> int:
    """The choice (counting from 0) of ``count`` values or integers that Morris grid level ``level``
    of ``levels`` takes: ``floor(u count)`` at ``u = level / (levels - 1)``, the top level the last,
    computed in integers (SALib's float level, 4 as 3.9999999999999996, would floor one too low)."""
    return min(level * count // (levels - 1), count - 1)


def _refuse_values_morris_skips(key: str, count: int, levels: int) -> None:
    """Refuse a set of ``count`` values that a Morris design of ``levels`` levels never samples
    whole: its points lie on ``levels`` grid levels, each taking one value (:func:`morris_choice`),
    so a set of more values than levels always leaves some out (and one of at most ``levels``
    values none: the choice moves by at most one value a level)."""
    if count <= levels:
        return
    skipped = count - levels
    enough = count + count % 2  # the levels must be even (Design)
    fix = (f"set levels = {enough} (even, and no fewer than the {count} values)" if
           enough <= MAX_LEVELS else "use method = \"sobol\"")
    raise ValueError(f"parameters.{key}: a Morris design with levels = {levels} takes one value of a set "
                     f"per grid level, so {skipped} of this set's {count} values would never run; {fix}, "
                     f"or give at most {levels} values")


#: The experiment key a sweep refuses: the replications' seeds come from the sweep's own seed.
SEED_KEY = "experiment.seed"


def set_key(entry: str) -> str:
    """The key of a ``set`` entry or a parameter as ``--set`` reads it: ``"inference.kappa = 0.3"``
    and ``"inference . kappa"`` -> ``"inference.kappa"`` (empty when it names no settable key)."""
    return ".".join(settable_path(entry.partition("=")[0]) or [])


#: The keys of a ``[parameters]`` entry's table: a set of values, or a range.
PARAMETER_KEYS = ("values", "low", "high", "integer")


def _fits(key: str, value: Any) -> bool:
    """Whether ``value`` is of the kind the parameter table's ``key`` takes."""
    if key == "values":
        return isinstance(value, list)
    if key == "integer":
        return isinstance(value, bool)
    return isinstance(value, int | float) and not isinstance(value, bool)


def _refuse_unknown_keys(where: str, key: str, written: dict[str, Any]) -> None:
    """A :class:`ValueError` for a key of a parameter's table that is none of :data:`PARAMETER_KEYS`,
    before the table is taken for a range (which said "a range needs low and high" of ``hgh`` or
    ``value``): a near miss with its did-you-mean, and a table of tables or lists (TOML's reading of
    an unquoted dotted key, ``disambiguation.window = [3, 5]``) with the quotes it needs."""
    unknown = [name for name in written if name not in PARAMETER_KEYS]
    if not unknown:
        return
    known = written.keys() & set(PARAMETER_KEYS)
    for name in unknown:
        hint = did_you_mean(name, PARAMETER_KEYS)
        meant = next((k for k in PARAMETER_KEYS if f"{k!r}" in hint), "")
        if hint and (known or _fits(meant, written[name])):
            raise ValueError(f"{where}: unknown key {name!r}{hint}; a parameter is a list of values, "
                             "{ values = [...] } or { low = ..., high = ... }")
    if not known and all(isinstance(value, dict | list) for value in written.values()):
        path, value = [key, unknown[0]], written[unknown[0]]
        while isinstance(value, dict) and value and not value.keys() & set(PARAMETER_KEYS):
            inner = next(iter(value))
            path, value = [*path, inner], value[inner]
        raise ValueError(f"{where}: a table of {', '.join(repr(n) for n in unknown)}, not a parameter; a "
                         f"dotted key must be quoted, e.g. \"{'.'.join(path)}\" = {as_written(value)}")
    raise ValueError(f"{where}: unknown key {unknown[0]!r}; a parameter's table holds values, or low and "
                     "high (integer optional)")


def parameter(key: str, written: Any) -> Any:
    """One ``[parameters]`` entry as written -> a :class:`Values` or :class:`Range`.

    A list is a set of values, a table with ``values`` too, a table with ``low`` and ``high`` a
    range. Checked here, one entry at a time, so that a mistake is named by its key in words
    (validating the union would report pydantic's attempts at both types).

    Raises
    ------
    ValueError
        ``parameters.<key>: ...`` with the fix.
    """
    if isinstance(written, Range | Values):
        return written
    where = f"parameters.{key}"
    if isinstance(written, list):
        written = {"values": written}
    if not isinstance(written, dict):
        raise ValueError(f"{where}: give a list of values, e.g. [0.6, 0.7], or a range, e.g. "
                         f"{{ low = 0.5, high = 0.8 }} (got {as_written(written)})")
    _refuse_unknown_keys(where, key, written)
    if "values" in written and {"low", "high", "integer"} & written.keys():
        raise ValueError(f"{where}: give either values or low and high, not both")
    if "values" in written and isinstance(written["values"], list) and not written["values"]:
        raise ValueError(f"{where}: an empty list; give at least one value, e.g. [0.6, 0.7]")
    if "values" in written and isinstance(written["values"], list):  # a value twice weighs it twice
        seen = [json.dumps(v, sort_keys=True, default=str) for v in written["values"]]
        twice = [i for i in range(len(seen)) if seen[i] in seen[:i]]
        if twice:
            raise ValueError(f"{where}: {as_written(written['values'][twice[0]])} is given twice; give "
                             "each value once")
    model: type[Range] | type[Values] = Values if "values" in written else Range
    missing = [bound for bound in ("low", "high") if bound not in written]
    if model is Range and missing:
        raise ValueError(f"{where}: a range needs low and high, e.g. {{ low = 0.5, high = 0.8 }} (missing: "
                         f"{' and '.join(missing)}), or a list of values")
    try:
        return model.model_validate(written)
    except ValidationError as exc:
        raise ValueError(format_validation_error(exc, where, model)) from None
