"""The paper's calibration phases 1-2 with a live person, recorded as the logs ``nudge fit`` reads.

- :class:`MappingRecorder` (phase 1, ``p(phi_i | a)``, prompt-and-select): the study's protocol
  as :func:`nudgecli.sim.calibration.simulate_mapping_session` runs it with a simulated person:
  ``mapping_blocks`` blocks of the 12 action prompts in random order; an answer (key 1-4) clears
  the prompt ``answer_clear_s`` later, no answer within ``answer_timeout_s`` clears it unanswered;
  the last prompt of a block is cleared by ``hard_puff_training`` and the next block follows
  ``block_break_s`` later.
- :class:`DistortionRecorder` (phase 2, ``p(phi_m | phi_i)``, prompt-and-produce): ``prompts_per_label``
  rounds of the four labels in random order, each shown ``prompt_s`` then blank ``blank_s``, the
  input stream sampled at every protocol step and labelled by the driver's bands; a prompt that
  got no input is appended again at the end, as in the study.

Both produce the in-memory sessions of :mod:`nudgecli.sim.calibration_io`, written in the tidy
format and fitted by the estimators of :mod:`nudgecli.sim.calibration` (those of ``nudge fit``).
Times are seconds on the live session's clock.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from nudgecli.config import CalibrationSection, InterfaceSection
from nudgecli.errors import RunFolderError
from nudgecli.model.interface import ACTIONS, LABELS, N_LABELS, label_of_pressure
from nudgecli.model.world import MODE_NAMES
from nudgecli.run_folder_calibration import LIVE_CALIBRATION_FILES, changed_logs, log_digests
from nudgecli.sim.calibration import IMAGE_TO_MODE_ACTION, MAX_REPEAT_ROUNDS, PROMPT_GAP_S
from nudgecli.sim.calibration_io import (
    ACTION_IMAGES,
    BLOCK_BREAK_COMMAND,
    TIDY_FILES,
    DistortionSession,
    MappingSession,
    is_counted_code,
    write_sessions,
)
from nudgecli.store import write_error

#: The participant's manifest entry's record of their calibration logs' SHA-256 (file name -> hex),
#: written when each part ends: a crash during part 2 keeps part 1, and a resume starts at part 2
#: (the key is :mod:`nudgecli.run_folder_calibration`'s, which checks the logs wherever they are read).
CALIBRATION_FILES = LIVE_CALIBRATION_FILES

#: What the page shows for each action prompt.
_MOTION_TEXT = {
    "up": "Move the robot UP",
    "down": "Move the robot DOWN",
    "left": "Move the robot LEFT",
    "right": "Move the robot RIGHT",
    "clockwise": "Turn the robot CLOCKWISE",
    "counterclockwise": "Turn the robot COUNTERCLOCKWISE",
}


def action_prompt_text(image: str) -> str:
    """The words shown for an action prompt of the mapping session."""
    if image in _MOTION_TEXT:
        return _MOTION_TEXT[image]
    mode, action = IMAGE_TO_MODE_ACTION[image]
    direction = "forward" if ACTIONS[action] == "to_mode_r" else "backward"
    return f"Switch the mode {direction} (from the {MODE_NAMES[mode]} mode)"


@dataclass
class MappingRecorder:
    """Phase 1 with a live person: prompts shown and cleared, answers recorded."""

    calibration: CalibrationSection
    order: np.ndarray
    source: str = "live"
    index: int = 0
    shown_at: float | None = None
    answered_at: float | None = None
    next_show: float | None = None
    prompt_times: list[float] = field(default_factory=list)
    commands: list[str] = field(default_factory=list)
    response_times: list[float] = field(default_factory=list)
    response_labels: list[int] = field(default_factory=list)

    @classmethod
    def create(
        cls, calibration: CalibrationSection, rng: np.random.Generator, source: str
    ) -> MappingRecorder:
        """The prompts in random order per block (draws: the block orders ``(B, 12)``)."""
        n = len(ACTION_IMAGES)
        order = rng.permuted(np.tile(np.arange(n), (calibration.mapping_blocks, 1)), axis=1).ravel()
        return cls(calibration, order, source)

    @property
    def done(self) -> bool:
        return self.index >= len(self.order)

    @property
    def prompt(self) -> str | None:
        """The action image shown now, or ``None``."""
        if self.shown_at is None or self.answered_at is not None or self.done:
            return None
        return ACTION_IMAGES[int(self.order[self.index])]

    def answer(self, label: int, now: float) -> None:
        """A key 1-4 (label 0-3) pressed at ``now``: counts while a prompt is shown and unanswered."""
        if self.prompt is None:
            return
        self.response_times.append(now)
        self.response_labels.append(label)
        self.answered_at = now

    def tick(self, now: float) -> None:
        """Show, time out and clear prompts on the session's clock."""
        if self.done:
            return
        c = self.calibration
        if self.shown_at is None:
            if self.next_show is None or now >= self.next_show:
                self.shown_at = now
                self.prompt_times.append(now)
                self.commands.append(ACTION_IMAGES[int(self.order[self.index])])
            return
        if self.answered_at is not None:
            clear = now >= self.answered_at + c.answer_clear_s
        else:
            clear = now >= self.shown_at + c.answer_timeout_s
        if not clear:
            return
        n = len(ACTION_IMAGES)
        block_end = (self.index + 1) % n == 0 and self.index + 1 < len(self.order)
        self.prompt_times.append(now)
        self.commands.append(BLOCK_BREAK_COMMAND if block_end else "")
        self.next_show = now + (c.block_break_s if block_end else PROMPT_GAP_S)
        self.index += 1
        self.shown_at = self.answered_at = None

    @property
    def in_break(self) -> bool:
        """Between two blocks (the study's hard-puff refresher)."""
        return bool(self.commands) and self.commands[-1] == BLOCK_BREAK_COMMAND and self.shown_at is None

    def session(self) -> MappingSession:
        return MappingSession(
            np.array(self.prompt_times, dtype=float),
            tuple(self.commands),
            np.array(self.response_times, dtype=float),
            np.array(self.response_labels, dtype=int),
            {"source": self.source},
        )

    def progress(self) -> tuple[int, int]:
        return self.index, len(self.order)


@dataclass
class DistortionRecorder:
    """Phase 2 with a live person: label prompts and the labelled 10 Hz stream."""

    calibration: CalibrationSection
    interface: InterfaceSection
    labels: list[int]
    source: str = "live"
    index: int = 0
    shown_at: float | None = None
    blank_at: float | None = None
    counted_in_prompt: bool = False
    repeats: dict[int, int] = field(default_factory=dict)
    prompt_times: list[float] = field(default_factory=list)
    commands: list[str] = field(default_factory=list)
    stream_times: list[float] = field(default_factory=list)
    stream_codes: list[int] = field(default_factory=list)
    stream_pressure: list[float] = field(default_factory=list)

    @classmethod
    def create(
        cls,
        calibration: CalibrationSection,
        interface: InterfaceSection,
        rng: np.random.Generator,
        source: str,
    ) -> DistortionRecorder:
        """Rounds of the four labels in random order (draws: the rounds' orders ``(R, 4)``)."""
        rounds = np.tile(np.arange(N_LABELS), (calibration.prompts_per_label, 1))
        labels = [int(v) for v in rng.permuted(rounds, axis=1).ravel()]
        return cls(calibration, interface, labels, source)

    @property
    def done(self) -> bool:
        return self.index >= len(self.labels)

    @property
    def prompt(self) -> str | None:
        """The label to produce now, or ``None`` (blank)."""
        if self.shown_at is None or self.blank_at is not None or self.done:
            return None
        return LABELS[self.labels[self.index]]

    def sample(self, now: float, pressure: float) -> None:
        """One stream sample at ``now``, then the prompt's timing."""
        if self.done:
            return
        i = self.interface
        code = label_of_pressure(pressure, i.soft_threshold, i.hard_threshold, i.zero_threshold)
        self.stream_times.append(now)
        self.stream_codes.append(code)
        self.stream_pressure.append(pressure)
        counted = bool(is_counted_code(np.array([code]))[0])
        c = self.calibration
        if self.shown_at is None:
            self.shown_at = now
            self.counted_in_prompt = counted
            self.prompt_times.append(now)
            self.commands.append(LABELS[self.labels[self.index]])
            return
        if self.blank_at is None:
            if now >= self.shown_at + c.prompt_s:
                self.blank_at = now
                self.prompt_times.append(now)
                self.commands.append("")
            else:
                self.counted_in_prompt = self.counted_in_prompt or counted
            return
        if now >= self.blank_at + c.blank_s:
            label = self.labels[self.index]
            if not self.counted_in_prompt and self.repeats.get(label, 0) < MAX_REPEAT_ROUNDS:
                self.repeats[label] = self.repeats.get(label, 0) + 1
                self.labels.append(label)  # as in the study: a prompt without input comes again
            self.index += 1
            self.shown_at = self.blank_at = None

    def session(self) -> DistortionSession:
        return DistortionSession(
            np.array(self.prompt_times, dtype=float),
            tuple(self.commands),
            np.array(self.stream_times, dtype=float),
            np.array(self.stream_codes, dtype=int),
            np.array(self.stream_pressure, dtype=float),
            {"source": self.source},
        )

    def progress(self) -> tuple[int, int]:
        return self.index, len(self.labels)


def write_calibration_logs(folder: Path, mapping: MappingSession | None,
                           distortion: DistortionSession | None) -> dict[str, str]:
    """Write a part's log in the tidy format into ``folder`` (each file atomically); returns each
    file's SHA-256 (name -> hex), for the manifest.

    Raises
    ------
    WriteError
        A file could not be written, naming the folder.
    """
    try:
        return log_digests(write_sessions(folder, mapping, distortion))
    except OSError as exc:
        raise write_error(folder, exc) from exc


def mapping_recorded(entry: Mapping[str, Any]) -> bool:
    """Whether a participant's manifest entry records their calibration part 1 (mapping)."""
    return TIDY_FILES["mapping_prompts"] in (entry.get(CALIBRATION_FILES) or {})


def check_calibration_files(folder: Path, participant: int, entry: Mapping[str, Any]) -> None:
    """Refuse, on resume, a calibration log missing or changed since the manifest recorded it.

    Raises
    ------
    RunFolderError
        Naming the file.
    """
    changed = changed_logs(folder, entry.get(CALIBRATION_FILES) or {})
    if changed:
        name, missing = changed[0]
        path = folder / name
        what = "is missing" if missing else \
            "changed since it was written (its SHA-256 differs from the one in the manifest)"
        raise RunFolderError(f"{path}: {what}, but the manifest records it as participant "
                             f"{entry.get('participant_id', participant)}'s calibration; restore it from a "
                             "backup (a person's calibration cannot be recorded again as it was)")
