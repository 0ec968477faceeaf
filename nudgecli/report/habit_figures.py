"""The one rule of a habit's figure given by a user (a habits table's median or quartile, a
``--compare`` reference's median or people range): a finite, non-negative number, at most 1 for a
share, in the unit ``nudge habits`` measures the habit in. Read by ``nudge fit-people``'s habits
table (:mod:`nudgecli.report.twin_sources`) and ``nudge habits --compare``
(:func:`nudgecli.report.habits.load_reference`)."""

from __future__ import annotations

import math

from nudgecli.errors import DataError


def figure(value: object) -> float:
    """``value`` as a float; NaN where it is none (text, empty, ``None``)."""
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return math.nan


def checked_figure(where: str, habit: str, name: str, given: object, unit: str) -> float:
    """A habit's figure: a finite, non-negative number, at most 1 for a share (NaN: a figure left
    empty, other than a ``median``); a :class:`DataError` naming it otherwise.

    Parameters
    ----------
    where
        The file (and participant) the figure is in, as the message names it.
    habit
        The habit's key.
    name
        The figure's name (``median``, ``q25``, ``people min``).
    given
        The figure as written.
    unit
        The habit's unit: ``share`` or ``s``.
    """
    value = figure(given)
    text = str(given).strip()
    if math.isnan(value):
        if name == "median":
            raise DataError(f"{where}: {habit}: the median is not a number ({text or 'empty'})")
        if text.lower() not in ("", "nan"):
            raise DataError(f"{where}: {habit}: {name} {text!r} is not a number; give seconds, or leave it "
                            "empty")
        return value
    if math.isinf(value):
        raise DataError(f"{where}: {habit}: the {name} {text} is infinite; give the measured "
                        f"{'share' if unit == 'share' else 'seconds'}")
    if value < 0:
        raise DataError(f"{where}: {habit}: the {name} {value:g} is negative; habits are durations or shares")
    if unit == "share" and value > 1:
        hint = f" (a percent? {value:g} / 100 is {value / 100:g})" if value <= 100 else ""
        raise DataError(f"{where}: {habit}: the {name} {value:g} is above 1, and a share is 0-1{hint}; give "
                        "the share as a fraction")
    return value


def check_unit(where: str, habit: str, given: object, unit: str) -> None:
    """Refuse a ``unit`` other than the habit's own (``unit``; empty or absent: the habit's own):
    milliseconds, say, would be compared as seconds."""
    written = "" if given is None else str(given).strip()
    if written not in ("", "nan", unit):
        raise DataError(f"{where}: {habit}: unit {written!r}; nudge measures it in {unit!r}; give the "
                        f"figures in {unit!r}")


def check_reference_habit(where: str, habit: str, entry: object, unit: str) -> None:
    """Refuse a ``--compare`` reference's habit entry (``nudge habits --format json``'s shape) whose
    ``pooled.median`` or ``people`` range (``[min, max]``, or ``null``: given pooled only) is no
    figure of the habit (:func:`checked_figure`; NaN, a figure not measured, is read as missing),
    whose range is the wrong way round, or whose
    ``unit`` is not the habit's own (:func:`check_unit`)."""
    shape = (f"{where}: habit {habit!r} needs pooled.median and people [min, max] (or null) as numbers, "
             "as `nudge habits --format json` writes them")
    if not isinstance(entry, dict):
        raise DataError(shape)
    pooled, people = entry.get("pooled"), entry.get("people", ...)
    if not isinstance(pooled, dict) or "median" not in pooled or people is ... or \
            (people is not None and not (isinstance(people, list) and len(people) == 2)):
        raise DataError(shape)
    check_unit(where, habit, entry.get("unit"), unit)
    for name, given in [("pooled median", pooled["median"]), *([] if people is None else
                                                               [("people min", people[0]),
                                                                ("people max", people[1])])]:
        if isinstance(given, bool) or not isinstance(given, (int, float)):
            raise DataError(f"{where}: {habit}: the {name} {given!r} is not a number; give it as a number, "
                            "as `nudge habits --format json` writes it")
        if not math.isnan(given):  # NaN: not measured (an older nudge wrote it), compared as missing
            checked_figure(where, habit, name, given, unit)
    if people is not None and people[0] > people[1]:
        raise DataError(f"{where}: {habit}: people [{people[0]:g}, {people[1]:g}] is the wrong way round; "
                        "give the range as [min, max]")
