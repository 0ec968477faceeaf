"""Writing figures: each format through :func:`nudgecli.store.atomic_path` (the usual permissions),
every file to its temporary first and all renamed into place only once all are written.

:func:`save_figures` writes several figures' files at once in forked processes: a figure's
drawing and encoding (about 0.3-0.6 s a file at 300 dpi) is single-threaded, and ``nudge run``
and ``nudge plot`` write ten files one after the other while the other cores wait. Ctrl-C is the
parent's: the children ignore it, and the parent ends them and raises ``KeyboardInterrupt``.
"""

from __future__ import annotations

import contextlib
import errno
import gc
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

from nudgecli.cores import available_cores
from nudgecli.errors import ConfigError, failure_from_message, failure_message
from nudgecli.report.style import figure_style
from nudgecli.run_folder_names import FIGURES_DIR
from nudgecli.run_folder_record import file_sha256
from nudgecli.run_folder_state import refuse_links
from nudgecli.store import atomic_path, write_error

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


def refuse_linked_figures(out_dir: str | os.PathLike[str]) -> None:
    """Refuse a ``figures/`` folder that is a symbolic link (a run's, a batch's, an analysis's):
    its figures would be written (and an earlier plot's removed) in another folder
    (:func:`~nudgecli.run_folder_state.refuse_links`). A folder given by another name (``--out``)
    is the person's choice.

    Raises
    ------
    RunFolderError
        Names the link and where it points."""
    if (folder := Path(out_dir)).name == FIGURES_DIR:
        refuse_links(folder.parent, (FIGURES_DIR,))


def figure_file(out_dir: str | os.PathLike[str], stem: str, fmt: str) -> Path:
    """The file :func:`save_figure` writes a figure ``stem`` into in format ``fmt``: ``<stem>.<fmt>``."""
    return Path(out_dir) / f"{stem}.{fmt}"


def save_figure(fig: Figure, out_dir: str | os.PathLike[str], stem: str,
                formats: Sequence[str] = ("png", "pdf"), *, dpi: int = PNG_DPI) -> list[Path]:
    """Write a figure in each format, atomically (:func:`nudgecli.store.atomic_path`): all the files
    are renamed into place once every one is written.

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
    refuse_linked_figures(out_dir)
    targets = [figure_file(out_dir, stem, fmt) for fmt in fmts]
    with contextlib.ExitStack() as stack:  # every format to its temporary, renamed once all are written
        _render(fig, [stack.enter_context(atomic_path(target)) for target in targets], targets, fmts, dpi)
    return targets


def save_figures(figures: Mapping[str, Figure], out_dir: str | os.PathLike[str], formats: Sequence[str],
                 *, dpi: int = PNG_DPI, processes: int | None = None,
                 before_rename: Callable[[dict[str, str]], None] | None = None) -> list[Path]:
    """Write every figure in every format, the figures spread over forked processes where there
    are several figures and cores: every file to its temporary (:func:`nudgecli.store.atomic_path`)
    first, all of them renamed into place only once every one is written, so a failure (a file
    that cannot be written, an error drawing, Ctrl-C) changes no file and leaves no temporary.

    Every file has the bytes :func:`save_figure` gives it: a figure's files are written by one
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
    before_rename
        Called with each file's name -> SHA-256 once all are written, before the first rename
        (``nudge plot`` records them: :mod:`nudgecli.report.figure_records`).

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
    refuse_linked_figures(out_dir)
    targets = {stem: [figure_file(out_dir, stem, fmt) for fmt in fmts] for stem in figures}
    with contextlib.ExitStack() as stack:  # closed without an error: every temporary renamed into place
        for target in (path for paths in targets.values() for path in paths):
            if target.is_dir():  # found now, before any file is drawn or renamed
                raise write_error(target, IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR)))
        staged = {stem: [stack.enter_context(atomic_path(path)) for path in paths]
                  for stem, paths in targets.items()}
        _render_all(figures, staged, targets, fmts, dpi, processes)
        if before_rename is not None:
            before_rename({path.name: file_sha256(tmp) for stem, paths in targets.items()
                           for path, tmp in zip(paths, staged[stem], strict=True)})
    return [path for paths in targets.values() for path in paths]


def _render(fig: Figure, temporaries: Sequence[Path], targets: Sequence[Path], formats: Sequence[str],
            dpi: int) -> None:
    """Write ``fig`` into its temporaries, one per format (what :func:`save_figure` writes)."""
    with figure_style():
        for fmt, tmp, target in zip(formats, temporaries, targets, strict=True):
            try:
                with open(tmp, "wb") as handle:
                    fig.savefig(handle, format=fmt, dpi=dpi, metadata=_METADATA[fmt])
            except OSError as exc:
                raise write_error(target, exc) from exc


def _render_all(figures: Mapping[str, Figure], staged: Mapping[str, list[Path]],
                targets: Mapping[str, list[Path]], fmts: Sequence[str], dpi: int,
                processes: int | None) -> None:
    """Write every figure into its temporaries (:func:`save_figures`), in forked processes where
    it can; raise the first figure's failure."""
    stems = list(figures)
    workers = min(len(stems), processes or len(stems), available_cores())
    if workers < 2 or not _can_fork() or _other_threads_running():
        for stem, fig in figures.items():
            _render(fig, staged[stem], targets[stem], fmts, dpi)
        return
    import multiprocessing

    context = multiprocessing.get_context("fork")  # the children draw the figures they inherit
    # the objects so far are left out of the collector's passes, here and in the children: a pass
    # in a child would write to (and so copy) every page of this process's heap it inherited
    gc.freeze()
    next_figure = context.Value("i", 0)
    parent = os.getpid()  # the children end with this process (_end_with_parent)
    children = []
    outcomes: dict[int, tuple[str, Any]] = {}
    try:
        with _stop_signals_held():  # Ctrl-C now is raised as the block ends, inside this try
            for _ in range(workers):
                receive, send = context.Pipe(duplex=False)
                child = context.Process(target=_write_figures, daemon=True, name="nudge-figures",
                                        args=(figures, staged, targets, fmts, dpi, next_figure, send, parent))
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
    for index, stem in enumerate(stems):
        status, payload = outcomes.get(index, ("error", "a process writing figures exited with code(s) "
                                                        f"{[c.exitcode for c, _ in children]}"))
        if status != "ok":
            raise failure_from_message(status, payload, f"writing figure {stem!r}")


def _write_figures(figures: Mapping[str, Figure], staged: Mapping[str, list[Path]],
                   targets: Mapping[str, list[Path]], formats: Sequence[str], dpi: int, next_figure: Any,
                   send: Connection, parent: int) -> None:
    """A child of :func:`save_figures`: write the next unwritten figure into its temporaries until
    none is left (a slow one then holds up no other); send back ``{index: (status, None or the
    failure)}``.

    Ctrl-C (sent to the whole process group by a terminal) is ignored here: the parent ends its
    children; SIGTERM (the parent's ``terminate``) ends this one at once. Both were held back
    since the fork (:func:`_stop_signals_held`), and are let through once this process's own
    handling is set.

    It never outlives ``parent`` (the pid of :func:`save_figures`' process): it closes its copy of
    the folder's lock (:func:`~nudgecli.locks.release_inherited_locks`), and ends when the parent
    dies (:func:`_end_with_parent`), even by SIGKILL, which ends no child by itself."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # ignoring discards a Ctrl-C held since the fork
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    from nudgecli.locks import release_inherited_locks  # locks builds on store, as this module does

    release_inherited_locks()
    _end_with_parent(parent)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, _STOP_SIGNALS)
    stems = list(figures)
    outcomes: dict[int, tuple[str, Any]] = {}
    while os.getppid() == parent:  # where no death signal is set: the parent gone, no figure more
        with next_figure.get_lock():
            index = next_figure.value
            next_figure.value += 1
        if index >= len(stems):
            break
        stem = stems[index]
        try:
            _render(figures[stem], staged[stem], targets[stem], formats, dpi)
        except Exception as exc:  # the parent raises it again: one error line
            outcomes[index] = failure_message(exc)
            break
        outcomes[index] = ("ok", None)
    send.send(outcomes)
    send.close()


def _end_with_parent(parent: int) -> None:
    """Have the kernel kill this process when its parent dies (Linux's ``PR_SET_PDEATHSIG``, through
    ctypes; elsewhere :func:`_write_figures` looks for its parent between figures), and exit now
    if the parent ``parent`` died before that was set."""
    if sys.platform.startswith("linux"):
        with contextlib.suppress(Exception):  # no libc to load (a static build): the loop's check remains
            import ctypes

            ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    if os.getppid() != parent:
        os._exit(1)


#: prctl's option: the signal the kernel sends this process when its parent ends (linux/prctl.h).
_PR_SET_PDEATHSIG = 1


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
