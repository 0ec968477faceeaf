"""A live session's run folder: the same files as a simulated run, checkpointed after every trial.

The folder is the one ``nudge simulate`` writes (:mod:`nudgecli.store`), so ``nudge analyze`` and
``nudge plot`` read it unchanged; several participants can be recorded into one folder (same
experiment and seed). Per participant ``i``:

- ``trials/part-iiii.parquet`` and ``steps/part-iiii.parquet``: every completed evaluation
  trial, rewritten atomically after each trial (both written, their SHA-256 noted in the
  participant's entry, renamed into place, then the manifest listing the trial and recording the
  SHA-256 under ``checksums`` as ``nudge simulate`` does; :mod:`nudgecli.live.record_checks`
  checks them on resume);
- ``participants/part-iiii.parquet``: written when the participant's session is complete (a
  participant counts as complete when its three parts exist, as for a simulated run);
- ``calibration/participant-iiii/``: the calibration logs in the tidy format (``nudge fit`` reads
  them), each part's when it ends, their SHA-256 in the entry's ``calibration_files``;
- ``questionnaires.csv`` (shared): one row per participant and block, the format
  ``nudge analyze --questionnaires`` reads and ``nudge plot`` draws.

The manifest holds the simulate keys (``experiment``, ``config``, ``seed``, ``participants``,
``trials_per_participant``, ``versions``, ``created``, ``status``, ``completed``, ``timings_s``,
``executor = "live"``) and a ``live`` entry per participant with ``completed_trials``: the truth
about which trials are done. On resume, rows of trials not listed there (a crash between two
writes) are dropped, so at most the trial that was running is lost.

Several servers (one per participant) may record into one folder at once. Each holds its
participant's lock (``.nudge-participant-iiii.lock``, the run-folder lock of
:func:`nudgecli.store.run_lock` for one participant) for as long as it serves, so a second server
for the same participant is refused (the page's token waits in ``.nudge-participant-iiii.token``
until the participant is complete, so ``--resume`` serves the tab that is still open); and every
manifest write is a read-modify-write of this participant's entry under the folder's lock, so one
participant's checkpoint never drops another's.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import secrets
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pandas as pd

from nudgecli.config import ExperimentConfig
from nudgecli.errors import LockError, NudgeError, RunFolderError
from nudgecli.live.calibration import CALIBRATION_FILES, check_calibration_files, write_calibration_logs
from nudgecli.live.questionnaire import answered_blocks, answers_by_hand, merged_answers, read_answers
from nudgecli.live.record_checks import (
    CHECKSUMS,
    TRIAL_PARTS,
    WRITING,
    CheckedParts,
    check_answered_blocks,
    check_trial_parts,
    recorded_sums,
)
from nudgecli.locks import acquire_lock_file, describe_holder, read_holder, run_lock
from nudgecli.run_folder_names import CONFIG, LAYOUTS, LOCK, QUESTIONNAIRES_CSV
from nudgecli.run_folder_record import FILE_CHECKSUMS, file_sha256
from nudgecli.sim.calibration_io import DistortionSession, MappingSession
from nudgecli.sim.counterbalance import order_choice
from nudgecli.sim.study import StudyLayout, layouts_frame
from nudgecli.store import (
    RunFolder,
    atomic_path,
    new_manifest,
    part_name,
    prepare_mode,
    study_resume_command,
    utc_now,
    write_error,
    write_parquet_atomic,
    write_text_atomic,
)

EXECUTOR = "live"
#: How long a manifest write waits for another participant's server to release the folder lock
#: (each holds it for one read-modify-write, milliseconds; ``nudge analyze`` may hold it longer).
FOLDER_LOCK_WAIT_S = 30.0

#: Participant locks this process holds: lock file -> [open handle, holders]. A process serves one
#: participant, but may build their session again (tests do): re-entrant, released by its last holder.
_PARTICIPANT_LOCKS: dict[Path, list[Any]] = {}


def participant_lock_name(participant: int) -> str:
    """The file name of a participant's lock in a live folder."""
    return f".nudge-participant-{participant:04d}.lock"


def participant_token_name(participant: int) -> str:
    """The file name of a participant's page token in a live folder (read by ``--resume``)."""
    return f".nudge-participant-{participant:04d}.token"


#: What a stored token must look like to be used again (``secrets.token_urlsafe(16)`` gives 22
#: such characters); anything else (an edited or truncated file) is replaced by a new token.
_TOKEN_PATTERN = re.compile(r"[A-Za-z0-9_-]{22,64}")


def unsaved_answers_name(participant: int) -> str:
    """The file of a participant's answers that could not be written to ``questionnaires.csv``."""
    return f"questionnaires-unsaved-{participant:04d}.csv"


def _warn(line: str) -> None:
    """A ``Warning:`` line of ``nudge study`` (a stale lock taken over) on its stderr."""
    print(line, file=sys.stderr)


def _is_lock_file(name: str) -> bool:
    return name == LOCK or (name.startswith(".nudge-participant-") and name.endswith(".lock"))


@contextlib.contextmanager
def folder_lock(path: Path, wait_s: float = FOLDER_LOCK_WAIT_S) -> Iterator[None]:
    """Hold the folder's lock for one read-modify-write, waiting while another server holds it."""
    deadline = time.monotonic() + wait_s
    while True:
        try:
            lock = run_lock(path, command="nudge study (manifest update)", log=_warn)
            lock.__enter__()
        except LockError:
            if time.monotonic() >= deadline:
                raise
            time.sleep(0.02)
            continue
        break
    try:
        yield
    finally:
        lock.__exit__(None, None, None)


class LiveFolder:
    """The run folder of live sessions.

    Parameters
    ----------
    path
        The folder.
    """

    def __init__(self, path: str | Path) -> None:
        self.run = RunFolder(path)
        self.path = self.run.path
        self.manifest: dict[str, Any] = {}
        self.entry: dict[str, Any] = {}
        #: The SHA-256 of the participant's parts as written (kind -> hex), recorded in the manifest.
        self.sums: dict[str, str] = {}
        self._parts: CheckedParts | None = None
        self._lock_path: Path | None = None

    # --- opening ------------------------------------------------------------------------------

    def open(
        self,
        config: ExperimentConfig,
        seed: int,
        layouts: list[StudyLayout],
        participant: int,
        participant_id: str,
        trials_per_participant: int,
        condition_order: list[str],
        resume: bool,
    ) -> dict[str, Any]:
        """Create the folder or join the live study in it; return the participant's manifest entry.

        The folder's config.toml and manifest record the experiment with the seed used (``seed``,
        a ``--seed`` or the experiment's own), as ``nudge simulate`` records it; a folder made
        before, whose config.toml holds the experiment's own seed, is still joined with the
        same experiment and ``--seed`` (its config.toml is rewritten with the seed used).
        ``condition_order`` is the participant's order of blocks, recorded in their entry.

        Raises
        ------
        RunFolderError
            The folder holds a simulated run, another experiment or seed, a non-run, or (without
            ``resume``) this participant already; the participant's index belongs to another ID;
            ``resume`` with nothing to resume, or with another condition order than the recorded one.
        """
        existed = self.path.exists()
        try:
            self.lock_participant(participant, participant_id)
            with folder_lock(self.path):
                return self._open_locked(
                    config, seed, layouts, participant, participant_id, trials_per_participant,
                    condition_order, resume,
                )
        except BaseException:
            self.release()
            if not existed:  # refused before anything was recorded: leave no empty folder behind
                with contextlib.suppress(OSError):
                    for child in self.path.iterdir():
                        if _is_lock_file(child.name):
                            child.unlink()
                    self.path.rmdir()
            raise

    def lock_participant(self, participant: int, participant_id: str) -> None:
        """Take the participant's lock for as long as this server serves them.

        Raises
        ------
        LockError
            Another server (process) serves this participant from this folder now.
        """
        with contextlib.suppress(OSError):  # taking the lock file below names the problem
            self.path.mkdir(parents=True, exist_ok=True)
        lock_path = (self.path / participant_lock_name(participant)).resolve()
        if lock_path == self._lock_path:
            return
        if lock_path in _PARTICIPANT_LOCKS:
            _PARTICIPANT_LOCKS[lock_path][1] += 1
            self._lock_path = lock_path
            return
        try:
            handle = acquire_lock_file(lock_path, None, _warn)
        except LockError:
            holder = describe_holder(read_holder(lock_path))
            raise LockError(
                f"{self.path}: participant {participant_id} is already being served by {holder}; "
                "continue there, or stop that server (Ctrl-C) before starting another"
            ) from None
        _PARTICIPANT_LOCKS[lock_path] = [handle, 1]
        self._lock_path = lock_path

    def release(self) -> None:
        """Give up the participant's lock (the server stopped)."""
        lock_path, self._lock_path = self._lock_path, None
        if lock_path is None:
            return
        held = _PARTICIPANT_LOCKS.get(lock_path)
        if held is None:
            return
        held[1] -= 1
        if held[1] == 0:
            del _PARTICIPANT_LOCKS[lock_path]
            with contextlib.suppress(OSError):
                lock_path.unlink()
            held[0].close()

    def _open_locked(
        self,
        config: ExperimentConfig,
        seed: int,
        layouts: list[StudyLayout],
        participant: int,
        participant_id: str,
        trials_per_participant: int,
        condition_order: list[str],
        resume: bool,
    ) -> dict[str, Any]:
        run, key = self.run, str(participant)
        run.refuse_live_links()  # a linked trials/ would have a person's trials written into another folder
        # config.toml records the seed used, so `nudge study RUN/config.toml` runs the same study
        used = config.model_copy(update={"experiment": config.experiment.model_copy(update={"seed": seed})})
        config_text = used.to_toml()
        if run.is_run():
            manifest = run.read_manifest()
            entry = manifest.setdefault("live", {}).get(key)
            config_toml_warning = self._check_joined(
                manifest, config, seed, config_text, participant, participant_id, resume, entry
            )
            if entry is not None and entry.get("condition_order", condition_order) != condition_order:
                raise RunFolderError(self._other_order_message(config, participant, participant_id, entry))
            if entry is not None:  # a resume: the participant's records must be as the manifest says
                self._parts = check_trial_parts(self.path, manifest, participant, entry)
                check_answered_blocks(self.path, participant, entry)
                check_calibration_files(self.calibration_dir(participant), participant, entry)
                self.sums = recorded_sums(manifest, participant)
                self._rewrite_crashed_parts(participant, entry)
            if config_toml_warning is not None:  # the manifest's experiment: put config.toml back
                write_text_atomic(self.path / CONFIG, config_text)
                _warn(f"Warning: {config_toml_warning}")
        else:
            prepare_mode(self.path, None, resume, False, own_file=_is_lock_file, can_force=False,
                         resume_first=True)
            self.path.mkdir(parents=True, exist_ok=True)
            write_text_atomic(self.path / CONFIG, config_text)
            layouts_sum = run.write_layouts(layouts_frame(layouts))
            manifest = new_manifest(used, seed, 0, trials_per_participant)
            manifest.update({"status": "running", "completed": [], "executor": EXECUTOR, "live": {}})
            manifest[FILE_CHECKSUMS] = {LAYOUTS: layouts_sum}  # checked by its readers, as simulate's
            entry = None
        if entry is None:
            entry = {
                "participant_id": participant_id,
                "calibrated": False,
                "familiarised": False,
                "completed_trials": [],
                "questionnaire_blocks": [],
                "started": utc_now(),
            }
            manifest["live"][key] = entry
        entry["condition_order"] = condition_order
        self._take_in_unsaved_answers(participant, entry)
        manifest["participants"] = len(manifest["live"])
        self.manifest = manifest
        self.entry = entry
        self.save(participant, status_of_participant="running")
        return entry

    def _check_joined(
        self,
        manifest: dict[str, Any],
        config: ExperimentConfig,
        seed: int,
        config_text: str,
        participant: int,
        participant_id: str,
        resume: bool,
        entry: dict[str, Any] | None,
    ) -> str | None:
        """Refuse to join a folder of a simulated run, of another experiment or seed (naming each
        key that differs from the manifest's), or with the participant's index taken by another
        ID, recorded without ``resume``, or missing with it. Returns the warning to print when
        config.toml is rewritten from the experiment (it held the experiment's own seed, a folder
        made before it recorded the seed used; or it was missing or edited), else ``None``."""
        if manifest.get("executor") != EXECUTOR:
            raise RunFolderError(f"{self.path}: holds a simulated run; record live sessions in another --out")
        # the manifest is the record of the study's settings, as for a simulated run's resume
        differences = [difference for difference in
                       self.run.resume_differences(manifest, config, seed, manifest.get("participants", 0))
                       if not difference.startswith("nudgecli version:")]
        if differences:
            raise RunFolderError(self._other_settings_message(manifest, differences, config, participant,
                                                              participant_id, entry))
        recorded_id = None if entry is None else entry.get("participant_id")
        if entry is not None and recorded_id != participant_id:
            raise RunFolderError(
                f"{self.path}: index {participant} belongs to participant {recorded_id}, not "
                f"{participant_id} (IDs with the same number are one participant); continue "
                f"{recorded_id}'s session with --participant {recorded_id} --resume"
                f"{self._order_option(config, participant, entry)}, or give another participant number"
            )
        if entry is not None and entry.get("status") == "complete":
            raise RunFolderError(
                f"{self.path}: participant {participant_id}'s session is complete (all their trials and "
                f"questionnaires are recorded) and nothing is left to run: analyse it with `nudge analyze "
                f"{self.path}`, or give another --participant"
            )
        if entry is not None and not resume:
            raise RunFolderError(
                f"{self.path}: participant {participant_id} (index {participant}) is already "
                f"recorded there; add --resume{self._order_option(config, participant, entry)} to "
                "continue their session, or give another --participant"
            )
        if entry is None and resume:
            raise RunFolderError(
                f"{self.path}: no session of participant {participant_id} to resume; drop --resume"
            )
        config_path = self.path / CONFIG
        old = config_path.read_text(encoding="utf-8") if config_path.is_file() else None
        if old == config_text:
            return None
        if old == config.to_toml():
            return (f"{config_path} held the experiment's own seed ({config.experiment.seed}), not the one "
                    f"the sessions use ({seed}); rewritten with it")
        return self.run.config_toml_warning(
            config.model_copy(update={"experiment": config.experiment.model_copy(update={"seed": seed})}))

    def _other_settings_message(self, manifest: dict[str, Any], differences: list[str],
                                config: ExperimentConfig, participant: int, participant_id: str,
                                entry: dict[str, Any] | None) -> str:
        """Why joining with other settings than the manifest's is refused: each key that differs,
        and the command with the folder's config.toml (it holds the --set values and the seed)."""
        more = len(differences) - 6
        shown = "; ".join(differences[:6]) + (f"; and {more} more" if more > 0 else "")
        config_path = self.path / CONFIG
        option = self._order_option(config, participant, entry) if entry is not None else ""
        port = self.run.resume_port(entry or {})  # the open tab reconnects only on its port
        command = study_resume_command(str(config_path), participant_id, self.path, port,
                                       condition_order=option.removeprefix(" --condition-order ") or None)
        command = command if entry is not None else command.removesuffix(" --resume")
        if not config_path.is_file():
            fix = f"use the experiment, --set values and seed the manifest records ({config_path} is missing)"
        else:  # an edited config.toml is named: the command below runs it
            fix = f"{self.run._edited_config_hint(manifest)}use the same ones: `{command}`"
        return (f"{self.path}: holds live sessions of another experiment, --set or seed ({shown}); {fix}, "
                "or choose another --out")

    def _other_order_message(
        self, config: ExperimentConfig, participant: int, participant_id: str, entry: dict[str, Any]
    ) -> str:
        """Why a resume with another condition order than the recorded one is refused, and the
        ``--condition-order`` (or none) that continues the session."""
        recorded = ",".join(str(name) for name in entry["condition_order"])
        option = self._order_option(config, participant, entry)
        fix = f"resume with{option}" if option else "resume without --condition-order"
        return (f"{self.path}: participant {participant_id} (index {participant}) was started with the "
                f"condition order {recorded}; {fix}")

    @staticmethod
    def _order_option(config: ExperimentConfig, participant: int, entry: dict[str, Any]) -> str:
        """`` --condition-order A,B`` when the participant's recorded order is not the one the
        experiment assigns them by itself (so a resume needs it), else ``""``."""
        recorded = entry.get("condition_order")
        if not isinstance(recorded, list):  # recorded before the order was
            return ""
        choice = order_choice([str(c) for c in config.study.conditions], config.study.counterbalancing,
                              participant, [str(name) for name in recorded])
        return "" if choice is None else f" --condition-order {choice}"

    # --- checkpoints --------------------------------------------------------------------------

    def save(self, participant: int, status_of_participant: str | None = None,
             add_seconds: float = 0.0) -> None:
        """Write this participant's entry into the manifest (the study is complete when every
        participant in it is).

        A read-modify-write under the folder's lock: the other participants' entries and timings
        are those on disk, so servers of several participants in one folder keep each other's.
        """
        key = str(participant)
        entry = self.entry
        if status_of_participant is not None:
            entry["status"] = status_of_participant
        entry["updated"] = utc_now()
        with folder_lock(self.path):
            m = self.run.read_manifest() if self.run.is_run() else self.manifest
            m.setdefault("live", {})[key] = entry
            if self.sums:
                m.setdefault(CHECKSUMS, {})[key] = dict(self.sums)
            timings = m.setdefault("timings_s", {})
            if add_seconds:
                timings[key] = round(timings.get(key, 0.0) + add_seconds, 3)
            m["participants"] = len(m["live"])
            m["completed"] = sorted(int(k) for k, e in m["live"].items() if e.get("status") == "complete")
            m["status"] = "complete" if len(m["completed"]) == len(m["live"]) else "running"
            self.run.write_manifest(m)
            self.manifest = m

    def read_participant_tables(
        self, participant: int, completed: list[int]
    ) -> tuple[pd.DataFrame | None, pd.DataFrame | None]:
        """The participant's trials and steps of the ``completed`` trials (``None`` if no part yet),
        as checked when their session was resumed (:func:`~nudgecli.live.record_checks.check_trial_parts`)."""
        if self._parts is None:
            return None, None  # a new participant: no part yet
        tables = [self._parts.tables[kind] for kind in TRIAL_PARTS]
        return tuple(t if t is None else t[t["trial"].isin(completed)].reset_index(drop=True)
                     for t in tables)  # type: ignore[return-value]

    def _rewrite_crashed_parts(self, participant: int, entry: dict[str, Any]) -> None:
        """Write again the parts a crash left holding the rows of a trial the manifest does not list
        (renamed into place, the manifest not yet updated), without those rows, and record them."""
        assert self._parts is not None
        for kind in self._parts.rewrite:
            frame = self._parts.tables[kind]
            assert frame is not None
            self.sums[kind] = write_parquet_atomic(self.path / kind / part_name(participant), frame)
        entry.pop(WRITING, None)

    def write_trial(
        self, participant: int, trials: pd.DataFrame, steps: pd.DataFrame, trial: int, wall_s: float
    ) -> None:
        """Checkpoint after a trial: both parts written to temporary files, their SHA-256 recorded in
        the entry as being written (:data:`~nudgecli.live.record_checks.WRITING`), the parts renamed
        into place, then the manifest naming ``trial`` complete with the parts' SHA-256."""
        name = part_name(participant)
        with atomic_path(self.path / "steps" / name) as steps_tmp, \
                atomic_path(self.path / "trials" / name) as trials_tmp:
            sums: dict[str, str] = {}
            for kind, frame, tmp in (("steps", steps, steps_tmp), ("trials", trials, trials_tmp)):
                try:
                    frame.to_parquet(tmp, index=False)
                    sums[kind] = file_sha256(tmp)
                except OSError as exc:  # named by its part, not by the last one opened
                    raise write_error(self.path / kind / name, exc) from exc
            self.entry[WRITING] = {"trial": trial, **sums}
            self.save(participant)
        self.entry.pop(WRITING)
        self.sums.update(sums)
        self.entry["completed_trials"] = sorted({*self.entry["completed_trials"], trial})
        self.save(participant, add_seconds=wall_s)

    def write_participant(self, participant: int, record: pd.DataFrame) -> None:
        """The participant's session is complete: their participants part, then the manifest."""
        self.sums["participants"] = write_parquet_atomic(self.path / "participants" / part_name(participant),
                                                         record)
        self.save(participant, status_of_participant="complete")
        with folder_lock(self.path):  # another participant may finish at the same moment
            self.run.write_participants_table()
        self.save(participant)
        self.forget_page_token(participant)

    def write_questionnaire(self, participant: int, row: dict[str, Any]) -> None:
        """Add (or replace) one participant's answers for one block in ``questionnaires.csv``.

        Raises
        ------
        NudgeError
            The file cannot be read (:func:`~nudgecli.live.questionnaire.read_answers`) or written,
            or the folder's lock not taken: the answers are then kept in the participant's
            :func:`unsaved_answers_name` file (named in the message), taken in by the next resume.
        """
        try:
            with folder_lock(self.path):  # the file is shared by the participants of the folder
                self._add_answers([row])
        except (NudgeError, OSError) as exc:
            raise self._answers_kept(participant, row, exc) from None
        entry = self.entry
        entry["questionnaire_blocks"] = sorted({*entry["questionnaire_blocks"], int(row["block"])})
        self.save(participant)

    def _add_answers(self, rows: list[dict[str, Any]]) -> None:
        """Write ``rows`` into ``questionnaires.csv`` (the folder's lock held)."""
        path = self.path / QUESTIONNAIRES_CSV
        old = read_answers(path) if path.is_file() else None
        write_text_atomic(path, merged_answers(old, rows, path).to_csv(index=False))

    def _answers_kept(self, participant: int, row: dict[str, Any], exc: NudgeError | OSError) -> NudgeError:
        """The error of answers that could not be written to ``questionnaires.csv``: they are added
        to the participant's unsaved-answers file, or (that failing too) given in the message."""
        error = exc if isinstance(exc, NudgeError) else write_error(self.path / QUESTIONNAIRES_CSV, exc)
        side = self.path / unsaved_answers_name(participant)
        try:
            kept = read_answers(side) if side.is_file() else None
            write_text_atomic(side, merged_answers(kept, [row], side).to_csv(index=False))
            where = f"the answers of block {row['block']} are kept in {side} (the next --resume adds them)"
        except (NudgeError, OSError):  # the answers in the message: JSON, and the line to add by hand
            where = (f"the answers of block {row['block']} could not be kept in a file: {json.dumps(row)}; "
                     f"{answers_by_hand(self.path / QUESTIONNAIRES_CSV, row)}")
        return type(error)(f"{error}; {where}")

    def _take_in_unsaved_answers(self, participant: int, entry: dict[str, Any]) -> None:
        """On joining: check ``questionnaires.csv``, and add the answers a failed write kept in the
        participant's unsaved-answers file (the folder's lock held)."""
        path, side = self.path / QUESTIONNAIRES_CSV, self.path / unsaved_answers_name(participant)
        if path.is_file():
            read_answers(path)
        if not side.is_file():
            return
        rows = read_answers(side).to_dict("records")
        self._add_answers(rows)
        blocks = {int(row["block"]) for row in rows}
        entry["questionnaire_blocks"] = sorted({*entry["questionnaire_blocks"], *blocks})
        side.unlink()

    def take_in_answered_blocks(self, participant: int, blocks: list[int]) -> None:
        """On joining: count as answered the complete ``blocks`` whose answers ``questionnaires.csv``
        holds already (a crash after they were written, before the manifest recorded the block)."""
        waiting = set(blocks) - {int(block) for block in self.entry["questionnaire_blocks"]}
        path = self.path / QUESTIONNAIRES_CSV
        with folder_lock(self.path):
            found = answered_blocks(path, participant, waiting) if waiting else set()
        if found:
            self.entry["questionnaire_blocks"] = sorted({*self.entry["questionnaire_blocks"], *found})
            self.save(participant)

    # --- the calibration logs -------------------------------------------------------------------

    def write_calibration(self, participant: int, mapping: MappingSession | None = None,
                          distortion: DistortionSession | None = None) -> None:
        """Write a calibration part's log (:func:`~nudgecli.live.calibration.write_calibration_logs`),
        then the manifest with its SHA-256; with ``distortion``, the participant is ``calibrated``."""
        sums = write_calibration_logs(self.calibration_dir(participant), mapping, distortion)
        self.entry[CALIBRATION_FILES] = {**self.entry.get(CALIBRATION_FILES, {}), **sums}
        if distortion is not None:
            self.entry["calibrated"] = True
        self.save(participant)

    # --- the page's token -----------------------------------------------------------------------

    def page_token(self, participant: int, resume: bool) -> str:
        """The token of the participant's page: on ``resume`` the one stored at the last start, so
        the participant's open tab reconnects to the resumed server; otherwise (or when none is
        stored, or the stored one is not a token) a new random one, stored for the next resume.

        The token is written to a file of this folder readable by its owner only (mode 0600):
        it keeps other web pages out, and a process that can read the folder can drive the study
        anyway. It is removed when the participant's session is complete.
        """
        path = self.path / participant_token_name(participant)
        if resume:
            with contextlib.suppress(OSError, UnicodeDecodeError):
                stored = path.read_text(encoding="ascii").strip()
                if _TOKEN_PATTERN.fullmatch(stored):
                    return stored
        token = secrets.token_urlsafe(16)
        temporary = path.with_name(path.name + ".tmp")
        descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(descriptor, "w", encoding="ascii") as handle:
            handle.write(token + "\n")
        os.replace(temporary, path)
        return token

    def forget_page_token(self, participant: int) -> None:
        """The participant's session is complete: its page token is no longer needed."""
        with contextlib.suppress(OSError):
            (self.path / participant_token_name(participant)).unlink()

    def calibration_dir(self, participant: int) -> Path:
        return self.run.calibration_dir(participant)
