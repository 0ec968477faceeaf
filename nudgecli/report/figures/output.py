"""Writing figures: each format through :func:`nudgecli.store.atomic_path` (the usual permissions).

:func:`save_figures` writes several figures' files at once in forked processes: a figure's
drawing and encoding (about 0.3-0.6 s a file at 300 dpi) is single-threaded, and ``nudge run``
and ``nudge plot`` write ten files one after the other while the other cores wait. Ctrl-C is the
parent's: the children ignore it, and the parent ends them and raises ``KeyboardInterrupt``.
"""

from __future__ import annotations

import contextlib
import gc
import os
import signal
import threading
from collections.abc import Iterator, Mapping, Sequence
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

from nudgecli.cores import available_cores
from nudgecli.errors import ConfigError, failure_from_message, failure_message
from nudgecli.report.style import figure_style
from nudgecli.store import atomic_path

SUPPORTED_FORMATS = ("png", "pdf", "svg")
PNG_DPI = 300
#: What ends a command (Ctrl-C, and SIGTERM, which ``nudge`` handles as Ctrl-C): held back while
#: the figures' writers are forked.
_STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
#: Metadata that would make the files differ from run to run (dates, versions): left out.
_METADATA: dict[str, dict[str, Any]] = {
    "png": {"Software": None},
    "pdf": {"CreationDate": None, "Producer": None},
    "svg": {"Date": None},
}


def check_formats(formats: Sequence[str]) -> tuple[str, ...]:
    """The formats, normalised (``".PNG"`` -> ``"png"``), or a :class:`ConfigError` naming a bad one."""
    fmts = tuple(f.strip().lower().lstrip(".") for f in formats if f.strip())
    bad = [f for f in fmts if f not in SUPPORTED_FORMATS]
    if bad or not fmts:
        shown = repr(bad[0]) if bad else "(none)"
        raise ConfigError(f"figure format {shown} is not supported; use one or more of "
                          f"{', '.join(SUPPORTED_FORMATS)} (e.g. --formats png,pdf)")
    return fmts


def figure_file(out_dir: str | os.PathLike[str], stem: str, fmt: str) -> Path:
    """The file :func:`save_figure` writes a figure ``stem`` into in format ``fmt``: ``<stem>.<fmt>``."""
    return Path(out_dir) / f"{stem}.{fmt}"


def save_figure(fig: Figure, out_dir: str | os.PathLike[str], stem: str,
                formats: Sequence[str] = ("png", "pdf"), *, dpi: int = PNG_DPI) -> list[Path]:
    """Write a figure in each format, atomically (:func:`nudgecli.store.atomic_path`).

    Parameters
    ----------
    fig
        The figure.
    out_dir
        Folder (created if missing).
    stem
        File name without suffix.
    formats
        Any of ``png``, ``pdf``, ``svg``.
    dpi
        Resolution of raster output.

    Returns
    -------
    list[Path]
        The written files, in the order of ``formats``.

    Raises
    ------
    ConfigError
        An unsupported format.
    """
    fmts = check_formats(formats)
    out = Path(out_dir)
    written = []
    with figure_style():
        for fmt in fmts:
            target = figure_file(out, stem, fmt)
            with atomic_path(target) as tmp, open(tmp, "wb") as handle:
                fig.savefig(handle, format=fmt, dpi=dpi, metadata=_METADATA[fmt])
            written.append(target)
    return written


def save_figures(figures: Mapping[str, Figure], out_dir: str | os.PathLike[str], formats: Sequence[str],
                 *, dpi: int = PNG_DPI, processes: int | None = None) -> list[Path]:
    """Write every figure in every format (:func:`save_figure`), the figures spread over forked
    processes where there are several figures and cores.

    Every file has the bytes it has when written here: a figure's files are written by one
    process in the order of ``formats`` (a figure drawn once keeps what its layout engine
    computed, so a PDF written after the PNG can differ in the last digit of a position from one
    written first). Without ``fork`` (Windows), with one process, or while another thread of
    this process runs (a dask client's: a child forked then could wait for ever on a lock that
    thread held), the figures are written here, one after the other.

    Parameters
    ----------
    figures
        File stem -> figure.
    out_dir
        Folder (created if missing).
    formats
        Any of ``png``, ``pdf``, ``svg``.
    dpi
        Resolution of raster output.
    processes
        Processes writing at once; default one per figure, at most the cores this process may use.

    Returns
    -------
    list[Path]
        The written files, figure by figure, each in the order of ``formats``.

    Raises
    ------
    ConfigError
        An unsupported format.
    WriteError
        A file cannot be written (the first file's error, in the order of the returned list).
    """
    fmts = check_formats(formats)
    stems = list(figures)
    workers = min(len(stems), processes or len(stems), available_cores())
    if workers < 2 or not _can_fork() or _other_threads_running():
        return [path for stem, fig in figures.items()
                for path in save_figure(fig, out_dir, stem, fmts, dpi=dpi)]
    import multiprocessing

    context = multiprocessing.get_context("fork")  # the children draw the figures they inherit
    # the objects so far are left out of the collector's passes, here and in the children: a pass
    # in a child would write to (and so copy) every page of this process's heap it inherited
    gc.freeze()
    next_figure = context.Value("i", 0)
    children = []
    outcomes: dict[int, tuple[str, Any]] = {}
    try:
        with _stop_signals_held():  # Ctrl-C now is raised as the block ends, inside this try
            for _ in range(workers):
                receive, send = context.Pipe(duplex=False)
                child = context.Process(target=_write_figures, daemon=True, name="nudge-figures",
                                        args=(figures, fmts, out_dir, dpi, next_figure, send))
                child.start()
                send.close()
                children.append((child, receive))
        for child, receive in children:  # Ctrl-C while waiting ends the children in `finally`
            with contextlib.suppress(EOFError):  # a child that died without a word (killed)
                outcomes.update(receive.recv())
            child.join()
    finally:
        for child, receive in children:
            if child.is_alive():
                child.terminate()
            receive.close()
        gc.unfreeze()
    written: list[Path] = []
    for index, stem in enumerate(stems):
        status, payload = outcomes.get(index, ("error", "a process writing figures exited with code(s) "
                                                        f"{[c.exitcode for c, _ in children]}"))
        if status != "ok":
            raise failure_from_message(status, payload, f"writing figure {stem!r}")
        written += [Path(path) for path in payload]
    return written


def _write_figures(figures: Mapping[str, Figure], formats: Sequence[str], out_dir: str | os.PathLike[str],
                   dpi: int, next_figure: Any, send: Connection) -> None:
    """A child of :func:`save_figures`: write the next unwritten figure until none is left (a slow
    one then holds up no other); send back ``{index: (status, its paths or the failure)}``.

    Ctrl-C (sent to the whole process group by a terminal) is ignored here: the parent ends its
    children; SIGTERM (the parent's ``terminate``) ends this one at once. Both were held back
    since the fork (:func:`_stop_signals_held`), and are let through once this process's own
    handling is set."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # ignoring discards a Ctrl-C held since the fork
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, _STOP_SIGNALS)
    stems = list(figures)
    outcomes: dict[int, tuple[str, Any]] = {}
    while True:
        with next_figure.get_lock():
            index = next_figure.value
            next_figure.value += 1
        if index >= len(stems):
            break
        try:
            paths = save_figure(figures[stems[index]], out_dir, stems[index], formats, dpi=dpi)
        except Exception as exc:  # the parent raises it again: one error line
            outcomes[index] = failure_message(exc)
            break
        outcomes[index] = ("ok", [str(path) for path in paths])
    send.send(outcomes)
    send.close()


@contextlib.contextmanager
def _stop_signals_held() -> Iterator[None]:
    """Hold back Ctrl-C and SIGTERM for the block; one that came meanwhile is raised as it ends.

    Forking runs the interpreter's after-fork hooks (``logging``'s among them), and a
    ``KeyboardInterrupt`` raised inside one is only reported ("Exception ignored in ...") and then
    lost: the command went on, or, its children interrupted too, failed with their exit codes.
    A child forked meanwhile starts with both held, and so cannot be interrupted before it has
    set its own handling (:func:`_write_figures`).
    """
    held = signal.pthread_sigmask(signal.SIG_BLOCK, _STOP_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, held)


def _can_fork() -> bool:
    return hasattr(os, "fork")


def _other_threads_running() -> bool:
    """Whether a thread besides this one runs (a notebook's kernel, a dask client, a server)."""
    return threading.active_count() > 1


__all__ = ["PNG_DPI", "SUPPORTED_FORMATS", "check_formats", "save_figure", "save_figures"]
