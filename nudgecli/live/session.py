"""One participant's live session: the paper's four phases, driven by a clock and by input events.

The session knows nothing of the web: the server (:mod:`nudgecli.live.server`) calls
:meth:`LiveSession.handle` with each message from the page and :meth:`LiveSession.tick` at the
protocol rate (10 Hz), and sends :meth:`LiveSession.view` back. Phases:

1. ``mapping``: calibration of ``p(phi_i | a)`` (prompt-and-select, keys 1-4);
2. ``distortion``: calibration of ``p(phi_m | phi_i)`` (prompt-and-produce); each part's log is
   written in the tidy format when the part ends (a resume after a crash in part 2 starts at
   part 2), then both are fitted with the estimators of ``nudge fit``, and the agent uses
   those tables for the rest of the session (skipped when the experiment says
   ``model.tables = "default"``);
3. ``familiarisation``: three practice trials: teleoperation (no blending, no autonomy turn),
   blending (no autonomy turn) and turn-taking (the whole protocol); not recorded as trials;
4. ``trial``: the evaluation blocks of :func:`nudgecli.sim.study.participant_schedule`, each trial a
   :class:`~nudgecli.sim.protocol.TrialSession` (the simulator's protocol, one step per tick) fed
   by :class:`~nudgecli.live.input.LiveInput`; after each block a ``questionnaire`` (NASA-TLX and
   the study's Likert items).

Between trials the session waits in ``ready`` until the person presses Space. The handover idle
time of a live person is the middle of the experiment's ``population.handover_idle_s`` range.
"""

from __future__ import annotations

import dataclasses
import json
import re
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from nudgecli.config import ExperimentConfig
from nudgecli.errors import ConfigError
from nudgecli.live.calibration import (
    DistortionRecorder,
    MappingRecorder,
    action_prompt_text,
    mapping_recorded,
)
from nudgecli.live.input import KEY_LABELS, LiveInput, key_meanings
from nudgecli.live.questionnaire import complete_blocks, questionnaire_form, questionnaire_row
from nudgecli.live.records import LiveFolder
from nudgecli.model.disambiguation import DisambiguationModel
from nudgecli.model.human_actions import DistinctActionRows
from nudgecli.model.interface import default_distortion_table, default_mapping_table
from nudgecli.model.world import (
    CORNERS,
    GOAL_RADIUS,
    MODE_NAMES,
    N_CELLS_X,
    N_CELLS_Y,
    ROBOT_RADIUS,
    X_MAX,
    X_MIN,
    Y_MAX,
    Y_MIN,
    Layout,
    sample_layout,
)
from nudgecli.rng import generator, seed_key
from nudgecli.sim.calibration import estimate_distortion, estimate_mapping
from nudgecli.sim.calibration_readers import read_sessions
from nudgecli.sim.protocol import ProtocolSettings, TrialSession, TrialSpec
from nudgecli.sim.study import StudyLayout, StudyPlan, participant_schedule, solve_layouts
from nudgecli.sim.trials import handover_steps
from nudgecli.steplog import AUTONOMY_TURN, HUMAN_TURN, STEP_COLUMNS, steps_frame

#: The practice trials of phase 3, in order.
PRACTICE = ("teleoperation", "blending", "turn-taking")
#: Seconds after the turn's first input over which the page's border turns from blue to red
#: (the paper: 3-4 s; the study software: 200 loop iterations).
BORDER_S = 3.5


#: The longest participant ID (it names files and is printed; a longer one is a mistake).
MAX_ID_LENGTH = 32
#: The largest participant number: part files are numbered with four digits (``part-0001``).
MAX_PARTICIPANT = 9999
#: The rule a participant ID follows, as the error message says it.
ID_RULE = (
    f"ASCII letters (optionally then '_'), then the participant's number from 1 to {MAX_PARTICIPANT} "
    f"in the digits 0-9, at most {MAX_ID_LENGTH} characters, no spaces, e.g. P01, p_12 or 3"
)


def participant_index(participant_id: str) -> int:
    """The index in a participant ID: its trailing number (``P01`` -> 1, ``7`` -> 7).

    The index seeds the participant's schedule and true goals and, without ``--condition-order``,
    rotates the starting condition, exactly as participant ``i`` of a simulated study. IDs that
    would map to a surprising number are refused (:data:`ID_RULE`): ``P00`` (0 is no participant
    number), ``P-1`` (reads as minus one, would be 1), more than four digits, digits of other
    scripts (``P\u0661``, Arabic-Indic one; ``P\uff11``, fullwidth one: Python's ``int`` reads both),
    and spaces around the ID (it names the participant in the manifest and the resume command
    as given: refused rather than silently changed).
    """
    text = participant_id
    match = re.fullmatch(r"[A-Za-z]*_?([0-9]{1,4})", text, re.ASCII) if len(text) <= MAX_ID_LENGTH else None
    index = int(match.group(1)) if match else 0
    if not match or not 1 <= index <= MAX_PARTICIPANT:
        shown = participant_id if len(participant_id) <= MAX_ID_LENGTH else f"{participant_id[:12]}... " \
            f"({len(participant_id)} characters)"
        raise ConfigError(
            f"--participant {shown!r}: give an ID ending in the participant's number: {ID_RULE} "
            "(the number seeds their schedule)"
        )
    return index


def live_handover_idle_s(config: ExperimentConfig) -> float:
    """The live person's handover idle time: the middle of ``population.handover_idle_s``."""
    low, high = config.population.handover_idle_s
    return (low + high) / 2.0


@dataclass
class RunningTrial:
    """A trial in progress."""

    kind: str  # "evaluation" or one of PRACTICE
    session: TrialSession
    started: float  # wall clock, for the manifest's timings
    new_turn: bool = True


class LiveSession:
    """One participant's session (see the module docstring).

    Parameters
    ----------
    config
        The resolved experiment.
    seed
        The study's master seed.
    participant_id
        The participant's ID (its number is their index, :func:`participant_index`).
    folder
        Where the session is recorded.
    condition_order
        The order of the conditions' blocks, one of the experiment's counterbalancing orders
        (``None``: the one the design assigns the participant's index).
    resume
        Continue this participant's session in ``folder``.
    plan
        The study plan (layouts and their solved MDPs); built when ``None``.
    """

    def __init__(
        self,
        config: ExperimentConfig,
        seed: int,
        participant_id: str,
        folder: LiveFolder,
        condition_order: Sequence[str] | None = None,
        resume: bool = False,
        plan: StudyPlan | None = None,
    ) -> None:
        if config.study.rate_hz != config.calibration.rate_hz:
            raise ConfigError(
                f"calibration.rate_hz ({config.calibration.rate_hz:g}) must equal study.rate_hz "
                f"({config.study.rate_hz:g}) in a live session: the input is sampled at one rate"
            )
        if config.world.kind != "grid":
            raise ConfigError(
                f"world.kind = {config.world.kind!r} in experiment {config.experiment.name}: the study page "
                "runs only the grid world's experiments (world.kind = \"grid\", e.g. paper); simulate this "
                "one with nudge simulate"
            )
        self.config, self.seed, self.folder = config, seed, folder
        self.participant_id = participant_id
        self.index = participant_index(participant_id)
        self.plan = plan or StudyPlan.build(config, seed)
        self.settings = ProtocolSettings.from_config(config)
        self.handover_s = live_handover_idle_s(config)
        self.handover_steps = handover_steps(self.handover_s, self.settings.dt)
        self.schedule = participant_schedule(
            config, seed, self.index, self.plan.layouts, condition_order=condition_order
        )
        self.input = LiveInput.from_interface(config.interface)
        self.entry = folder.open(
            config, seed, self.plan.layouts, self.index, participant_id, len(self.schedule),
            _condition_order(self.schedule), resume,
        )
        self.entry["handover_idle_s"] = self.handover_s
        complete = complete_blocks(self.schedule, self.entry["completed_trials"])
        folder.take_in_answered_blocks(self.index, complete)  # a crash left their answers unlisted
        trials, steps = folder.read_participant_tables(self.index, self.entry["completed_trials"])
        self.trials = trials if trials is not None else pd.DataFrame()
        self.steps = steps if steps is not None else pd.DataFrame(columns=list(STEP_COLUMNS))
        self.mapping: np.ndarray | None = None
        self.distortion: np.ndarray | None = None
        self.provenance: dict[str, Any] = {}
        self.models: dict[int, DisambiguationModel] = {}
        if config.model.tables == "default":
            noise = config.model.default_table_noise
            self.mapping, self.distortion = default_mapping_table(noise), default_distortion_table(noise)
            self.provenance = {"tables": "default"}
        elif self.entry["calibrated"]:
            self._fit_calibration()
        self.mapping_recorder: MappingRecorder | None = None
        self.distortion_recorder: DistortionRecorder | None = None
        self.trial: RunningTrial | None = None
        self.practice_index = 0
        self.last_outcome: dict[str, Any] | None = None
        self.tick_count = 0
        self.phase = "welcome"
        self.ready_for = ""  # what Space starts in the "ready" phase
        folder.save(self.index)

    # --- what comes next ----------------------------------------------------------------------

    @property
    def next_trial(self) -> TrialSpec | None:
        done = set(self.entry["completed_trials"])
        return next((spec for spec in self.schedule if spec.trial not in done), None)

    def _pending_questionnaire(self) -> int | None:
        """A block whose trials are all done but whose questionnaire is not answered."""
        answered = set(self.entry["questionnaire_blocks"])
        complete = complete_blocks(self.schedule, set(self.entry["completed_trials"]))
        return next((block for block in complete if block not in answered), None)

    def _advance(self) -> None:
        """Go to the next phase the participant has not done."""
        self.trial = None
        if self.mapping is None:
            self._start_calibration()
        elif not self.entry["familiarised"] and self.practice_index < len(PRACTICE):
            self.phase, self.ready_for = "ready", PRACTICE[self.practice_index]
        elif self._pending_questionnaire() is not None:
            self.phase = "questionnaire"
        elif self.next_trial is not None:
            self.phase, self.ready_for = "ready", "evaluation"
        else:
            self._finish()

    # --- events -------------------------------------------------------------------------------

    def handle(self, message: dict[str, Any], now: float) -> dict[str, Any] | None:
        """One message from the page; returns a reply for the sender (or ``None``).

        Messages: ``{"type": "key", "key": "1", "down": true}``, ``{"type": "axis", "value": -0.2}``
        (``null``: no gamepad), ``{"type": "start"}`` (as Space), ``{"type": "skip"}`` (skip the
        practice), ``{"type": "questionnaire", "answers": {...}}`` (answered ``{"type":
        "answers_recorded", "block": b}`` once written, else an error), ``{"type": "blur"}`` (the page
        lost focus: keys up), ``{"type": "ping"}``; and from the server ``{"type": "disconnect"}``
        (the last page closed: the running trial is abandoned, unrecorded, and starts again from
        its beginning on the next Space). The server passes only messages that follow the schema of
        :mod:`nudgecli.live.messages`, and input only from the controlling page.
        """
        kind = message.get("type")
        if kind == "key":
            key, down = str(message.get("key", "")), bool(message.get("down"))
            label = KEY_LABELS.get(key)
            if label is not None:
                self.input.key(label, down)
                if down and self.phase == "mapping" and self.mapping_recorder is not None:
                    self.mapping_recorder.answer(label, now)
            elif key == " " and down:
                self._start()
        elif kind == "axis":
            value = message.get("value")
            self.input.axis(None if value is None else float(value))
        elif kind == "start":
            self._start()
        elif kind == "skip" and self.phase == "ready" and self.ready_for in PRACTICE:
            self._end_practice()
        elif kind == "questionnaire":  # answered out of phase too: the page hears it was not taken
            return self._record_questionnaire(message.get("answers") or {})
        elif kind == "blur":
            self.input.release_all()
        elif kind == "disconnect":
            self.input.release_all()
            self._abandon_trial()
        elif kind == "ping":
            return {"type": "pong", "tick": self.tick_count}
        return None

    def _start(self) -> None:
        if self.phase == "welcome":
            self._advance()
        elif self.phase == "ready":
            self._start_trial()

    def tick(self, now: float) -> None:
        """One protocol step (``1 / study.rate_hz`` seconds)."""
        self.tick_count += 1
        if self.phase == "mapping" and self.mapping_recorder is not None:
            self.input.sample()
            self.mapping_recorder.tick(now)
            if self.mapping_recorder.done:  # part 1 recorded: a crash in part 2 resumes at part 2
                self.folder.write_calibration(self.index, mapping=self.mapping_recorder.session())
                self.phase = "distortion"
        elif self.phase == "distortion" and self.distortion_recorder is not None:
            _, pressure = self.input.sample()
            self.distortion_recorder.sample(now, pressure)
            if self.distortion_recorder.done:
                self._end_calibration()
        elif self.phase == "trial" and self.trial is not None:
            self._step_trial()
        else:
            self.input.sample()

    # --- calibration --------------------------------------------------------------------------

    def _start_calibration(self) -> None:
        rng = generator(self.seed, "participant", self.index, "live", "calibration")
        mapping_rng, distortion_rng = rng.spawn(2)
        source = f"live {self.participant_id}"
        c = self.config.calibration
        self.mapping_recorder = MappingRecorder.create(c, mapping_rng, source)
        self.distortion_recorder = DistortionRecorder.create(c, self.config.interface, distortion_rng, source)
        self.phase = "distortion" if mapping_recorded(self.entry) else "mapping"

    def _end_calibration(self) -> None:
        assert self.distortion_recorder is not None
        self.folder.write_calibration(self.index, distortion=self.distortion_recorder.session())
        self._fit_calibration()
        self._advance()

    def _fit_calibration(self) -> None:
        """Fit the agent's tables from the logs on disk with the estimators of ``nudge fit``."""
        folder = self.folder.calibration_dir(self.index)
        mapping_session, distortion_session = read_sessions(folder)
        assert mapping_session is not None and distortion_session is not None
        mapping, distortion = estimate_mapping(mapping_session), estimate_distortion(distortion_session)
        self.mapping, self.distortion = mapping.table, distortion.table
        self.provenance = {
            "source": "live calibration",
            "folder": str(folder),
            "rows_from_default": {
                "p_phi_given_a": list(mapping.unanswered),
                "p_phm_given_phi": list(distortion.rows_without_data),
            },
        }
        self.models.clear()

    # --- trials -------------------------------------------------------------------------------

    def _model(
        self, layout_index: int, goal_cells: np.ndarray, p_a_given_sg: np.ndarray | DistinctActionRows
    ) -> DisambiguationModel:
        assert self.mapping is not None and self.distortion is not None
        model = self.models.get(layout_index)
        if model is None:
            model = DisambiguationModel(goal_cells, p_a_given_sg, self.mapping, self.distortion)
            if layout_index >= 0:
                self.models[layout_index] = model
        return model

    def _start_trial(self) -> None:
        kind = self.ready_for
        if kind == "evaluation":
            spec = self.next_trial
            if spec is None:
                self._advance()
                return
            session = self.trial_session(spec)
        else:
            session = self._practice_session(kind)
        self.input.release_all()
        self.trial = RunningTrial(kind, session, time.perf_counter())
        self.phase = "trial"

    def trial_session(self, spec: TrialSpec) -> TrialSession:
        """The protocol of one evaluation trial, seeded as the simulator seeds it (the agent's child
        stream of ``participant/i/trial/t``)."""
        solved = self.plan.solved[spec.layout_index]
        if not isinstance(spec.layout, Layout):
            raise ConfigError("nudge study runs the paper's grid world; this experiment's world is another")
        model = self._model(spec.layout_index, spec.layout.goal_cells, solved.actions)
        _, agent_rng = generator(self.seed, "participant", self.index, "trial", spec.trial).spawn(2)
        return TrialSession(spec, self.settings, model, self.handover_steps, agent_rng)

    def _practice_session(self, kind: str) -> TrialSession:
        k = PRACTICE.index(kind)
        rng = generator(self.seed, "participant", self.index, "familiarisation", k)
        layout = sample_layout(rng, CORNERS[k % len(CORNERS)], 3, k % len(MODE_NAMES))
        item = StudyLayout(-1 - k, "practice", 3, CORNERS[k % len(CORNERS)], k % len(MODE_NAMES), layout)
        solved = solve_layouts(self.config, [item])[0]
        settings, idle = self.settings, self.handover_steps
        if kind != "turn-taking":
            idle = settings.time_limit_steps  # no autonomy turn: the person keeps the robot
        if kind == "teleoperation":
            settings = dataclasses.replace(
                settings, blending=dataclasses.replace(settings.blending, rho3=0.0)
            )
        condition = self.config.study.conditions[0]
        spec = TrialSpec(
            participant=self.index,
            condition=condition,
            block=-1,
            trial=-1 - k,
            layout_index=-1 - k,
            layout=layout,
            true_goal=int(rng.integers(3)),
        )
        model = self._model(-1 - k, layout.goal_cells, solved.actions)
        return TrialSession(spec, settings, model, idle, rng.spawn(1)[0])

    def _step_trial(self) -> None:
        """One step of the running trial: the person's sample in their turn, the autonomy's otherwise."""
        assert self.trial is not None
        running, session = self.trial, self.trial.session
        if session.turn == HUMAN_TURN:
            if running.new_turn:
                self.input.start_turn(session.autonomy_turns > 0)
                running.new_turn = False
            session.human_step(*self.input.next_input(session))
        else:
            self.input.sample()  # inputs during the autonomy's turn are not the protocol's
            session.autonomy_step()
            running.new_turn = True
        if session.finished:
            self._end_trial()

    def _end_trial(self) -> None:
        assert self.trial is not None
        running, session = self.trial, self.trial.session
        summary = session.summary()
        self.last_outcome = {
            "kind": running.kind,
            "number": self._trial_number(running),
            "success": bool(summary["success"]),
            "timed_out": bool(summary["timed_out"]),
            "duration_s": summary["duration_s"],
        }
        if running.kind == "evaluation":
            steps = steps_frame(session.columns)  # the step log's one frame maker, as a simulated run's
            self.trials = (
                pd.concat([self.trials, pd.DataFrame([summary])], ignore_index=True)
                if len(self.trials)
                else pd.DataFrame([summary])
            )
            self.steps = pd.concat([self.steps, steps], ignore_index=True) if len(self.steps) else steps
            self.folder.write_trial(
                self.index, self.trials, self.steps, session.spec.trial, time.perf_counter() - running.started
            )
        else:
            self.practice_index += 1
            if self.practice_index >= len(PRACTICE):
                self._end_practice()
                return
        self._advance()

    def _abandon_trial(self) -> None:
        """Drop the running trial (nothing of it is recorded); it starts again from the beginning."""
        if self.phase == "trial" and self.trial is not None:
            self.ready_for = self.trial.kind
            number = self._trial_number(self.trial)
            self.trial = None
            self.phase = "ready"
            self.last_outcome = {"kind": self.ready_for, "number": number, "abandoned": True}

    def _trial_number(self, running: RunningTrial) -> int | None:
        """An evaluation trial's place in the participant's schedule, from 1 (practice: ``None``)."""
        if running.kind != "evaluation":
            return None
        trial = running.session.spec.trial
        return next(n for n, spec in enumerate(self.schedule, start=1) if spec.trial == trial)

    def _end_practice(self) -> None:
        self.entry["familiarised"] = True
        self.folder.save(self.index)
        self._advance()

    # --- questionnaires and the end -----------------------------------------------------------

    def _record_questionnaire(self, answers: dict[str, Any]) -> dict[str, Any]:
        """Validate and write one block's answers; returns the reply for the page: an error, or
        ``{"type": "answers_recorded", "block": b}`` (the page keeps the answers until then)."""
        block = self._pending_questionnaire() if self.phase == "questionnaire" else None
        if block is None:  # e.g. a second submit of answers already recorded
            return {"type": "error", "message": "no questionnaire is due"}
        condition = next(spec.condition for spec in self.schedule if spec.block == block)
        row = questionnaire_row(answers)
        if isinstance(row, str):
            return {"type": "error", "message": row}
        row = {"participant": self.index, "condition": condition, "block": block, **row}
        self.folder.write_questionnaire(self.index, row)
        self._advance()
        return {"type": "answers_recorded", "block": block}

    def _finish(self) -> None:
        self.phase = "done"
        if self.entry.get("status") == "complete":
            return
        assert self.mapping is not None and self.distortion is not None
        record = {
            "participant": self.index,
            "participant_id": self.participant_id,
            "seed_key": seed_key("participant", self.index),
            "source": "live",
            "handover_idle_s": self.handover_s,
            "agent_p_phi_given_a": json.dumps(self.mapping.tolist()),
            "agent_p_phm_given_phi": json.dumps(self.distortion.tolist()),
            "calibration": json.dumps(self.provenance),
        }
        self.folder.write_participant(self.index, pd.DataFrame([record]))

    # --- what the page draws ------------------------------------------------------------------

    def view(self) -> dict[str, Any]:
        """The JSON state the page draws (see ``static/app.js``)."""
        done = len(self.entry["completed_trials"])
        out: dict[str, Any] = {
            "type": "state",
            "tick": self.tick_count,
            "phase": self.phase,
            "participant": self.participant_id,
            "trials_done": done,
            "trials_total": len(self.schedule),
            "ready_for": self.ready_for,
            "last_outcome": self.last_outcome,
            "keys": key_meanings(),
        }
        if self.phase == "mapping" and self.mapping_recorder is not None:
            prompt = self.mapping_recorder.prompt
            index, total = self.mapping_recorder.progress()
            out["calibration"] = {
                "part": 1,
                "prompt": action_prompt_text(prompt) if prompt else None,
                "break": self.mapping_recorder.in_break,
                "done": index,
                "total": total,
            }
        elif self.phase == "distortion" and self.distortion_recorder is not None:
            index, total = self.distortion_recorder.progress()
            out["calibration"] = {
                "part": 2,
                "prompt": self.distortion_recorder.prompt,
                "done": index,
                "total": total,
            }
        elif self.phase == "trial" and self.trial is not None:
            out["trial"] = self._trial_view(self.trial)
        elif self.phase == "questionnaire":
            block = self._pending_questionnaire()
            out["questionnaire"] = {**self._block_named(block), **questionnaire_form()}
        return out

    def _block_named(self, block: int | None) -> dict[str, Any]:
        """A block as the questionnaire names it: its number, its place among the participant's
        blocks (from 1), how many there are, and its condition."""
        blocks = sorted({spec.block for spec in self.schedule})
        condition = next((spec.condition for spec in self.schedule if spec.block == block), None)
        number = blocks.index(block) + 1 if block in blocks else None
        return {"block": block, "block_number": number, "blocks": len(blocks), "condition": condition}

    def _trial_view(self, running: RunningTrial) -> dict[str, Any]:
        s = running.session
        initiated = s.turn == HUMAN_TURN and s.initiated_at >= 0
        since = (s.step - s.initiated_at) * self.settings.dt if initiated else 0.0
        return {
            "kind": running.kind,
            "x": s.x,
            "y": s.y,
            "theta": s.theta,
            "mode": MODE_NAMES[s.mode],
            "turn": s.turn,
            "goals": s.goal_poses.tolist(),
            "true_goal": s.spec.true_goal,
            "step": s.step,
            "t": round(s.step * self.settings.dt, 3),
            "border": min(since / BORDER_S, 1.0) if s.turn == HUMAN_TURN else None,
            "border_s": BORDER_S,
            "autonomy": s.turn == AUTONOMY_TURN,
            "trial": s.spec.trial,
            "block": s.spec.block,
            "time_limit_s": self.config.study.time_limit_s,
            "world": {
                "x": [X_MIN, X_MAX],
                "y": [Y_MIN, Y_MAX],
                "cells": [N_CELLS_X, N_CELLS_Y],
                "robot_radius": ROBOT_RADIUS,
                "goal_radius": GOAL_RADIUS,
            },
        }


def _condition_order(schedule: list[TrialSpec]) -> list[str]:
    """The conditions in the order the participant meets them (their blocks alternate in this order)."""
    return list(dict.fromkeys(spec.condition for spec in schedule))
