"""The analysis folder of a metrics table, and whose analysis such a folder holds.

``nudge analyze study.csv`` writes its files to ``study-analysis/`` beside the table
(:func:`analysis_folder`). ``study.csv`` and ``study.parquet`` would share that folder, so the
folder's ``stats.json`` is asked whose analysis it holds (:func:`analysed_table`): its
``metrics_table`` names the table analysed as it is, and for a table the analysis changed (its
rows are then in ``metrics.csv``) the SHA-256 of ``table_read``
(:mod:`nudgecli.report.table_read`) tells which table beside the folder it was. One table's
analysis never silently replaces another's (:func:`check_folder_is_the_tables`), and
``nudge plot FOLDER --plan PLAN`` knows which table to analyse again.

An analysis writes :data:`ANALYSIS_FILES` with ``stats.json``, which every reader starts from,
removed first and written last: a folder holding analysis files (or their temporaries) but no
``stats.json`` holds an analysis cut short (:func:`interrupted_analysis`), which ``nudge plot``
refuses naming the command that completes it (:func:`check_analysis_complete`). ``nudge plot
--plan`` analyses again before it draws, and puts the analysis it replaced back when the plot
then fails (:func:`analysis_restored_on_failure`); killed meanwhile, the next analysis of the
folder puts it back (:func:`recover_kept_analysis`).
"""

from __future__ import annotations

import contextlib
import filecmp
import glob
import json
import os
import re
import shutil
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from nudgecli.errors import RunFolderError, shell_words
from nudgecli.locks import LOCK, pid_alive
from nudgecli.report.tables import TABLE_SUFFIXES
from nudgecli.run_folder_names import (
    ANALYSIS_FILES,
    MANIFEST,
    METRICS_CSV,
    STATS_JSON,
)
from nudgecli.run_folder_record import file_sha256
from nudgecli.run_folder_state import refuse_links
from nudgecli.store import temporary_prefix, write_error

#: What a table's default analysis folder adds to its stem: ``study.csv`` -> ``study-analysis/``.
ANALYSIS_FOLDER_SUFFIX = "-analysis"


def analysis_folder(table: Path) -> Path:
    """The default output folder of a metrics table: ``study.csv`` -> ``study-analysis/`` beside it."""
    return table.with_name(f"{table.stem}{ANALYSIS_FOLDER_SUFFIX}")


def tables_beside(folder: Path) -> list[Path]:
    """The metrics tables whose default analysis folder is ``folder`` (same folder, the stem it
    names, a table's suffix: ``study.csv``, ``study.parquet`` for ``study-analysis/``), sorted."""
    if not folder.name.endswith(ANALYSIS_FOLDER_SUFFIX) or not folder.parent.is_dir():
        return []
    stem = folder.name[:-len(ANALYSIS_FOLDER_SUFFIX)]
    return sorted(path for path in folder.parent.iterdir()
                  if path.stem == stem and path.suffix.lower() in TABLE_SUFFIXES and path.is_file())


def analysed_table(folder: Path) -> Path | None:
    """The metrics table whose analysis ``folder`` holds, as its ``stats.json`` records it.

    ``metrics_table`` names it (relative to the folder) when the table was analysed as it is. When
    it names the folder's own ``metrics.csv`` (the analysis changed the table), the table is the one
    ``table_read`` names (relative to the folder) while its SHA-256 is the record's, else (a record
    of an older nudge, or a table moved) the one beside the folder (:func:`tables_beside`) with it.

    Returns
    -------
    Path | None
        The table (it may since have been removed, when named); ``None`` without a readable
        ``stats.json``, for a run folder's analysis, or when no table beside the folder has the
        recorded bytes (edited since, or moved).
    """
    try:
        stats = json.loads((folder / STATS_JSON).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    named = stats.get("metrics_table") if isinstance(stats, dict) else None
    if not isinstance(named, str):
        return None
    if named != METRICS_CSV:
        return Path(os.path.normpath(folder / named))
    record = stats.get("table_read")
    sha256 = record.get("sha256") if isinstance(record, dict) else None
    if not isinstance(sha256, str):
        return None  # a run's analysis, or one of an older nudge: nothing says which table
    named = record.get("table") if isinstance(record, dict) else None
    candidates = [Path(os.path.normpath(folder / named))] if isinstance(named, str) else []
    candidates += tables_beside(folder)
    return next((table for table in candidates if table.is_file() and file_sha256(table) == sha256), None)


def _same_file(a: Path, b: Path) -> bool:
    """Whether two paths name one file (resolved, or the same inode: a hard link)."""
    if a.resolve() == b.resolve():
        return True
    with contextlib.suppress(OSError):
        return os.path.samefile(a, b)
    return False


def check_folder_is_the_tables(table: Path, folder: Path) -> None:
    """Refuse to analyse ``table`` into ``folder`` when the folder holds another table's analysis.

    Raises
    ------
    RunFolderError
        ``folder``'s ``stats.json`` records another metrics table (:func:`analysed_table`): one
        line naming the folder, that table and the fix (``--out`` or ``--force``).
    """
    other = analysed_table(folder)
    if other is None or _same_file(other, table):
        return
    own = table.with_name(f"{table.stem}-{table.suffix.lstrip('.').lower()}{ANALYSIS_FOLDER_SUFFIX}")
    raise RunFolderError(f"{folder} holds the analysis of {other}, not of {table}; analysing {table} "
                         f"there would replace it: give {table} a folder of its own with --out (e.g. "
                         f"--out {own}), or use --force to replace that analysis")


def refuse_linked_analysis(folder: Path) -> None:
    """Refuse an analysis folder where a file the analysis writes (:data:`ANALYSIS_FILES`) is a
    symbolic link: the analysis would replace (or a killed plot put back) what the link names
    (:func:`~nudgecli.run_folder_state.refuse_links`), one ``Error:`` line naming it."""
    refuse_links(folder, ANALYSIS_FILES)


def left_by_a_killed_analysis(folder: str | Path) -> Callable[[str], bool]:
    """Whether a file name in ``folder`` may be left by an analysis killed there (the next replaces or
    removes it): the lock, an analysis file but ``stats.json`` (a complete analysis is not replaced
    unasked), a temporary of any of them (:func:`~nudgecli.store.temporary_prefix`) but those this
    process keeps (:func:`analysis_restored_on_failure`: the analysis it runs must not remove them)."""
    mine = _kept_suffix()
    return lambda name: name == LOCK or name in ANALYSIS_FILES[:-1] or (
        name.endswith(".tmp") and not name.endswith(mine)
        and any(name.startswith(temporary_prefix(Path(folder) / own)) for own in ANALYSIS_FILES))


def interrupted_analysis(folder: Path) -> list[str]:
    """The files an analysis cut short left in ``folder`` (sorted): its files or their temporaries
    where there is no ``stats.json`` (written last, removed first); empty for a complete analysis,
    or a folder no analysis wrote."""
    if not folder.is_dir() or (folder / STATS_JSON).exists():
        return []
    left = left_by_a_killed_analysis(folder)
    return sorted(path.name for path in folder.iterdir() if path.name != LOCK and left(path.name))


def check_analysis_complete(folder: Path, source: Path | None = None) -> None:
    """Refuse a folder that holds an analysis cut short (:func:`interrupted_analysis`).

    Parameters
    ----------
    folder
        The run folder or analysis folder about to be plotted.
    source
        What was analysed there: the run folder or the metrics table; ``None`` (an analysis
        folder given by itself): the table beside it whose analysis folder it is
        (:func:`tables_beside`), else a ``TABLE`` for the user to fill in.

    Raises
    ------
    RunFolderError
        One line naming the folder, what the interrupted analysis left and the ``nudge analyze``
        command that completes it.
    """
    left = interrupted_analysis(folder)
    if not left:
        return
    beside = tables_beside(folder)
    analysed = source if source is not None else beside[0] if len(beside) == 1 else None
    own = None if analysed is None else analysed if analysed.is_dir() else analysis_folder(analysed)
    words = ["nudge", "analyze", str(analysed or "TABLE")]
    if own is None or own.resolve() != folder.resolve():
        words += ["--out", str(folder)]
    table_is = "TABLE: the table analysed there; " if analysed is None else ""
    raise RunFolderError(f"{folder}: its analysis is incomplete ({', '.join(left)} but no {STATS_JSON}: an "
                         "analysis was interrupted before it finished); complete it with "
                         f"`{shell_words(words)}` ({table_is}with the options the interrupted analysis was "
                         "given, such as --plan), then plot")


@contextlib.contextmanager
def analysis_restored_on_failure(folder: Path, *, run: bool = False) -> Iterator[None]:
    """Put the analysis ``folder`` holds now back as it was if the block fails (``nudge plot
    --plan``: the plot after the analysis again), ``stats.json`` removed first and put back last;
    files the block wrote that were not there are removed. The caller holds the folder's lock.

    The files are kept as hard links (a copy where the file system has none) named as
    temporaries of the files (:func:`~nudgecli.store.temporary_prefix`), which the next analysis
    removes if this process is killed: an analysis's atomic writes replace a file's name, never
    the bytes the link holds. ``run``: the folder is a run folder, whose manifest the analysis may
    record its plan in, kept too.

    Raises
    ------
    WriteError
        The files cannot be kept (nothing has been changed then).
    """
    refuse_linked_analysis(folder)  # a link is neither kept nor analysed through
    recover_kept_analysis(folder)  # what a killed plot kept first: else this one would keep its mix
    names = [MANIFEST, *ANALYSIS_FILES] if run else list(ANALYSIS_FILES)
    kept: dict[str, Path] = {}
    try:  # stats.json first: a kept set without it (killed meanwhile) kept a folder without one
        for name in sorted(names, key=lambda name: name != STATS_JSON):
            if (folder / name).is_file():
                kept[name] = _kept_copy(folder / name)
    except OSError as exc:
        _remove(kept.values())
        raise write_error(folder, exc) from exc
    try:
        yield
    except BaseException:
        with contextlib.suppress(OSError):  # as far as it goes: stats.json stays away from a mix
            _put_back(folder, names, kept)
        _remove(kept.values())
        raise
    _finished(folder, kept)


def _finished(folder: Path, kept: dict[str, Path]) -> None:
    """The block succeeded: its analysis (and the figures drawn of it) stands. A marker says so
    before the kept files go (the kept ``stats.json`` renamed to it, else an empty one), so that a
    kill while they are removed leaves a set the next command discards (:func:`recover_kept_analysis`),
    never one it puts back beside the figures drawn of the new analysis."""
    done = _done_marker(folder, os.getpid())
    with contextlib.suppress(OSError):
        if STATS_JSON in kept:
            os.replace(kept.pop(STATS_JSON), done)
        else:
            done.touch()
        _remove(kept.values())
        done.unlink(missing_ok=True)


def recover_kept_analysis(folder: Path) -> None:
    """Put back the analysis a ``nudge plot --plan`` killed in ``folder`` kept
    (:func:`analysis_restored_on_failure`, whose process is no longer running), as that plot would
    have on failure, unless the folder holds it still; then remove the kept files. The caller holds
    the folder's lock; every command that writes an analysis there calls it first.

    The files were kept ``stats.json`` first and changed only once all were kept: a kept set whose
    every file is the folder's own (and ``stats.json`` kept exactly where the folder has one) is the
    analysis the folder holds (the plot was killed before it changed anything), and is discarded.

    Raises
    ------
    WriteError
        A file cannot be put back or removed.
    """
    for _, kept in sorted(_kept_by_dead_processes(folder).items()):
        try:
            if _DONE in kept:  # the plot had finished: its analysis stands, what it kept goes
                for path in kept.values():
                    path.unlink(missing_ok=True)
                continue
            if MANIFEST in kept and not _only_plan_recorded(kept[MANIFEST], folder / MANIFEST):
                kept.pop(MANIFEST).unlink()  # changed since by another command: the folder's own stays
            if not _kept_is_current(folder, kept):
                _put_back(folder, [MANIFEST, *ANALYSIS_FILES] if MANIFEST in kept else list(ANALYSIS_FILES),
                          kept)
            for path in kept.values():  # a link to the file itself is not replaced: it stays until here
                path.unlink(missing_ok=True)
        except OSError as exc:
            raise write_error(folder, exc) from exc


def _kept_by_dead_processes(folder: Path) -> dict[int, dict[str, Path]]:
    """The files processes no longer running kept in ``folder`` (:func:`_kept_copy`): pid -> {name
    of the file kept: the kept file}, and :data:`_DONE`: the marker of a plot that had finished."""
    found: dict[int, dict[str, Path]] = {}
    if not folder.is_dir():
        return found
    for name, word in [(name, "kept") for name in (MANIFEST, *ANALYSIS_FILES)] + [(_DONE, "done")]:
        prefix = temporary_prefix(folder / (STATS_JSON if name == _DONE else name))
        for path in folder.glob(f"{glob.escape(prefix)}{word}-*.tmp"):
            pid = re.fullmatch(rf"{word}-(\d+)\.tmp", path.name[len(prefix):])
            if pid is not None and int(pid[1]) != os.getpid() and not pid_alive(int(pid[1])):
                found.setdefault(int(pid[1]), {})[name] = path
    return found


#: The key of a finished plot's marker among what a process kept (:func:`_finished`).
_DONE = "done"


def _done_marker(folder: Path, pid: int) -> Path:
    """The marker of process ``pid``'s finished plot: a temporary of ``stats.json``'s (:func:`_finished`)."""
    return folder / f"{temporary_prefix(folder / STATS_JSON)}{_DONE}-{pid}.tmp"


def _only_plan_recorded(kept: Path, current: Path) -> bool:
    """Whether the run manifest ``current`` is the ``kept`` one or differs from it only by the
    ``plan`` an analysis records in a manifest without one (``nudge analyze``'s only change to a
    manifest): then the kept one is put back; a manifest another command changed since is not."""
    try:
        old, new = (json.loads(path.read_text(encoding="utf-8")) for path in (kept, current))
    except (OSError, ValueError):
        return False
    if not isinstance(old, dict) or not isinstance(new, dict):
        return False
    return old == new or ("plan" not in old and old == {k: v for k, v in new.items() if k != "plan"})


def _kept_is_current(folder: Path, kept: dict[str, Path]) -> bool:
    """Whether the files ``kept`` are the folder's own (the same file, or the same bytes where they
    were copied) and ``stats.json`` was kept exactly where the folder has one."""
    if (STATS_JSON in kept) != (folder / STATS_JSON).is_file():
        return False
    for name, path in kept.items():
        current = folder / name
        if not current.is_file() or not (os.path.samefile(path, current)
                                         or filecmp.cmp(path, current, shallow=False)):
            return False
    return True


def _put_back(folder: Path, names: list[str], kept: dict[str, Path]) -> None:
    """Put the files ``kept`` back in ``folder`` and remove its other ``names``: ``stats.json``
    removed first and put back last, so that it never stands beside a mix of two analyses. A kept
    link to the file itself is not replaced (``os.replace`` leaves both names): the caller removes it.

    Raises
    ------
    OSError
        A file cannot be put back or removed (the folder then holds no ``stats.json``).
    """
    (folder / STATS_JSON).unlink(missing_ok=True)
    for name in sorted(names, key=lambda name: name == STATS_JSON):
        if name in kept:
            os.replace(kept[name], folder / name)
        else:
            (folder / name).unlink(missing_ok=True)


def _kept_copy(path: Path) -> Path:
    """A hard link to ``path`` (else a copy) named as one of its temporaries (the caller holds the
    folder's lock: a temporary of that name is one a killed process left)."""
    kept = path.with_name(f"{temporary_prefix(path)}{_kept_suffix()}")
    kept.unlink(missing_ok=True)
    try:
        os.link(path, kept)
    except OSError:  # no hard links on this file system: a copy
        shutil.copy2(path, kept)
    return kept


def _kept_suffix() -> str:
    """How the names of the files this process keeps end (:func:`_kept_copy`)."""
    return f"kept-{os.getpid()}.tmp"


def _remove(paths: Iterable[Path]) -> None:
    """Remove the kept files ``paths`` that are still there."""
    for path in list(paths):
        with contextlib.suppress(OSError):
            path.unlink(missing_ok=True)


__all__ = ["ANALYSIS_FILES", "ANALYSIS_FOLDER_SUFFIX", "analysed_table", "analysis_folder",
           "analysis_restored_on_failure", "check_analysis_complete", "check_folder_is_the_tables",
           "interrupted_analysis", "left_by_a_killed_analysis", "recover_kept_analysis",
           "refuse_linked_analysis", "tables_beside"]
