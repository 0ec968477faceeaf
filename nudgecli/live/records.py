"""A live session's run folder: the same files as a simulated run, checkpointed after every trial.

The folder is the one ``nudge simulate`` writes (:mod:`nudgecli.store`), so ``nudge analyze`` and
``nudge plot`` read it unchanged; several participants can be recorded into one folder (same
experiment and seed). Per participant ``i``:

- ``trials/part-iiii.parquet`` and ``steps/part-iiii.parquet``: every completed evaluation
  trial, rewritten atomically after each trial (steps first, then trials, then the manifest);
- ``participants/part-iiii.parquet``: written when the participant's session is complete (a
  participant counts as complete when its three parts exist, as for a simulated run);
- ``calibration/participant-iiii/``: the calibration logs in the tidy format (``nudge fit`` reads
  them);
- ``questionnaires.csv`` (shared): one row per participant and block, the format
  ``nudge analyze --questionnaires`` reads and ``nudge plot`` draws.

The manifest holds the simulate keys (``experiment``, ``config``, ``seed``, ``participants``,
``trials_per_participant``, ``versions``, ``created``, ``status``, ``completed``, ``timings_s``,
``executor = "live"``) and a ``live`` entry per participant with ``completed_trials``: the truth
about which trials are done. On resume, rows of trials not listed there (a crash between two
writes) are dropped, so at most the trial that was running is lost.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd

from nudgecli.config import ExperimentConfig
from nudgecli.errors import RunFolderError
from nudgecli.sim.study import StudyLayout, layouts_frame
from nudgecli.store import (
    CONFIG,
    RunFolder,
    library_versions,
    part_name,
    utc_now,
    write_parquet_atomic,
    write_text_atomic,
)

QUESTIONNAIRES = "questionnaires.csv"
EXECUTOR = "live"


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

    # --- opening ------------------------------------------------------------------------------

    def open(
        self,
        config: ExperimentConfig,
        seed: int,
        layouts: list[StudyLayout],
        participant: int,
        participant_id: str,
        trials_per_participant: int,
        resume: bool,
    ) -> dict[str, Any]:
        """Create the folder or join the live study in it; return the participant's manifest entry.

        Raises
        ------
        RunFolderError
            The folder holds a simulated run, another experiment or seed, a non-run, or (without
            ``resume``) this participant already; or ``resume`` with nothing to resume.
        """
        run, key = self.run, str(participant)
        config_text = config.to_toml()
        if run.is_run():
            manifest = run.read_manifest()
            if manifest.get("executor") != EXECUTOR:
                raise RunFolderError(
                    f"{self.path}: holds a simulated run; record live sessions in another --out"
                )
            config_path = self.path / CONFIG
            old = config_path.read_text(encoding="utf-8") if config_path.is_file() else ""
            if old != config_text or manifest.get("seed") != seed:
                raise RunFolderError(
                    f"{self.path}: holds live sessions of another experiment, --set or seed; "
                    "use the same ones, or choose another --out"
                )
            entry = manifest.setdefault("live", {}).get(key)
            if entry is not None and not resume:
                raise RunFolderError(
                    f"{self.path}: participant {participant_id} (index {participant}) is already "
                    "recorded there; add --resume to continue their session, or give another "
                    "--participant"
                )
            if entry is not None and entry.get("participant_id") != participant_id:
                raise RunFolderError(
                    f"{self.path}: index {participant} belongs to participant "
                    f"{entry.get('participant_id')}, not {participant_id}"
                )
            if entry is None and resume:
                raise RunFolderError(
                    f"{self.path}: no session of participant {participant_id} to resume; drop --resume"
                )
        else:
            if resume:
                raise RunFolderError(f"{self.path}: nothing to resume (no run there); drop --resume")
            if self.path.exists() and any(self.path.iterdir()):
                raise RunFolderError(f"{self.path}: exists and is not empty; choose another --out")
            self.path.mkdir(parents=True, exist_ok=True)
            write_text_atomic(self.path / CONFIG, config_text)
            run.write_layouts(layouts_frame(layouts))
            manifest = {
                "experiment": config.experiment.name,
                "config": config.model_dump(mode="json"),
                "seed": seed,
                "participants": 0,
                "trials_per_participant": trials_per_participant,
                "versions": library_versions(),
                "created": utc_now(),
                "timings_s": {},
                "status": "running",
                "completed": [],
                "executor": EXECUTOR,
                "live": {},
            }
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
        manifest["participants"] = len(manifest["live"])
        self.manifest = manifest
        self.save(participant, status_of_participant="running")
        return entry

    # --- checkpoints --------------------------------------------------------------------------

    def save(self, participant: int, status_of_participant: str | None = None) -> None:
        """Write the manifest (the study is complete when every participant in it is)."""
        m = self.manifest
        entry = m["live"][str(participant)]
        if status_of_participant is not None:
            entry["status"] = status_of_participant
        entry["updated"] = utc_now()
        m["completed"] = sorted(int(k) for k, e in m["live"].items() if e.get("status") == "complete")
        m["status"] = "complete" if len(m["completed"]) == len(m["live"]) else "running"
        self.run.write_manifest(m)

    def read_participant_tables(
        self, participant: int, completed: list[int]
    ) -> tuple[pd.DataFrame | None, pd.DataFrame | None]:
        """The participant's trials and steps of the ``completed`` trials (``None`` if no part yet)."""
        tables: list[pd.DataFrame | None] = []
        for kind in ("trials", "steps"):
            path = self.path / kind / part_name(participant)
            if not path.is_file():
                tables.append(None)
                continue
            frame = pd.read_parquet(path)
            tables.append(frame[frame["trial"].isin(completed)].reset_index(drop=True))
        return tables[0], tables[1]

    def write_trial(
        self, participant: int, trials: pd.DataFrame, steps: pd.DataFrame, trial: int, wall_s: float
    ) -> None:
        """Checkpoint after a trial: steps, trials, then the manifest naming ``trial`` complete."""
        write_parquet_atomic(self.path / "steps" / part_name(participant), steps)
        write_parquet_atomic(self.path / "trials" / part_name(participant), trials)
        entry = self.manifest["live"][str(participant)]
        entry["completed_trials"] = sorted({*entry["completed_trials"], trial})
        self.manifest["timings_s"][str(participant)] = round(
            self.manifest["timings_s"].get(str(participant), 0.0) + wall_s, 3
        )
        self.save(participant)

    def write_participant(self, participant: int, record: pd.DataFrame) -> None:
        """The participant's session is complete: their participants part, then the manifest."""
        write_parquet_atomic(self.path / "participants" / part_name(participant), record)
        self.save(participant, status_of_participant="complete")
        self.run.write_participants_table()
        self.save(participant)

    def write_questionnaire(self, participant: int, row: dict[str, Any]) -> None:
        """Add (or replace) one participant's answers for one block in ``questionnaires.csv``."""
        path = self.path / QUESTIONNAIRES
        new = pd.DataFrame([row])
        if path.is_file():
            old = pd.read_csv(path)
            keep = ~((old["participant"] == row["participant"]) & (old["block"] == row["block"]))
            new = pd.concat([old[keep], new], ignore_index=True).sort_values(["participant", "block"])
        write_text_atomic(path, new.to_csv(index=False))
        entry = self.manifest["live"][str(participant)]
        entry["questionnaire_blocks"] = sorted({*entry["questionnaire_blocks"], int(row["block"])})
        self.save(participant)

    def calibration_dir(self, participant: int) -> Path:
        return self.run.calibration_dir(participant)
