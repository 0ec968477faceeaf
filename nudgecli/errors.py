"""Errors a user can cause and fix.

Every ``NudgeError`` is printed by the command line as one ``Error: ...`` line and exits
with status 1; anything else is a bug and shows a traceback.
"""

from __future__ import annotations

import contextlib
import difflib
import shlex
import traceback
from collections.abc import Iterable, Iterator, Sequence
from contextvars import ContextVar
from typing import Any


class NudgeError(Exception):
    """Base class of errors caused by the user's input, with a message saying how to fix it."""


class ConfigError(NudgeError):
    """An experiment file, analysis plan or ``--set`` override is invalid."""


class DataError(NudgeError):
    """An input table or log (metrics, calibration, questionnaires) is invalid."""


class ProbabilityTableError(NudgeError, ValueError):
    """A probability table is negative, mis-shaped, or has a row that does not sum to 1."""


class RunFolderError(NudgeError):
    """A run folder is missing, incomplete, or holds a different run."""


class WriteError(NudgeError):
    """A file could not be written (read-only folder, full disk, ...): names the path and the cause."""


class LockError(RunFolderError):
    """A run folder is being written by another command (its lock names the holder)."""


class PolicyError(NudgeError):
    """A condition's own policy does not import, does not fit the interface, or fails at run time."""


class WorkerLostError(NudgeError):
    """A worker (a dask worker, a pool's process) was lost mid-run: what was finished is kept, and
    the command line adds how to resume (``nudgecli.cli``)."""


class ClusterError(WorkerLostError):
    """The dask cluster cannot run nudge's tasks (its workers lack nudgecli, or another version of
    it): what was finished is kept, and the command line adds how to resume once it is fixed."""


def user_error(kind: str, message: str) -> NudgeError:
    """The :class:`NudgeError` of class name ``kind`` with ``message`` (one sent from a worker by name)."""
    classes = {cls.__name__: cls for cls in (NudgeError, ConfigError, DataError, RunFolderError, WriteError,
                                             LockError, PolicyError)}
    return classes.get(kind, NudgeError)(message)


class WorkerError(RuntimeError):
    """A task failed in a worker (the worker's traceback is the message)."""


def failure_message(exc: Exception) -> tuple[str, Any]:
    """An exception a worker process met, as ``(status, payload)`` that pickles and that
    :func:`failure_from_message` raises again in the parent: an ``OSError`` keeps its code, cause
    and paths (the command's one error line names them), a :class:`NudgeError` its class and
    message, anything else becomes the worker's traceback. Call it in the ``except`` block."""
    if isinstance(exc, OSError):
        return "oserror", (exc.errno, exc.strerror or str(exc), exc.filename, exc.filename2)
    if isinstance(exc, NudgeError):
        return "nudgeerror", (type(exc).__name__, str(exc))
    return "error", traceback.format_exc()


def failure_from_message(status: str, payload: Any, task: str) -> Exception:
    """The exception of :func:`failure_message`'s ``(status, payload)``, raised by the parent for
    ``task`` (named in a :class:`WorkerError`'s message)."""
    if status == "oserror":
        code, cause, path, other = payload
        return OSError(code, cause, path, None, other)
    if status == "nudgeerror":
        return user_error(*payload)
    return WorkerError(f"{task} failed in a worker:\n{payload}")


def did_you_mean(name: str, candidates: Iterable[object]) -> str:
    """``" (did you mean 'x'?)"`` for the closest candidate, or ``""`` when none is close."""
    matches = difflib.get_close_matches(str(name), [str(c) for c in candidates], n=1, cutoff=0.6)
    return f" (did you mean {matches[0]!r}?)" if matches else ""


def shell_words(words: Sequence[str]) -> str:
    """``words`` as one command line a user can paste, each quoted for the shell where needed
    (the one quoting of every command or option a message suggests)."""
    return shlex.join(words)


@contextlib.contextmanager
def outermost_name(named: ContextVar[str | None], name: str) -> Iterator[None]:
    """Within the block, ``named`` holds ``name`` unless a caller outside set it first: an option's
    refusals name it as the outermost front end spells it (the command line calls the Python API,
    which names ``confirm=True`` or ``scheduler=`` for its own callers)."""
    token = named.set(name) if named.get() is None else None
    try:
        yield
    finally:
        if token is not None:
            named.reset(token)
