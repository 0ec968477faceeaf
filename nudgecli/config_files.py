"""Experiment and analysis-plan files: the shipped presets, which plan a run is analysed with,
TOML reading and writing, ``--set`` overrides and the one-line message of a validation error."""

from __future__ import annotations

import json
import re
import tomllib
from collections.abc import Mapping, Sequence
from copy import deepcopy
from datetime import date, datetime, time
from pathlib import Path
from types import UnionType
from typing import Any, Literal, TypeVar, Union, get_args, get_origin

from pydantic import BaseModel, ValidationError

from nudgecli.config_base import admits, plain
from nudgecli.errors import ConfigError, did_you_mean, shell_words
from nudgecli.run_folder_names import BATCH_MANIFEST, MANIFEST, PLAN_COPY

#: A plan as a command holds it: a preset name, a path or a loaded plan (:func:`resolve_plan`).
PlanT = TypeVar("PlanT")
ModelT = TypeVar("ModelT", bound=BaseModel)
#: A parsed ``--set``: its text, its key's path and its value.
Override = tuple[str, list[str], Any]


def preset_dir(kind: Literal["experiments", "analysis"]) -> Path:
    """The folder holding the shipped presets of ``kind``.

    Installed, they sit in ``nudgecli/presets/<kind>/`` (pyproject maps the top-level folders
    there); in a source tree without an install, in the top-level ``<kind>/`` folder.
    """
    installed = Path(__file__).resolve().parent / "presets" / kind
    if any(installed.glob("*.toml")):
        return installed
    return Path(__file__).resolve().parents[1] / kind


def list_presets(kind: Literal["experiments", "analysis"]) -> dict[str, Path]:
    """Preset name -> file, sorted by name."""
    return {p.stem: p for p in sorted(preset_dir(kind).glob("*.toml"))}


#: The plan preset of a world whose measures are not the paper's (``world.kind``): a CIAA run has
#: no assistance to engage and no turns, and is measured as the CIAA study measured its people.
WORLD_PLANS = {"ciaa": "ciaa-teleop"}


def default_plan_name(experiment: str, world: str | None = None) -> str:
    """The analysis plan a run of ``experiment`` is analysed with by default: the plan preset of
    the same name (``study-code``), else the plan of its world (``world.kind``,
    :data:`WORLD_PLANS`: ``ciaa`` -> ``ciaa-teleop``), else ``paper``."""
    if experiment in list_presets("analysis"):
        return experiment
    return WORLD_PLANS.get(world or "", "paper")


def world_kind_of(manifest: Mapping[str, Any] | None) -> str | None:
    """The ``world.kind`` a run folder's manifest records (its resolved experiment), if any."""
    config = (manifest or {}).get("config")
    world = config.get("world") if isinstance(config, Mapping) else None
    kind = world.get("kind") if isinstance(world, Mapping) else None
    return kind if isinstance(kind, str) else None


def resolve_plan(plan: PlanT | None, *, recorded: str | None = None,
                 experiment: str | None = None, world: str | None = None) -> PlanT | str:
    """The analysis plan a command uses: the one rule of ``analyze``, ``plot``, ``run``,
    ``replicate`` and ``power``.

    Parameters
    ----------
    plan
        The plan given (``--plan``: a preset name, a path or a loaded plan); wins when not None.
    recorded
        The plan recorded in the run folder's manifest (what the run was simulated or analysed
        with), if any.
    experiment
        The experiment's name (the run's manifest, or the experiment file's ``[experiment] name``).
    world
        The experiment's ``world.kind`` (:func:`world_kind_of` a manifest), if known.

    Returns
    -------
    The plan given, else the recorded one, else the plan named like the experiment, else its
    world's plan (:func:`default_plan_name`), else ``paper``.
    """
    if plan is not None:
        return plan
    if recorded:
        return recorded
    return default_plan_name(experiment or "", world)


def resolve_preset(name_or_path: str, kind: Literal["experiments", "analysis"]) -> Path:
    """A preset name or a TOML path -> an existing file, or a ``ConfigError`` with suggestions."""
    candidate = Path(name_or_path)
    a_folder = f"{name_or_path}: a folder, not a .toml file; give a preset name or a path to a .toml file"
    if candidate.suffix == ".toml" or candidate.is_file():
        if candidate.is_dir():  # a folder named x.toml is no missing file
            raise ConfigError(a_folder)
        if not candidate.is_file():
            raise ConfigError(f"{name_or_path}: no such file; give a preset name or a path to a .toml file")
        return candidate
    presets = list_presets(kind)
    if name_or_path in presets:  # a preset's name, even beside a folder of that name (a run's --out)
        return presets[name_or_path]
    if candidate.exists():
        raise ConfigError(a_folder)
    what = "an experiment" if kind == "experiments" else "an analysis plan"
    raise ConfigError(
        f"{name_or_path!r} is neither {what} preset nor a file{did_you_mean(name_or_path, presets)}; "
        f"presets: {', '.join(presets)} (see `nudge presets`)")


def read_toml(path: Path) -> dict[str, Any]:
    """Parse a TOML file, turning syntax errors into a ``ConfigError`` naming the file. A leading
    UTF-8 byte order mark (which Windows editors write) is skipped, as the CSV readers skip it.

    A file the command's own output folder keeps (:func:`~nudgecli.runs.batch_trust.reading_as_folder`)
    is checked against the SHA-256 its manifest records first: an experiment whose policy copies changed
    since kept is a ``DataError`` (:func:`~nudgecli.runs.batch_trust.own_copy_refusal`), and a kept input
    that does not parse is named as changed since the batch wrote it (its fix), not by the parse error;
    another folder's files, read to start a new run or batch, are read as any file."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read ({exc.strerror})") from exc
    beside = path.parent
    if path.name != PLAN_COPY and ((beside / MANIFEST).is_file() or (beside / BATCH_MANIFEST).is_file()):
        from nudgecli.runs.batch_trust import own_copy_refusal  # the folder's own experiment: its copies

        if (refusal := own_copy_refusal(path)) is not None:  # named before they are imported
            raise refusal
    try:
        return toml_of_bytes(data, path)
    except ConfigError:
        if (changed := _kept_input_changed(path)) is not None:  # a batch's copy damaged: its fix, not TOML's
            raise ConfigError(changed) from None
        raise


def _kept_input_changed(path: Path) -> str | None:
    """Why ``path``, an input a batch folder keeps beside its ``batch.json``, changed since the batch
    wrote it (:func:`nudgecli.runs.batch_trust.kept_input_changed`); ``None`` where it is no such input."""
    if not (path.parent / BATCH_MANIFEST).is_file():
        return None
    from nudgecli.runs.batch_trust import kept_input_changed, read_as_own  # the batch's record, read here

    return kept_input_changed(path) if read_as_own(path) else None


def toml_of_bytes(data: bytes, path: Path) -> dict[str, Any]:
    """:func:`read_toml` of the bytes ``data`` of the file ``path`` (a byte order mark skipped;
    errors name ``path``)."""
    try:
        text = data.decode("utf-8").removeprefix("\ufeff")  # tomllib reads a BOM as an invalid statement
    except UnicodeDecodeError as exc:  # TOML is UTF-8 (toml.io, "Spec"); say where the first bad byte is
        line = data.count(b"\n", 0, exc.start) + 1
        raise ConfigError(f"{path}: not UTF-8 text (byte 0x{data[exc.start]:02x} on line {line}); TOML files "
                          "are UTF-8: save it as UTF-8 in your editor") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: invalid TOML: {exc}") from exc


def parse_override(text: str) -> tuple[list[str], Any]:
    """``section.key=value`` -> (path, value); the value is read as a TOML literal, else a string.

    One assignment per ``--set``: a line break would let TOML read a second one (``2\\nb=3``), which
    was silently dropped.
    """
    if any(c in text for c in "\n\r"):
        first = text.splitlines()[0] if text.splitlines() else ""
        raise ConfigError(f"--set {first!r}...: one assignment per --set, on one line; give each its own "
                          "--set (e.g. --set study.participants=4 --set experiment.seed=3)")
    if "=" not in text:
        raise ConfigError(f"--set {text!r}: expected section.key=value, e.g. --set study.participants=4")
    key, raw = text.split("=", 1)
    path = settable_path(key)
    if path is None:
        raise ConfigError(f"--set {text!r}: name the section and the key, e.g. disambiguation.window=5")
    try:
        value = tomllib.loads(f"v = {raw.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw.strip()
    return path, value


def settable_path(key: str) -> list[str] | None:
    """The path of a key ``--set`` can set: ``"policies.threshold.params.weight"`` -> its parts.

    The one rule of what a settable key is, for ``--set`` and a sweep file's ``[parameters]``: the
    parts between dots, stripped, empty ones dropped; at least a section and a key, any depth below
    (a custom policy's ``policies.NAME.params.KEY``). ``None`` when fewer than two parts remain.
    Whether the key exists is the experiment's validation to say (with its "did you mean").
    """
    path = [part.strip() for part in key.strip().split(".") if part.strip()]
    return path if len(path) >= 2 else None


def apply_override(data: dict[str, Any], path: list[str], value: Any) -> None:
    node = data
    for part in path[:-1]:
        child = node.setdefault(part, {})
        if not isinstance(child, dict):
            raise ConfigError(f"--set {'.'.join(path)}: {part!r} is not a section")
        node = child
    node[path[-1]] = value


def validate_overridden(model: type[ModelT], data: dict[str, Any], overrides: Sequence[str],
                        refused: ConfigError | None = None, file_source: str = "") -> ModelT:
    """``data`` (a file's, checked on its own) with every ``--set`` applied, then validated once.

    The overrides make one setup together, whatever their order (the later of two of one key wins):
    a step on the way need not be valid (``study.start_modes=["x"]`` before
    ``study.blocks_per_condition=1``, 8 trials in 3 blocks). A problem that remains names the
    overrides at fault (:func:`_at_fault`), its field and its fix, in one line.

    ``refused`` is the file's refusal on its own, if it had one: the overrides may mend it (a file's
    ``gate = "none"`` beside ``gap = 0.3`` with ``--set blending.gate=gap``). Where a problem remains,
    it names the overrides when it lies at a place they write (:func:`_writes_at`: the mend
    taken, the override's own fault), else the file (``file_source``, its name), from the problem
    that remains, not the file's first refusal (advice the overrides may already have followed).
    """
    if refused is not None and not overrides:
        raise refused
    parsed = [(text, *parse_override(text)) for text in overrides]
    final = _overridden(data, parsed)
    try:
        return model.model_validate(final)
    except ValidationError as exc:
        near = [text for text, path, _ in parsed if _writes_at(path, exc)] if refused is not None else []
        if refused is not None and not near:  # the problem lies where no override writes: the file's
            raise ConfigError(format_validation_error(exc, file_source, model, final)) from None
        source = "--set " + " and ".join(near or _at_fault(model, data, parsed, _problem(exc)))
        raise ConfigError(format_validation_error(exc, source, model, final)) from None


def _writes_at(path: list[str], exc: ValidationError) -> bool:
    """Whether an override of ``path`` writes where the first problem of ``exc`` lies: its key holds
    the problem's place or lies in it (a section's own check: the field its message names first);
    an experiment-wide check (no place) is where it names the key (``study.rate_hz``)."""
    first = exc.errors()[0]
    place = [str(part) for part in first["loc"]]
    if not place:
        return ".".join(path) in str(first["msg"])
    head, sep, _ = str(first["msg"]).removeprefix("Value error, ").partition(": ")
    if first["type"] == "value_error" and sep and " " not in head:
        place.append(head)
    return path[:len(place)] == place[:len(path)]


def _overridden(data: dict[str, Any], parsed: Sequence[Override]) -> dict[str, Any]:
    """A copy of ``data`` with ``parsed`` applied in order."""
    copy = deepcopy(data)
    for _, path, value in parsed:
        apply_override(copy, path, value)
    return copy


def _problem(exc: ValidationError) -> tuple[Any, ...]:
    """The first problem of ``exc``: its place, kind and message (what its one line reports)."""
    first = exc.errors()[0]
    return tuple(first["loc"]), first["type"], first["msg"]


def _at_fault(model: type[BaseModel], data: dict[str, Any], parsed: Sequence[Override],
              problem: tuple[Any, ...]) -> list[str]:
    """The texts of the overrides at fault for ``problem``: each without which it goes or changes
    (not one a later override of the same key replaced); where none alone is (one value given
    twice), those whose key holds the problem's place or lies in it; else all of them."""
    alone = []
    for index, (text, _, _) in enumerate(parsed):
        try:
            model.model_validate(_overridden(data, [*parsed[:index], *parsed[index + 1:]]))
        except ValidationError as exc:
            if _problem(exc) == problem:
                continue
        except ConfigError:  # a later key inside a value only this one made a section
            pass
        alone.append(text)
    if alone:
        return alone
    place = [str(part) for part in problem[0]]
    near = [text for text, path, _ in parsed if path[:len(place)] == place[:len(path)]]
    return near or [text for text, _, _ in parsed]


def _section_type(annotation: Any) -> Any:
    """``annotation`` without ``| None`` (an optional section is its section)."""
    args = [arg for arg in get_args(annotation) if arg is not type(None)]
    is_union = get_origin(annotation) in (Union, UnionType)
    return args[0] if is_union and len(args) == 1 else annotation


def _walk(model: type[BaseModel], loc: tuple[Any, ...]) -> tuple[type[BaseModel], list[int]]:
    """The (nested) model at ``loc``, and the places in ``loc`` that name an entry of a table of
    sections (``[policies.NAME]``, a ``dict[str, Section]``: its key is a name, not a field)."""
    current, names, place = model, [], 0
    while place < len(loc):
        field = current.model_fields.get(loc[place]) if isinstance(loc[place], str) else None
        annotation = _section_type(field.annotation) if field is not None else None
        if get_origin(annotation) is dict and place + 1 < len(loc):
            annotation = _section_type(get_args(annotation)[1])
            names.append(place + 1)
            place += 1
        if not (isinstance(annotation, type) and issubclass(annotation, BaseModel)):
            break
        current, place = annotation, place + 1
    return current, names


def _field_names(model: type[BaseModel], loc: tuple[Any, ...]) -> list[str]:
    """The field names of the (nested) model at ``loc`` (for "did you mean"), less the internal ones
    a file never holds (``exclude``: not written out)."""
    current, _ = _walk(model, loc)
    return [field.alias or name for name, field in current.model_fields.items() if not field.exclude]


def _entry_hint(loc: tuple[Any, ...], model: type[BaseModel], data: Mapping[str, Any] | None) -> str:
    """``" (did you mean 'threshold'?)"`` where ``loc`` runs through an entry of a table of sections
    that another entry's name resembles (``policies.thresold``, new, beside ``policies.threshold``):
    a misspelt name makes a new entry, whose required keys are then missing."""
    _, names = _walk(model, loc)
    for place in names:
        table: Any = data
        for part in loc[:place]:
            table = table.get(part) if isinstance(table, Mapping) else None
        if isinstance(table, Mapping):
            hint = did_you_mean(str(loc[place]), [name for name in table if name != loc[place]])
            if hint:
                return f"; {str(loc[place])!r} is no entry of {'.'.join(map(str, loc[:place]))} yet{hint}"
    return ""


def format_validation_error(exc: ValidationError, source: str, model: type[BaseModel],
                            data: Mapping[str, Any] | None = None) -> str:
    """One readable line naming the file, the field and the fix (``data``: what was validated, for
    the "did you mean" of a misspelt entry name of a table of sections, :func:`_entry_hint`)."""
    first = exc.errors()[0]
    if first["type"] == "missing":  # a misspelt required key: the unknown key beside it is the fix
        first = next((e for e in exc.errors() if e["type"] == "extra_forbidden"
                      and tuple(e["loc"])[:-1] == tuple(first["loc"])[:-1]), first)
    loc = tuple(first["loc"])
    where = ".".join(str(p) for p in loc)
    if first["type"] == "extra_forbidden":
        names = _field_names(model, loc[:-1])
        hint = did_you_mean(str(loc[-1]), names)
        return f"{source}: unknown key {where!r}{hint or '; known keys: ' + ', '.join(names)}"
    message = problem_words(first)
    value = first.get("input")
    # a section's own check names its field first ("participants: ..."): that is the field's place
    head, sep, rest = message.partition(": ")
    if first["type"] == "value_error" and sep and head in _field_names(model, loc) and head not in loc:
        where, message = f"{where}.{head}" if where else head, rest
    listed = _field_at(model, loc[:-1]) if loc and isinstance(loc[-1], int) else None  # an item's list
    house = _house_words(first, where, source, _field_at(model, loc), listed)
    if house is not None:
        message = house
    elif first["type"] in ("tuple_type", "list_type"):  # TOML has lists; "tuple" is pydantic's word
        what = message if message.startswith("should be a list") else "should be a list"
        example = list_example(value, _field_at(model, loc))
        message = f"{what}, e.g. {_as_set(where, example) if source.startswith('--set ') else example}"
    elif first["type"] == "missing" and loc and isinstance(loc[-1], int):
        where = ".".join(str(p) for p in loc[:-1])  # "rest_s.1: Field required": a value too few
        message = "too few values"
    elif first["type"] == "missing":
        message += _entry_hint(loc, model, data)
    shown = "" if isinstance(value, dict) else f" (got {as_written(value)})"
    more = f" (and {len(exc.errors()) - 1} more problem(s))" if len(exc.errors()) > 1 else ""
    return f"{source}: {where + ': ' if where else ''}{message}{shown}{more}"


def _house_words(problem: Mapping[str, Any], where: str, source: str, field: Any,
                 listed: Any = None) -> str | None:
    """A problem of a wrong kind in the house's words with an example of the right one (a choice not
    among the field's, text given as a number, a list where a table goes, too many values, a TOML
    date where a number goes, anything but true or false for a strict flag); ``None`` for any other
    problem. ``listed``: the list field of which ``where`` is an item, whose example is then the
    whole list (``--set KEY.1=...`` is no key)."""
    kind, value = problem["type"], problem.get("input")
    key = where.rsplit(".", 1)[-1] if where else "key"
    as_set = source.startswith("--set ")

    def example(written: str) -> str:
        parent, _, index = where.rpartition(".")
        if index.isdigit() and parent and listed is not None:  # an item: the example gives the list
            whole = list_example(None, listed)
            return _as_set(parent, whole) if as_set else f"{parent.rsplit('.', 1)[-1]} = {whole}"
        return _as_set(where, written) if as_set else f"{key} = {written}"

    if kind == "literal_error":
        choices = _choices(problem, field)
        shown = [repr(c) if isinstance(c, str) else toml_value(c) for c in choices]  # 'exact', 3
        listed = " or ".join(filter(None, [", ".join(shown[:-1]), shown[-1]]))
        texts = [c for c in choices if isinstance(c, str)]
        return f"should be {listed}{closest_choice(value, texts) if isinstance(value, str) else ''}"
    if kind == "string_type":  # as the user wrote it, in quotes (true, not Python's True)
        quoted = toml_value(as_written(value) if isinstance(value, int | float | bool) else "text")
        parent, _, index = where.rpartition(".")
        if index.isdigit() and parent:  # an item of a list: the example gives the list
            listed = f"[{quoted}]"
            return "should be text, in quotes: e.g. " + (
                _as_set(parent, listed) if as_set else f"{parent.rsplit('.', 1)[-1]} = {listed}")
        return f"should be text, in quotes: e.g. {example(quoted)}"
    if kind in ("int_type", "float_type", "int_parsing", "float_parsing") and isinstance(value, date | time):
        number = "a whole number" if kind.startswith("int") else "a number"
        return f"should be {number}, not a TOML date or time: e.g. {example(_number_example(field))}"
    if kind in ("model_type", "dict_type"):
        table = f"[{where}]" if where else "a table"
        fix = (f"set its keys, e.g. --set {where or 'SECTION'}.KEY=VALUE" if as_set
               else f"write {table} once, its keys below it, one per line")
        return f"should be a table of keys (not a list, nor [[{where}]]): {fix}"
    if kind in ("bool_type", "bool_parsing"):  # a strict flag (a sweep range's integer): no "yes", no 1
        return f"should be true or false (no quotes), e.g. {example('true')}"
    if kind == "finite_number":  # inf or nan: no value a setting or a maximum can take
        return f"should be a finite number (not inf or nan), e.g. {example(_number_example(field))}"
    if kind in ("too_long", "too_short"):
        limit = problem.get("ctx", {}).get("max_length" if kind == "too_long" else "min_length")
        most = "at most" if kind == "too_long" else "at least"
        written = example(list_example(None, field))
        return f"too {'many' if kind == 'too_long' else 'few'} values: give {most} {limit}, e.g. {written}"
    return None


def _number_example(field: Any) -> str:
    """A number for ``field``'s example: its default where that is a finite number, else ``10``."""
    default = field.get_default() if field is not None and not field.is_required() else None
    if isinstance(default, int | float) and not isinstance(default, bool) and abs(default) < float("inf"):
        return toml_value(default)
    return "10"


def _choices(problem: Mapping[str, Any], field: Any) -> list[Any]:
    """The values a choice field takes: its ``Literal``'s, else those pydantic's message names (an
    item of a list: ``'x', 'y' or 'theta'``; a number there is unquoted)."""
    annotation = _section_type(field.annotation) if field is not None else None
    if get_origin(annotation) is Literal:
        return list(get_args(annotation))
    expected = str(problem.get("ctx", {}).get("expected", ""))
    return [_item_value(part.strip()) if not part.strip().startswith("'") else part.strip().strip("'")
            for part in re.split(r",| or ", expected) if part.strip()]


def closest_choice(value: Any, choices: Sequence[str]) -> str:
    """``" (did you mean 'williams'?)"``: the choice ``value`` names but for case, else the closest
    (:func:`~nudgecli.errors.did_you_mean`, compared case-insensitively), else ``""``."""
    folded = {choice.casefold(): choice for choice in choices}
    text = str(value).strip().casefold()
    if text in folded:
        return f" (did you mean {folded[text]!r}?)"
    hint = did_you_mean(text, folded)
    match = re.fullmatch(r" \(did you mean '(.*)'\?\)", hint)
    return f" (did you mean {folded[match.group(1)]!r}?)" if match else hint


#: pydantic's bound checks (``Field(ge=..)`` etc.) in the house's words, the bound from their ``ctx``.
_BOUNDS = {"greater_than_equal": "must be at least {}", "greater_than": "must be greater than {}",
           "less_than_equal": "must be at most {}", "less_than": "must be less than {}"}


def problem_words(problem: Mapping[str, Any]) -> str:
    """One problem of a ``ValidationError`` (an item of its ``errors()``) in the house's words: a
    bound as ``must be at most 10000``, a validator's own message without pydantic's prefix."""
    if problem["type"] in _BOUNDS:
        return _BOUNDS[problem["type"]].format(*problem.get("ctx", {}).values())
    return str(problem["msg"]).removeprefix("Value error, ")


def _field_at(model: type[BaseModel], loc: tuple[Any, ...]) -> Any:
    """The field at ``loc`` in ``model`` (``None`` where ``loc`` names no field)."""
    if not loc or not isinstance(loc[-1], str):
        return None
    return _walk(model, loc[:-1])[0].model_fields.get(loc[-1])


def list_example(value: Any, field: Any) -> str:
    """A list for a field that was given ``value``, not a list, as TOML writes it: the items
    ``value`` names where they fit the field (``"[tr]"`` and ``"tr,bl"`` -> ``["tr"]``, ``["tr",
    "bl"]``: a text item quoted, as a shell drops the quotes of ``["tr"]``), else the field's
    default, else a list of its item type (``[0.5, 1.0]``)."""
    item, length = _item_type(field.annotation) if field is not None else (float, None)
    text = str(value).strip().removeprefix("[").removesuffix("]") if isinstance(value, str) else None
    named = [_item_value(part.strip().strip("'\"")) for part in (text or "").split(",") if part.strip()]
    numbers = admits(item, float) or admits(item, int)
    choices = get_args(item) if get_origin(item) is Literal else ()
    if isinstance(value, int | float) and not isinstance(value, bool) and numbers:
        named = [value]
    fits = all(isinstance(v, str) != numbers and (not choices or v in choices) for v in named)
    if named and fits and length in (None, len(named)):
        return toml_value(named)
    # a default_factory field's default is made by calling it (get_default() alone: PydanticUndefined)
    default = field.get_default(call_default_factory=True, validated_data={}) \
        if field is not None and not field.is_required() else None
    if default and isinstance(default, list | tuple):
        return toml_value(list(default))
    return toml_value(list(choices[:2]) if choices else [0.5, 1.0] if numbers else ["a", "b"])


def _item_type(annotation: Any) -> tuple[Any, int | None]:
    """The type of the items of a list or tuple field (``float`` where it is no sequence) and their
    number where it is fixed (``tuple[float, float]``: 2)."""
    annotation = _section_type(annotation)
    args = get_args(annotation)
    if get_origin(annotation) not in (tuple, list) or not args:
        return float, None
    fixed = get_origin(annotation) is tuple and Ellipsis not in args
    return args[0], len(args) if fixed else None


def _item_value(text: str) -> Any:
    """One item a text names: a number as TOML reads it, else the text."""
    try:
        read = tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text
    return read if isinstance(read, int | float) and not isinstance(read, bool) else text


def _as_set(key: str, example: str) -> str:
    """``--set KEY=EXAMPLE`` as a shell reads it back (quoted: a shell drops a bare ``"``)."""
    return shell_words(["--set", f"{key}={example}"])


def as_written(value: Any) -> str:
    """``value`` as a user writes it in TOML or ``--set``: ``150.0``, ``"abc"``, ``[0.5, 1.0]``,
    ``true`` (JSON's spelling, which TOML shares for these), not ``np.float64(150.0)`` or ``True``."""
    try:
        return json.dumps(plain(value), ensure_ascii=False)
    except (TypeError, ValueError):  # not JSON: a date as TOML writes it, else Python's spelling
        return value.isoformat() if isinstance(value, date | time) else repr(plain(value))


def dump_toml(data: dict[str, Any]) -> str:
    """A small TOML writer for nested dicts of scalars and lists (what our configs hold).

    A dict is a table ``[a]``, a dict inside it ``[a.b]`` (a table holding only tables gets no
    header of its own), and so on at any depth; a dict inside a list an inline table. What it
    writes, ``tomllib`` reads back as ``data`` (a test checks any text as a key or a string).
    """
    lines: list[str] = []
    _dump_table(data, (), lines)
    return "\n".join(lines) + "\n"


def _dump_table(table: dict[str, Any], path: tuple[str, ...], lines: list[str]) -> None:
    scalars = {k: v for k, v in table.items() if not isinstance(v, dict)}
    if path and (scalars or len(scalars) == len(table)):
        if lines:
            lines.append("")
        lines.append(f"[{'.'.join(toml_key(part) for part in path)}]")
    for key, value in scalars.items():
        lines.append(f"{toml_key(key)} = {toml_value(value)}")
    for key, value in table.items():
        if isinstance(value, dict):
            _dump_table(value, (*path, key), lines)


#: TOML's escapes in a basic string: the backslash, the quotation mark and every control character
#: (U+0000-U+001F, U+007F), the usual ones by their short escape and the others as ``\u`` and
#: four hexadecimal digits (``\u001B``).
_STRING_ESCAPES = {**{code: f"\\u{code:04X}" for code in [*range(0x20), 0x7F]},
                   **{ord(c): e for c, e in {"\\": "\\\\", '"': '\\"', "\b": "\\b", "\t": "\\t",
                                               "\n": "\\n", "\f": "\\f", "\r": "\\r"}.items()}}
_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def toml_key(key: str) -> str:
    """``key`` as a TOML key: bare where it is one (``A-Za-z0-9_-``), else a quoted string."""
    return key if _BARE_KEY.fullmatch(key) else _toml_string(key)


def _toml_string(text: str) -> str:
    return f'"{text.translate(_STRING_ESCAPES)}"'


def toml_value(value: Any) -> str:
    """``value`` as TOML writes it: the one rendering of a value, for :func:`dump_toml` and for a
    ``--set`` text built from a value (a sweep's point); a dict is an inline table."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return int.__repr__(value)
    if isinstance(value, float):
        return float.__repr__(value)  # inf, nan and 1e+16 are TOML's spelling too
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, datetime | date | time):
        return value.isoformat()
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{toml_key(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")
