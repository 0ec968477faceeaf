"""A batch's progress on stderr: tasks done, rate and time left (:class:`Progress`)."""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from typing import TextIO


class Progress:
    """Progress on a stream: tasks done, rate and ETA, one line every ``interval`` seconds.

    On a terminal the line is rewritten in place (every 0.5 s), padded with spaces to the length
    of the line it overwrites (a shorter one, "ETA 20 s" after "ETA 16.5 min", would leave the
    old line's last characters; spaces work on any terminal, where an erase code may not);
    otherwise (a log, CI) a new line is written at most every ``interval`` seconds, and always
    for the last task.

    The ETA is the tasks left at the rate so far plus ``tail_s``: the seconds the command runs after
    its last task (a batch's tables and figures), which the batch sets from its size estimate
    (:func:`nudgecli.runs.size.tail_seconds`); 0 until then, so the ETA counts the tasks only.
    """

    def __init__(self, label: str, stream: TextIO | None = None, interval: float = 5.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.clock = clock
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.interval = 0.5 if self.tty else interval
        self.start = clock()
        self.first_done: int | None = None
        self.last = -math.inf
        self.shown = 0  # the length of the line on the terminal now (to overwrite it all)
        self.tail_s = 0.0

    def line(self, done: int, total: int) -> str:
        """``label: done/total tasks (pct), rate tasks/s, ETA ...`` (the rate counts this session only;
        with every task done the ETA is ``tail_s``, and a batch whose tasks were all done before, a
        finished one resumed, says ``done before`` for its rate: "ETA unknown" read as work left)."""
        if self.first_done is None:
            self.first_done = done
        elapsed = self.clock() - self.start
        new = done - self.first_done
        rate = new / elapsed if elapsed > 0 and new > 0 else 0.0
        pct = 100.0 * done / total if total else 100.0
        ran = f"{rate:.2f} tasks/s"
        if done >= total:  # only the tables and figures are left, whatever the rate (none: all done before)
            ran = ran if new > 0 else "done before"
            eta = format_duration(self.tail_s)
        else:
            eta = format_duration((total - done) / rate + self.tail_s) if rate > 0 else "unknown"
        return f"{self.label}: {done}/{total} tasks ({pct:.0f}%), {ran}, ETA {eta}"

    def __call__(self, done: int, total: int) -> None:
        text = self.line(done, total)
        now = self.clock()
        if done < total and now - self.last < self.interval:
            return
        self.last = now
        if self.tty:
            self.stream.write("\r" + text.ljust(self.shown) + ("\n" if done >= total else ""))
            self.shown = 0 if done >= total else len(text)
        else:
            self.stream.write(text + "\n")
        self.stream.flush()


def format_duration(seconds: float) -> str:
    """Seconds as "42 s", "3.5 min" or "1.2 h"."""
    if seconds < 60:
        return f"{seconds:.0f} s"
    if seconds < 3600:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"
