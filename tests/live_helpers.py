"""Shared pieces of the live-session tests: a two-trial study and a recorded input stream."""

from __future__ import annotations

import socket
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from nudgecli.live.input import KEY_LABELS, key_pressures
from nudgecli.model.interface import NO_INPUT

#: A two-trial study (one layout per condition, one block each), short trials, short calibration.
TWO_TRIALS = (
    "study.blocks_per_condition=1",
    "study.goal_counts=[3]",
    'study.corners=["tr"]',
    'study.start_modes=["x"]',
    "study.time_limit_s=4",
    "calibration.mapping_blocks=1",
    "calibration.prompts_per_label=1",
    "calibration.prompt_s=1",
    "calibration.blank_s=0.3",
    "calibration.answer_clear_s=0",
    "calibration.block_break_s=0",
)
DEFAULT_TABLES = ("model.tables=default",)

ANSWERS = {
    **{
        f"tlx_{k}": v
        for k, v in zip(
            ("mental", "physical", "temporal", "performance", "effort", "frustration"),
            (35, 10, 40, 20, 45, 30),
            strict=True,
        )
    },
    **{f"likert_{q}": v for q, v in zip(("q3", "q4", "q7", "q10"), (6, 5, 4, 3), strict=True)},
}

#: One recorded input: ("key", "1".."4"), ("axis", pressure) or ("none", 0).
Item = tuple[str, object]


def free_port() -> int:
    """A port on 127.0.0.1 that nothing listens on now (the system's pick): a test's own ``--port``,
    since ``nudge study`` binds its port before it checks the rest, and a fixed port may be held by
    another test running at the same time (pytest -n) or by anything else on the machine."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def recorded_stream(rng: np.random.Generator, n: int) -> list[Item]:
    """``n`` samples of keys held (soft for a while, hard briefly), pauses long enough to hand over,
    and gamepad-axis stretches with a new pressure each sample."""
    out: list[Item] = []
    while len(out) < n:
        kind = rng.integers(4)
        if kind == 0:
            out += [("key", str(int(rng.integers(3, 5))))] * int(rng.integers(3, 15))
        elif kind == 1:
            out += [("key", str(int(rng.integers(1, 3))))] * int(rng.integers(1, 4))
        elif kind == 2:
            out += [("none", 0)] * int(rng.integers(1, 26))
        else:
            out += [("axis", float(v)) for v in rng.uniform(-1.0, 1.0, int(rng.integers(2, 8)))]
    return out[:n]


def as_samples(stream: list[Item], interface) -> list[tuple[int, float]]:
    """The ``(intended, pressure)`` samples a stream means (keys at their band's middle)."""
    pressures = key_pressures(interface)
    samples = []
    for kind, value in stream:
        if kind == "key":
            label = KEY_LABELS[str(value)]
            samples.append((label, float(pressures[label])))
        elif kind == "axis":
            samples.append((NO_INPUT, float(value)))
        else:
            samples.append((NO_INPUT, 0.0))
    return samples


def transition(current: Item, wanted: Item) -> list[dict]:
    """The page's messages that change the input from ``current`` to ``wanted``."""
    messages: list[dict] = []
    if current == wanted:
        return messages
    if current[0] == "key" and (wanted[0] != "key" or wanted[1] != current[1]):
        messages.append({"type": "key", "key": current[1], "down": False})
    if current[0] == "axis" and wanted[0] != "axis":
        messages.append({"type": "axis", "value": None})
    if wanted[0] == "key" and current != wanted:
        messages.append({"type": "key", "key": wanted[1], "down": True})
    if wanted[0] == "axis":
        messages.append({"type": "axis", "value": wanted[1]})
    return messages


def played_folder(out: Path, until: Callable[[Any], bool], participant: str = "P01") -> Any:
    """The :class:`nudgecli.live.session.LiveSession` of ``participant`` in a two-trial study
    (:data:`TWO_TRIALS`, :data:`DEFAULT_TABLES`) written to ``out``, played
    (:func:`play_session`) until ``until(session)`` holds and its folder released."""
    from nudgecli.live.app import build_session  # the live server needs aiohttp: a test skips first

    session = build_session("paper", participant, out, overrides=TWO_TRIALS + DEFAULT_TABLES)
    play_session(session, until)
    session.folder.release()
    return session


def play_session(session: Any, until: Callable[[Any], bool]) -> None:
    """Skip the practice of a :class:`nudgecli.live.session.LiveSession`, then run its trials without
    input, answering each questionnaire with :data:`ANSWERS`, until ``until(session)`` holds (or the
    session is done)."""
    for message in ({"type": "start"}, {"type": "skip"}):
        session.handle(message, 0.0)
    while session.phase != "done" and not until(session):
        if session.phase == "questionnaire":
            session.handle({"type": "questionnaire", "answers": ANSWERS}, 0.0)
        elif session.phase == "ready":
            session.handle({"type": "start"}, 0.0)
        else:
            session.tick(0.0)
