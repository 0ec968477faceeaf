"""Run folders: atomic writes, the manifest, resume, and readers of the tables.

A run folder (DESIGN.md section 4)::

    manifest.json          experiment, seed, versions, status, per-participant completion, timings
    config.toml            the resolved experiment
    participants.parquet   one row per participant (written when the run completes)
    layouts.parquet        the trial layouts
    trials/part-NNNN.parquet, steps/part-NNNN.parquet, participants/part-NNNN.parquet
                           one set per participant, each written atomically: the checkpoints
    calibration/participant-NNNN/
                           the participant's simulated calibration logs (tidy format; they
                           re-fit with `nudge fit` to the tables the agent used)

Every file is written to a temporary name in the same folder and renamed into place, so a
crash (even SIGKILL) leaves either the old file or the new one, never half of one. A
participant counts as done only when its three parts exist; ``--resume`` recomputes the others.
"""

from __future__ import annotations

import contextlib
import json
import os
import platform
import tempfile
from collections.abc import Iterator, Sequence
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow.parquet as pq

from nudgecli import __version__
from nudgecli.config import ExperimentConfig, experiment_from_toml
from nudgecli.errors import DataError, RunFolderError

MANIFEST = "manifest.json"
CONFIG = "config.toml"
PARTICIPANTS = "participants.parquet"
LAYOUTS = "layouts.parquet"
PART_KINDS = ("trials", "steps", "participants")
_LIBRARIES = ("numpy", "scipy", "pandas", "pyarrow", "pydantic", "click", "matplotlib", "scikit-posthocs")


def _read_umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


#: The process's umask, so atomically written files get the usual permissions (not mkstemp's 0600).
_UMASK = _read_umask()


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; if the block succeeds, flush it to disk and rename
    it onto ``path``, so readers see the old file or the new one, never part of one.

    Every file the toolkit writes goes through here.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        os.chmod(tmp_path, 0o666 & ~_UMASK)
        yield tmp_path
        with open(tmp_path, "rb") as handle:
            os.fsync(handle.fileno())
        os.replace(tmp_path, target)
    finally:
        tmp_path.unlink(missing_ok=True)


def write_text_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically (UTF-8, newlines as given)."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8", newline="")


def write_json_atomic(path: str | Path, data: Any) -> None:
    """Write ``data`` as indented JSON to ``path`` atomically."""
    write_text_atomic(path, json.dumps(data, indent=2) + "\n")


def write_parquet_atomic(path: str | Path, frame: pd.DataFrame) -> None:
    """Write ``frame`` to ``path`` as Parquet atomically (no index)."""
    with atomic_path(path) as tmp:
        frame.to_parquet(tmp, index=False)


def library_versions() -> dict[str, str]:
    """Versions of the package, Python and the libraries a result depends on."""
    versions = {"nudgecli": __version__, "python": platform.python_version()}
    for name in _LIBRARIES:
        with contextlib.suppress(metadata.PackageNotFoundError):
            versions[name] = metadata.version(name)
    return versions


def utc_now() -> str:
    """The current UTC time, ISO 8601 to the second."""
    return datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def default_run_dir(experiment: str, root: Path | None = None) -> Path:
    """``results/<experiment>-<UTC timestamp>/`` under the current directory (or ``root``)."""
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    return (root or Path("results")) / f"{experiment}-{stamp}"


def part_name(participant: int) -> str:
    """The file name of a participant's parts."""
    return f"part-{participant:04d}.parquet"


class RunFolder:
    """A run folder on disk.

    Parameters
    ----------
    path
        The folder.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)

    # --- inspection ---------------------------------------------------------------------------

    @property
    def manifest_path(self) -> Path:
        return self.path / MANIFEST

    def is_run(self) -> bool:
        """Whether the folder holds a run (it has a manifest)."""
        return self.manifest_path.is_file()

    def read_manifest(self) -> dict[str, Any]:
        """The manifest, or a ``RunFolderError`` naming the problem."""
        if not self.is_run():
            raise RunFolderError(f"{self.path}: not a run folder (no {MANIFEST}); run `nudge simulate` first")
        try:
            return json.loads(self.manifest_path.read_text(encoding="utf-8"))
        except json.JSONDecodeError as exc:
            raise RunFolderError(f"{self.manifest_path}: unreadable manifest ({exc})") from exc

    def read_config(self) -> ExperimentConfig:
        """The resolved experiment the run was made with."""
        path = self.path / CONFIG
        if not path.is_file():
            raise RunFolderError(f"{self.path}: no {CONFIG}; the run folder is incomplete")
        return experiment_from_toml(path.read_text(encoding="utf-8"), str(path))

    def completed_participants(self) -> list[int]:
        """Participants whose three parts are all on disk."""
        done: set[int] | None = None
        for kind in PART_KINDS:
            folder = self.path / kind
            found = {int(p.stem.split("-")[1]) for p in folder.glob("part-*.parquet")}
            done = found if done is None else done & found
        return sorted(done or set())

    def read_table(self, kind: str, columns: Sequence[str] | None = None) -> pd.DataFrame:
        """All parts of ``kind`` (``trials``, ``steps`` or ``participants``) concatenated in order.

        Parameters
        ----------
        kind
            The table.
        columns
            Only these columns (every part must have them); ``None`` reads all.

        Raises
        ------
        RunFolderError
            No part yet (saying what to run).
        DataError
            A part is unreadable or lacks one of ``columns``.
        """
        parts = sorted((self.path / kind).glob("part-*.parquet"))
        if not parts:
            raise RunFolderError(self._no_parts_message(kind))
        frames = []
        for part in parts:
            try:
                names = pq.ParquetFile(part).schema_arrow.names
            except Exception as exc:  # pyarrow raises several types for broken files
                raise DataError(f"{part} is not a readable Parquet file ({exc}); re-run `nudge simulate "
                                "--resume` to rewrite it") from None
            missing = [c for c in columns or () if c not in names]
            if missing:
                raise DataError(f"{part} lacks the column(s) {', '.join(missing)}; it was written by "
                                "another version of nudge: re-run `nudge simulate` with this version")
            frames.append(pd.read_parquet(part, columns=list(columns) if columns is not None else None))
        return pd.concat(frames, ignore_index=True)

    def _no_parts_message(self, kind: str) -> str:
        folder = self.path
        if kind == "steps" and (folder / "trials").is_dir() and any((folder / "trials").glob("part-*")):
            return (f"{folder} has trials but no steps/part-*.parquet; finish the run with "
                    f"`nudge simulate EXPERIMENT --out {folder} --resume`")
        if (folder / "metrics.csv").is_file():
            # e.g. a committed reference run: its step logs were left out, its metrics kept
            return (f"{folder} holds metrics but not the step logs they came from; "
                    f"analyse the table instead: `nudge analyze {folder / 'metrics.csv'}`")
        return (f"{folder} has no {kind} yet (no {kind}/part-*.parquet); run "
                f"`nudge simulate EXPERIMENT --out {folder}` first")

    def read_trials(self) -> pd.DataFrame:
        return self.read_table("trials")

    def read_steps(self) -> pd.DataFrame:
        return self.read_table("steps")

    def read_layouts(self) -> pd.DataFrame:
        path = self.path / LAYOUTS
        if not path.is_file():
            raise RunFolderError(f"{self.path}: no {LAYOUTS}; the run folder is incomplete")
        return pd.read_parquet(path)

    # --- writing ------------------------------------------------------------------------------

    def prepare(self, config: ExperimentConfig, seed: int, participants: int, resume: bool,
                force: bool) -> str:
        """Make the folder ready for a run; return ``"new"`` or ``"resume"``.

        A folder that holds another run is refused unless ``resume`` (which requires the same
        resolved experiment and seed) or ``force`` (which deletes the old run's tables first).
        A non-empty folder that is not a run is refused unless ``force``.
        """
        config_text = config.to_toml()
        if self.is_run():
            manifest = self.read_manifest()
            if resume and not force:
                config_path = self.path / CONFIG
                old = config_path.read_text(encoding="utf-8") if config_path.is_file() else ""
                if old != config_text or manifest.get("seed") != seed or \
                        manifest.get("participants") != participants:
                    raise RunFolderError(
                        f"{self.path}: holds a run with a different experiment, seed or participant count; "
                        "resume it with the same settings, or use --force to replace it")
                return "resume"
            if not force:
                state = manifest.get("status", "unknown")
                raise RunFolderError(
                    f"{self.path}: already holds a run ({manifest.get('experiment')}, {state}); "
                    "use --resume to finish it, --force to replace it, or choose another --out")
            self._clear()
        elif self.path.exists() and any(self.path.iterdir()):
            if not force:
                raise RunFolderError(
                    f"{self.path}: exists and is not empty; choose another --out or use --force")
            self._clear()
        elif resume:
            raise RunFolderError(f"{self.path}: nothing to resume (no run there); drop --resume")
        self.path.mkdir(parents=True, exist_ok=True)
        write_text_atomic(self.path / CONFIG, config_text)
        return "new"

    def _clear(self) -> None:
        """Remove what a run writes (only the run's own files and folders)."""
        for kind in PART_KINDS:
            folder = self.path / kind
            if folder.is_dir():
                for p in folder.glob("*.parquet"):
                    p.unlink()
        for name in (MANIFEST, CONFIG, PARTICIPANTS, LAYOUTS, "metrics.csv", "stats.json", "stats.csv",
                     "summary.md"):
            (self.path / name).unlink(missing_ok=True)
        calibration = self.path / "calibration"
        if calibration.is_dir():
            for log in calibration.glob("participant-*/*.csv"):
                log.unlink()
            for folder in calibration.glob("participant-*"):
                folder.rmdir()

    def calibration_dir(self, participant: int) -> Path:
        """Where a participant's simulated calibration logs go."""
        return self.path / "calibration" / f"participant-{participant:04d}"

    def write_manifest(self, manifest: dict[str, Any]) -> None:
        write_json_atomic(self.manifest_path, manifest)

    def write_layouts(self, layouts: pd.DataFrame) -> None:
        write_parquet_atomic(self.path / LAYOUTS, layouts)

    def write_participant_parts(self, participant: int, trials: pd.DataFrame, steps: pd.DataFrame,
                                record: pd.DataFrame) -> None:
        """Write one participant's checkpoint; the participants part last marks it complete."""
        write_parquet_atomic(self.path / "trials" / part_name(participant), trials)
        write_parquet_atomic(self.path / "steps" / part_name(participant), steps)
        write_parquet_atomic(self.path / "participants" / part_name(participant), record)

    def write_participants_table(self) -> None:
        """Combine the participants' parts into ``participants.parquet``."""
        write_parquet_atomic(self.path / PARTICIPANTS, self.read_table("participants"))
