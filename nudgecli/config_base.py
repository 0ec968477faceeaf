"""The building blocks of the experiment's sections (:mod:`nudgecli.config`): the section base,
the value types and the range check their validators share."""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field

PositiveFloat = Annotated[float, Field(gt=0)]
Probability = Annotated[float, Field(ge=0, le=1)]


class Section(BaseModel):
    """Base of every section: unknown keys are errors, values are validated on assignment."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True, frozen=True)


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
