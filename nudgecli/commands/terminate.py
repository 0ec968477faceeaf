"""SIGTERM handled as Ctrl-C is: the run folder marked ``interrupted``, its lock released, the
resume command printed, exit status 143 (128 + SIGTERM, as shells report it).

Python's default for SIGTERM ends the process at once, running no ``finally`` block: a run's
manifest stayed ``running`` and its lock file behind. :func:`terminate_as_interrupt` makes
SIGTERM raise :class:`Terminated`, a ``KeyboardInterrupt``, so every cleanup Ctrl-C runs runs
for it too (``nudgecli.runs.study`` marks the manifest, ``nudgecli.locks`` releases the lock,
``nudgecli.cli.NudgeGroup`` prints how to resume).
"""

from __future__ import annotations

import _thread
import os
import signal
import sys
import time
from types import FrameType
from typing import Any

#: Exit status after SIGTERM (128 + 15).
EXIT_TERMINATED = 128 + signal.SIGTERM


class Terminated(KeyboardInterrupt):
    """SIGTERM reached the command: raised where Ctrl-C raises ``KeyboardInterrupt``."""


def _send_sigterm_later(pid: int) -> None:
    """SIGTERM to ``pid`` after 10 ms (run in a thread of its own)."""
    time.sleep(0.01)
    os.kill(pid, signal.SIGTERM)


def terminate_as_interrupt() -> None:
    """Make SIGTERM to this process raise :class:`Terminated` (call once, in the main thread).

    A forked worker inherits the handler; there SIGTERM (a pool stopping its workers) keeps its
    default meaning, to end the worker at once, since the cleanup is the parent's. Once raised,
    further SIGTERMs are ignored, so that a second one cannot cut the cleanup short (SIGKILL
    still ends the process).

    Python runs a signal's handler in whatever Python code runs next, and where that code's
    exceptions are only reported ("Exception ignored in ...": a callback of ``os.fork``, a
    ``__del__``) the :class:`Terminated` would be lost and the command would go on to exit 0.
    So such a lost :class:`Terminated` sends SIGTERM again (through ``sys.unraisablehook``), until
    it is raised where it ends the command (and nothing is reported).
    """
    owner = os.getpid()
    raised = False

    def on_sigterm(signum: int, frame: FrameType | None) -> None:
        nonlocal raised
        if os.getpid() != owner:  # a forked worker: die as SIGTERM asks
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
            os.kill(os.getpid(), signal.SIGTERM)
            return
        if raised:  # the cleanup of the first one is running
            return
        raised = True
        raise Terminated

    previous_hook = sys.unraisablehook

    def on_unraisable(unraisable: Any) -> None:
        nonlocal raised
        if isinstance(unraisable.exc_value, Terminated) and os.getpid() == owner:
            raised = False
            # sent from another thread, a moment later: os.kill here would run the handler inside
            # this hook, whose exceptions are lost too (and threading's start waits, where the
            # signal could land as well); the main thread handles it in the code it runs next
            _thread.start_new_thread(_send_sigterm_later, (owner,))
            return
        previous_hook(unraisable)

    sys.unraisablehook = on_unraisable
    signal.signal(signal.SIGTERM, on_sigterm)
