"""The house's defaults (issue 22): each default value of an experiment key is written once.

``nudgecli.config``'s sections own the defaults of the experiment's keys. A function argument, a
dataclass field or a module constant of the domain (``nudgecli/model``, ``nudgecli/sim``) whose
name is a config key's (or one of :data:`ALIASES`) must not repeat that key's default value as
a literal: either it takes the value from its caller (no default), or the config's default reads
the domain's one constant (``gamma = DEFAULT_GAMMA``), so the number is written in one place.

What still repeats a default today is listed in :data:`KNOWN_REPEATS`, which may only shrink.
"""

from __future__ import annotations

import ast
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from nudgecli.config import ExperimentConfig

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "nudgecli"
#: The domain's folders whose defaults are checked. ``sim/validation`` is the paper's separate
#: validation of D(s): its settings are its own (``ValidationSettings``, ``nudge validate``).
DOMAIN = ("model", "sim")
EXCLUDED = ("sim/validation/",)
#: Config modules: the sections live here.
CONFIG_MODULES = tuple(sorted(PACKAGE.glob("config*.py")))

#: Domain names -> the config key they stand for, where the names differ.
ALIASES: dict[str, tuple[str, ...]] = {
    "knee": ("assistance.distance_knee",),
    "drop": ("assistance.distance_drop",),
    "speed": ("interface.human_speed", "assistance.autonomy_speed"),
    "turn_rate": ("interface.human_turn_rate", "assistance.autonomy_turn_rate"),
    "delay": ("inference.decay_delay",),
    "rate": ("inference.decay_rate",),
    "cap": ("inference.decay_cap",),
    "startup_delay": ("assistance.startup_delay_s",),
    "step": ("calibration.event_step",),
    "hindsight_gain": ("hindsight.gain",),
    "mode_criterion": ("mode_switch.criterion",),
    "blending_gap": ("blending.gap",),
    "move": ("model.move_reward",),
    "mode_switch": ("model.mode_switch_reward",),
    "bump": ("model.bump_reward",),
    "goal": ("model.goal_reward",),
    "noise": ("model.default_table_noise",),
    "DEFAULT_TABLE_NOISE": ("model.default_table_noise",),
    "DEFAULT_GAMMA": ("model.gamma",),
    "DEFAULT_HUMAN_EPSILON": ("model.epsilon",),
    "ZERO_THRESHOLD": ("interface.zero_threshold",),
    "SOFT_THRESHOLD_EARLY": ("interface.soft_threshold",),
    "HARD_THRESHOLD_EARLY": ("interface.hard_threshold",),
    "AUTONOMY_SPEED": ("assistance.autonomy_speed",),
    "AUTONOMY_TURN_RATE": ("assistance.autonomy_turn_rate",),
}

#: ``path:line name`` of the domain's defaults that still repeat a config default, a debt that
#: may only shrink (each entry must still be found; remove it once fixed).
KNOWN_REPEATS: frozenset[str] = frozenset()


@dataclass(frozen=True)
class Written:
    """One place a value is written: ``where`` (``path:line name``) and the value."""

    where: str
    name: str
    value: Any


def config_defaults() -> dict[str, Any]:
    """``section.key`` -> default value of every experiment key (sections' defaults)."""
    found: dict[str, Any] = {}
    for section, field in ExperimentConfig.model_fields.items():
        options = [a for a in (field.annotation, *typing.get_args(field.annotation))
                   if isinstance(a, type) and issubclass(a, BaseModel)]
        if not options:  # not a section: the [policies.NAME] tables and their import folder
            continue
        for key, sub in options[0].model_fields.items():
            found[f"{section}.{key}"] = sub.default
    return found


def _literal(node: ast.AST | None) -> tuple[bool, Any]:
    """Whether ``node`` is a literal (numbers, strings, booleans, tuples of them), and its value."""
    if node is None:
        return False, None
    if isinstance(node, ast.Call) and getattr(node.func, "id", "") == "Field":  # Field(default=...)
        default = next((k.value for k in node.keywords if k.arg == "default"), None)
        return _literal(default)
    try:
        return True, ast.literal_eval(node)
    except ValueError:
        return False, None


def config_literals() -> set[str]:
    """The config keys whose default is written as a literal in the config's modules (not read
    from a constant), as ``ClassName.key``."""
    found: set[str] = set()
    for path in CONFIG_MODULES:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef):
                for item in node.body:
                    if isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name) \
                            and _literal(item.value)[0]:
                        found.add(f"{node.name}.{item.target.id}")
    return found


def domain_defaults(root: Path = PACKAGE) -> list[Written]:
    """Every literal default of the domain: function arguments, class-body fields (dataclasses)
    and module-level constants."""
    found: list[Written] = []
    for folder in DOMAIN:
        for path in sorted((root / folder).rglob("*.py")):
            relative = path.relative_to(root.parent).as_posix()
            if any(part in relative for part in EXCLUDED):
                continue
            tree = ast.parse(path.read_text(encoding="utf-8"))
            found += _defaults_in(tree, relative)
    return found


def _defaults_in(tree: ast.Module, relative: str) -> list[Written]:
    found: list[Written] = []

    def add(line: int, name: str, node: ast.AST | None) -> None:
        ok, value = _literal(node)
        if ok and value is not None:
            found.append(Written(f"{relative}:{line} {name}", name, value))

    for node in tree.body:  # module constants
        if isinstance(node, ast.Assign):
            for target in node.targets:
                if isinstance(target, ast.Name):
                    add(node.lineno, target.id, node.value)
                elif isinstance(target, ast.Tuple) and isinstance(node.value, ast.Tuple):
                    for t, v in zip(target.elts, node.value.elts, strict=False):
                        if isinstance(t, ast.Name):
                            add(node.lineno, t.id, v)
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            args = node.args
            positional = args.posonlyargs + args.args
            pairs = list(zip(positional[len(positional) - len(args.defaults):], args.defaults, strict=True))
            pairs += [(a, d) for a, d in zip(args.kwonlyargs, args.kw_defaults, strict=True) if d is not None]
            for arg, default in pairs:
                add(node.lineno, arg.arg, default)
        elif isinstance(node, ast.ClassDef):
            for item in node.body:
                if isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name):
                    add(item.lineno, item.target.id, item.value)
    return found


def _section_classes() -> dict[str, str]:
    """``section`` -> the name of its class (``assistance`` -> ``AssistanceSection``)."""
    classes: dict[str, str] = {}
    for section, field in ExperimentConfig.model_fields.items():
        options = [a for a in (field.annotation, *typing.get_args(field.annotation))
                   if isinstance(a, type) and issubclass(a, BaseModel)]
        if options:  # [policies] and its import folder are not sections
            classes[section] = options[0].__name__
    return classes


def _same(a: Any, b: Any) -> bool:
    """Equal values of the same kind (``True`` is not ``1``; ``3`` is ``3.0``)."""
    if isinstance(a, bool) or isinstance(b, bool):
        return type(a) is type(b) and a == b
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, int | float) and isinstance(b, int | float):
        return a == b
    return type(a) is type(b) and a == b


def repeats(defaults: dict[str, Any], literal_keys: set[str], classes: dict[str, str],
            written: list[Written]) -> dict[str, list[str]]:
    """``section.key`` -> where its default value is written more than once: the config's own
    literal (if it is one) and every domain default of the same name (or alias) and value."""
    by_name: dict[str, list[str]] = {}
    for key in defaults:
        by_name.setdefault(key.split(".", 1)[1], []).append(key)
    found: dict[str, list[str]] = {}
    for w in written:
        for key in (*by_name.get(w.name, ()), *ALIASES.get(w.name, ())):
            if key in defaults and _same(w.value, defaults[key]):
                found.setdefault(key, []).append(w.where)
    result: dict[str, list[str]] = {}
    for key, places in found.items():
        section, name = key.split(".", 1)
        owner = f"{classes[section]}.{name}"
        in_config = [f"config {owner}"] if owner in literal_keys else []
        if len(in_config) + len(places) > 1:
            result[key] = in_config + places
    return result


def test_each_config_default_is_written_once() -> None:
    found = repeats(config_defaults(), config_literals(), _section_classes(), domain_defaults())
    new = {key: places for key, places in found.items()
           if any(p not in KNOWN_REPEATS and not p.startswith("config ") for p in places)}
    assert not new, ("defaults written twice; take the value from the caller (no default) or read the "
                     f"one constant in the config: {new}")


def test_the_known_repeats_are_still_there() -> None:
    found = repeats(config_defaults(), config_literals(), _section_classes(), domain_defaults())
    still = {p for places in found.values() for p in places}
    assert sorted(KNOWN_REPEATS - still) == [], "fixed: remove them from KNOWN_REPEATS"


def test_a_restated_default_is_found(tmp_path: Path) -> None:
    # the checker itself, on a small package: a function argument, a dataclass field and a
    # constant that repeat config defaults, and one that does not
    model = tmp_path / "nudgecli" / "model"
    model.mkdir(parents=True)
    (tmp_path / "nudgecli" / "sim").mkdir()
    (model / "m.py").write_text(
        "AUTONOMY_SPEED = 5.0\nOTHER = 5.0\n\n"
        "def f(x, rho3=0.8, window=5, knee=35.0):\n    return x\n\n"
        "class S:\n    gamma: float = 0.96\n    epsilon: float = 0.3\n", encoding="utf-8")
    written = domain_defaults(tmp_path / "nudgecli")
    defaults = {"assistance.rho3": 0.8, "assistance.autonomy_speed": 5.0, "disambiguation.window": 3,
                "assistance.distance_knee": 35.0, "model.gamma": 0.96, "model.epsilon": 0.1}
    classes = {"assistance": "AssistanceSection", "disambiguation": "DisambiguationSection",
               "model": "ModelSection"}
    found = repeats(defaults, {"AssistanceSection.rho3", "ModelSection.gamma"}, classes, written)
    assert found == {
        "assistance.rho3": ["config AssistanceSection.rho3", "nudgecli/model/m.py:4 rho3"],
        "model.gamma": ["config ModelSection.gamma", "nudgecli/model/m.py:8 gamma"],
    }
    # a config default that reads the constant is written once; two domain literals are not
    found = repeats(defaults, set(), classes, [*written, Written("elsewhere.py:1 speed", "speed", 5.0)])
    assert found == {"assistance.autonomy_speed": ["nudgecli/model/m.py:1 AUTONOMY_SPEED",
                                                   "elsewhere.py:1 speed"]}
