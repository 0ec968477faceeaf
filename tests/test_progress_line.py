"""On a terminal the progress line is rewritten in place; a shorter line must not leave the end of
the longer one before it on the screen ("ETA 20 sn", the "n" left of "ETA 16.5 min")."""

from __future__ import annotations

import io

from nudgecli.runs.progress import Progress


class FakeTerminal(io.StringIO):
    """A stream that says it is a terminal and shows its last line as a terminal would: a carriage
    return moves back to the line's start, and what follows overwrites it character by character."""

    def isatty(self) -> bool:
        return True

    def screen_line(self) -> str:
        shown = ""
        for piece in self.getvalue().split("\n")[-1].split("\r"):
            shown = piece + shown[len(piece):]
        return shown


def test_a_shorter_line_overwrites_all_of_the_longer_one_before_it() -> None:
    now = [0.0]
    terminal = FakeTerminal()
    progress = Progress("sweep", stream=terminal, clock=lambda: now[0])
    progress(0, 1000)
    now[0] = 100.0
    progress(100, 1000)  # 1 task/s: 900 s to go, "ETA 15.0 min"
    assert terminal.screen_line().endswith("ETA 15.0 min")
    now[0] = 101.0
    progress(980, 1000)  # far faster: "ETA 2 s", shorter
    assert terminal.screen_line().rstrip() == "sweep: 980/1000 tasks (98%), 9.70 tasks/s, ETA 2 s"
    now[0] = 102.0
    progress(1000, 1000)  # the last line ends the line
    assert terminal.getvalue().endswith("ETA 0 s\n")
