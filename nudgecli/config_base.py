"""The building blocks of the experiment's sections (:mod:`nudgecli.config`): the section base,
the value types and the range check their validators share."""

from __future__ import annotations

import json
from typing import Annotated, Any, Literal, get_args, get_origin

from pydantic import BaseModel, ConfigDict, Field, model_validator

#: The fastest step rate a study or a calibration may simulate, Hz (1 ms steps; the paper's is 10 Hz).
MAX_RATE_HZ = 1000.0
#: The longest trial time limit, s (an hour; the paper's is 120 s), and the longest any one duration of
#: a person or a calibration prompt may be: a longer one is no setting a study means, and inf or 1e300
#: crashed the run (an overflow, or arrays of a negative or astronomical size).
MAX_TIME_LIMIT_S = 3600.0
#: The largest size of an MDP reward (``[model]``, ``[behaviour]`` ``plan_*``): the study's lie in
#: -100..100 (goal 100). Within 1e6 the goal MDPs' values (at most a reward over 1 - gamma) stay far from
#: float overflow, and 10^4 times the study's scale is room for any reward design; -1e308 gave every
#: trial a time-out.
MAX_REWARD = 1e6
#: The most steps (samples) one trial can have: the longest time limit at the fastest rate, 3,600,000;
#: a count of a trial's samples (``[inference]`` ``decay_delay``, ``decay_cap``) is no larger, and 1e30
#: overflowed numpy's integers in the worker.
MAX_TRIAL_STEPS = int(MAX_TIME_LIMIT_S * MAX_RATE_HZ)
#: The largest distance, world units: the grid workspace is 42 x 34 units (diagonal about 54), so 100
#: already holds every pair of its points (the study's success distance is 1, its distance knee 35).
MAX_DISTANCE = 100.0
#: The fastest speed (world units/s) or turn rate (rad/s): at the fastest step rate (1000 Hz) one step
#: still moves at most a unit (a grid cell is 4.2 x 3.4) or turns a radian; the study's are 3 and 5
#: units/s, 1.95 and 1.5 rad/s, and 1e300 ran, writing that command to the step log.
MAX_SPEED = 1000.0

# finite: every float field refuses inf and NaN (Section's allow_inf_nan=False); these types say so too,
# for a field read outside a Section
PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
Probability = Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)]
#: A duration of up to :data:`MAX_TIME_LIMIT_S` seconds, zero allowed.
Seconds = Annotated[float, Field(ge=0, le=MAX_TIME_LIMIT_S, allow_inf_nan=False)]
#: A positive distance of at most :data:`MAX_DISTANCE` world units.
Distance = Annotated[float, Field(gt=0, le=MAX_DISTANCE, allow_inf_nan=False)]
#: A positive speed (units/s) or turn rate (rad/s) of at most :data:`MAX_SPEED`.
Speed = Annotated[float, Field(gt=0, le=MAX_SPEED, allow_inf_nan=False)]
#: An MDP reward: finite, at most :data:`MAX_REWARD` in size.
Reward = Annotated[float, Field(ge=-MAX_REWARD, le=MAX_REWARD, allow_inf_nan=False)]
#: An MDP's discount, in (0, 1).
Discount = Annotated[float, Field(gt=0, lt=1)]


class Section(BaseModel):
    """Base of every section: unknown keys are errors, values are validated on assignment."""

    # defer_build: the validator is built at a section's first validation, not at import; a study's
    # worker receives its config pickled and validates none, its defaults from
    # nudgecli.config.section_defaults (about 25 ms of every start-up)
    # allow_inf_nan=False: inf or NaN is no experiment value; NaN passed every range check and made
    # every trial time out (model.move_reward = nan), inf crashed runs or gave meaningless tables
    model_config = ConfigDict(extra="forbid", validate_assignment=True, frozen=True, defer_build=True,
                              allow_inf_nan=False)

    @model_validator(mode="before")
    @classmethod
    def _numbers_as_written(cls, data: Any) -> Any:
        # pydantic's lax mode converts what a number field is given: true to 1 (`--set
        # study.rate_hz=true` would simulate at 1 Hz), the text "10" to 10 and 2.0 to 2 for a whole
        # number; a file or --set must say the number itself
        if not isinstance(data, dict):
            return data
        for name, value in data.items():
            field = cls.model_fields.get(name)
            if field is None:
                continue
            if get_origin(field.annotation) is dict and isinstance(value, dict):
                # a table of numbers (an analysis plan's [filters]): each entry is a number
                for key, entry in value.items():
                    _check_number_as_written(f"{name}.{key}", get_args(field.annotation)[1], entry)
            else:
                _check_number_as_written(name, field.annotation, value)
                _check_bool_as_written(name, field.annotation, value)
        return data


def _check_bool_as_written(name: str, annotation: Any, value: Any) -> None:
    """Refuse anything but true/false where the field ``name`` of type ``annotation`` takes only a
    boolean: pydantic's lax mode took "yes", "true" and 1 as true (:meth:`Section._numbers_as_written`)."""
    if value is None or isinstance(value, bool) or not admits(annotation, bool):
        return
    if any(admits(annotation, kind) for kind in (int, float, str)):
        return  # a field that takes numbers or text too (none today) checks its own values
    raise ValueError(f"{name} = {json.dumps(plain(value), ensure_ascii=False)}: give true or false "
                     "(no quotes)")


def _check_number_as_written(name: str, annotation: Any, value: Any) -> None:
    """Refuse true/false, text, or a decimal for a whole number where the field ``name`` of type
    ``annotation`` takes a number (:meth:`Section._numbers_as_written`)."""
    if admits(annotation, bool) or not (admits(annotation, float) or admits(annotation, int)):
        return
    items = value if isinstance(value, list | tuple) else (value,)
    if any(isinstance(item, bool) for item in items):
        shown = str(value).lower() if isinstance(value, bool) else "a list with true/false"
        raise ValueError(f"{name} = {shown}: give a number, not true/false")
    # a scalar given for a list is pydantic's to name ("should be a list")
    numbers = () if items is not value and holds_sequence(annotation) else items
    if not admits(annotation, str) and any(isinstance(item, str) for item in numbers):
        shown = json.dumps(value, ensure_ascii=False)
        raise ValueError(f"{name}: give a number, not text: no quotes (got {shown})")
    if not admits(annotation, float) and any(isinstance(item, float) for item in numbers):
        raise ValueError(f"{name}: give a whole number, no decimal point (got {json.dumps(value)})")


def admits(annotation: Any, kind: type) -> bool:
    """Whether a field's type admits values of ``kind`` (the type itself, a literal of such values,
    or a union, container or annotation holding one)."""
    if annotation is kind:
        return True
    if get_origin(annotation) is Literal:
        return any(type(arg) is kind for arg in get_args(annotation))
    return any(admits(arg, kind) for arg in get_args(annotation))


def holds_sequence(annotation: Any) -> bool:
    """Whether a field's type is (or its union holds) a tuple or list."""
    if get_origin(annotation) in (tuple, list):
        return True
    return any(holds_sequence(arg) for arg in get_args(annotation))


def plain(value: Any) -> Any:
    """``value`` with numpy scalars and arrays made plain Python (lists, tuples, dicts recursively),
    so a message shows ``150.0``, not ``np.float64(150.0)``."""
    if isinstance(value, dict):
        return {plain(k): plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return type(value)(plain(v) for v in value)
    if hasattr(value, "tolist") and not isinstance(value, str | bytes):
        return value.tolist()
    return value


def check_range(name: str, value: tuple[float, float], lo: float, hi: float) -> None:
    """Raise ``ValueError`` unless ``lo <= value[0] <= value[1] <= hi``."""
    if not (lo <= value[0] <= value[1] <= hi):
        raise ValueError(f"{name} must be [low, high] with {plain(lo)} <= low <= high <= {plain(hi)}, "
                         f"got {list(plain(tuple(value)))}")
