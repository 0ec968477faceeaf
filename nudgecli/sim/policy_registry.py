"""Which policy a condition runs: a built-in one by name, or a researcher's own by import path.

An experiment names its own policy in a ``[policies.NAME]`` section (``nudgecli.config``)::

    [study]
    conditions = ["control", "threshold"]

    [policies.threshold]
    factory = "policies.threshold:ThresholdAssist"   # module:attribute
    params = { threshold = 0.6 }

The module is imported from the experiment file's folder (then from ``sys.path``); the attribute
is called with ``params`` as keyword arguments once per trial and must return an object with the
:class:`~nudgecli.sim.policy_interface.Policy` interface. Everything is checked when the
experiment is loaded (:func:`check_custom_policy`), and a custom policy's every answer is checked
at run time (:class:`CheckedPolicy`): a failure is one :class:`~nudgecli.errors.PolicyError`
naming the condition and the policy.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import inspect
import math
import numbers
import pickle
import random
import sys
import traceback
from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

from nudgecli.errors import PolicyError, did_you_mean
from nudgecli.model.conditions import CONSTANT_METRICS, METRIC_NAMES, not_applicable_metrics, policy_name
from nudgecli.model.world import ROBOT_RADIUS, X_MAX, X_MIN, Y_MAX, Y_MIN, clamp_position
from nudgecli.sim.builtin_policies import BUILTIN_POLICIES
from nudgecli.sim.policy_interface import (
    TURN_EVENTS,
    Assistance,
    AutonomyTurn,
    Policy,
    StepView,
    checked_command,
    checked_pose,
)
from nudgecli.sim.policy_loader import (
    folder_modules,
    import_policy_module,
    module_file,
    sibling_import_advice,
)

if TYPE_CHECKING:
    from nudgecli.config import ExperimentConfig
    from nudgecli.sim.protocol import ProtocolSettings

#: Metrics constant by construction for a policy that does not take turns / does not infer.
_WITHOUT_TURNS = frozenset({"human_effort", "human_turns"})
_WITHOUT_INFERENCE = frozenset({"assistance_engagement", "assistance_strength"})
#: What a researcher's code may raise that is a failure of their policy: any error, and SystemExit
#: (a stray ``sys.exit()``, which would otherwise end the command quietly with its code);
#: KeyboardInterrupt is the person's Ctrl-C and stays one.
POLICY_FAILURES = (Exception, SystemExit)


def is_flag(value: Any) -> bool:
    """Whether ``value`` is True or False: a Python or a numpy bool (not 0 or 1)."""
    return isinstance(value, (bool, np.bool_))


def is_index(value: Any) -> bool:
    """Whether ``value`` is an integer (numpy's too, ``np.argmax``'s ``np.int64``), not a bool
    (True is no mode or goal) nor a float (2.0)."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


@dataclass(frozen=True)
class PolicySpec:
    """A condition's own policy: ``factory`` (``module:attr``), its parameters, where to import from.

    ``search_path`` is the experiment file's folder (absolute; it is not written to a run folder's
    ``config.toml``, which records ``factory`` and ``params`` only): the module is imported from its
    files first (:mod:`nudgecli.sim.policy_loader`; the folder does not go on ``sys.path``), in the
    process that loads the experiment and in every worker.
    """

    condition: str
    factory: str
    params: tuple[tuple[str, Any], ...] = ()
    search_path: str | None = None

    @property
    def described(self) -> str:
        return f"condition {self.condition!r} (policy {self.factory})"


def load_factory(spec: PolicySpec, *, reload_changed: bool = True) -> Callable[..., Any]:
    """The callable ``spec.factory`` names, its module imported from ``spec.search_path`` first
    (:func:`~nudgecli.sim.policy_loader.import_policy_module`: by file, one module per folder, an
    edited file imported again when ``reload_changed``), then from ``sys.path``.

    Raises
    ------
    PolicyError
        The factory is not ``module:attribute``, the module does not import, or has no such
        attribute, or it is not callable.
    """
    where = spec.described
    module_name, sep, attribute = spec.factory.partition(":")
    if not sep or not all(part.isidentifier() for part in (*module_name.split("."), *attribute.split("."))):
        raise PolicyError(f"{where}: the policy must be named as 'module:attribute', e.g. "
                          "'policies.threshold:ThresholdAssist'")
    key = (spec.search_path, module_name)
    known = _IMPORTED.get(key)
    # each trial loads its factory (make_policy, reload_changed=False): the module it had is there,
    # nothing is imported, so nothing can draw and the digests (about 130 µs) are not taken
    settled = not reload_changed and known is not None and sys.modules.get(known.__name__) is known
    before = None if settled else global_rng_digest()
    try:
        module = import_policy_module(module_name, spec.search_path, reload_changed=reload_changed)
    except POLICY_FAILURES as exc:  # a researcher's module: any failure of its import is theirs to see
        raised = "" if isinstance(exc, ModuleNotFoundError) else where_raised(exc, spec)  # its own code's
        advice = (_missing_dependency(exc, module_name, spec.search_path) or raised
                  or f" {_import_advice(module_name, attribute, spec.search_path, exc)}")
        raise PolicyError(f"{where}: cannot import module {module_name!r}: {type(exc).__name__}: {exc}"
                          f"{advice}") from exc
    _IMPORTED[key] = module
    if before is not None and global_rng_digest() != before:  # its import drew (np.random.uniform)
        _note_global_draw(spec, module)
    target: Any = module
    for part in attribute.split("."):
        if not hasattr(target, part):
            public = [name for name in dir(target) if not name.startswith("_")]
            raise PolicyError(f"{where}: module {module_name!r} has no attribute {attribute!r}"
                              f"{did_you_mean(part, public)}")
        target = getattr(target, part)
    if not callable(target):
        raise PolicyError(f"{where}: {attribute!r} is not callable; name a class or a function that "
                          "returns a policy")
    return target  # type: ignore[no-any-return]


def global_rng_digest() -> bytes:
    """A digest of numpy's and Python's global random generators' states (reading them draws nothing)."""
    return hashlib.sha256(pickle.dumps((np.random.get_state(), random.getstate()))).digest()


#: (search path, module name) -> the module :func:`load_factory` was given for it last.
_IMPORTED: dict[tuple[str | None, str], ModuleType] = {}
#: (search path, factory) -> the module of a policy whose import (or the making of its checked
#: policy) drew from a global random generator: before any trial, so no trial's watch sees it.
_DREW_WHEN_LOADED: dict[tuple[str | None, str], ModuleType] = {}


def _note_global_draw(spec: PolicySpec, module: ModuleType | None) -> None:
    if module is not None:
        _DREW_WHEN_LOADED[(spec.search_path, spec.factory)] = module


def drew_when_loaded(spec: PolicySpec) -> bool:
    """Whether importing ``spec``'s module (as this process has it now) or making its checked
    policy drew from numpy's or Python's global random generator (:func:`global_rng_digest`): the
    draw of a module's top level (``W = np.random.uniform()``) happens once, before any trial."""
    module = _DREW_WHEN_LOADED.get((spec.search_path, spec.factory))
    return module is not None and sys.modules.get(module.__name__) is module


def _missing_dependency(exc: BaseException, module_name: str, folder: str | None) -> str:
    """Where the policy's module imports a module that is not installed (``import torch`` without
    torch): ``; p/mine.py line 2 imports 'torch', which is not installed in this Python``, the
    innermost frame of the import's traceback outside nudge and Python's import machinery; ``""``
    where the missing module is the policy's module itself, one of the folder's (or the folder's
    private package's, a relative import), or no frame shows the import."""
    missing = getattr(exc, "name", None) if isinstance(exc, ModuleNotFoundError) else None
    if (missing is None or module_name == missing or module_name.startswith(missing + ".")
            or missing.startswith("_nudge_policies_")):
        return ""
    if folder is not None and (module_file(folder, missing) is not None
                               or Path(folder).joinpath(*missing.split(".")).is_dir()):
        return ""
    base = None if folder is None else Path(folder).resolve()
    for frame in reversed(traceback.extract_tb(exc.__traceback__)):
        if frame.filename.startswith("<"):  # Python's import machinery (<frozen importlib._bootstrap>)
            continue
        path = Path(frame.filename).resolve()
        if path.is_relative_to(_NUDGE_CODE):
            break
        shown = path.relative_to(base).as_posix() if base is not None and path.is_relative_to(base) \
            else frame.filename
        return f"; {shown} line {frame.lineno} imports {missing!r}, which is not installed in this Python"
    return ""


def _import_advice(module_name: str, attribute: str, folder: str | None, exc: BaseException) -> str:
    """What to do about a module that does not import: an absolute import of the folder's own
    module inside it made relative, a module named without ``.py``, or the module of the folder
    closest to a misspelt name (the named module itself not found)."""
    where = "(the module is looked up beside the experiment file, then on sys.path)"
    missing = getattr(exc, "name", None) if isinstance(exc, ModuleNotFoundError) else None
    if missing is None:
        return where
    found_in_folder = folder is not None and module_file(folder, module_name) is not None
    if folder is not None and found_in_folder and isinstance(exc, ModuleNotFoundError):  # an import in it
        return where + sibling_import_advice(exc, folder)
    if not (module_name == missing or module_name.startswith(missing + ".")):
        return where
    if module_name.endswith(".py"):
        return f"{where}; name the module without .py, e.g. '{module_name[:-3]}:{attribute}'"
    close = did_you_mean(module_name, folder_modules(folder) if folder is not None else ())
    return f"{where}{close}"


def check_custom_policy(spec: PolicySpec) -> Policy:
    """Import ``spec``'s factory, check its parameters, make one policy and check its interface.

    Returns
    -------
    Policy
        The policy made (its traits say which metrics it makes constant).

    Raises
    ------
    PolicyError
        With one line naming the condition, the policy and what is wrong.
    """
    factory = load_factory(spec)
    before = global_rng_digest()  # a draw made once, in making the first policy, no trial sees
    policy = _checked_policy(factory, spec)
    if global_rng_digest() != before:
        _note_global_draw(spec, inspect.getmodule(factory))
    return policy


def _checked_policy(factory: Callable[..., Any], spec: PolicySpec) -> Policy:
    """One policy of ``factory`` made with ``spec``'s parameters, its interface checked."""
    params = dict(spec.params)
    try:
        inspect.signature(factory).bind(**params)
    except TypeError as exc:
        known = inspect.signature(factory).parameters
        close = "".join(did_you_mean(name, known) for name in sorted(params) if name not in known)
        raise PolicyError(f"{spec.described}: its parameters {sorted(params)} do not fit its signature "
                          f"{inspect.signature(factory)}: {exc}{close}") from None
    except ValueError:  # no signature to inspect (a builtin): calling it will tell
        pass
    policy = _make(factory, params, spec)
    found = {name: policy_attribute(policy, name, spec)
             for name in ("infers", "takes_turns", "assist", "start_turn", "constant_metrics")}
    missing = [name for name, value in found.items() if value is _MISSING and name != "constant_metrics"]
    if missing:
        raise PolicyError(f"{spec.described}: the object it returns lacks {', '.join(missing)} of the policy "
                          "interface (nudgecli.sim.policy_interface.Policy; see docs/policies.md)")
    for name in ("infers", "takes_turns"):
        if not is_flag(found[name]):
            raise PolicyError(f"{spec.described}: its {name} must be True or False")
    for name in ("assist", "start_turn"):
        if not callable(found[name]):
            raise PolicyError(f"{spec.described}: its {name} must be a method")
    _check_constant_metrics(() if found["constant_metrics"] is _MISSING else found["constant_metrics"], spec)
    return policy


#: What :func:`policy_attribute` answers for an attribute the policy does not have.
_MISSING = object()


def policy_attribute(policy: Any, name: str, spec: PolicySpec) -> Any:
    """``policy``'s attribute ``name``, or ``_MISSING`` where it has none; reading it is the
    researcher's code (a property): what it raises is a :class:`PolicyError` naming the attribute."""
    try:
        return getattr(policy, name, _MISSING)
    except POLICY_FAILURES as exc:
        raise PolicyError(f"{spec.described}: reading its {name} raised {raised_text(exc, spec)}") from exc


def _check_constant_metrics(value: Any, spec: PolicySpec) -> None:
    """Refuse a ``constant_metrics`` that is not a collection of known metric names (not a string)."""
    where = f"{spec.described}: its constant_metrics"
    if isinstance(value, str):
        raise PolicyError(f"{where} {value!r} is a string; it must be a set of metric names, "
                          f"e.g. {{{value!r}}}")
    if not isinstance(value, Collection):
        raise PolicyError(f"{where} must be a set of metric names, e.g. {{'completion_time'}}, got {value!r}")
    for name in value:
        if name not in METRIC_NAMES:
            raise PolicyError(f"{where} names unknown metric {name!r}{did_you_mean(name, METRIC_NAMES)}; "
                              f"known: {', '.join(METRIC_NAMES)}")


def _make(factory: Callable[..., Any], params: Mapping[str, Any], spec: PolicySpec) -> Any:
    try:
        return factory(**params)
    except POLICY_FAILURES as exc:
        raise PolicyError(f"{spec.described}: making the policy failed: {raised_text(exc, spec)}") from exc


#: nudge's own code: never the policy's, whatever folder holds it.
_NUDGE_CODE = Path(__file__).resolve().parents[1]


def raised_text(exc: BaseException, spec: PolicySpec) -> str:
    """``exc`` of the policy's code in its error: its type, its message where it has one, and
    where in the policy's own code it was raised (:func:`where_raised`)."""
    message = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
    return message + where_raised(exc, spec)


def where_raised(exc: BaseException, spec: PolicySpec) -> str:
    """Where in the policy's own code ``exc`` was raised: `` (p/mine.py line 6: assert view.step <
    5); nudge --debug, or the exception's __cause__ in Python, shows the whole traceback``, the
    innermost frame of its traceback in a file under the experiment's folder (or the factory's
    module's file, one from ``sys.path``), its path relative to the folder; ``""`` where no frame
    is the policy's (its code raised nothing itself)."""
    folder = None if spec.search_path is None else Path(spec.search_path).resolve()
    name = spec.factory.partition(":")[0]
    module_path = getattr(sys.modules.get(name), "__file__", None)
    if name not in sys.modules:  # an import that raised removed it: its file as the import finds it
        with contextlib.suppress(Exception):  # a parent package that raises as it is imported: unnamed
            module_path = getattr(importlib.util.find_spec(name), "origin", None)
    own = None if module_path is None else Path(module_path).resolve()
    for frame in reversed(traceback.extract_tb(exc.__traceback__)):
        path = Path(frame.filename).resolve()
        if path.is_relative_to(_NUDGE_CODE) or {"site-packages", "dist-packages"} & set(path.parts):
            continue  # nudge's own code or a library's, though the folder may hold them (a venv in it)
        if folder is not None and path.is_relative_to(folder):
            shown = path.relative_to(folder).as_posix()
        elif path == own:
            shown = frame.filename
        else:
            continue
        line = (frame.line or "").strip()
        return (f" ({shown} line {frame.lineno}: {line}); nudge --debug, or the exception's __cause__ in "
                "Python, shows the whole traceback")
    return ""


#: A command's speed may pass its limit by this factor (a speed computed in floating point).
_LIMIT_TOLERANCE = 1.0 + 1e-9


def command_limits(settings: ProtocolSettings) -> tuple[float, float]:
    """The fastest a policy's command may move (units/s, ``hypot(vx, vy)``) and turn (rad/s,
    ``|omega|``): the person's full command (``[interface]`` ``human_speed``, ``human_turn_rate``)
    plus the autonomy's (``[assistance]`` ``autonomy_speed``, ``autonomy_turn_rate``).

    The sum, not the larger of the two: a convex blend (``Assistance.convex``) stays within the
    larger, but an additive one (``Assistance.additive``, ADA's blend and hindsight among the
    built-ins) adds an assistance to the person's full command (the baselines' hindsight turns at
    up to 3.38 rad/s, 1.95 plus its far-field 0.735 of it: above either 1.95 or 1.5 alone).
    """
    return (settings.human_speed + settings.autonomy_speed,
            settings.human_turn_rate + settings.autonomy_turn_rate)


class CheckedPolicy:
    """A researcher's policy with every answer checked: an exception, a NaN or a command of the
    wrong shape is a :class:`PolicyError` naming the condition and the policy."""

    def __init__(self, inner: Any, spec: PolicySpec) -> None:
        self.inner = inner
        self.spec = spec
        self.infers = bool(policy_attribute(inner, "infers", spec))
        self.takes_turns = bool(policy_attribute(inner, "takes_turns", spec))
        # the optional hook, checked like the rest; absent when the policy has none
        hooks = {name: callable(policy_attribute(inner, name, spec))
                 for name in ("choose_mode", "assist_quiet")}
        self.choose_mode = self._choose_mode if hooks["choose_mode"] else None
        self.assist_quiet = self._assist_quiet if hooks["assist_quiet"] else None

    def _choose_mode(self, view: StepView, requested: int) -> int | None:
        try:
            mode = self.inner.choose_mode(view, requested)
        except POLICY_FAILURES as exc:
            raise self._raised("choose_mode", exc) from exc
        if mode is not None and not (is_index(mode) and 0 <= int(mode) <= 2):
            self._fail(f"choose_mode returned {mode!r}; it must be 0, 1, 2 or None")
        return None if mode is None else int(mode)

    def assist(self, view: StepView) -> Assistance:
        try:
            answer = self.inner.assist(view)
        except POLICY_FAILURES as exc:
            raise self._raised("assist", exc) from exc
        return self._checked_assistance(answer, view, "assist")

    def _assist_quiet(self, view: StepView, steps: int) -> list[tuple[int, Assistance]]:
        try:
            runs = list(self.inner.assist_quiet(view, steps))
        except POLICY_FAILURES as exc:
            raise self._raised("assist_quiet", exc) from exc
        checked = []
        for run in runs:
            if not (isinstance(run, tuple) and len(run) == 2 and isinstance(run[0], numbers.Integral)
                    and int(run[0]) >= 1):
                self._fail(f"assist_quiet gave {run!r}; each item must be (count >= 1, Assistance)")
            checked.append((int(run[0]), self._checked_assistance(run[1], view, "assist_quiet")))
        return checked

    def _checked_assistance(self, answer: Any, view: StepView, method: str) -> Assistance:
        if not isinstance(answer, Assistance):
            answer = self._fail(f"{method} returned {type(answer).__name__}, not an Assistance")
        try:
            command = checked_command(answer.command, "its command")
            u_a = checked_command(answer.u_a, "its u_a")
        except ValueError as exc:
            raise PolicyError(f"{self.spec.described}: {method}: {exc}") from None
        if any(command):  # a command that stands is within any limit (most steps of a person's turn)
            self._check_speed(command, view.settings, method)
        alpha, goal = answer.alpha, answer.goal
        # numpy's scalars are numbers too (np.float32(0.5), np.argmax's np.int64)
        if (not isinstance(alpha, numbers.Real) or is_flag(alpha) or not math.isfinite(alpha)
                or not 0 <= float(alpha) <= 1):
            self._fail(f"{method} returned alpha {alpha!r}; it must be a number from 0 to 1 (the "
                       "assistance's weight)")
        return Assistance(command, u_a, float(alpha), self._checked_goal(goal, view, method))

    def _check_speed(self, command: tuple[float, float, float], settings: ProtocolSettings,
                     method: str) -> None:
        """Refuse a command faster than the robot is driven by anyone (:func:`command_limits`)."""
        speed_limit, turn_limit = command_limits(settings)
        speed, turn = math.hypot(command[0], command[1]), abs(command[2])
        if speed > speed_limit * _LIMIT_TOLERANCE or turn > turn_limit * _LIMIT_TOLERANCE:
            self._fail(f"{method} returned command {command}: speed {speed:g} units/s, turn {turn:g} rad/s; "
                       f"a command may move at most {speed_limit:g} units/s and turn at most {turn_limit:g} "
                       "rad/s ([interface] human_speed plus [assistance] autonomy_speed, human_turn_rate "
                       "plus autonomy_turn_rate: the person's full command plus the autonomy's); scale it "
                       "down (drive_towards gives the autonomy's)")

    def _checked_goal(self, goal: Any, view: StepView, method: str) -> int:
        """``goal`` as the index of one of the view's goals, or -1 for none."""
        if not is_index(goal) or not -1 <= int(goal) < len(view.goal_poses):
            self._fail(f"{method} returned goal {goal!r}; it must be -1 or a goal index below "
                       f"{len(view.goal_poses)}")
        return int(goal)

    def start_turn(self, view: StepView) -> AutonomyTurn:
        try:
            plan = self.inner.start_turn(view)
        except POLICY_FAILURES as exc:
            raise self._raised("start_turn", exc) from exc
        if not isinstance(plan, AutonomyTurn):
            self._fail(f"start_turn returned {type(plan).__name__}, not an AutonomyTurn")
        if plan.target is not None:
            try:
                target = checked_pose(plan.target, "its target")
            except ValueError as exc:
                raise PolicyError(f"{self.spec.described}: start_turn: {exc}") from None
            self._check_reachable(target, view.settings)
        mode, events, nudge = plan.mode, plan.events, plan.nudge
        if mode is not None and not (is_index(mode) and 0 <= int(mode) <= 2):
            self._fail(f"start_turn returned mode {mode!r}; it must be 0, 1, 2 or None")
        if isinstance(events, str) or not isinstance(events, Collection):
            self._fail(f"start_turn returned events {events!r}; they must be a tuple of event names, "
                       f"e.g. ({TURN_EVENTS[0]!r},)")
        for event in events:
            if event not in TURN_EVENTS:
                self._fail(f"start_turn returned event {event!r}{did_you_mean(event, TURN_EVENTS)}; a "
                           f"turn's events are {', '.join(TURN_EVENTS)}")
        if not is_flag(nudge):
            self._fail(f"start_turn returned nudge {nudge!r}; it must be True or False")
        goal = self._checked_goal(plan.goal, view, "start_turn")
        mode = None if mode is None else int(mode)
        return AutonomyTurn(plan.target, mode, tuple(events), goal, bool(nudge))

    def _check_reachable(self, target: tuple[float, float, float], settings: ProtocolSettings) -> None:
        """Refuse a turn's target the robot cannot arrive at: a turn ends on arrival only, so it would
        hold the robot at the wall until the trial's time limit. A custom policy runs in the grid
        world (the path world runs its task's conditions only): its robot keeps its radius from the walls."""
        x, y = target[0], target[1]
        nearest_x, nearest_y = clamp_position(x, y)
        if math.hypot(x - nearest_x, y - nearest_y) > settings.arrival_tolerance:
            self._fail(f"start_turn returned target {target} outside the workspace the robot reaches (x "
                       f"{X_MIN + ROBOT_RADIUS:g} to {X_MAX - ROBOT_RADIUS:g}, y {Y_MIN + ROBOT_RADIUS:g} to "
                       f"{Y_MAX - ROBOT_RADIUS:g}: the workspace x {X_MIN:g} to {X_MAX:g}, y {Y_MIN:g} to "
                       f"{Y_MAX:g}, less the robot's radius {ROBOT_RADIUS:g}); the turn ends only within "
                       f"[assistance] arrival_tolerance {settings.arrival_tolerance:g} of its target, so it "
                       "would run to the trial's time limit; give a target inside it, e.g. a goal's pose "
                       "(view.goal_poses)")

    def _raised(self, method: str, exc: BaseException) -> PolicyError:
        """The error of the policy's ``method`` that raised ``exc``: where in its own code."""
        return PolicyError(f"{self.spec.described}: {method} raised {raised_text(exc, self.spec)}")

    def _fail(self, what: str) -> Any:
        raise PolicyError(f"{self.spec.described}: {what}")


def make_policy(condition: str, settings: ProtocolSettings) -> Policy:
    """A fresh policy for one trial of ``condition``: the experiment's own, or the built-in one."""
    for spec in settings.custom_policies:
        if spec.condition == condition:
            # the module the run was checked with: an edit during the run does not change its policy
            factory = load_factory(spec, reload_changed=False)
            return CheckedPolicy(_make(factory, dict(spec.params), spec), spec)
    return BUILTIN_POLICIES[policy_name(condition)](settings)  # type: ignore[no-any-return]


def policy_specs(config: ExperimentConfig) -> tuple[PolicySpec, ...]:
    """The experiment's own policies (``[policies.NAME]``) that its conditions run."""
    own = config.policies or {}
    return tuple(PolicySpec(name, own[name].factory, tuple(sorted(own[name].params.items())),
                            config.policy_search_path)
                 for name in config.study.conditions if name in own)


def unused_policy_notes(config: ExperimentConfig) -> tuple[str, ...]:
    """A note naming the experiment's ``[policies.NAME]`` sections that no condition it runs names
    (:func:`run_conditions`): they are neither imported nor checked. A note, not an error: a
    ``--set study.conditions=...`` or a sweep may rightly leave a policy out."""
    own = config.policies or {}
    unused = [name for name in own if name not in run_conditions(config)]
    if not unused:
        return ()
    sections = ", ".join(f"[policies.{name}] ({own[name].factory})" for name in unused)
    verb = "is" if len(unused) == 1 else "are"
    return (f"{sections} {verb} not in study.conditions, so not run (nor imported or checked); "
            "list it in study.conditions to run it",)


def checked_policy_specs(config: ExperimentConfig) -> tuple[PolicySpec, ...]:
    """:func:`policy_specs`, each imported, made once and checked (:func:`check_custom_policy`), so
    a policy that cannot run is refused before any work starts: the one check of ``nudge simulate``
    (through its protocol settings), ``replicate``, ``power`` and every point of a ``sweep``."""
    specs = policy_specs(config)
    for spec in specs:
        check_custom_policy(spec)
    return specs


def run_conditions(config: ExperimentConfig) -> tuple[str, ...]:
    """The conditions a run of the experiment holds trials of: ``world.ciaa_conditions`` in the
    CIAA path world (which does not read ``study.conditions``), ``study.conditions`` in the grid."""
    return tuple(config.world.ciaa_conditions if config.world.kind == "ciaa" else config.study.conditions)


def constant_metrics_of(config: ExperimentConfig) -> dict[str, frozenset[str]]:
    """Condition -> the metrics its policy makes constant by construction, for the conditions the
    experiment runs (:func:`run_conditions`).

    A built-in policy's are its own (``additive`` blending adds strength); a researcher's policy's
    are those of its traits (no turns: human effort and turns; no inference: engagement and
    strength) plus any it lists in a ``constant_metrics`` attribute.
    """
    specs = {spec.condition: spec for spec in policy_specs(config)}
    table: dict[str, frozenset[str]] = {}
    for condition in run_conditions(config):
        spec = specs.get(condition)
        if spec is None:
            name = policy_name(condition)
            metrics = CONSTANT_METRICS.get(name, frozenset())
            if name == "blending" and _blending_strength_is_constant(config):
                metrics = metrics | {"assistance_strength"}
            requests = config.mode_switch is not None and config.mode_switch.trigger == "request"
            if name == "mode-switch" and requests:  # no autonomy turn: the person's turn is the trial
                metrics = metrics | _WITHOUT_TURNS
            table[condition] = metrics
            continue
        policy = check_custom_policy(spec)
        metrics = frozenset(getattr(policy, "constant_metrics", ()))
        if not policy.takes_turns:
            metrics |= _WITHOUT_TURNS
        if not policy.infers:
            metrics |= _WITHOUT_INFERENCE
        table[condition] = metrics
    return table


def _blending_strength_is_constant(config: ExperimentConfig) -> bool:
    """Whether the ``blending`` condition's alpha, where it is not 0, has one value by construction.

    Additive blending's alpha is 1 whenever it acts. The convex blend gated by the confidence gap
    acts only when ``p1 - p2 > gap``; the second highest belief is at least ``(1 - p1) / (G - 1)``,
    so then ``p1 > (gap (G - 1) + 1) / G``. Where that bound reaches every goal count's ``rho2 =
    rho2_factor / G`` (``rho2_factor <= gap (G - 1) + 1``), the paper's ramp is at ``rho3``
    whenever the gate passes, and without the distance weighting nothing else scales it: alpha is
    0 or ``rho3``.
    """
    section = config.blending
    if section is None:
        return False
    if section.kind == "additive":
        return True
    ass = config.assistance
    return (section.gate == "gap" and not ass.distance_weighting
            and all(ass.rho2_factor <= section.gap * (goals - 1) + 1 for goals in config.study.goal_counts))


def not_applicable_of(config: ExperimentConfig, *, success: str) -> dict[str, tuple[str, ...]]:
    """Metric -> the experiment's conditions for which it is not applicable under an analysis plan
    whose success definition is ``success``
    (:func:`~nudgecli.model.conditions.not_applicable_metrics` of :func:`constant_metrics_of`, the
    rule ``nudge analyze`` applies to a run folder's recorded table)."""
    return not_applicable_metrics(run_conditions(config), constant_metrics_of(config), success=success)
