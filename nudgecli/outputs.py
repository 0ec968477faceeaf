"""Where a command may write: never onto a file it read, and into a folder of its own.

Two rules every command that writes files follows:

- **No output replaces an input.** The files a command reads that the user named (its path
  arguments, ``--questionnaires``, a ``--plan`` file, ...) are declared while it runs
  (:func:`declare_input`, within :func:`command_inputs`), and
  :func:`nudgecli.store.atomic_path`, which every written file goes through, refuses to replace
  one of them (:func:`check_not_an_input`): a participant's raw
  answers can never be overwritten by the scores computed from them, nor a metrics table by its
  filtered copy.
- **An output folder given with ``--out`` is new, empty, or the source's own.** A folder that
  holds a run other than the one analysed, or that is not empty, is refused without ``--force``
  (:func:`check_output_folder`): the analysis of one run written into another would be drawn by
  ``nudge plot`` as the other's. ``simulate``, ``run`` and the batches apply the same rule to
  the folder they write (:func:`nudgecli.store.prepare_mode`); ``plot-population`` to its
  ``--out`` (the current folder by default), its own earlier outputs aside.
- **An output folder is a folder**: a path that names a file is refused before any work, in one
  message for every command (:func:`check_not_a_file`).
- **An output file that exists is replaced only with ``--force``** (:func:`check_output_file`):
  ``nudge fit --out PROFILE.json`` does not write over a profile fitted before.
- **A command's tables and figures change together or not at all** (:func:`written_together`):
  the tables wait in their temporaries while the figures are drawn, so a ``--force`` whose figure
  cannot be written leaves the earlier tables beside the earlier figures.
"""

from __future__ import annotations

import contextlib
import errno
import os
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path

from nudgecli.errors import DataError, RunFolderError, WriteError, shell_words
from nudgecli.run_folder_names import LOCK

#: The files the running command read, as it named them: (device, inode) and resolved path ->
#: how the user gave it (``--questionnaires``, ``SOURCE``).
_INPUTS: dict[tuple[int, int] | Path, str] = {}


def _keys(path: Path) -> list[tuple[int, int] | Path]:
    """The keys of a file in :data:`_INPUTS`: its resolved path and, when it exists, its inode
    (the same file under another name: a hard link)."""
    keys: list[tuple[int, int] | Path] = [path.resolve()]
    with contextlib.suppress(OSError):
        status = os.stat(path)
        keys.append((status.st_dev, status.st_ino))
    return keys


@contextlib.contextmanager
def command_inputs() -> Iterator[None]:
    """The block of one command: the inputs declared in it (:func:`declare_input`) are forgotten
    when it ends (a test runner runs many commands in one process)."""
    saved = dict(_INPUTS)
    try:
        yield
    finally:
        _INPUTS.clear()
        _INPUTS.update(saved)


def declare_input(label: str, *paths: str | Path | None) -> None:
    """Declare files the running command reads, given by the user as ``label`` (``SOURCE``,
    ``--questionnaires``). Paths that are not existing files (a folder, ``None``, a preset's name)
    are skipped: a folder's own files are governed by the run-folder rules."""
    for path in paths:
        if path is not None and Path(path).is_file():
            for key in _keys(Path(path)):
                _INPUTS[key] = label


def check_not_an_input(target: str | Path) -> None:
    """Refuse to write ``target`` when it is one of the running command's inputs.

    Raises
    ------
    WriteError
        ``target`` is (the same file as) a declared input; names it and how it was given.
    """
    if not _INPUTS:
        return
    for key in _keys(Path(target)):
        if key in _INPUTS:
            raise WriteError(f"{target} is this command's input ({_INPUTS[key]}); an output never "
                             "replaces a file the command read: choose another --out")


def check_output_file(target: str | Path, *, force: bool) -> None:
    """Refuse to replace an existing file ``target`` unless ``force`` (a file the command read is
    refused even then: :func:`check_not_an_input`).

    Raises
    ------
    WriteError
        ``target`` is one of the command's inputs.
    RunFolderError
        ``target`` exists and ``force`` is not given.
    """
    path = Path(target)
    check_not_an_input(path)  # the stronger reason first: --force would not help
    if path.exists() and not force:
        raise RunFolderError(f"{path}: exists; choose another --out or use --force to replace it")


def check_not_a_file(folder: str | Path) -> None:
    """Refuse an output folder's path that names an existing file, before any work: every command's
    one message for it (writing there would fail later as "File exists", which says nothing of the fix).

    Raises
    ------
    DataError
        ``folder`` exists and is not a folder.
    """
    path = Path(folder)
    if path.exists() and not path.is_dir():
        raise DataError(f"--out {path} is a file; give a folder")


def check_output_folder(folder: str | Path, *, force: bool, own: Iterable[str | Path] = (),
                        own_file: Callable[[str], bool] = LOCK.__eq__) -> None:
    """Refuse an output folder that holds a run or other files, unless ``force`` or it is ``own``.

    Parameters
    ----------
    folder
        The folder a command is about to write (given with ``--out``).
    force
        ``--force``: write there anyway (files of the same names are replaced, nothing else is
        touched).
    own
        Folders the command writes as its own for this source (``nudge analyze RUN`` writes into
        ``RUN``, ``nudge analyze T.csv`` into ``T-analysis/``): always accepted here (``analyze``
        itself refuses a ``T-analysis/`` that holds the analysis of another table, ``T.parquet``:
        :func:`nudgecli.report.analysis_folders.check_folder_is_the_tables`).
    own_file
        The names of files the folder may hold without counting as not empty: the lock, and a
        command's own outputs of an earlier call (which it replaces).

    Raises
    ------
    RunFolderError
        ``folder`` holds a run or a batch, or is not empty (the lock file aside).
    """
    from nudgecli.runs.batch_folder import BATCH_MANIFEST
    from nudgecli.store import is_run_folder, prepare_mode

    path = Path(folder)
    if force or not path.is_dir() or any(_same_folder(path, Path(o)) for o in own):
        return
    if is_run_folder(path) or (path / BATCH_MANIFEST).is_file():
        plot = shell_words(["nudge", "plot", str(path)])
        raise RunFolderError(f"{path} holds another run (or batch): files written there would be read as "
                             f"that run's (`{plot}` would draw them); choose another --out (a new "
                             "or empty folder), or use --force to write there anyway")
    prepare_mode(path, None, resume=False, force=False, own_file=own_file)  # the rule of a non-empty folder


def _same_folder(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve() or (a.exists() and b.exists() and os.path.samefile(a, b))
    except OSError:
        return False


def written_together(texts: Mapping[Path, str], beside: Callable[[], list[Path]] | None = None) -> list[Path]:
    """Write each text file of ``texts`` (path -> UTF-8 text) to its temporary
    (:func:`nudgecli.store.atomic_path`), call ``beside`` (what writes the other files of the same
    output, e.g. its figures, each atomically), and only then rename the texts into place: a
    failure anywhere (a figure path that is a folder, a full disk) leaves every text file as it was
    and no temporary.

    Returns
    -------
    list[Path]
        The text files, in the order of ``texts``, then the files ``beside`` wrote.
    """
    from nudgecli.store import atomic_path, write_error  # the store builds on this module

    for path in texts:  # found now, before any file is written or renamed
        if Path(path).is_dir():
            raise write_error(path, IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR)))
    with contextlib.ExitStack() as stack:  # closed without an error: every temporary renamed into place
        for path, text in texts.items():
            stack.enter_context(atomic_path(path)).write_text(text, encoding="utf-8", newline="")
        others = beside() if beside is not None else []
    return [*texts, *others]
