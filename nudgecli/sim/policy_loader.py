"""Import a researcher's policy module from the experiment's folder, else from ``sys.path``.

``policies.threshold`` named by an experiment in ``experiments/`` is the file
``experiments/policies/threshold.py`` (or ``.../threshold/__init__.py``) when it is there, and a
plain import otherwise. A module found in the folder is imported under a private parent package of
that folder's own (``_nudge_policies_<digest of the folder>``, whose ``__path__`` is the folder), so

- two experiments in different folders whose factories name the same module each get their own
  (one process may load both: a notebook, a batch);
- the folder never goes on ``sys.path``: a ``scipy.py`` beside an experiment does not shadow scipy;
- packages (with or without ``__init__.py``) and relative imports inside them work as usual;
- an edited file is imported again: the size and modification time of every file imported under
  the folder's package are recorded, and when one has changed (or gone) the folder's modules are
  all dropped and imported afresh (:func:`import_policy_module` with ``reload_changed``), the
  changed files' cached bytecode removed (it is checked against whole seconds and the size only).

Worker processes (``--workers``, dask) call the same function with the same folder, so they import
the same files.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import importlib.machinery
import importlib.util
import os
import re
import sys
import threading
import traceback
from pathlib import Path
from types import ModuleType

#: Folder's private package name -> {file: (st_mtime_ns, st_size)} of the modules imported under it.
_IMPORTED_FILES: dict[str, dict[str, tuple[int, int]]] = {}
_LOCK = threading.RLock()


def import_policy_module(module_name: str, folder: str | None, *, reload_changed: bool = True) -> ModuleType:
    """The module ``module_name`` (dotted), from ``folder`` when its file is there, else ``sys.path``.

    Parameters
    ----------
    module_name
        A dotted module name of identifiers (``policies.threshold``).
    folder
        The experiment file's folder (absolute), or ``None`` to import from ``sys.path`` only.
    reload_changed
        Whether to import the folder's modules afresh when a file imported from it has changed
        since (when an experiment is loaded); without, the module already imported in this process
        is returned as it is (each trial of a run makes its policy with the run's code).

    Raises
    ------
    Exception
        Whatever importing the module raises (the caller words it).
    """
    location = None if folder is None else module_file(folder, module_name)
    if folder is None or location is None:
        return importlib.import_module(module_name)
    root = private_package_name(folder)
    with _LOCK:
        changed = _changed(root) if reload_changed else []
        if changed:
            _forget(root, changed)
        qualified = f"{root}.{module_name}"
        module = sys.modules.get(qualified)
        if module is None:
            _install_root(root, folder)
            importlib.invalidate_caches()  # a file written since the last import is seen
            try:
                module = importlib.import_module(qualified)
            finally:
                _IMPORTED_FILES[root] = _file_stats(root)
        return module


def imported_files(folder: str) -> list[Path]:
    """The files of ``folder``'s modules imported in this process (by :func:`import_policy_module`),
    sorted: the code a run of an experiment in ``folder`` runs (a run folder keeps their copies,
    :mod:`nudgecli.sim.policy_files`). Packages without ``__init__.py`` have no file of their own."""
    with _LOCK:
        return sorted(Path(path) for path in _IMPORTED_FILES.get(private_package_name(folder), {}))


def module_file(folder: str, module_name: str) -> Path | None:
    """The file of ``module_name`` in ``folder`` (a module's ``.py`` or a package's ``__init__.py``;
    the packages above it may be folders without one), or ``None`` when it is not there."""
    base = Path(folder).joinpath(*module_name.split("."))
    for candidate in (base.with_name(base.name + ".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def sibling_import_advice(exc: ModuleNotFoundError, folder: str) -> str:
    """Where a module of ``folder`` imports another of the folder absolutely (``from mypol.common
    import W`` in ``mypol/quiet.py``), which the folder not on ``sys.path`` does not find: the
    file and line that failed and its relative form (``from .common import W``); ``""`` for any
    other missing module."""
    missing = exc.name or ""
    # the folder's own module: a file, a package, or a package without __init__.py (a folder)
    if module_file(folder, missing) is None and not Path(folder).joinpath(*missing.split(".")).is_dir():
        return ""
    root = Path(folder).resolve()
    frames = [frame for frame in traceback.extract_tb(exc.__traceback__)
              if Path(frame.filename).resolve().is_relative_to(root)]
    if not frames:
        return ""
    frame = frames[-1]
    source = Path(frame.filename).resolve().relative_to(root)
    package = list(source.parent.parts)
    line = (frame.line or "").strip()
    found = re.fullmatch(r"from\s+([\w.]+)\s+import\s+(.+)", line)
    plain = re.fullmatch(r"import\s+([\w.]+)(\s+as\s+\w+)?", line)
    named = found or plain
    target = (named.group(1) if named else missing).split(".")
    shared = 0
    while shared < min(len(package), len(target)) and package[shared] == target[shared]:
        shared += 1
    dots = "." * (len(package) - shared + 1)
    rest = target[shared:]
    names = found.group(2) if found else rest.pop() if rest else "..."
    relative = f"from {dots}{'.'.join(rest)} import {names}"
    return (f"; {source.as_posix()} line {frame.lineno} ({line}) imports the folder's module {missing!r} "
            f"absolutely: the experiment's folder is not on sys.path, import it relatively: {relative}")


def folder_modules(folder: str, depth: int = 3) -> list[str]:
    """The dotted names of the modules and packages in ``folder`` (down to ``depth`` levels): what
    a factory may name from there (for a "did you mean" of a misspelt one)."""
    names: list[str] = []
    root = Path(folder)
    for current, folders, files in os.walk(root):
        parts = Path(current).relative_to(root).parts
        folders[:] = sorted(name for name in folders if name.isidentifier() and len(parts) < depth)
        prefix = "".join(f"{part}." for part in parts)
        names += [prefix + name for name in folders]
        names += [prefix + name[:-3] for name in sorted(files)
                  if name.endswith(".py") and name[:-3].isidentifier() and name != "__init__.py"]
    return names


def private_package_name(folder: str) -> str:
    """The private parent package of ``folder``'s modules: one name per resolved folder."""
    digest = hashlib.sha256(str(Path(folder).resolve()).encode()).hexdigest()[:16]
    return f"_nudge_policies_{digest}"


def _install_root(root: str, folder: str) -> None:
    """The folder's private package: a package with no code whose ``__path__`` is the folder."""
    if root in sys.modules:
        return
    spec = importlib.machinery.ModuleSpec(root, None, is_package=True)
    spec.submodule_search_locations = [str(Path(folder).resolve())]
    sys.modules[root] = importlib.util.module_from_spec(spec)


def _file_stats(root: str) -> dict[str, tuple[int, int]]:
    """The size and modification time of each file imported under ``root``."""
    stats = {}
    for name, module in list(sys.modules.items()):
        path = getattr(module, "__file__", None)
        if path and (name == root or name.startswith(root + ".")):
            try:
                found = os.stat(path)
            except OSError:
                continue
            stats[path] = (found.st_mtime_ns, found.st_size)
    return stats


def _changed(root: str) -> list[str]:
    """The files imported under ``root`` that have been edited or removed since."""
    changed = []
    for path, (mtime_ns, size) in _IMPORTED_FILES.get(root, {}).items():
        try:
            found = os.stat(path)
        except OSError:
            changed.append(path)
            continue
        if (found.st_mtime_ns, found.st_size) != (mtime_ns, size):
            changed.append(path)
    return changed


def _forget(root: str, changed: list[str]) -> None:
    """Drop every module imported under ``root`` so the next import reads the files again, and the
    bytecode cached for the ``changed`` files: Python checks it against a source's whole seconds and
    size, so an edit within the same second that keeps the size would run the old code."""
    for path in changed:
        remove_cached_bytecode(path)
    for name in [name for name in sys.modules if name == root or name.startswith(root + ".")]:
        del sys.modules[name]
    _IMPORTED_FILES.pop(root, None)


def remove_cached_bytecode(source: str | Path) -> None:
    """Remove the bytecode Python cached for the module file ``source``, where there is any.

    No cache is not an error: the file was never imported, or bytecode is not written
    (``PYTHONDONTWRITEBYTECODE``: ``OSError`` on removal), or the interpreter caches none (its
    ``sys.implementation.cache_tag`` is ``None``).
    """
    if sys.implementation.cache_tag is None:  # an interpreter without a bytecode cache
        return
    with contextlib.suppress(OSError):
        os.remove(importlib.util.cache_from_source(str(source)))
