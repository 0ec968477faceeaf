"""The policy modules a run keeps: an exact copy of each file of a researcher's own policies that the
experiment imported from its folder, so that the run folder is self-contained.

A run of ``experiments/custom-policy.toml`` imports ``policies.threshold`` from
``experiments/policies/threshold.py`` (:mod:`nudgecli.sim.policy_loader`). The run folder ``R``
keeps that file's bytes as ``R/policies/threshold.py`` (the same path relative to the folder) and
its SHA-256 in the manifest (:data:`MANIFEST_KEY`), and so each module of the folder its code
imports relatively, however late (:func:`package_files`). Its ``R/config.toml`` then finds the copy
where it finds any policy module, beside itself, so the resume command every damaged or
interrupted run prints (``nudge simulate R/config.toml --out R ... --resume``) works from any
folder. A resume whose modules differ from the recorded ones is refused naming the file: its
trials would be a mix of two policies. This is the people file's rule
(:func:`nudgecli.sim.people_file.keep_copy`) for policy code.

A factory imported from elsewhere (a module on ``sys.path``, a class of the calling script,
``__main__``) is not copied: the manifest records its SHA-256 only (:data:`SOURCES_KEY`, the
module's file, or the class's source in ``__main__``), and a resume with another one is refused
the same way (:func:`check_same_policy_sources`).
"""

from __future__ import annotations

import ast
import contextlib
import hashlib
import inspect
import os
import sys
import textwrap
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nudgecli.errors import ConfigError, DataError, PolicyError, RunFolderError, did_you_mean
from nudgecli.run_folder_names import BATCH_MANIFEST, CONFIG, FIGURES_DIR, MANIFEST, PART_KINDS, PEOPLE_DIR
from nudgecli.sim.policy_loader import imported_files, module_file, remove_cached_bytecode
from nudgecli.sim.policy_registry import PolicySpec, load_factory, policy_specs

if TYPE_CHECKING:
    from nudgecli.config import ExperimentConfig

#: The manifest's record of the copies: ``{relative path: SHA-256}``.
MANIFEST_KEY = "policy_files"
#: The manifest's record of the factories imported from elsewhere: ``{module: SHA-256 of its file}``,
#: ``{"__main__:Attr": SHA-256 of its source}`` for one of the calling script.
SOURCES_KEY = "policy_sources"
#: The run folder's own folders, which a policy package of the same name would write into.
RUN_FOLDERS = frozenset({PEOPLE_DIR, FIGURES_DIR, "calibration", *PART_KINDS})


def loaded_policy_files(config: ExperimentConfig, own_folders: frozenset[str] = RUN_FOLDERS,
                        kind: str = "run") -> dict[str, bytes]:
    """The files of the experiment's own policy modules imported from its folder, by their path
    relative to the folder (``policies/threshold.py``, POSIX separators) -> their bytes; empty
    without such modules (none of its own, or all imported from ``sys.path``).

    Each condition's factory is imported first (an edited file afresh, as the experiment's checks
    do), so the files are those the run will run. ``own_folders`` are the folders of the ``kind``
    of folder that keeps the copies (a run's, :data:`RUN_FOLDERS`; a batch's,
    :data:`nudgecli.runs.batch_folder.BATCH_FOLDERS`).

    Raises
    ------
    PolicyError
        A module that does not import (:func:`~nudgecli.sim.policy_registry.load_factory`).
    ConfigError
        A module whose top folder is named like one of ``own_folders`` (a run's ``trials``,
        ``people``, ...): its copy would be written among the folder's own files.
    """
    specs = policy_specs(config)
    folder = config.policy_search_path
    if folder is None or not specs:
        return {}
    for spec in specs:
        _load(spec)
    base = Path(folder).resolve()
    files: dict[str, bytes] = {}
    for path in package_files(base, imported_files(folder)):
        relative = path.relative_to(base)
        if relative.parts[0] in own_folders:
            top = relative.parts[0]
            raise ConfigError(f"{path}: a policy package named {top!r} would be copied into the {kind} "
                              f"folder's own {top}/; rename the package (and its factory's "
                              "module) in the experiment's folder")
        files[relative.as_posix()] = path.read_bytes()
    return files


#: The most module files of the folder a policy's modules may import: a run copies and hashes them all.
MAX_PACKAGE_FILES = 300


def package_files(base: Path, imported: list[Path]) -> list[Path]:
    """The module files under the folder ``base`` that a run keeps: the ``imported`` ones and the
    folder's modules their code imports relatively (``from .common import W``, ``from . import
    common``), transitively and wherever the import is (inside a method too: it runs only as the
    policy does), with the packages above each (their ``__init__.py``). An absolute import is
    looked up on ``sys.path``, as the loader does (the folder is not on it), so it names no module
    of the folder. A file is kept by its path inside the folder, a link to a file outside it too
    (its target's bytes); a name that is no regular file is left out. Sorted.

    Raises
    ------
    ConfigError
        More than :data:`MAX_PACKAGE_FILES` module files.
    """
    found: set[Path] = set()
    pending = [path for path in map(_inside_folder, imported, [base] * len(imported)) if path is not None]
    while pending:
        path = pending.pop()
        if path in found:
            continue
        found.add(path)
        if len(found) > MAX_PACKAGE_FILES:
            raise ConfigError(f"{base}: the policy's modules import more than the {MAX_PACKAGE_FILES} "
                              "module files of the folder a run copies and hashes (each one imported, "
                              "relatively, however late); keep the policy in a package of its own beside "
                              "the experiment file")
        pending += [module for module in _relative_imports(base, path) if module not in found]
    return sorted(found)


def _inside_folder(path: Path, base: Path) -> Path | None:
    """``path`` without ``..`` and with its links kept (the name the folder's tree has for it), when
    it lies under ``base`` and is a regular file (a link's target is); else ``None``."""
    inside = Path(os.path.abspath(path))
    return inside if inside.is_relative_to(base) and inside.is_file() else None


def _relative_imports(base: Path, path: Path) -> list[Path]:
    """The files under ``base`` that the module file ``path`` of it imports relatively, as Python
    resolves them in the folder's private package (:mod:`nudgecli.sim.policy_loader`): the named
    module, the packages above it, and each imported name that is a module of its own."""
    try:
        tree = ast.parse(path.read_bytes(), str(path))
    except (SyntaxError, ValueError, OSError):  # it would not import either: nothing it imports
        return []
    parts = path.relative_to(base).parts
    package = list(parts[:-1])  # a module's package; an __init__.py's is its own folder
    files: list[Path] = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.ImportFrom) or node.level < 1 or node.level - 1 > len(package):
            continue  # an absolute import (sys.path's), or one above the folder (it fails)
        target = package[:len(package) - (node.level - 1)] + (node.module.split(".") if node.module else [])
        names = [target[:end] for end in range(1, len(target) + 1)]
        names += [[*target, alias.name] for alias in node.names if alias.name != "*"]
        for name in names:
            found = module_file(str(base), ".".join(name))
            kept = None if found is None else _inside_folder(found, base)
            if kept is not None:
                files.append(kept)
    return files


def _load(spec: PolicySpec) -> object:
    """:func:`load_factory`; a factory of ``__main__`` that is not there says where it can run: a
    run's or batch's own experiment (``R/config.toml``, resumed) from the script that started it,
    any other from the script that defines it; a misspelt one only its "did you mean"."""
    try:
        return load_factory(spec)
    except PolicyError as exc:
        module, _, attribute = spec.factory.partition(":")
        script, name = sys.modules.get("__main__"), attribute.split(".")[0]
        if module != "__main__" or hasattr(script, name):  # not a missing policy of the calling script
            raise
        folder = None if spec.search_path is None else Path(spec.search_path)
        if folder is not None and ((folder / MANIFEST).is_file() or (folder / BATCH_MANIFEST).is_file()):
            how = ("resume the run from the script that started it (nudgecli.simulate(..., resume=True)), "
                   "or move the policy into a module beside the experiment file")
        elif did_you_mean(name, [known for known in dir(script) if not known.startswith("_")]):
            raise  # a misspelt name: its "did you mean" says it all
        else:
            how = ("run the experiment from that script (nudgecli.simulate), or move the policy into a "
                   "module beside the experiment file")
        raise PolicyError(f"{exc}: a policy of the calling script (__main__) exists only while that script "
                          f"runs; {how} (docs/policies.md)") from exc


def outside_policy_sources(config: ExperimentConfig) -> dict[str, str]:
    """The manifest's :data:`SOURCES_KEY` entry: the experiment's own factories whose module is not
    in its folder (so not copied, :func:`loaded_policy_files`), each module -> the SHA-256 of its
    file; a factory of ``__main__`` (the calling script) as ``__main__:Attr`` -> the SHA-256 of its
    source (:func:`script_policy_source`). Empty without such.

    Raises
    ------
    PolicyError
        A factory of ``__main__`` whose source Python cannot show (a script read from stdin,
        ``python - < study.py``, or code run by ``exec``): a run of it could never be resumed (a
        resume could not check it runs the same policy), so it is refused before any work.
    """
    record: dict[str, str] = {}
    for spec in policy_specs(config):
        factory = _load(spec)
        name = spec.factory.partition(":")[0]
        if config.policy_search_path is not None and module_file(config.policy_search_path, name) is not None:
            continue
        if name == "__main__":
            source = script_policy_source(factory)
            if source is None:
                raise PolicyError(f"{spec.described}: Python cannot show the source of this policy of "
                                  "the calling script (a script read from stdin, python - < script.py, or "
                                  "code run by exec), so its run could never be checked and resumed; put the "
                                  "policy in a file: a script run as python script.py, or a module beside "
                                  "the experiment file (docs/policies.md)")
            record[spec.factory] = hashlib.sha256(source.encode()).hexdigest()
            continue
        path = getattr(sys.modules.get(name), "__file__", None)
        if path is not None and Path(path).is_file():
            record[name] = hashlib.sha256(Path(path).read_bytes()).hexdigest()
    return dict(sorted(record.items()))


def script_policy_source(factory: object) -> str | None:
    """The source of a factory of the calling script (``__main__``), what a run records the digest
    of: ``inspect.getsource``; for a class whose own source Python cannot find but whose methods'
    it can (a notebook's cell: Python looks for a class in its module's file, which a notebook's
    ``__main__`` lacks), its name, its methods' sources and its other attributes' values, in name
    order; ``None`` where neither is there (a script read from stdin, code run by ``exec``). Then
    the script's globals its code reads (:func:`_script_globals_read`), where it reads any."""
    source = _own_source(factory)
    if source is None:
        return None
    read = _script_globals_read(factory)
    return "\n".join([source, *read]) if read else source


def _script_globals_read(factory: object) -> list[str]:
    """The script-level names the factory's code reads (a function's, or a class's methods'), and
    those the script's functions and classes it reads read in turn, in name order, that an edit of
    the script could change without changing the factory's code: a constant (``W = 0.3``; None, a
    bool, a number, a string, or a list or tuple of them) and a function or class the script
    defines (its source). Its imports (modules, nudge's classes) are not the script's to change;
    other objects are left out (their value shows no stable text)."""
    script = vars(sys.modules["__main__"]) if "__main__" in sys.modules else {}
    read: dict[str, str] = {}
    pending, seen = [factory], {id(factory)}
    while pending:
        names: set[str] = set()
        for item in _callables(pending.pop()):
            names |= _global_names(item)
        for name in names - set(read):
            value = script.get(name, factory)
            if id(value) in seen:
                continue
            if (inspect.isfunction(value) or inspect.isclass(value)) and value.__module__ == "__main__":
                with contextlib.suppress(OSError, TypeError):
                    read[name] = inspect.getsource(value)
                seen.add(id(value))
                pending.append(value)
            elif _plain(value):
                read[name] = f"{name} = {value!r}"
    return [read[name] for name in sorted(read)]


def _global_names(item: object) -> set[str]:
    """The global names the function ``item`` (its nested functions and comprehensions too) reads:
    its code's names (``co_names``), less those its source uses only as an attribute's (``step``
    of ``view.step``), where Python can show its source."""
    names: set[str] = set()
    codes = [_code_of(item)]
    while codes:  # nested functions and comprehensions are code objects among the constants
        code = codes.pop()
        if code is not None:
            names.update(code.co_names)
            codes += [const for const in code.co_consts if inspect.iscode(const)]
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(item)))  # type: ignore[arg-type]
    except (OSError, TypeError, SyntaxError):  # no source (a lambda's line may not parse alone)
        return names
    return names & {node.id for node in ast.walk(tree) if isinstance(node, ast.Name)}


def _callables(item: object) -> list[object]:
    """A function, or a class's methods (static and class methods, properties' getters)."""
    if isinstance(item, type):
        return [getattr(value, "__func__", getattr(value, "fget", value)) for value in vars(item).values()]
    return [item]


def _code_of(item: object) -> Any:
    return item.__code__ if inspect.isfunction(item) else None


def _own_source(factory: object) -> str | None:
    """:func:`script_policy_source` of the factory's own code."""
    try:
        return inspect.getsource(factory)  # type: ignore[arg-type]
    except (OSError, TypeError):
        if not isinstance(factory, type):
            return None
    parts = [f"class {factory.__qualname__}"]
    for name, value in sorted(vars(factory).items()):
        code = getattr(value, "__func__", getattr(value, "fget", value))  # a static/class method, a property
        if inspect.isfunction(code):
            try:
                parts.append(inspect.getsource(code))
            except (OSError, TypeError):
                return None
        elif not name.startswith("__"):  # a set's order is the hash seed's: its items sorted
            shown = sorted(map(repr, value)) if isinstance(value, set | frozenset) else value
            parts.append(f"{name} = {shown!r}" if _plain(shown) else f"{name}: {type(value).__name__}")
    return "\n".join(parts)


def _plain(value: object) -> bool:
    """Whether ``repr(value)`` is the same in every process: no object's address in it."""
    if isinstance(value, list | tuple):
        return all(_plain(item) for item in value)
    return value is None or isinstance(value, bool | int | float | str)


def script_resume_call(manifest: Mapping[str, Any], experiment: str, folder: str | Path, seed: object,
                       participants: object, people: str | None) -> str | None:
    """The Python call that resumes the run ``folder`` whose manifest records a policy of the
    calling script (``__main__:Attr`` in :data:`SOURCES_KEY`): ``nudgecli.simulate(EXPERIMENT,
    out=..., resume=True)`` run from the script that defines it, the one place that policy exists
    (a ``nudge simulate`` command cannot import it); ``None`` for any other run. A run whose last
    part ran on a dask scheduler is resumed there: ``scheduler='ADDRESS'`` (as the command's
    ``--scheduler ADDRESS``, :func:`~nudgecli.run_folder_state.resume_scheduler`; a string, as the
    call's other values are printed, so that the call pasted is Python), for without it the call
    would run on local workers."""
    from nudgecli.run_folder_state import resume_scheduler  # it builds on the run folder modules

    sources = manifest.get(SOURCES_KEY)
    own = sorted(str(name) for name in sources if str(name).startswith("__main__:")) \
        if isinstance(sources, Mapping) else []
    if not own:
        return None
    options = [f"{key}={value!r}" for key, value in (("seed", seed), ("participants", participants),
                                                     ("people", people)) if value is not None]
    scheduler = resume_scheduler(manifest)  # a placeholder, as PLAN in other Python advice: the address
    options += [f"scheduler={scheduler!r}"] if scheduler is not None else []
    arguments = ", ".join([repr(str(experiment)), f"out={str(folder)!r}", *options, "resume=True"])
    return (f"nudgecli.simulate({arguments})  # in the script that defines {', '.join(own)}: a nudge "
            "command cannot import a policy of the calling script")


def check_same_policy_sources(recorded: object, now: Mapping[str, str], where: str | Path,
                              kind: str = "run") -> None:
    """Refuse to resume the run (or the batch, ``kind``) ``where`` when a factory imported from
    outside the experiment's folder (:func:`outside_policy_sources`) is not the one it was simulated
    with; ``recorded`` not a mapping (a folder of an older nudge, or one without such factories):
    nothing to compare.

    Raises
    ------
    DataError
        The first module (by name) whose SHA-256 differs, or that one side lacks.
    """
    if not isinstance(recorded, Mapping):
        return
    for name in sorted({*map(str, recorded), *now}):
        if recorded.get(name) == now.get(name) != "unknown":
            continue
        module = sys.modules.get(name.partition(":")[0])
        shown = getattr(module, "__file__", None) or name
        if name.startswith("__main__:"):
            what = (f"{where} recorded no source of {name}, the calling script's policy (an older nudge ran "
                    "it without one), so it cannot check it is the one it was simulated with"
                    if recorded.get(name) == "unknown" else
                    f"{name} ({shown}) is not the policy {where} was simulated with (its source's SHA-256 "
                    "differs from the manifest's)")
        elif name not in now:
            what = (f"{where} was simulated with the policy module {name}, which its experiment no longer "
                    "imports")
        else:
            what = (f"{shown} is not the policy module {where} was simulated with (its SHA-256 differs from "
                    "the manifest's; nudge keeps no copy of a module imported from sys.path)")
        raise DataError(f"{what}: resuming would mix two policies in one {kind}; put the module back as it "
                        "was and resume, or start again with --force")


def record_policies(manifest: dict[str, Any], files: Mapping[str, bytes], sources: Mapping[str, str]) -> None:
    """Set the manifest's :data:`MANIFEST_KEY` (:func:`policy_record` of ``files``) and
    :data:`SOURCES_KEY` (``sources``, :func:`outside_policy_sources`) entries; either is left out
    when empty (the paper's runs have neither)."""
    for key, entry in ((MANIFEST_KEY, policy_record(files)), (SOURCES_KEY, dict(sources))):
        if entry:
            manifest[key] = entry
        else:
            manifest.pop(key, None)


def check_resumed_policies(manifest: Mapping[str, Any], files: Mapping[str, bytes],
                           sources: Mapping[str, str], source: str | None, where: str | Path,
                           started: bool) -> list[str]:
    """Refuse to resume the run ``where`` (its ``manifest``) with other policy code than it was
    simulated with (:func:`check_same_policy_files`, :func:`check_same_policy_sources`) once a
    participant has finished (``started``). Before, there is nothing to mix: the run takes the code
    the experiment imports now (a policy that raised in the first participant, fixed), the copies it
    no longer imports are removed, and the returned note (empty when nothing changed) says so.
    """
    if started:
        check_same_policy_files(manifest.get(MANIFEST_KEY), files, source, where)
        check_same_policy_sources(manifest.get(SOURCES_KEY), sources, where)
        return []
    recorded = manifest.get(MANIFEST_KEY)
    if (recorded or {}) == policy_record(files) and (manifest.get(SOURCES_KEY) or {}) == dict(sources):
        return []
    if isinstance(recorded, Mapping):
        remove_policy_copies(where, {name: digest for name, digest in recorded.items() if name not in files})
    return [f"{where}: no participant had finished, so the run is resumed with its policy code as the "
            "experiment imports it now (its copies replaced)"]


def policy_record(files: Mapping[str, bytes]) -> dict[str, str]:
    """The manifest's :data:`MANIFEST_KEY` entry of ``files``: relative path -> SHA-256 (hex)."""
    return {name: hashlib.sha256(data).hexdigest() for name, data in sorted(files.items())}


def check_same_policy_files(recorded: object, files: Mapping[str, bytes], source: str | None,
                            where: str | Path, kind: str = "run") -> None:
    """Refuse to resume the run (or the batch, ``kind``) ``where`` with policy modules other than it
    was simulated with.

    Parameters
    ----------
    recorded
        The manifest's :data:`MANIFEST_KEY` entry, read from disk; not a mapping (a run without
        policies of its own, or of an older nudge that kept no copies): nothing to compare.
    files
        The modules the experiment now loads (:func:`loaded_policy_files`).
    source
        The folder they are loaded from (the experiment file's), to name the file.
    where
        The run folder (the batch folder).
    kind
        ``run`` or ``batch``: which folder it is (a run is resumed with its own ``config.toml``,
        which imports the copies; a batch with its experiment).

    Raises
    ------
    DataError
        The first file (by its relative path) whose SHA-256 differs, or that one side lacks.
    """
    if not isinstance(recorded, Mapping):
        return
    missing = missing_copies(recorded, where)
    if missing and _same_path(Path(source or "."), Path(where)):  # resumed from the run's own copies
        raise missing_copy_error(missing[0], where, kind)
    now = policy_record(files)
    for name in sorted({*map(str, recorded), *now}):
        if recorded.get(name) == now.get(name):
            continue
        shown = Path(source or ".") / name
        if name not in now:
            what = (f"{where} was simulated with the policy module {name}, which its experiment no longer "
                    "imports")
        elif name not in recorded:
            what = f"{shown} is a policy module the {kind} was not simulated with"
        else:
            what = (f"{shown} is not the policy module {where} was simulated with (its SHA-256 differs from "
                    "the manifest's)")
        copy = Path(where) / name
        if _same_path(shown, copy):  # the copy itself was edited (resumed from the folder's own files)
            fix = _changed_copy_fix(kind)
        else:
            how = "resume with the run's own config.toml" if kind == "run" else "resume"
            fix = f"put the file back as it was (copy it from the {kind}'s copy, {copy}) and {how}"
        raise DataError(f"{what}: resuming would mix two policies in one {kind}; {fix}, or start again "
                        "with --force")


def _changed_copy_fix(kind: str) -> str:
    """How a ``kind`` (run or batch) folder's policy copy edited since it was kept is put right."""
    return (f"delete it and resume with the command that started the {kind} (it imports the module from "
            "the experiment's own folder and writes the copy again), or copy the module back from the "
            "experiment's own folder")


def changed_copy_error(experiment: Path) -> DataError | None:
    """The refusal of the experiment file ``experiment`` of a run's or a batch's folder (its
    ``config.toml``; a batch's kept experiment or sweep file) whose policy copies (the manifest's
    :data:`MANIFEST_KEY`) are not all as kept: checked before the experiment imports them, so a copy
    emptied or cut off is named as changed with its fix, not by what importing it raises. A run
    none of whose participants finished is left alone (it takes the code as it is now:
    :func:`check_resumed_policies`); ``None`` where nothing differs (or nothing is recorded)."""
    import json

    folder = experiment.parent
    run = experiment.name == CONFIG
    kind, record = ("run", folder / MANIFEST) if run else ("batch", folder / BATCH_MANIFEST)
    try:
        manifest = json.loads(record.read_text(encoding="utf-8"))
        recorded = {str(name): str(digest) for name, digest in manifest[MANIFEST_KEY].items()}
    except (OSError, ValueError, LookupError, TypeError, AttributeError):  # none kept, or its own refusal
        return None
    if kind == "run" and not manifest.get("checksums"):
        return None
    for name, digest in sorted(recorded.items()):
        copy = folder / name
        with contextlib.suppress(OSError):  # a copy gone: missing_copies' refusal, where it matters
            if hashlib.sha256(copy.read_bytes()).hexdigest() != digest:
                return DataError(f"{copy}: changed since the {kind} kept it (its SHA-256 differs from the "
                                 f"one {record} records in {MANIFEST_KEY!r}), so {experiment} would not "
                                 f"import the policy the {kind} was simulated with; "
                                 f"{_changed_copy_fix(kind)}, or start again with --force")
    return None


def missing_copies(recorded: object, where: str | Path) -> list[str]:
    """The policy copies the manifest's :data:`MANIFEST_KEY` entry ``recorded`` lists that are not
    in the folder ``where`` (deleted), by their relative path."""
    if not isinstance(recorded, Mapping):
        return []
    return [name for name in sorted(map(str, recorded)) if not (Path(where) / name).is_file()]


def missing_copy_error(name: str, where: str | Path, kind: str = "run") -> DataError:
    """The error of a resume of the run (the batch) ``where`` whose copy of the policy module
    ``name`` is gone: say so and how to restore it."""
    copy = Path(where) / name
    how = (f" (nudge simulate EXPERIMENT --out {where} --resume, EXPERIMENT its experiment file)"
           if kind == "run" else "")
    return DataError(f"{copy}: the {kind}'s copy of its policy module {name} is missing; restore it by "
                     f"resuming with the command that started the {kind}{how}, which imports the module "
                     "from the experiment's own folder and writes the copy again, or copy the module back to "
                     f"{copy}")


def _same_path(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve()
    except OSError:
        return False


def check_copies_placeable(files: Mapping[str, bytes], folder: str | Path, recorded: object,
                           kind: str = "run", what: str = "policy module") -> None:
    """Refuse to keep ``files`` in ``folder`` where one of their paths holds something of the
    person's own: a file with other bytes (or a folder, or a file where a copy's folder goes) that
    the folder's manifest does not record as a copy (``recorded``: its :data:`MANIFEST_KEY` entry,
    ``None`` without one). ``--force`` into a folder that is not a run (or a batch) writes into it
    rather than clearing it, and :func:`keep_policy_copies` would write over such a file; a file
    that holds the copy's bytes already is left alone, and a recorded copy is the folder's own (a
    replacement removes it, a resume puts it back). Checked before the folder is touched. ``what``
    names the copies in the message (a batch's experiment and plan are ``input`` copies).

    Raises
    ------
    RunFolderError
        The first such path, by its relative path: names it, the module and the fix.
    """
    root = Path(folder)
    own = set(map(str, recorded)) if isinstance(recorded, Mapping) else set()
    for name, data in sorted(files.items()):
        if name in own:
            continue
        target = root / name
        parents = [parent for parent in target.parents if root in parent.parents]
        blocked = next((parent for parent in reversed(parents) if parent.exists() and not parent.is_dir()),
                       None)
        if blocked is None and (not target.exists() or (target.is_file() and target.read_bytes() == data)):
            continue
        shown = blocked or target
        raise RunFolderError(f"{shown}: a file of your own where the {kind} keeps its copy of the {what} "
                             f"{name} (not one its manifest records); the {kind} never writes over "
                             "it: move it out of the folder, or choose another --out")


def keep_policy_copies(files: Mapping[str, bytes], folder: str | Path) -> None:
    """Keep ``files`` (:func:`loaded_policy_files`) in the run folder under their relative paths,
    each written atomically; a copy that holds these bytes already is left alone (a resume from the
    run's own ``config.toml`` imports the copies themselves)."""
    if not files:
        return
    from nudgecli.store import write_bytes_atomic  # the folders' writer; it imports the config

    for name, data in files.items():
        target = Path(folder) / name
        if target.is_file() and target.read_bytes() == data:
            continue
        target.parent.mkdir(parents=True, exist_ok=True)
        write_bytes_atomic(target, data)


def remove_policy_copies(folder: str | Path, recorded: object) -> None:
    """Remove the policy copies a run's manifest records (its :data:`MANIFEST_KEY` entry), their
    cached bytecode and the folders they leave empty: what ``--force`` replaces with the run (a file
    of the person's own there stays, and an entry that would reach outside the folder is skipped)."""
    if not isinstance(recorded, Mapping):
        return
    root = Path(folder).resolve()
    for name in recorded:
        target = (root / str(name)).resolve()
        if root not in target.parents or not target.is_file():
            continue
        target.unlink()
        remove_cached_bytecode(target)
        for parent in [target.parent / "__pycache__", *target.parents]:
            if parent == root:
                break
            with contextlib.suppress(OSError):  # not empty: kept
                parent.rmdir()
