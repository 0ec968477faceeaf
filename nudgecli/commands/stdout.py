"""stdout as a command's document needs it: every byte written, or an error.

A command's stdout is its document (a table, ``--format json|csv``). Python's own stream can lose
part of it silently: unbuffered (``PYTHONUNBUFFERED``), a short write to a nearly full disk is
dropped (4,096 of 6,849 bytes written, exit 0); buffered, the failure surfaces only at the
interpreter's exit (exit 120 and a traceback-like "Exception ignored"); with stdout closed
(``>&-``) ``click.echo`` drops everything and the exit is 0.

While a command runs, ``sys.stdout`` is a :class:`CheckedStdout` (:func:`checked_stdout`): each
write goes to the file descriptor in a loop until every byte is taken (``os.write`` may take
part of it), each failure raises. What the command line does with them (``nudgecli.cli``):

- a reader that went away (``nudge presets | head -1``): :class:`ReaderGoneError`, ended
  quietly with :data:`EXIT_BROKEN_PIPE`, the status a shell reports for a process killed by
  SIGPIPE (as ``cat`` or ``yes`` end in a pipe), so ``set -o pipefail`` still sees that the
  output was cut;
- any other failure (a full disk, an I/O error) and a closed stdout: a
  :class:`~nudgecli.errors.WriteError`, one ``Error:`` line and exit 1.
"""

from __future__ import annotations

import codecs
import contextlib
import errno
import io
import os
import select
import sys
from collections.abc import Iterator
from typing import Any

from nudgecli.errors import WriteError

#: Exit status after the reader of stdout went away: 128 + SIGPIPE (13), as a shell reports a
#: process that SIGPIPE ended.
EXIT_BROKEN_PIPE = 141


class ReaderGoneError(BrokenPipeError):
    """The reader of stdout went away (a closed pipe): the command ends quietly."""


def _stdout_error(exc: OSError) -> WriteError:
    cause = exc.strerror or str(exc) or type(exc).__name__
    return WriteError(f"cannot write to stdout: {cause}; the output is incomplete")


#: What a closed stdout (``>&-``) says when a command has something to print.
CLOSED_MESSAGE = ("stdout is closed, so the output could not be printed; run the command with stdout "
                  "open (redirect it to a file, or to /dev/null to discard it)")


class CheckedStdout(io.TextIOBase):
    """A text stream over the process's stdout that writes every byte or raises.

    Parameters
    ----------
    stream
        The stream it replaces (``sys.stdout``); ``None`` when stdout is closed, and then every
        write of text raises :class:`~nudgecli.errors.WriteError`. A stream with a file
        descriptor is written through the descriptor (after its own buffer is flushed); one
        without (click's test runner) is written and flushed as it is.
    """

    def __init__(self, stream: Any) -> None:
        super().__init__()
        self._stream = stream
        self._fd: int | None = None
        encoding = getattr(stream, "encoding", None) or "utf-8"
        # an ASCII stdout (a C locale) would fail on the first non-ASCII character: click's rule
        ascii_only = codecs.lookup(encoding).name == "ascii"
        self._encoding = "utf-8" if ascii_only else encoding
        self._errors = "replace" if ascii_only else (getattr(stream, "errors", None) or "strict")
        if stream is None:
            return
        with contextlib.suppress(AttributeError, OSError, ValueError):  # io.UnsupportedOperation
            self._fd = stream.fileno()
        if self._fd is not None:
            self._checked(stream.flush)  # what was printed before goes first, whole

    @property
    def encoding(self) -> str:  # type: ignore[override]
        return self._encoding

    @property
    def errors(self) -> str:  # type: ignore[override]
        return self._errors

    def writable(self) -> bool:
        return True

    def isatty(self) -> bool:
        return bool(self._stream is not None and self._stream.isatty())

    def fileno(self) -> int:
        if self._fd is None:
            raise io.UnsupportedOperation("stdout has no file descriptor here")
        return self._fd

    def write(self, text: str) -> int:  # type: ignore[override]
        if not isinstance(text, str):
            raise TypeError(f"write() argument must be str, not {type(text).__name__}")
        if self._stream is None:
            if text:
                raise WriteError(CLOSED_MESSAGE)
            return 0
        if self._fd is None:
            self._checked(self._stream.write, text)
            self._checked(self._stream.flush)
            return len(text)
        view = memoryview(text.encode(self._encoding, self._errors))
        while view:
            view = view[self._checked(self._write_some, view):]
        return len(text)

    def _write_some(self, data: memoryview) -> int:
        """One ``os.write`` (waiting first when stdout is a non-blocking descriptor that is full)."""
        assert self._fd is not None
        try:
            return os.write(self._fd, data)
        except BlockingIOError:
            select.select([], [self._fd], [])
            return 0

    def flush(self) -> None:
        if self._stream is not None and self._fd is None:
            self._checked(self._stream.flush)

    @staticmethod
    def _checked(action: Any, *args: Any) -> Any:
        """``action(*args)``, a broken pipe raised as :class:`ReaderGoneError`, any other ``OSError``
        as a ``WriteError`` naming stdout."""
        try:
            return action(*args)
        except BrokenPipeError as exc:
            raise ReaderGoneError(errno.EPIPE, "the reader of stdout went away") from exc
        except OSError as exc:
            raise _stdout_error(exc) from exc


@contextlib.contextmanager
def checked_stdout() -> Iterator[CheckedStdout]:
    """Make ``sys.stdout`` a :class:`CheckedStdout` for the block; restored after it.

    A closed stdout (``>&-``: Python then sets ``sys.stdout`` to ``None``) gets ``/dev/null`` as
    its descriptor 1, so that no file the command opens becomes "stdout" by taking the free
    number; writes of text still raise, since nothing the command prints can reach anyone.
    """
    original = sys.stdout
    if original is None:
        _plug_descriptor(1)
    stream = CheckedStdout(original)
    sys.stdout = stream
    try:
        yield stream
    finally:
        sys.stdout = original


def _plug_descriptor(fd: int) -> None:
    """Open ``/dev/null`` as descriptor ``fd`` if ``fd`` is closed."""
    try:
        os.fstat(fd)
    except OSError:
        devnull = os.open(os.devnull, os.O_WRONLY)
        if devnull != fd:
            os.dup2(devnull, fd)
            os.close(devnull)

