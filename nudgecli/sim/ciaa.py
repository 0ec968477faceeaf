"""The CIAA study's design: its 36 layouts and the order each subject ran them.

The task specification is ``layouts.json`` of the sibling study's task data (written for
re-implementation from the study's trial definition files and per-subject block orders); a copy
ships inside the package as ``nudgecli/sim/data/ciaa_layouts.json``. The layouts are rebuilt here
from each entry's trial definition (start, goal, turns, first-leg axis, start mode, turn
location, goal heading) with TASK.md section 3; the tests check them against the file's waypoints,
segments and optimal command plans.

Participant ``i`` runs the trials of the chosen conditions in the order subject
``sorted(subject_blocks)[i mod 10]`` ran them (blocks by ``session_position``, trials in their
block's order), so ten participants reproduce the ten subjects' orders.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from nudgecli.errors import ConfigError
from nudgecli.model.path_world import MODE_LETTERS, PathLayout, build_waypoints

#: The packaged task specification (a copy of the task data's ``layouts.json``).
LAYOUTS_RESOURCE = "ciaa_layouts.json"


@dataclass(frozen=True)
class CIAATrial:
    """One trial of a subject's session: its block (0-based, in session order) and layout index."""

    block: int
    layout_index: int
    condition: str


def load_task(path: str | Path | None = None) -> dict[str, Any]:
    """The task specification: the packaged copy of ``layouts.json``, or the file at ``path``."""
    try:
        if path is None:
            packaged = resources.files("nudgecli.sim").joinpath("data", LAYOUTS_RESOURCE)
            text = packaged.read_text(encoding="utf-8")
        else:
            text = Path(path).read_text(encoding="utf-8")
        data: dict[str, Any] = json.loads(text)
    except (OSError, json.JSONDecodeError) as exc:
        raise ConfigError(f"{path or LAYOUTS_RESOURCE}: cannot read the CIAA task file ({exc})") from exc
    for key in ("layouts", "subject_blocks"):
        if key not in data:
            raise ConfigError(f"{path or LAYOUTS_RESOURCE}: no {key!r} in the CIAA task file")
    return data


@cache
def packaged_task() -> dict[str, Any]:
    """The packaged task specification, read once per process."""
    return load_task()


def layout_from_entry(entry: dict[str, Any]) -> PathLayout:
    """A :class:`PathLayout` from one ``layouts.json`` entry's trial definition."""
    start = (float(entry["start_pose"]["x"]), float(entry["start_pose"]["y"]))
    goal = (float(entry["goal_pose"]["x"]), float(entry["goal_pose"]["y"]))
    first_axis = {"X": 0, "Y": 1}[str(entry["start_direction"]).upper()]
    waypoints = build_waypoints(start, goal, int(entry["num_turns"]), first_axis)
    legs = np.diff(waypoints, axis=0)
    modes = tuple(int(np.flatnonzero(leg)[0]) for leg in legs)
    directions = tuple(int(np.sign(leg[m])) for leg, m in zip(legs, modes, strict=True))
    index = entry["trial_index"]
    return PathLayout(
        index=int(index) if isinstance(index, int) else -1,
        condition=str(entry["condition"]),
        waypoints=waypoints,
        leg_modes=modes,
        leg_directions=directions,
        turn_waypoint=int(entry["location_of_turn"]),
        goal_theta=float(entry["goal_pose"]["theta"]) % (2.0 * math.pi),
        start_mode=MODE_LETTERS.index(str(entry["start_mode"])),
    )


def task_layouts(task: dict[str, Any]) -> dict[int, PathLayout]:
    """Trial index -> layout, for every layout of the task."""
    return {int(entry["trial_index"]): layout_from_entry(entry) for entry in task["layouts"]}


def subject_schedule(task: dict[str, Any], participant: int, conditions: tuple[str, ...]) -> list[CIAATrial]:
    """Participant ``participant``'s trials of ``conditions``, in the order their subject ran them.

    Parameters
    ----------
    task
        The task specification.
    participant
        0-based participant index; it follows subject ``sorted(subject_blocks)[participant mod n]``.
    conditions
        The study's condition names (``no_assistance``, ``filter_assistance``,
        ``corrective_assistance``) whose blocks are run.
    """
    subjects = sorted(task["subject_blocks"])
    blocks = task["subject_blocks"][subjects[participant % len(subjects)]]
    ordered = sorted(blocks.items(), key=lambda item: int(item[1]["session_position"]))
    trials: list[CIAATrial] = []
    block_number = 0
    for name, block in ordered:
        condition = name.rsplit("_", 1)[0]
        if condition not in conditions:
            continue
        trials.extend(CIAATrial(block_number, int(k), condition) for k in block["trial_indices_in_order"])
        block_number += 1
    return trials
