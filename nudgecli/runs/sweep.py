"""Sweep files: which experiment keys vary, and the design points (grid, Sobol or Morris via SALib).

A sweep file is TOML::

    experiment = "smoke"          # preset or path (relative paths: to the sweep file's folder)
    replications = 4              # studies per design point, the same seeds at every point
    seed = 11                     # master seed of the replications' seeds
    plan = "paper"                # analysis plan (preset or path); default: the plan named
                                  # like the experiment, else its world's, else paper
                                  # (config_files.resolve_plan)
    set = ["study.participants=4"]    # fixed overrides applied at every point (optional)

    [design]
    method = "sobol"              # "grid", "sobol" or "morris"
    samples = 8                   # sobol: base samples N (N (D + 2) points); morris: trajectories
                                  # (both at least 2)
    levels = 4                    # morris: grid levels (even; SALib)
    seed = 0                      # the design's own seed (Sobol scrambling, Morris trajectories)

    [parameters]                  # any key --set takes (section.key, or deeper)
    "inference.kappa" = { low = 0.5, high = 0.8 }            # a range (sobol, morris)
    "study.participants" = { low = 4, high = 9, integer = true }
    "disambiguation.window" = { values = [3, 5] }            # a set of values (any design)
    "model.epsilon" = [0.05, 0.1, 0.2]                       # shorthand for { values = [...] }

A grid takes every combination of the parameters' values (ranges are refused; ``samples`` and
``levels`` unused). Sobol and Morris designs sample the unit hypercube with SALib: a range maps
linearly; a set of ``k`` values is the range ``[0, k]`` and takes the value at the floor (the top
end the last); an integer range is the set of its integers ``ceil(low)..floor(high)``, each with
an equal share, never one outside the bounds. ``experiment.seed`` is refused (the replications'
seeds come from the sweep's ``seed``), and so is a key both in ``set`` and under
``[parameters]``, or in ``set`` inside a table ``[parameters]`` sets whole (which would drop it),
a Morris set of more values than ``levels`` (a level takes one value: some would never run),
and a range without ``integer = true`` over a key that takes whole numbers (named as the fix).
Every point is validated as an experiment before anything runs, and so is every value of a set
and both ends of a range, which a design need not draw.

A parameter's value in the sweep's tables (``sweep.csv``, ``replications.csv``, ``points.csv``) is
its :func:`parameter_cell`: a number, string or boolean as it is, a table or list as compact JSON
with sorted keys (``{"threshold":0.5}``, ``[3,4]``), which ``json.loads`` reads back.
"""

from __future__ import annotations

import itertools
import json
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import ValidationError

from nudgecli.config import ExperimentConfig, load_experiment
from nudgecli.config_files import (
    format_validation_error,
    list_presets,
    preset_dir,
    read_toml,
    resolve_plan,
    resolve_preset,
    toml_value,
)
from nudgecli.errors import ConfigError, PolicyError, did_you_mean
from nudgecli.runs.sweep_file import (  # the format, read from here too
    Design,
    Range,
    SweepFile,
    Values,
    morris_choice,
)
from nudgecli.sim.policy_registry import checked_policy_specs, run_conditions, unused_policy_notes

#: Where the shipped example sweeps live (beside the experiment presets, in their own folder so
#: that ``nudge presets`` does not list them as experiments).
SWEEP_FOLDER = "sweeps"


#: The start of the warning scipy's Sobol' sequence gives for a number of points that is no power of
#: 2 (scipy/stats/_qmc.py, ``Sobol.random``), which SALib's ``sobol.sample`` passes on.
SOBOL_BALANCE_WARNING = "The balance properties of Sobol' points require n to be a power of 2"
@dataclass(frozen=True)
class DesignPoint:
    """One point of a design: its index, the swept values and the experiment they give."""

    index: int
    parameters: dict[str, Any]
    config: ExperimentConfig


@dataclass
class Sweep:
    """A loaded sweep: the file, its design points and (sampled designs) the SALib problem.

    Attributes
    ----------
    source
        The sweep file.
    spec
        Its validated content.
    points
        The design points, in design order.
    experiment_file
        The experiment file it names (a preset's own file, or the file beside it), which the batch
        folder keeps (:func:`nudgecli.runs.batch_folder.sweep_inputs`).
    problem
        SALib's problem (``names``, ``bounds``, ``num_vars``); ``None`` for a grid.
    samples
        ``(n_points, D)`` the design in the problem's units (what SALib's analysers take);
        ``None`` for a grid.
    notes
        What the batch tells once its folder is prepared (:func:`design_notes`).
    """

    source: Path
    spec: SweepFile
    points: list[DesignPoint]
    experiment_file: Path
    problem: dict[str, Any] | None = None
    samples: np.ndarray | None = field(default=None, repr=False)
    notes: tuple[str, ...] = ()

    @property
    def names(self) -> list[str]:
        return list(self.spec.parameters)


def resolve_sweep(name_or_path: str) -> Path:
    """A sweep file path, or the shipped sweep of that name (``experiments/sweeps/NAME.toml``)."""
    candidate = Path(name_or_path)
    if candidate.is_file():
        return candidate
    if candidate.is_dir():
        inside = sorted(p.name for p in candidate.glob("*.toml"))
        raise ConfigError(f"{name_or_path} is a folder, not a sweep file; give a .toml sweep file"
                          + (f" (it holds {', '.join(inside[:5])}{', ...' if len(inside) > 5 else ''})"
                             if inside else ""))
    shipped = preset_dir("experiments") / SWEEP_FOLDER
    names = sorted(p.stem for p in shipped.glob("*.toml")) if shipped.is_dir() else []
    if name_or_path in names:
        return shipped / f"{name_or_path}.toml"
    raise ConfigError(f"sweep file {name_or_path!r} does not exist; give a .toml sweep file"
                      + (f" or one of the shipped sweeps: {', '.join(names)}" if names else ""))


def beside_sweep(path: Path, field: str, written: str, kind: Literal["experiments", "analysis"]) -> str:
    """The sweep file's ``experiment`` or ``plan``: a preset by name, else a file, a relative path
    being to the sweep file's folder (never the current one).

    A bare name (no ``.toml``, no folder) that is both a preset and a file beside the sweep file
    is ambiguous, and refused: neither the preset rule nor the path rule says which was meant.

    Raises
    ------
    ConfigError
        Neither a preset nor a file, or both: names the sweep file, the field and where it looked.
    """
    presets = list_presets(kind)
    looks_like_path = written.endswith(".toml") or "/" in written or "\\" in written
    target = path.parent / Path(written).expanduser()
    if written in presets and not looks_like_path:
        if target.is_file():
            what = "experiment" if kind == "experiments" else "analysis plan"
            raise ConfigError(f"{path}: {field}: {written!r} is both the {what} preset {written} "
                              f"({presets[written]}) and the file {target} beside the sweep file; write "
                              f'"./{written}" for the file, or rename the file to use the preset')
        return written
    if target.is_file():
        return str(target)
    if looks_like_path:
        raise ConfigError(f"{path}: {field}: no file {target} (a relative path is to the sweep file's "
                          "folder)")
    what = "an experiment" if kind == "experiments" else "an analysis plan"
    hint = did_you_mean(written, presets)
    raise ConfigError(f"{path}: {field}: {written!r} is neither {what} preset{hint} nor a file beside the "
                      f"sweep file ({target}); presets: {', '.join(presets)}")


def load_sweep(name_or_path: str) -> Sweep:
    """Read a sweep file, build its design and validate every point's experiment.

    Raises
    ------
    ConfigError
        Syntax, unknown key, bad range, an unknown experiment, or a point whose experiment is
        invalid or whose own policy refuses its parameters (naming the file, the parameter and the
        value).
    """
    path = resolve_sweep(name_or_path)
    data = read_toml(path)  # the one reading of a TOML file: a BOM skipped, a bad byte named
    try:
        spec = SweepFile.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc, str(path), SweepFile)) from None
    experiment = beside_sweep(path, "experiment", spec.experiment, "experiments")
    load_experiment(experiment)  # a bad experiment file fails early, named as itself
    base, set_alone = None, None
    try:
        base = load_experiment(experiment, spec.set)
    except ConfigError as exc:  # it may need a point's parameters (blocks that divide the trials)
        set_alone = ConfigError(f"{path}: set: {str(exc).removeprefix('--set ')}")
    values, problem, samples = design_values(spec)
    try:
        points = _design_points(path, experiment, spec.set, values, set_alone)
    except ConfigError:
        _refuse_real_ranges_on_whole_numbers(path, experiment, spec)  # the fix, where that is the fault
        raise
    _refuse_undrawn_values(path, experiment, spec, points[0].parameters)
    plan = None if spec.plan is None else beside_sweep(path, "plan", spec.plan, "analysis")
    # the plan rule of replicate and power: the plan given, else the one named like the experiment
    # (as the set names it; where the set needs the parameters, as the first point does)
    named = (base if base is not None else points[0].config)
    spec = spec.model_copy(update={"plan": resolve_plan(plan, experiment=named.experiment.name,
                                                        world=named.world.kind)})
    return Sweep(source=path, spec=spec, points=points, problem=problem, samples=samples,
                 experiment_file=resolve_preset(experiment, "experiments"),
                 notes=(*design_notes(spec.design), *unrun_policy_notes(points)))


def design_notes(design: Design) -> tuple[str, ...]:
    """The notes on a design that runs, but not as well as it could: a Sobol design's ``samples``
    that is no power of 2 (the Sobol' sequence is balanced only for a power of 2 points; scipy
    warns, and :func:`design_values` silences its warning for this one line)."""
    n = design.samples
    if design.method != "sobol" or n & (n - 1) == 0:
        return ()
    below = 1 << (n.bit_length() - 1)
    return (f"design.samples = {n}: a Sobol design is balanced only for a power of 2 base samples; use "
            f"{below} or {below * 2}",)


def unrun_policy_notes(points: Sequence[DesignPoint]) -> tuple[str, ...]:
    """The note ``nudge simulate`` gives on the experiment's ``[policies.NAME]`` sections that no
    condition runs (:func:`~nudgecli.sim.policy_registry.unused_policy_notes`, its owner), once for
    the sweep, not once a point: on the sections that no point runs (a point whose conditions a
    parameter or the ``set`` changes may run one that others leave out)."""
    run_somewhere = {condition for point in points for condition in run_conditions(point.config)}
    unrun = {name: section for point in points for name, section in (point.config.policies or {}).items()
             if name not in run_somewhere}
    return unused_policy_notes(points[0].config.model_copy(update={"policies": unrun}))


def point_overrides(fixed: list[str], assignment: dict[str, Any]) -> list[str]:
    """A point's ``--set`` texts: the sweep file's ``set``, then each parameter as ``key=value``,
    the value as the TOML writer renders it (a table an inline table), so ``--set`` reads back
    every TOML value a parameter can take."""
    return [*fixed, *(f"{key}={toml_value(value)}" for key, value in assignment.items())]


def point_words(assignment: dict[str, Any]) -> str:
    """A design point's values in a message, as its ``--set`` texts (:func:`point_overrides`) write
    them: ``study.participants=1, policies.x.params={threshold = 0.5}``, not Python's reprs."""
    return ", ".join(point_overrides([], assignment))


def parameter_cell(value: Any) -> Any:
    """A swept parameter's value as a cell of the sweep's tables: a number, string or boolean as it
    is; a table or list (``policies.threshold.params``, ``study.goal_counts``) as compact JSON with
    sorted keys, which ``json.loads`` reads back (its Python repr, ``{'threshold': 0.5}``, is neither
    JSON nor TOML). A TOML date or time inside is written as its ISO text."""
    if isinstance(value, bool | int | float | str):
        return value
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=False,
                      default=_json_scalar)


def _json_scalar(value: Any) -> Any:
    """A value JSON has no type for: a numpy number as the number, a TOML date, time or datetime
    as its ISO text."""
    if isinstance(value, np.generic):
        return value.item()
    isoformat = getattr(value, "isoformat", None)
    if isoformat is None:
        raise TypeError(f"{type(value).__name__} is not a TOML value")
    return str(isoformat())


def _design_points(path: Path, experiment: str, fixed: list[str], values: list[dict[str, Any]],
                   set_alone: ConfigError | None) -> list[DesignPoint]:
    """Every point's experiment: the sweep file's ``set`` (``fixed``), then the point's parameters.

    A failing point is named with its values (the first that fails), unless every point fails and
    the set is invalid on its own (``set_alone``): then the set is at fault whatever the point, and
    its own error is raised. A set that only some points' parameters make valid is no fault of it.
    """
    points: list[DesignPoint] = []
    first: ConfigError | None = None
    for index, assignment in enumerate(values):
        try:
            config = _checked_point(experiment, fixed, assignment)
        except (ConfigError, PolicyError) as exc:
            shown = point_words(assignment)
            first = first or ConfigError(f"{path}: design point {index} ({shown}) is not a valid experiment: "
                                         f"{str(exc).removeprefix('--set ')}")
            if set_alone is None or points:  # a point's own fault: no need to try the rest
                raise first from None
            continue
        if first is not None:  # this point is valid with the set: the first failing one is at fault
            raise first from None
        points.append(DesignPoint(index=index, parameters=assignment, config=config))
    if first is not None:
        raise (set_alone or first) from None
    return points


def _checked_point(experiment: str, fixed: list[str], assignment: dict[str, Any]) -> ExperimentConfig:
    """A point's experiment, checked as ``nudge simulate`` checks one (a policy of one's own is made
    once with the point's parameters), so that a bad point is refused before a folder exists."""
    config = load_experiment(experiment, point_overrides(fixed, assignment))
    checked_policy_specs(config)
    return config


def _point_fault(experiment: str, fixed: list[str], assignment: dict[str, Any]) -> str | None:
    """Why a point's experiment is refused (its ``--set`` text first), or ``None`` when it is valid."""
    try:
        _checked_point(experiment, fixed, assignment)
    except (ConfigError, PolicyError) as exc:
        return str(exc).removeprefix("--set ")
    return None


def _refuse_real_ranges_on_whole_numbers(path: Path, experiment: str, spec: SweepFile) -> None:
    """Refuse a range of reals (no ``integer = true``) over a key that takes whole numbers only,
    naming the fix: ``integer = true``. The key's own refusal of a point ("give a whole number")
    would send the researcher to the drawn value, which the sweep file does not hold.

    A key takes whole numbers only where, with the sweep's ``set``, it takes an integer of the
    range but not the same number written as a real (``4`` but not ``4.0``).

    Raises
    ------
    ConfigError
        Naming the sweep file, each such key, and the range with ``integer = true``.
    """
    advice = []
    for key, value in spec.parameters.items():
        if not isinstance(value, Range) or value.integer:
            continue
        first, last = value.integers()
        if first > last:
            continue  # no integer inside: integer = true is refused there, so it is no fix
        whole = (first + last) // 2
        if (_point_fault(experiment, spec.set, {key: whole}) is None
                and _point_fault(experiment, spec.set, {key: float(whole)}) is not None):
            advice.append(f"parameters.{key}: {key} takes whole numbers, and a range without integer = "
                          f"true gives it real ones; add integer = true: \"{key}\" = {{ low = "
                          f"{value.low:g}, high = {value.high:g}, integer = true }} (the integers "
                          f"{first}-{last}, each an equal share)")
    if advice:
        raise ConfigError(f"{path}: {'; '.join(advice)}")


def _refuse_undrawn_values(path: Path, experiment: str, spec: SweepFile, base: dict[str, Any]) -> None:
    """Refuse a set's value or a range's end that the experiment does not take, drawn or not.

    Every point is checked, but a Sobol or Morris design need not draw every value of a set (nor a
    range's ends): one outside the key's bounds passed unseen with some seeds and samples, and
    was refused with others. Each is checked with the first point's other values (``base``); a
    grid's points hold every value already.

    Raises
    ------
    ConfigError
        Naming the sweep file, the parameter, the value and the experiment's refusal of it.
    """
    if spec.design.method == "grid":
        return
    for key, value in spec.parameters.items():
        if isinstance(value, Values):
            given = [("the value", choice) for choice in value.values]
            fix = "correct it or drop it"
        else:
            ends = value.integers() if value.integer else (value.low, value.high)
            given = list(zip(("the range's low end", "the range's high end"), ends, strict=True))
            fix = f"keep the range within what {key} takes"
        for what, choice in given:
            if type(choice) is type(base[key]) and choice == base[key]:  # the first point, checked already
                continue
            fault = _point_fault(experiment, spec.set, {**base, key: choice})
            if fault is not None:
                raise ConfigError(f"{path}: parameters.{key}: {what} {toml_value(choice)} is not valid, "
                                  f"whether or not this design draws it ({fault}); {fix}")


def salib_problem(spec: SweepFile) -> dict[str, Any]:
    """SALib's problem: one variable per parameter, a range's bounds, ``[0, k]`` for k values and
    ``[first, last + 1]`` for an integer range whose integers run from ``first`` to ``last``."""
    bounds = []
    for value in spec.parameters.values():
        if isinstance(value, Range) and value.integer:
            first, last = value.integers()
            bounds.append([float(first), float(last + 1)])
        elif isinstance(value, Range):
            bounds.append([value.low, value.high])
        else:
            bounds.append([0.0, float(len(value.values))])
    return {"num_vars": len(spec.parameters), "names": list(spec.parameters), "bounds": bounds}


def map_sample(value: Range | Values, x: float, bounds: Sequence[float] | None = None,
               levels: int | None = None) -> Any:
    """The parameter value of the design coordinate ``x`` (in the problem's units).

    A set of ``k`` values and an integer range share one rule: the coordinate's whole part picks
    the value, so each of the ``k`` values (each integer ``first..last``) owns an equal share
    ``[i, i + 1)`` of the bounds, and the top end (``u = 1``) the last one. In the unit
    coordinate ``u`` an integer range gives ``first + floor(u n)``, ``n = last - first + 1``.

    A Morris coordinate (``levels`` and the problem's ``bounds`` given) is the grid level
    ``u = j / (L - 1)``, which SALib computes in floats (``4`` comes back ``3.9999999999999996``):
    the rule is then evaluated on the exact level, ``floor(j k / (L - 1))``, in integers.
    """
    if levels is not None and bounds is not None and not (isinstance(value, Range) and not value.integer):
        low, high = bounds
        level = round((x - low) / (high - low) * (levels - 1))
        count = round(high - low)  # k values, or n integers: the bounds span one unit per choice
        x = low + morris_choice(level, levels, count)
    if isinstance(value, Values):
        return value.values[min(math.floor(x), len(value.values) - 1)]
    if value.integer:
        first, last = value.integers()
        return max(first, min(math.floor(x), last))
    return float(x)


def design_values(spec: SweepFile) -> tuple[list[dict[str, Any]], dict[str, Any] | None, np.ndarray | None]:
    """The design: every point's parameter values, SALib's problem and the ``(n, D)`` samples.

    A grid has no problem or samples. Sobol uses Saltelli's scheme without second-order terms
    (``N (D + 2)`` points, scrambled with the design seed); Morris ``N`` trajectories of
    ``D + 1`` points on a ``levels`` grid.
    """
    names = list(spec.parameters)
    if spec.design.method == "grid":
        choices = [spec.parameters[n].values for n in names]  # type: ignore[union-attr]
        return [dict(zip(names, combo, strict=True)) for combo in itertools.product(*choices)], None, None
    problem = salib_problem(spec)
    if spec.design.method == "sobol":
        from SALib.sample import sobol

        with warnings.catch_warnings():  # scipy's, with its source line: design_notes says it once
            warnings.filterwarnings("ignore", message=SOBOL_BALANCE_WARNING, category=UserWarning)
            samples = sobol.sample(problem, spec.design.samples, calc_second_order=False, scramble=True,
                                   seed=spec.design.seed)
    else:
        from SALib.sample import morris

        samples = morris.sample(problem, spec.design.samples, num_levels=spec.design.levels,
                                seed=spec.design.seed)
    levels = spec.design.levels if spec.design.method == "morris" else None
    values = [{n: map_sample(spec.parameters[n], float(x), bounds, levels)
               for n, x, bounds in zip(names, row, problem["bounds"], strict=True)} for row in samples]
    return values, problem, np.asarray(samples, dtype=float)
