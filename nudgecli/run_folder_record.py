"""What a run folder records and holds: its manifest and the participants it promises, the
parts on disk and the SHA-256 the manifest recorded of each, and how the recorded experiment
differs from one now.

:class:`RunRecord` reads and checks; :class:`nudgecli.store.RunFolder` builds on it to prepare,
write and resume a run, and to read its tables (naming the command that restores a damaged part).
The names of the files are in :mod:`nudgecli.run_folder_names`.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nudgecli.config import ExperimentConfig, experiment_from_toml
from nudgecli.errors import DataError, RunFolderError, shell_words
from nudgecli.parquet_reader import read_parquet
from nudgecli.recording_digests import RECORDINGS_DIFFER, RECORDINGS_KEY, compared, recordings
from nudgecli.run_folder_config import _ABSENT, _EXPERIMENT_SEED, ConfigRecord, _shown, experiment_differences
from nudgecli.run_folder_live import LiveRecord
from nudgecli.run_folder_names import (
    BATCH_MANIFEST,
    CALIBRATION_DIR,
    CONFIG,
    FIGURE_FORMATS,
    FIGURES_DIR,
    FIGURES_RECORD,
    LAYOUTS,
    MANIFEST,
    METRICS_CSV,
    PART_KINDS,
    PARTICIPANTS,
    numbered_parts,
    part_name,
    stray_part_files,
)
from nudgecli.run_folder_state import repair_advice, simulate_again, start_advice, version_difference

if TYPE_CHECKING:  # pandas loads on first use, after a batch has started its workers
    import pandas as pd

#: The manifest's record of the run's whole files: ``{"layouts.parquet": SHA-256, ...}`` (the parts'
#: are under ``checksums``, by participant).
FILE_CHECKSUMS = "files"
#: The manifest's entry of what each condition's policy makes constant (condition -> metrics).
CONSTANT_METRICS_KEY = "constant_metrics"
#: What a nudge run writes beside its parts: a folder with parts and one of these but no manifest
#: is a run whose manifest was lost, not a folder of parts assembled by hand.
RUN_TRACES = (CONFIG, LAYOUTS, PARTICIPANTS, CALIBRATION_DIR)


def file_sha256(path: str | Path) -> str:
    """The SHA-256 of a file's bytes, as hex (read in 1 MiB blocks)."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def readable_parquet(part: Path) -> bool:
    """Whether ``part`` is a Parquet file whose footer parses (a truncated file's does not)."""
    import pyarrow.parquet as pq

    try:
        pq.ParquetFile(part).close()
    except Exception:  # pyarrow raises several types for broken files
        return False
    return True


def is_figure_file(path: Path) -> bool:
    """Whether ``path`` is a figure's file: a plain file in one of :data:`FIGURE_FORMATS`."""
    return path.suffix.lower().lstrip(".") in FIGURE_FORMATS and path.is_file()


def remove_run_figures(folder: Path) -> None:
    """Remove a run's figures (``figures/*.png``, ``.pdf`` and ``.svg``) and ``nudge plot``'s record of
    them, and ``figures/`` once empty: what ``--force`` replaces with the run (another file a
    person put there stays, and its folder)."""
    figures = folder / FIGURES_DIR
    if not figures.is_dir():
        return
    for path in figures.iterdir():
        if is_figure_file(path):
            path.unlink()
    (figures / FIGURES_RECORD).unlink(missing_ok=True)
    with contextlib.suppress(OSError):  # not empty: a file of the person's own
        figures.rmdir()


#: A manifest's checksums: participant -> part kind -> SHA-256 (hex).
_Checksums = dict[int, dict[str, str]]



#: JSON's names of what Python's json module reads, for a damaged manifest's message (a run's or a
#: batch's).
JSON_TYPES = {list: "an array", str: "a string", int: "a number", float: "a number", bool: "true or false",
              type(None): "null"}


def json_kind(document: object) -> str:
    """What a JSON document that should be an object is, in JSON's words (``"an array"``)."""
    return JSON_TYPES.get(type(document), "not an object")

class RunRecord(LiveRecord, ConfigRecord):
    """What a run folder on disk records and holds (read and checked, never written).

    Parameters
    ----------
    path
        The folder.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        #: :meth:`manifest_to_read`'s last read: the file's identity, the manifest, its checksums
        self._kept: tuple[tuple[int, int, int], dict[str, Any], _Checksums | None] | None = None

    @property
    def manifest_path(self) -> Path:
        return self.path / MANIFEST

    def is_run(self) -> bool:
        """Whether the folder holds a run with a manifest (:func:`nudgecli.store.is_run_folder` is
        the looser test of a folder with any part of a run)."""
        return self.manifest_path.is_file()

    def refuse_other_kind(self, writing: str) -> None:
        """Refuse to write a ``writing`` (``"run"`` or ``"batch"``) into a folder that holds the other
        kind (its manifest: a run's ``manifest.json``, a batch's ``batch.json``), ``--force`` and
        ``--resume`` included: each kind's ``--force`` removes only its own files, so the folder
        would hold both, and then be resumed and analysed as either.

        Raises
        ------
        RunFolderError
            The folder holds the other kind: names it and the command that removes it.
        """
        other, name = ("batch", BATCH_MANIFEST) if writing == "run" else ("run", MANIFEST)
        if (self.path / name).is_file():
            folder = f"./{self.path}" if str(self.path).startswith("-") else str(self.path)  # not an option
            raise RunFolderError(f"{self.path}: holds a {other} ({name}), not a {writing}, and --force "
                                 f"replaces only a {writing}: delete the {other} first "
                                 f"(`{shell_words(['rm', '-r', folder])}`, which deletes the folder with "
                                 "everything in it), or choose another --out")

    def read_manifest(self) -> dict[str, Any]:
        """The manifest, or a ``RunFolderError`` naming the problem."""
        if not self.is_run():
            fix = self.restore_manifest_advice() if self.live_signs() else "run `nudge simulate` first"
            raise RunFolderError(f"{self.path}: not a run folder (no {MANIFEST}); {fix}")
        try:
            document = json.loads(self.manifest_path.read_text(encoding="utf-8"))
            if isinstance(document, dict):
                return document
            damage = f"{json_kind(document)}, not a JSON object"  # batch.json's words for the same damage
        except ValueError as exc:  # not JSON, or not UTF-8: nothing else records the run's participants
            damage = str(exc)
        fix = self.restore_manifest_advice() if self.live_signs() else (
            f"put it back from a copy, or delete it and simulate again: `{self.lost_run_command()}` "
            "(with its --seed)")
        raise RunFolderError(f"{self.manifest_path}: unreadable manifest ({damage}); neither reading nor "
                             f"--resume can use the run without it: {fix}")

    def manifest_to_read(self) -> dict[str, Any]:
        """:meth:`read_manifest` for a reader that does not change it (a table read a participant's
        part at a time: a 300-participant manifest is 0.1 MB of JSON), parsed again only once the
        file is another (an atomic write's new inode), or its size or modification time changed.
        While it is unchanged the same dict is returned: never modify it."""
        try:
            status = self.manifest_path.stat()
        except OSError:
            return self.read_manifest()  # its own error: no manifest
        identity = (status.st_ino, status.st_size, status.st_mtime_ns)
        if self._kept is None or self._kept[0] != identity:
            self._kept = (identity, self.read_manifest(), None)
        return self._kept[1]

    def checksums_to_read(self, manifest: Mapping[str, Any]) -> dict[int, dict[str, str]]:
        """:meth:`recorded_checksums` of ``manifest``, made once for :meth:`manifest_to_read`'s
        manifest while it is unchanged (never modify it)."""
        kept = self._kept
        if kept is None or kept[1] is not manifest:
            return self.recorded_checksums(manifest)
        if kept[2] is None:
            self._kept = kept = (kept[0], kept[1], self.recorded_checksums(manifest))
        assert kept[2] is not None
        return kept[2]

    def participant_count(self, manifest: Mapping[str, Any]) -> int:
        """The manifest's ``participants``: a whole number of at least 1 (a run simulates one at
        least), or a ``RunFolderError`` naming the value."""
        value = manifest.get("participants")
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            shown = json.dumps(value) if "participants" in manifest else "(missing)"
            raise RunFolderError(f"{self.manifest_path}: participants = {shown} is not a whole number of "
                                 "participants (1 or more); the manifest is damaged: restore it, or simulate "
                                 "the run again with --force")
        return value

    def manifest_participants(self, manifest: Mapping[str, Any]) -> list[int] | None:
        """The participants whose parts the manifest promises (a ``nudge study`` folder: those its
        ``live`` entries name), or ``None`` for a manifest that names no participant count."""
        if manifest.get("executor") == "live":
            try:
                return sorted(int(key) for key in (manifest.get("live") or {}))
            except (TypeError, ValueError):
                raise RunFolderError(f"{self.manifest_path}: a participant of 'live' is not a number; "
                                     "the manifest is damaged") from None
        if "participants" not in manifest:
            return None
        return list(range(self.participant_count(manifest)))

    def stray_parts(self, manifest: Mapping[str, Any]) -> list[str]:
        """Parts on disk of participants the manifest does not promise (``trials/part-0007.parquet``):
        copied in from another run, left by an earlier run with more participants; never read."""
        expected = self.manifest_participants(manifest)
        if expected is None:
            return []
        names = {part_name(index) for index in expected}
        return [f"{kind}/{part.name}" for kind in PART_KINDS
                for part in sorted((self.path / kind).glob("part-*.parquet")) if part.name not in names]

    def recorded_checksums(self, manifest: Mapping[str, Any]) -> dict[int, dict[str, str]]:
        """The manifest's ``checksums``: participant -> part kind -> SHA-256 (hex); empty for a
        manifest of an older nudge.

        Raises
        ------
        RunFolderError
            The entry is not of that shape (a damaged or edited manifest).
        """
        recorded = manifest.get("checksums") or {}
        try:
            sums = {int(key): dict(value) for key, value in recorded.items()}
            if all(kind in PART_KINDS and isinstance(digest, str)
                   for value in sums.values() for kind, digest in value.items()):
                return sums
        except (AttributeError, TypeError, ValueError):
            pass
        raise RunFolderError(f"{self.manifest_path}: 'checksums' is damaged (expected participant -> "
                             f"{{{', '.join(PART_KINDS)}}} -> SHA-256); restore the manifest, or simulate "
                             "the run again with --force")

    def changed_parts(self, manifest: Mapping[str, Any]) -> dict[int, list[str]]:
        """Participant -> its parts on disk whose SHA-256 differs from the one the manifest recorded."""
        changed: dict[int, list[str]] = {}
        for participant, sums in self.recorded_checksums(manifest).items():
            for kind, recorded in sums.items():
                part = self.part_path(kind, participant)
                if part.is_file() and file_sha256(part) != recorded:
                    changed.setdefault(participant, []).append(f"{kind}/{part.name}")
        return changed

    def integrity_notes(self, manifest: Mapping[str, Any]) -> list[str]:
        """What a reader of the run should be told: stray parts left out, participants left out
        whose parts the manifest checksummed beyond its count (a count lowered by hand), parts
        without a recorded SHA-256 (a manifest of an older nudge; in a ``nudge study`` folder, a
        participant an older nudge recorded) that were not verified."""
        notes = []
        beyond = self._checksummed_beyond_count(manifest)
        kept = {part_name(index) for index in beyond}  # named by the note of their own below
        strays = [stray for stray in self.stray_parts(manifest) if stray.split("/", 1)[1] not in kept]
        if strays:
            shown = ", ".join(strays[:6]) + (f" and {len(strays) - 6} more" if len(strays) > 6 else "")
            notes.append(f"{self.path}: left out {len(strays)} part(s) not in the manifest: {shown}; they do "
                         "not belong to this run (remove them)")
        if beyond:
            count = len(self.manifest_participants(manifest) or [])
            notes.append(f"{self.path}: the manifest records the SHA-256 of the parts of participant(s) "
                         f"{', '.join(map(str, beyond))}, beyond its {count} participant(s): this run wrote "
                         f"them, but they were left out (was 'participants' in {MANIFEST} lowered?); set it "
                         f"back to {beyond[-1] + 1} to read them")
        sums = self.recorded_checksums(manifest)
        # a live folder: its participants with parts (one recorded by an older nudge has no SHA-256)
        expected = [index for index, kinds in self.live_parts(manifest).items() if kinds] \
            if manifest.get("executor") == "live" else self.manifest_participants(manifest) or []
        unverified = [index for index in expected if index not in sums]
        if unverified:
            notes.append(f"{self.path}: the manifest records no SHA-256 of the parts of {len(unverified)} "
                         "participant(s) (written by an older nudge); they were read unverified")
        if self.study_under_way(manifest):
            notes.append(self._live_progress_note(manifest))
        return notes

    def _checksummed_beyond_count(self, manifest: Mapping[str, Any]) -> list[int]:
        """The participants whose parts' SHA-256 the manifest records but whose parts it does not
        promise (its ``participants`` lowered after the run wrote them), in order."""
        expected = self.manifest_participants(manifest)
        if expected is None:
            return []
        return sorted(set(self.recorded_checksums(manifest)) - set(expected))

    def read_config(self) -> ExperimentConfig:
        """The resolved experiment the run was made with."""
        path = self.path / CONFIG
        if not path.is_file():
            raise RunFolderError(f"{self.path}: no {CONFIG}; the run folder is incomplete")
        return experiment_from_toml(path.read_text(encoding="utf-8"), str(path))

    def part_path(self, kind: str, participant: int) -> Path:
        """Where participant ``participant``'s part of ``kind`` lives."""
        return self.path / kind / part_name(participant)

    def completed_participants(self) -> list[int]:
        """Participants whose three parts are all on disk and readable (a Parquet footer that parses)."""
        done: set[int] | None = None
        for kind in PART_KINDS:
            folder = self.path / kind
            found = {index for index, p in numbered_parts(folder).items() if readable_parquet(p)}
            done = found if done is None else done & found
        return sorted(done or set())

    def has_completed_participant(self) -> bool:
        """Whether :meth:`completed_participants` is not empty, reading footers only until the first
        participant whose three parts are readable (a complete run: three, not three per participant)."""
        on_disk = [numbered_parts(self.path / kind) for kind in PART_KINDS]
        candidates = sorted(set(on_disk[0]).intersection(*on_disk[1:]))
        return any(all(readable_parquet(parts[index]) for parts in on_disk) for index in candidates)

    def missing_parts(self, participants: int) -> dict[int, list[str]]:
        """Participant -> the parts (``trials/part-0003.parquet``, ...) missing or unreadable.

        Parameters
        ----------
        participants
            How many participants the run has (0 .. participants - 1 are expected).
        """
        return self._unusable_parts({index: PART_KINDS for index in range(participants)})

    def _unusable_parts(self, expected: Mapping[int, Sequence[str]]) -> dict[int, list[str]]:
        """Participant -> those of its expected part kinds that are missing or unreadable."""
        missing: dict[int, list[str]] = {}
        for index, kinds in expected.items():
            for kind in kinds:
                part = self.part_path(kind, index)
                if not part.is_file():
                    missing.setdefault(index, []).append(f"{kind}/{part.name} (missing)")
                elif not readable_parquet(part):
                    missing.setdefault(index, []).append(f"{kind}/{part.name} (unreadable)")
        return missing

    def read_layouts(self) -> pd.DataFrame:
        """The trial layouts, verified against the SHA-256 the manifest recorded when they were
        written (a manifest of an older nudge records none).

        Raises
        ------
        RunFolderError
            No layouts, or layouts changed since they were written (naming the command that
            writes them again).
        DataError
            Layouts that are not a readable Parquet file (a truncated file).
        """
        path, manifest = self.path / LAYOUTS, self.read_manifest() if self.is_run() else {}
        fix = self.resume_command(manifest) if manifest else "nudge simulate ... --resume"
        # a live folder's: made again from the experiment and its seed (never by a simulation there)
        rebuild = self.rebuild_layouts_hint(manifest) if manifest.get("executor") == "live" else None
        advise = (lambda verb: repair_advice(self.path, manifest, fix, verb)) if manifest else \
            (lambda verb: f"{verb} with `{fix}`")  # another version's run: its resume is refused
        again = rebuild or advise("write it again")
        if not path.is_file():
            raise RunFolderError(f"{self.path}: no {LAYOUTS}; the run folder is incomplete; "
                                 f"{rebuild or advise('restore it')}")
        files = manifest.get(FILE_CHECKSUMS)
        recorded = files.get(LAYOUTS) if isinstance(files, Mapping) else None
        data = path.read_bytes()
        if recorded is not None and hashlib.sha256(data).hexdigest() != recorded:
            raise RunFolderError(f"{self.path}: {LAYOUTS} changed since it was written (its SHA-256 differs "
                                 f"from the one in the manifest); {again}")
        try:
            return read_parquet(data)
        except Exception as exc:  # pyarrow raises several types for broken files
            raise DataError(f"{path} is not a readable Parquet file ({exc}); {again}") from None

    def resume_command(self, manifest: Mapping[str, Any] | None = None) -> str:
        """The command that finishes or repairs this run (``nudge simulate ... --resume``), with ``--people``
        where it simulated a people file (the folder's copy, by its path as given, else the file the
        manifest names: a resume without it is refused), ``--scheduler ADDRESS`` where it ran on a dask
        scheduler (:func:`resume_scheduler`); for a policy of the calling script, the Python call instead."""
        from nudgecli.run_folder_state import resume_scheduler
        from nudgecli.run_folder_trust import advised_experiment
        from nudgecli.sim.people_file import MANIFEST_KEY as PEOPLE_KEY
        from nudgecli.sim.people_file import resume_people
        from nudgecli.sim.policy_files import script_resume_call
        from nudgecli.store import simulate_resume_command  # store builds on this module

        manifest = manifest if manifest is not None else self.read_manifest()
        people = manifest.get(PEOPLE_KEY)
        file = resume_people(self.path, people, people.get("file")) if isinstance(people, dict) else None
        # a config.toml lost, damaged or edited: the experiment the manifest names (a resume writes
        # config.toml again from the manifest)
        experiment = advised_experiment(self.path, manifest)
        # a policy of the calling script (__main__) exists only in that script: resumed from Python there
        call = script_resume_call(manifest, experiment, self.path, manifest.get("seed"),
                                  manifest.get("participants"), file)
        return call or simulate_resume_command(experiment, self.path, manifest.get("seed"),
                                               manifest.get("participants"), people=file,
                                               scheduler=resume_scheduler(manifest))

    def resume_experiment(self, manifest: Mapping[str, Any]) -> str | None:
        """The experiment a command that resumes this run names in place of the one typed: its
        ``config.toml`` where the run keeps copies of its own policy modules (the manifest's
        ``policy_files``): the resolved experiment, its ``--set`` values in it, importing the copies,
        so the command works from any folder (docs/policies.md); ``None`` otherwise."""
        from nudgecli.run_folder_trust import own_config
        from nudgecli.sim.policy_files import MANIFEST_KEY as POLICY_FILES_KEY

        kept = own_config(self.path, manifest) if manifest.get(POLICY_FILES_KEY) else None
        return str(kept) if kept is not None else None

    def part_fix(self, manifest: Mapping[str, Any] | None, part: Path, verb: str) -> str:
        """What brings back a damaged ``part``: ``VERB with `nudge simulate ... --resume``` (where this
        nudge resumes the run: :func:`~nudgecli.run_folder_state.repair_advice`); in a live folder, a
        backup (a person's trial cannot be run again); without a manifest (nothing to resume), a copy."""
        if manifest is not None and manifest.get("executor") == "live":
            return self.live_part_fix(manifest, part)
        if manifest is not None:
            return repair_advice(self.path, manifest, self.resume_command(manifest), verb)
        return (f"{verb.split(' ')[0]} it from an intact copy (no {MANIFEST}: nothing resumes the run), "
                f"or {simulate_again(self.path, None)}")

    def unvouched_parts(self, manifest: Mapping[str, Any],
                        participants: Iterable[int]) -> dict[int, list[str]]:
        """Participant -> those of its parts on disk the manifest does not vouch for: no SHA-256
        recorded of it (not written by this run: copied in, or left by another), or one that
        differs (changed since written), and a calibration log recorded that is missing or changed
        (:func:`~nudgecli.run_folder_calibration.changed_calibration_logs`). Parts not on disk are
        :meth:`missing_parts`' business."""
        from nudgecli.run_folder_calibration import changed_calibration_logs  # which builds on this module

        sums = self.recorded_checksums(manifest)
        unvouched: dict[int, list[str]] = {}
        for participant in participants:
            for kind in PART_KINDS:
                part = self.part_path(kind, participant)
                recorded = sums.get(participant, {}).get(kind)
                if not part.is_file():
                    continue
                why = ("no SHA-256 recorded" if recorded is None else
                       "changed since written" if file_sha256(part) != recorded else None)
                if why is not None:
                    unvouched.setdefault(participant, []).append(f"{kind}/{part.name} ({why})")
            if logs := changed_calibration_logs(self, manifest, participant):
                unvouched.setdefault(participant, []).extend(logs)
        return unvouched

    def check_vouched(self, manifest: Mapping[str, Any]) -> None:
        """Refuse a run whose manifest records the parts' SHA-256 (this nudge's manifests do) but
        not those of every participant it promises (parts not written by this run; an older nudge's
        records none: :meth:`integrity_notes`), or a run file it records (``files``) that is gone.

        Raises
        ------
        RunFolderError
            Names the parts or files and the command that simulates or writes them again.
        """
        files = manifest.get(FILE_CHECKSUMS) or {}
        if not isinstance(files, Mapping):  # iterated below: a bare number would be a traceback
            raise RunFolderError(f"{self.manifest_path}: '{FILE_CHECKSUMS}' = {json.dumps(files)[:60]} is "
                                 "damaged (expected file name -> SHA-256); restore the manifest, or simulate "
                                 "the run again with --force")
        live = manifest.get("executor") == "live"
        if gone := [name for name in files if not (self.path / name).is_file()]:
            fix = self.restore_from_backup(gone) if live else \
                repair_advice(self.path, manifest, self.resume_command(manifest), "restore")
            if live and gone == [LAYOUTS]:
                fix = self.rebuild_layouts_hint(manifest)
            raise RunFolderError(f"{self.path} is incomplete: {' and '.join(gone)} (missing); {fix}")
        if "checksums" not in manifest:
            return
        sums = self.recorded_checksums(manifest)
        # a live folder: the parts of its participants recorded with SHA-256 (an older nudge recorded none)
        expected = {index: kinds for index, kinds in self.live_parts(manifest).items() if index in sums} \
            if live else {index: PART_KINDS for index in self.manifest_participants(manifest) or []}
        unrecorded = [f"{kind}/{part_name(index)}" for index, kinds in expected.items()
                      for kind in kinds if kind not in sums.get(index, {})]
        if unrecorded:
            shown = ", ".join(unrecorded[:6]) + (f" and {len(unrecorded) - 6} more" if len(unrecorded) > 6
                                                 else "")
            fix = self.restore_from_backup(unrecorded[:6]) if live else \
                repair_advice(self.path, manifest, self.resume_command(manifest), "simulate them again")
            raise RunFolderError(f"{self.path}: the manifest records no SHA-256 of {shown}: nothing shows "
                                 f"they are this run's (copied in from another run?); {fix}")

    def lost_run_command(self) -> str:
        return shell_words(["nudge", "simulate", str(self.path / CONFIG), "--out", str(self.path),
                            "--force"])  # a run without its manifest

    def lost_manifest_error(self) -> RunFolderError | None:
        """The refusal of a folder that holds a run's parts and another of its files
        (:data:`RUN_TRACES`) but no manifest: nothing shows which participants the run has, nor
        that the parts are its own (``None`` when there is a manifest, or no such trace)."""
        if self.is_run():
            return None
        found = sorted({index for kind in PART_KINDS for index in numbered_parts(self.path / kind)})
        if not found or not any((self.path / trace).exists() for trace in RUN_TRACES):
            return None
        fix = self.restore_manifest_advice() if self.live_signs() else (
            f"put {MANIFEST} back, or simulate the run again: `{self.lost_run_command()}` (with the --seed "
            "it was run with)")
        return RunFolderError(f"{self.path}: no {MANIFEST}: nothing shows how many participants the run "
                              f"has (parts of {len(found)} found) nor that its parts are its own, so it "
                              f"cannot be read as complete; {fix}")

    def unrecorded_note(self) -> str:
        """What a reader of a folder of parts without a manifest (assembled by hand) is told."""
        strays = [f"{kind}/{p.name}" for kind in PART_KINDS for p in stray_part_files(self.path / kind)]
        left_out = f"; left out {', '.join(strays)}: not named part-NNNN.parquet" if strays else ""
        return (f"{self.path} has no {MANIFEST}: nothing shows that its parts are the whole study or "
                f"unchanged; they were analysed as found, unverified{left_out}")

    def resume_differences(self, manifest: Mapping[str, Any], config: ExperimentConfig, seed: int,
                           participants: int) -> list[str]:
        """What differs between the run the manifest recorded and a resume of it with ``config``,
        ``seed`` and ``participants`` by this nudge: ``key: OLD in the manifest, NEW now`` each.

        The resolved experiment is compared key by key (a manifest without one: the run's
        ``config.toml``), then the seed, the participant count, the recordings' digests where the
        manifest records them (:mod:`nudgecli.recording_digests`) and nudgecli's version.
        """
        if isinstance(manifest.get("config"), Mapping):
            # the seed used is compared below; a run made before config.toml recorded it holds the
            # experiment's own seed there, not its --seed
            differences = [difference for difference in
                           experiment_differences(manifest["config"], config.model_dump(mode="json"))
                           if not difference.startswith(f"{_EXPERIMENT_SEED}:")]
        else:  # a manifest of an older nudge: the run's config.toml is the record
            config_path = self.path / CONFIG
            old = config_path.read_text(encoding="utf-8") if config_path.is_file() else ""
            differences = [] if old == config.to_toml() else [f"{CONFIG}: differs from the experiment now"]
        if manifest.get("seed") != seed:
            differences.append(f"seed: {_shown(manifest.get('seed', _ABSENT))} in the manifest, {seed} now")
        if manifest.get("participants") != participants and \
                not any(d.startswith("study.participants:") for d in differences):
            differences.append(f"participants: {_shown(manifest.get('participants', _ABSENT))} in the "
                               f"manifest, {participants} now")
        # a run that named none records none; a manifest without the record is not compared
        now = compared(manifest, recordings(config)).get(RECORDINGS_KEY)
        if manifest.get(RECORDINGS_KEY) != now:
            differences.append(f"{RECORDINGS_KEY}: {_shown(manifest.get(RECORDINGS_KEY, _ABSENT))} in the "
                               f"manifest, {_shown(now)} now ({RECORDINGS_DIFFER.format(what='run')})")
        if (version := version_difference(manifest)) is not None:  # repair_advice knows this refusal
            differences.append(version)
        return differences

    def no_parts_message(self, kind: str, manifest: Mapping[str, Any] | None) -> str:
        """Why the folder has no part of ``kind`` to read, and the command that writes them: a
        ``nudge study`` folder's continues a session (never a simulation: it would be refused)."""
        from nudgecli.run_folder_trust import advised_experiment
        from nudgecli.store import simulate_resume_command  # store builds on this module

        folder = self.path
        if manifest is not None and manifest.get("executor") == "live":
            return (f"{folder} holds live sessions with no {kind} recorded yet; "
                    f"{self.continue_session_hint(manifest)}")
        experiment = advised_experiment(folder, manifest)  # its own settings, where config.toml holds them
        if kind == "steps" and (folder / "trials").is_dir() and any((folder / "trials").glob("part-*")):
            return (f"{folder} has trials but no steps/part-*.parquet; finish the run with "
                    f"`{simulate_resume_command(experiment, folder)}`")
        if (folder / METRICS_CSV).is_file():
            # e.g. a committed reference run: its step logs were left out, its metrics kept
            analyze_table = shell_words(["nudge", "analyze", str(folder / METRICS_CSV)])
            return (f"{folder} holds metrics but not the step logs they came from; "
                    f"analyse the table instead: `{analyze_table}`")
        if manifest is None and (advice := start_advice(folder)) is not None:
            return advice
        return (f"{folder} has no {kind} yet (no {kind}/part-*.parquet); run "
                f"`{shell_words(['nudge', 'simulate', 'EXPERIMENT', '--out', str(folder)])}` first")

    def check_own_manifest(self, manifest: Mapping[str, Any], resume_seed: int | None = None) -> None:
        """Refuse a manifest that is another run's (copied over this one's:
        :func:`~nudgecli.run_folder_trust.other_run_error`), and, where its two seeds differ
        (:func:`~nudgecli.run_folder_trust.differing_seeds`), a resume (``resume_seed``) but with its own
        seed where its surviving parts were made with it, or, reading (``None``), a run that needs a resume.

        Raises
        ------
        RunFolderError
            Names the manifest as the suspect: a resume would simulate every part again, or
            participants of another seed."""
        from nudgecli.run_folder_trust import differing_seeds_error, other_run_error

        if (error := other_run_error(self, manifest)) is not None:
            raise error
        if resume_seed is None and manifest.get("status") == "complete" and \
                not self.missing_parts(self.participant_count(manifest)):
            return
        lead = f"{self.path} needs a resume" if resume_seed is None else \
            f"{self.path}: cannot resume with seed {resume_seed}"
        if (error := differing_seeds_error(self, manifest, lead, resume_seed)) is not None:
            raise error  # a resume with the manifest's own seed too, where the parts were not made with it
