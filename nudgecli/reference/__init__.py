"""Real people's published numbers, shipped with the package and read by ``sim`` and ``report``.

``ciaa_people.json`` is the table of ``shared/data/ciaa-task/HABITS.md``: the operating habits of
the sibling CIAA study's ten sip-and-puff users, per habit the pooled median and quartiles and the
range of the ten people's own medians (``people``, null where HABITS.md gives a pooled share only),
plus the ranges HABITS.md states only in words (``stated``). It is the one owner of those numbers:
the population's timing ranges (:mod:`nudgecli.sim.habit_ranges`) and ``nudge habits --compare
ciaa-people`` both read it, and a test checks it against HABITS.md.
"""

from __future__ import annotations

import json
from functools import cache
from importlib import resources
from typing import Any

#: Packaged references by the name ``--compare`` takes.
PACKAGED_REFERENCES = {"ciaa-people": "ciaa_people.json"}


@cache
def packaged_reference(name: str) -> dict[str, Any]:
    """A packaged reference (a key of :data:`PACKAGED_REFERENCES`), read once per process.

    Returns
    -------
    dict
        ``name``, ``source``, ``participants``, ``habits`` (habit -> ``label``, ``unit``,
        ``definition``, ``pooled`` with ``median`` and, where given, ``q25``/``q75``, ``people``
        as ``[lo, hi]``) and ``stated`` (habit -> ``label``, ``unit``, ``text``, ``people``).
    """
    text = resources.files(__name__).joinpath(PACKAGED_REFERENCES[name]).read_text(encoding="utf-8")
    data: dict[str, Any] = json.loads(text)
    return data


def people_ranges(name: str = "ciaa-people") -> dict[str, tuple[float, float]]:
    """Habit -> the range of the real people's own medians, from the table and the stated words
    (a habit given pooled only, ``people`` null, has none)."""
    data = packaged_reference(name)
    entries = {**data["habits"], **data.get("stated", {})}
    return {habit: (float(entry["people"][0]), float(entry["people"][1])) for habit, entry in entries.items()
            if entry.get("people") is not None}
