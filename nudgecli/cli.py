"""The ``nudge`` command line: parse, call one function, print. No model logic here.

stdout carries results (tables, JSON); logs and progress go to stderr. A ``NudgeError``
prints one ``Error: ...`` line and exits 1 (``--debug`` shows the traceback), and so does an
``OSError`` (naming the path and the cause); click usage errors exit 2; Ctrl-C exits 130 and
says how to resume, and so does SIGTERM, with 143 (:mod:`nudgecli.commands.terminate`). stdout
is written whole or not at all (:mod:`nudgecli.commands.stdout`): a failed write is an
``Error:`` line and exit 1; a reader that went away (``| head``) ends the command quietly with
141.
"""

from __future__ import annotations

import atexit
import contextlib
import gc
import os
import sys
from collections.abc import Callable
from typing import Any

import click

from nudgecli import __version__
from nudgecli.commands import analysis, batches, people, simulation, tools
from nudgecli.commands.common import EXIT_INTERRUPTED, INTERRUPT_HINT, declaring_inputs
from nudgecli.commands.stdout import EXIT_BROKEN_PIPE, ReaderGoneError, checked_stdout
from nudgecli.commands.terminate import EXIT_TERMINATED, Terminated, terminate_as_interrupt
from nudgecli.errors import NudgeError, WorkerLostError


def os_error_message(exc: OSError) -> str:
    """One line for an ``OSError``: the path(s) and the cause."""
    cause = exc.strerror or str(exc) or type(exc).__name__
    paths = [str(p) for p in (exc.filename, exc.filename2) if p is not None]
    return f"{' -> '.join(paths)}: {cause}" if paths else cause


class NudgeGroup(click.Group):
    """A click group that turns ``NudgeError`` and ``OSError`` into one ``Error:`` line and exit
    status 1, and Ctrl-C into exit status 130 with a line on how to resume (SIGTERM: 143). Its
    commands write stdout through :func:`~nudgecli.commands.stdout.checked_stdout`: a failed write of their
    output is such an error too, and a reader of stdout that went away ends them quietly with
    :data:`~nudgecli.commands.stdout.EXIT_BROKEN_PIPE`."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            with checked_stdout():  # every write reaches the descriptor or raises: nothing is left to flush
                return super().invoke(ctx)
        except ReaderGoneError:  # nothing of it was left in Python's own buffer: no message at exit
            ctx.exit(EXIT_BROKEN_PIPE)
        except NudgeError as exc:
            if ctx.meta.get("nudge.debug"):
                raise
            resume: Callable[[], str] | None = ctx.meta.get(INTERRUPT_HINT)
            if isinstance(exc, WorkerLostError) and resume is not None:  # what was finished is kept
                click.echo(f"Error: {exc}; {resume()}", err=True)
            else:
                click.echo(f"Error: {exc}", err=True)
            ctx.exit(1)
        except OSError as exc:
            if ctx.meta.get("nudge.debug"):
                raise
            click.echo(f"Error: {os_error_message(exc)}", err=True)
            ctx.exit(1)
        except KeyboardInterrupt as exc:
            hint: Callable[[], str] | None = ctx.meta.get(INTERRUPT_HINT)
            message = hint() if hint is not None else "nothing half-written was left; run the command again"
            terminated = isinstance(exc, Terminated)
            click.echo(f"\n{'Terminated' if terminated else 'Interrupted'}: {message}", err=True)
            ctx.exit(EXIT_TERMINATED if terminated else EXIT_INTERRUPTED)


@click.group(cls=NudgeGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="nudge")
@click.option("--debug", is_flag=True, help="Show full tracebacks for errors.")
@click.pass_context
def main(ctx: click.Context, debug: bool) -> None:
    """Simulate and analyse assistive shared-control studies (sip-and-puff intent disambiguation)."""
    ensure_stderr()
    ctx.meta["nudge.debug"] = debug


for _command in (*tools.COMMANDS, *simulation.COMMANDS, *analysis.COMMANDS, *batches.COMMANDS,
                 *people.COMMANDS):
    main.add_command(declaring_inputs(_command))  # no output replaces a file the command read


def ensure_stderr() -> None:
    """Give the process a stderr when it was started without one (``2>&-``).

    Without it, logs and progress have nowhere to go (Python sets ``sys.stderr`` to None and the
    first progress line raises), and worse, the next file opened would get descriptor 2, so a
    library or worker writing to "stderr" would write into that file. Descriptor 2 becomes
    ``/dev/null`` instead: the command works and says nothing on stderr.
    """
    try:
        os.fstat(2)
    except OSError:
        devnull = os.open(os.devnull, os.O_WRONLY)
        if devnull != 2:
            os.dup2(devnull, 2)
            os.close(devnull)
    if sys.stderr is None:
        sys.stderr = open(2, "w", buffering=1, errors="backslashreplace", closefd=False)  # noqa: SIM115


def freeze_collector_at_exit() -> None:
    """Freeze the garbage collector when the interpreter exits, after every exit handler
    registered later (they run last to first: call this first).

    The interpreter's final collections then skip the heap the command built, which took
    0.1-0.2 s of a short command; every object is still freed by its reference count, and the
    handlers that clean up (a pool's, a temporary folder's) have run by then.
    """
    atexit.register(gc.freeze)


def entry_point() -> None:
    """The ``nudge`` program: :data:`main`, SIGTERM handled as Ctrl-C, and after either a prompt exit.

    After Ctrl-C the run folder is already marked and the resume command printed; what is left
    is the interpreter's shutdown, which joins a process pool's management thread, and that
    thread can wait for ever on a queue whose worker was just stopped (CPython 3.11). So an
    interrupted command leaves at once (``os._exit``, streams flushed first). At every exit the
    collector is frozen last (:func:`freeze_collector_at_exit`).
    """
    freeze_collector_at_exit()
    terminate_as_interrupt()
    try:
        main()
    except SystemExit as exc:
        if exc.code in (EXIT_INTERRUPTED, EXIT_TERMINATED):
            for stream in (sys.stdout, sys.stderr):
                with contextlib.suppress(Exception):
                    stream.flush()
            os._exit(int(exc.code))
        raise


if __name__ == "__main__":  # pragma: no cover
    entry_point()
