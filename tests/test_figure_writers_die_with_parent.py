"""The figure writers `nudge plot` forks never outlive it: killed with SIGKILL, it leaves no writer
running, and no writer holding the folder's lock for a dead pid."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from nudgecli.locks import held_by_another_process
from nudgecli.run_folder_names import LOCK

#: A plot whose figure writers take long: each notes its pid, then sleeps.
_PLOT = """
import os, sys, time
from pathlib import Path
from matplotlib.figure import Figure
from nudgecli.locks import run_lock
from nudgecli.report.figures import output

folder = Path(sys.argv[1])

def slow(fig, temporaries, targets, formats, dpi):
    (folder / f"writer-{os.getpid()}").write_text("")
    time.sleep(30)

output._render = slow
output.available_cores = lambda: 2
output._other_threads_running = lambda: False
with run_lock(folder, "nudge plot"):
    output.save_figures({"a": Figure(), "b": Figure()}, folder / "figures", ["png"], processes=2)
"""


def _running(pid: int) -> bool:
    """Whether ``pid`` runs (an exited process its parent has not reaped yet does not)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state not in ("Z", "X")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_a_killed_plot_leaves_no_figure_writer_holding_its_lock(tmp_path: Path) -> None:
    plot = subprocess.Popen([sys.executable, "-c", _PLOT, str(tmp_path)])
    writers: list[int] = []
    try:
        deadline = time.monotonic() + 15
        while len(writers) < 2 and time.monotonic() < deadline and plot.poll() is None:
            time.sleep(0.02)
            writers = [int(p.name.split("-")[1]) for p in tmp_path.glob("writer-*")]
        assert len(writers) == 2, "the figure writers did not start"
        os.kill(plot.pid, signal.SIGKILL)
        plot.wait()
        deadline = time.monotonic() + 1.5
        while any(map(_running, writers)) and time.monotonic() < deadline:
            time.sleep(0.02)
        assert not any(map(_running, writers)), "a figure writer outlived its killed plot"
        assert not held_by_another_process(tmp_path)  # the lock went with its holder
    finally:
        for pid in writers:
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
        if plot.poll() is None:
            plot.kill()


@pytest.mark.skipif(not hasattr(os, "fork"), reason="forks")
def test_a_child_that_released_its_inherited_lock_keeps_no_folder_locked(tmp_path: Path) -> None:
    from nudgecli import locks
    from nudgecli.locks import release_inherited_locks

    # held as run_lock holds it; the holder then dies (SIGKILL): its lock file stays, its copy closes
    handle = locks.acquire_lock_file(tmp_path / LOCK, "nudge plot")
    locks._HELD[tmp_path.resolve()] = [handle, 1]
    read, write = os.pipe()
    child = os.fork()
    if child == 0:  # pragma: no cover - the child
        release_inherited_locks()
        os.write(write, b"x")
        time.sleep(10)
        os._exit(0)
    os.read(read, 1)
    del locks._HELD[tmp_path.resolve()]
    handle.close()
    try:
        assert (tmp_path / LOCK).is_file()
        assert not held_by_another_process(tmp_path)  # the child kept no copy of the dead holder's lock
    finally:
        os.kill(child, signal.SIGKILL)
        os.waitpid(child, 0)
        os.close(read)
        os.close(write)
