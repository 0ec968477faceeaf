"""Errors a user can cause and fix.

Every ``NudgeError`` is printed by the command line as one ``Error: ...`` line and exits
with status 1; anything else is a bug and shows a traceback.
"""

from __future__ import annotations

import difflib
import shlex
from collections.abc import Iterable, Sequence


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


def user_error(kind: str, message: str) -> NudgeError:
    """The :class:`NudgeError` of class name ``kind`` with ``message`` (one sent from a worker by name)."""
    classes = {cls.__name__: cls for cls in (NudgeError, ConfigError, DataError, RunFolderError, WriteError,
                                             LockError, PolicyError)}
    return classes.get(kind, NudgeError)(message)


def did_you_mean(name: str, candidates: Iterable[object]) -> str:
    """``" (did you mean 'x'?)"`` for the closest candidate, or ``""`` when none is close."""
    matches = difflib.get_close_matches(str(name), [str(c) for c in candidates], n=1, cutoff=0.6)
    return f" (did you mean {matches[0]!r}?)" if matches else ""


def shell_words(words: Sequence[str]) -> str:
    """``words`` as one command line a user can paste, each quoted for the shell where needed
    (the one quoting of every command or option a message suggests)."""
    return shlex.join(words)
