"""The run-folder lock: one writer at a time for a run, batch or analysis folder.

While a command writes a folder it holds the folder's lock (:func:`run_lock`, the file
``.nudge.lock`` with the holder's pid, host and command): a second writer is refused with a
:class:`LockError` naming the holder; a lock left behind by a process of this host that no longer
runs, or a lock file that is not a lock record (damaged, edited by hand), is taken over with a
warning to the caller's ``log`` (the command's stderr, an API caller's ``log=``; none printed
without one). ``nudge study`` takes one such lock per participant
(:func:`acquire_lock_file`).
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from nudgecli.errors import LockError
from nudgecli.run_folder_names import LOCK
from nudgecli.store import utc_now, write_error

#: Locks this process holds: resolved folder -> (open lock file, depth); re-entrant per folder.
_HELD: dict[Path, list[Any]] = {}


def pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` runs on this host."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # it exists, owned by someone else
        return True
    except OSError:  # pragma: no cover - e.g. Windows without the process
        return False
    return True


def read_holder(path: Path) -> dict[str, Any]:
    """What a lock file records of its holder (pid, host, command, since); empty if unreadable."""
    try:
        data = json.loads(path.read_text(encoding="utf-8") or "{}")
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _names_no_holder(path: Path) -> bool:
    """Whether the lock file ``path`` holds something that is not a lock record (:func:`read_holder`
    reads nothing of it); an empty file is what ``open`` leaves before the record is written."""
    try:
        return bool(path.read_bytes().strip()) and not read_holder(path)
    except OSError:
        return False


def _holder_pid(holder: dict[str, Any]) -> int:
    """The pid a lock file names; -1 (no process) when it names none or not a number (a damaged
    or hand-edited lock file is then taken over like a dead holder's)."""
    try:
        return int(holder.get("pid", -1))
    except (TypeError, ValueError, OverflowError):
        return -1


def describe_holder(holder: dict[str, Any]) -> str:
    """A lock holder for a message: its command, pid, host and start time."""
    what = holder.get("command") or "a nudge command"
    return (f"`{what}` (pid {holder.get('pid', '?')} on host {holder.get('host', '?')}, "
            f"since {holder.get('since', '?')})")


def held_by_another_process(folder: Path) -> bool:
    """Whether another live process holds ``folder``'s lock (:func:`run_lock`) now: never where this
    process holds it, nor where the folder has no lock file."""
    if folder.resolve() in _HELD:
        return False
    try:
        with open(folder / LOCK, "rb") as handle:  # closing it releases a lock taken here
            return _try_lock(handle) is False
    except OSError:  # no lock file: no command holds the folder
        return False


def _try_lock(handle: Any) -> bool | None:
    """Take an exclusive, non-blocking OS lock on an open file.

    Returns
    -------
    bool or None
        True when taken, False when another process holds it, None where the platform has no
        ``flock`` (then the holder's pid is the only sign of a live holder).
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        return None
    try:
        fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return False
    return True


@contextlib.contextmanager
def run_lock(folder: str | Path, command: str | None = None,
             log: Callable[[str], None] | None = None) -> Iterator[Path]:
    """Hold the lock of the run folder ``folder`` (made if missing) for the block.

    The lock is the file ``folder/.nudge.lock``, locked with ``flock`` while held (so the OS
    releases it when the holder dies, even by SIGKILL) and holding the owner's pid, host,
    command and start time. Re-entrant within one process (``nudge run`` holds it across
    simulate, analyze and plot). The file is removed when the block ends.

    Parameters
    ----------
    folder
        The run folder (or analysis folder) about to be written.
    command
        What holds it, for the message another writer gets (default: this process's command line).
    log
        Gets the warning of a stale lock taken over (:func:`acquire_lock_file`); default silent.

    Raises
    ------
    LockError
        Another process holds the lock (the message names it), or a lock file of another host
        that cannot be verified.
    WriteError
        The folder cannot be made or the lock file written.
    """
    path = Path(folder)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_error(path, exc) from exc
    key = path.resolve()
    if key in _HELD:
        _HELD[key][1] += 1
        try:
            yield path
        finally:
            _HELD[key][1] -= 1
        return
    lock_path = path / LOCK
    handle = acquire_lock_file(lock_path, command, log)
    _HELD[key] = [handle, 1]
    try:
        yield path
    finally:
        del _HELD[key]
        with contextlib.suppress(OSError):
            lock_path.unlink()
        handle.close()


def release_inherited_locks() -> None:
    """In a child forked while this process held locks (:func:`run_lock`): close its copies of the
    lock files and forget them. An inherited copy keeps the OS lock held for as long as the child
    lives, so a child outliving its killed parent would keep the folder locked for a dead pid.
    Closing a copy releases nothing while the parent holds its own (the lock belongs to the open
    file, shared by both), and the child, holding none, removes no lock file."""
    for handle, _depth in _HELD.values():
        with contextlib.suppress(OSError):
            handle.close()
    _HELD.clear()


def acquire_lock_file(lock_path: Path, command: str | None, log: Callable[[str], None] | None = None) -> Any:
    """Open, lock and fill in ``lock_path``; the open file (closing it releases the lock). A lock left
    by a process of this host that no longer holds it is taken over, with a ``Warning:`` line to ``log``."""
    host = socket.gethostname()
    for _ in range(20):
        try:
            handle = open(lock_path, "a+", encoding="utf-8")  # noqa: SIM115 - held until release
        except OSError as exc:
            raise write_error(lock_path, exc) from exc
        locked = _try_lock(handle)
        if locked is False:
            holder = read_holder(lock_path)
            handle.close()
            raise LockError(f"{lock_path.parent}: in use by {describe_holder(holder)}; wait for it to "
                            "finish or choose another --out")
        try:
            same_file = os.fstat(handle.fileno()).st_ino == os.stat(lock_path).st_ino
        except FileNotFoundError:
            same_file = False
        if not same_file:  # the previous holder removed the file between our open and our lock
            handle.close()
            continue
        holder = read_holder(lock_path)
        if holder:
            pid = _holder_pid(holder)
            if holder.get("host") != host:
                handle.close()
                raise LockError(
                    f"{lock_path.parent}: locked by {describe_holder(holder)}, another host, which cannot "
                    f"be checked from here; if no nudge command runs there any more, delete {lock_path}")
            if locked is None and pid != os.getpid() and pid_alive(pid):  # pragma: no cover - no flock
                handle.close()
                raise LockError(f"{lock_path.parent}: in use by {describe_holder(holder)}; wait for it "
                                "to finish or choose another --out")
            state = "no longer running" if not pid_alive(pid) else "no longer holding it"
            if log is not None:
                log(f"Warning: {lock_path.parent}: taking over the stale lock of {describe_holder(holder)}, "
                    f"{state}")
        elif log is not None and _names_no_holder(lock_path):  # damaged or edited: no holder to ask
            log(f"Warning: {lock_path.parent}: taking over the stale lock {lock_path.name}, which is not a "
                "lock record (damaged or edited by hand) and names no holder")
        record = {"pid": os.getpid(), "host": host, "command": command or " ".join(
            [Path(sys.argv[0]).name, *sys.argv[1:]]), "since": utc_now()}
        try:
            handle.seek(0)
            handle.truncate()
            handle.write(json.dumps(record) + "\n")
            handle.flush()
            os.fsync(handle.fileno())
        except OSError as exc:  # a full disk: the record is not there, so neither is the lock
            with contextlib.suppress(OSError):
                lock_path.unlink()  # still ours (locked): an emptied file would look like a damaged holder's
            with contextlib.suppress(OSError):  # closing flushes the unwritten record and fails again
                handle.close()
            raise write_error(lock_path, exc) from exc
        return handle
    raise LockError(f"{lock_path.parent}: could not take the lock (it changed hands repeatedly); try again")
