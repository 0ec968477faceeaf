"""``[world]``: which world the trials run in, the CIAA path world's constants, and the one rule of
which keys each world reads (:func:`check_world_keys`): a key the chosen world does not read is an
error where it is given, never a setting silently ignored."""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any, Literal

from pydantic import field_validator, model_validator

from nudgecli.config_base import PositiveFloat, Section, plain
from nudgecli.config_people import PERSON_PLAN_KEYS
from nudgecli.model.path_world import (
    HEADING_TOLERANCE,
    ROTATION,
    SHORTEST_LEG,
    SNAP_TOLERANCE,
    SUCCESS_DISTANCE,
)


class WorldSection(Section):
    """``[world]``: which world the trials run in, and the CIAA path world's constants.

    - ``kind``: ``grid`` is the paper's open workspace with its 10 x 10 x 8 x 3 grid (DESIGN.md
      section 2.1; the ``[study]`` design of layouts, goals and blocks); ``ciaa`` is the
      path-constrained teleoperation task of the sibling CIAA study (2020, "Customized Handling
      of Unintended Interface Operation in Assistive Robots"; its ``TASK.md`` and
      ``layouts.json``): one known goal, waypoints, one allowed mode and direction per leg, the
      rotation at the turn waypoint only. In ``ciaa`` the layouts, their order and the
      conditions come from the task file's ``subject_blocks`` (participant ``i`` runs as subject
      ``i mod 10`` did), and ``[study]`` keeps ``participants``, ``rate_hz`` and ``time_limit_s``
      (the study's 50 s): the keys of :data:`GRID_ONLY` are refused there unless at their defaults,
      and so are the agent's (:data:`AGENT_SECTIONS` but :data:`CIAA_AGENT_KEYS_READ`): its
      ``no_assistance`` infers no goal, disambiguates nothing and never assists.

    The keys below apply to ``ciaa`` only (:data:`CIAA_ONLY`: refused in ``grid`` unless at their
    defaults); their defaults are TASK.md's values:

    - ``ciaa_conditions``: the study's conditions whose blocks are run. Only ``no_assistance``
      (no inference, no blending, no autonomy) is implemented: 12 trials per participant. The
      study's ``filter_assistance`` and ``corrective_assistance`` (TASK.md section 9) are not
      simulated, and are refused naming them.
    - ``linear_speed`` / ``angular_speed``: full speed of a soft command in wall-clock time,
      1.6 units/s and 0.64 rad/s (TASK.md section 6: 3.9 units and 1.56 rad per simulated second,
      with the simulator's loop running at about 41 steps of 0.01 s per wall-clock second).
      They replace ``[interface]`` ``human_speed`` / ``human_turn_rate`` in this world.
    - ``snap_tolerance``: the robot snaps onto the next waypoint within 0.1 units on both axes,
      below half the shortest leg (2.5 units: a larger snap skips half a leg or more, above 5 a
      whole leg with no input); ``heading_tolerance``: onto the goal heading within 0.1 rad,
      below half the pi/2 turn (pi/4: above pi/2 the start heading snaps, the turn done with no
      input) (section 4).
    - ``success_distance``: the study's analysis rule, a final Manhattan distance to the goal of
      at most 0.1 (section 7). It is no setting here: a trial succeeds when the robot reaches the
      goal waypoint within ``study.time_limit_s``, and the goal snap puts it exactly on the goal,
      so no other distance would change a trial. Any value but 0.1 is refused; the key stays
      because every run folder's ``config.toml`` writes it.
    """

    kind: Literal["grid", "ciaa"] = "grid"
    ciaa_conditions: tuple[Literal["no_assistance"], ...] = ("no_assistance",)
    linear_speed: PositiveFloat = 1.6
    angular_speed: PositiveFloat = 0.64
    snap_tolerance: PositiveFloat = SNAP_TOLERANCE  # TASK.md's (nudgecli.model.path_world)
    heading_tolerance: PositiveFloat = HEADING_TOLERANCE
    success_distance: PositiveFloat = SUCCESS_DISTANCE

    @field_validator("ciaa_conditions", mode="before")
    @classmethod
    def _unsimulated_conditions(cls, value: Any) -> Any:
        # the sibling study's assistance conditions are real names, not typos: "did you mean
        # 'no_assistance'?" misled. Only a string can name one: a list or a table is no key of the
        # dict (unhashable), and pydantic's literal check names it
        for name in value if isinstance(value, list | tuple) else ():
            if isinstance(name, str) and name in UNSIMULATED_CONDITIONS:
                raise ValueError(
                    f"{json.dumps(name)} is the sibling study's "
                    f"{UNSIMULATED_CONDITIONS[name]} (TASK.md section 9), which is not simulated; "
                    'only "no_assistance" is: use ciaa_conditions = ["no_assistance"]')
        return value

    @model_validator(mode="after")
    def _check(self) -> WorldSection:
        if not self.ciaa_conditions or len(set(self.ciaa_conditions)) != len(self.ciaa_conditions):
            raise ValueError("ciaa_conditions must be a non-empty list without repeats")
        if self.snap_tolerance >= SHORTEST_LEG / 2:
            raise ValueError(
                f"snap_tolerance: {self.snap_tolerance:g} units is half the shortest leg ({SHORTEST_LEG:g}) "
                f"or more: a snap that large skips half a leg or more (above {SHORTEST_LEG:g}, a whole leg "
                f"with no input); give less than {SHORTEST_LEG / 2:g} (TASK.md's is {SNAP_TOLERANCE:g})")
        if self.heading_tolerance >= ROTATION / 2:
            raise ValueError(
                f"heading_tolerance: {self.heading_tolerance:g} rad is half the pi/2 turn or more: a snap "
                "that large skips half the turn or more (above pi/2, the start heading snaps onto the "
                f"goal's, the turn done with no input); give less than pi/4 = {ROTATION / 2:.4f} (TASK.md's "
                f"is {HEADING_TOLERANCE:g})")
        if self.success_distance != SUCCESS_DISTANCE:
            raise ValueError(
                f"success_distance: {self.success_distance:g} changes nothing: success is reaching the goal "
                "waypoint, which the goal snap makes exact (distance 0); remove it (only TASK.md's "
                f"{SUCCESS_DISTANCE:g} is taken, which a run folder's config.toml writes)")
        return self


#: The sibling study's conditions that are not simulated (TASK.md section 9), with what they are.
UNSIMULATED_CONDITIONS = {"filter_assistance": "filter assistance",
                          "corrective_assistance": "corrective assistance"}


_NO_ASSISTANCE = "no blending or autonomy turn for the person to answer"
#: What the CIAA world's success is instead of a distance or an angle (a snap makes it exact).
_GOAL_WAYPOINT = "reaching the goal waypoint (its snap puts the robot exactly on the goal pose)"
_SCHEDULE = 'world.ciaa_conditions (["no_assistance"]) in the task\'s subject blocks'
#: The keys the CIAA path world does not read, each with what that world runs instead.
_DESIGN = ("conditions", "counterbalancing", "shared_layouts", "goal_counts", "corners", "start_modes",
           "blocks_per_condition")
GRID_ONLY: dict[str, str] = {
    **{f"study.{key}": _SCHEDULE for key in _DESIGN},
    "study.success_distance": _GOAL_WAYPOINT, "study.success_angle": _GOAL_WAYPOINT,
    "interface.human_speed": "world.linear_speed", "interface.human_turn_rate": "world.angular_speed",
    # the person's fine positioning is inside the goal's grid cell, which a path has none of (its
    # trials pass no goal cell): they follow the waypoints to the goal waypoint
    **{f"behaviour.{key}": _GOAL_WAYPOINT for key in ("fine_position_tolerance", "fine_heading_tolerance")},
    # what a person does about blending or the autonomy's turn: no_assistance has neither
    **{f"behaviour.{key}": _NO_ASSISTANCE for key in ("lean_on_blending", "release_when_dragged",
                                                      "after_autonomy")},
    # the person's own task costs, which solve their goal MDPs in the grid: a path has one plan
    **{f"behaviour.{key}": "the path's one command plan (its legs, no costs to weigh)"
       for key in PERSON_PLAN_KEYS},
}
#: The condition sections (``None`` unless given), which a CIAA run never reads.
CONDITION_TABLES = ("blending", "mode-switch", "mode_switch", "hindsight", "policies")
#: The agent's sections. The CIAA world's ``no_assistance`` infers no goal, disambiguates nothing and
#: never assists, so it reads none of their keys but :data:`CIAA_AGENT_KEYS_READ`.
AGENT_SECTIONS = ("model", "inference", "disambiguation", "assistance")
#: The agent's keys a CIAA run reads all the same, as the grid world does: which tables the agent
#: holds of each participant (fitted from a simulated calibration, whose logs the run folder keeps,
#: or the defaults with this noise), recorded in ``participants.parquet``
#: (:func:`nudgecli.sim.study.agent_tables`). The simulated person reads no ``[model]`` key in either
#: world: their epsilon is their own (``[population]``), and so, in the grid, are their plan's costs
#: (``[behaviour]`` ``plan_*``).
CIAA_AGENT_KEYS_READ = ("model.tables", "model.default_table_noise")
_NO_AGENT = "no goal inference, disambiguation or assistance"
#: The keys the grid world does not read, each with what that world does instead.
CIAA_ONLY: dict[str, str] = {
    "world.ciaa_conditions": "runs study.conditions",
    "world.linear_speed": "reads interface.human_speed",
    "world.angular_speed": "reads interface.human_turn_rate",
    "world.snap_tolerance": "has no waypoints to snap onto",
    "world.heading_tolerance": "reads study.success_angle",
    "world.success_distance": "reads study.success_distance",
}


def ciaa_ignored(sections: Mapping[str, Any]) -> dict[str, str]:
    """The keys the CIAA path world does not read, each with what it runs instead: :data:`GRID_ONLY`
    and the keys of :data:`AGENT_SECTIONS` (``sections``: their classes by name) but
    :data:`CIAA_AGENT_KEYS_READ`."""
    agent = {f"{name}.{key}": _NO_AGENT for name in AGENT_SECTIONS for key in sections[name].model_fields
             if f"{name}.{key}" not in CIAA_AGENT_KEYS_READ}
    return {**GRID_ONLY, **agent}


def check_world_keys(data: Mapping[str, Any], sections: Mapping[str, Any]) -> None:
    """Raise ``ValueError`` (one line) where an experiment's raw ``data`` gives a key its world
    (``world.kind``) does not read a value other than its default, or, in the CIAA world, a
    condition's section. ``sections``: the section classes by name (``study``, ``interface``,
    ``world`` and :data:`AGENT_SECTIONS`), whose defaults are compared.

    A value at its default passes: a run folder's ``config.toml`` writes every key (the run's
    before this rule too), and the default changes nothing the world does.
    """
    kind = _given(data.get("world"), "kind", "grid")
    if kind not in ("grid", "ciaa"):
        return  # pydantic names the kind
    ignored = ciaa_ignored(sections) if kind == "ciaa" else CIAA_ONLY
    found = [f"[{name}]" for name in CONDITION_TABLES if kind == "ciaa" and data.get(name) is not None]
    for dotted in ignored:
        section_name, key = dotted.split(".")
        default = sections[section_name].model_fields[key].default
        value = _given(data.get(section_name), key, default)
        if not same_as_default(value, default):
            found.append(f"{dotted} = {json.dumps(plain(value))}")
    if not found:
        return
    them = "it" if len(found) == 1 else "them"
    keys = [item.split(" = ")[0] for item in found]
    if kind == "grid":
        does = "; ".join(f"for {key} it {ignored[key]}" for key in keys)
        raise ValueError(f"{', '.join(found)}: the grid world (world.kind = \"grid\") does not read {them} "
                         f"({does}); remove {them}, or set world.kind = \"ciaa\" for the CIAA path "
                         "world (docs/people.md)")
    reads = "".join(f", and {ignored[key]} in place of {key}" for key in keys
                    if ignored.get(key, _SCHEDULE) not in (_SCHEDULE, _NO_AGENT, _NO_ASSISTANCE))
    answered = [key for key in keys if ignored.get(key) == _NO_ASSISTANCE]
    if answered:
        reads += f", with {_NO_ASSISTANCE} ({', '.join(answered)})"
    if any(ignored.get(key) == _NO_AGENT for key in keys):
        model = any(key.startswith("model.") for key in keys)
        reads += f", with {_NO_AGENT}" + (
            " (of [model] it reads tables and default_table_noise only)" if model else "")
    raise ValueError(f"{', '.join(found)}: the ciaa world (world.kind = \"ciaa\") does not read {them} "
                     f"(it runs {_SCHEDULE}{reads}); remove {them}, or set world.kind = \"grid\" for the "
                     "grid world's study (docs/people.md)")


def _given(section: Any, key: str, default: Any) -> Any:
    """The value a raw section (a table, or a section made in Python) gives ``key``, else ``default``."""
    if isinstance(section, Mapping):
        return section.get(key, default)
    return getattr(section, key, default) if isinstance(section, Section) else default


def same_as_default(value: Any, default: Any) -> bool:
    """Whether a raw ``value`` (TOML's lists) is ``default`` (a section's tuples)."""
    if isinstance(default, tuple) and isinstance(value, list | tuple):
        return list(value) == list(default)
    if isinstance(value, bool) or isinstance(default, bool):  # true is no 1, and false is false's default
        return type(value) is type(default) and value == default
    return value == default
