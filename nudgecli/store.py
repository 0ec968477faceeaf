"""Run folders: atomic writes, the manifest, resume, and readers of the tables.

A run folder (DESIGN.md section 4)::

    manifest.json          experiment, seed, versions, status, per-participant completion, timings,
                           the SHA-256 of every part
    config.toml            the resolved experiment
    participants.parquet   one row per participant (written when the run completes)
    layouts.parquet        the trial layouts
    trials/part-NNNN.parquet, steps/part-NNNN.parquet, participants/part-NNNN.parquet
                           one set per participant, each written atomically: the checkpoints
    calibration/participant-NNNN/
                           the participant's simulated calibration logs (tidy format; they
                           re-fit with `nudge fit` to the tables the agent used)
    people/NAME.csv        with ``--people``: the people file's exact bytes (its resume names it)

Every file is written to a temporary name in the same folder and renamed into place, so a
crash (even SIGKILL) leaves either the old file or the new one, never half of one; an
``OSError`` while writing (read-only folder, full disk) becomes a :class:`WriteError` naming the
path and the cause. A participant counts as done only when its three parts exist and are
readable Parquet files; ``--resume`` recomputes the others, and those whose SHA-256 differs from
the one the manifest recorded when they were written. Readers take exactly the parts of the
participants the manifest promises and verify them against it.

While a command writes a run folder it holds its lock (:func:`nudgecli.locks.run_lock`). What a run
folder records and holds is read and checked by :class:`nudgecli.run_folder_record.RunRecord`."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import platform
import tempfile
from collections.abc import Callable, Collection, Iterable, Iterator, Sequence
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nudgecli import __version__
from nudgecli.config import ExperimentConfig
from nudgecli.errors import DataError, RunFolderError, WriteError, shell_words
from nudgecli.outputs import check_not_an_input
from nudgecli.parquet_reader import parquet_column_names, read_parquet
from nudgecli.results_folders import default_run_dir as default_run_dir  # where commands import it
from nudgecli.run_folder_calibration import calibration_dir
from nudgecli.run_folder_config import remove_run_analysis
from nudgecli.run_folder_names import (
    CALIBRATION_DIR,
    CONFIG,
    FIGURES_DIR,
    LAYOUTS,
    LOCK,
    MANIFEST,
    PART_KINDS,
    PARTICIPANTS,
    PEOPLE_DIR,
    PLAN_COPY,
    numbered_parts,
)
from nudgecli.run_folder_record import RunRecord, file_sha256, part_name, readable_parquet
from nudgecli.run_folder_state import (
    only_a_start,
    other_version,
    reader_state,
    refuse_links,
    repair_advice,
    simulate_again,
)

if TYPE_CHECKING:  # pandas and pyarrow load on first use, after a batch has started its workers
    import pandas as pd

_LIBRARIES = ("numpy", "scipy", "pandas", "pyarrow", "pydantic", "click", "matplotlib", "scikit-posthocs")


def _read_umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


#: The process's umask, so atomically written files get the usual permissions (not mkstemp's 0600).
_UMASK = _read_umask()


@contextlib.contextmanager
def atomic_path(path: str | Path, durable: bool = True) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; if the block succeeds, flush it to disk and rename
    it onto ``path``, so readers see the old file or the new one, never part of one.

    Every file the toolkit writes goes through here; so it refuses to replace a file the running
    command read (:func:`nudgecli.outputs.check_not_an_input`). ``durable=False`` skips the flush
    to disk (fsync) where a record of the file's SHA-256 finds a file a power cut left short (a
    batch's parts, :class:`~nudgecli.runs.batch_folder.PartRecord`); a killed process cannot.
    """
    target = Path(path)
    check_not_an_input(target)
    try:
        if not target.parent.is_dir():  # a stat: much cheaper than mkdir's call on every write
            target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=temporary_prefix(target), suffix=".tmp", dir=target.parent)
        os.close(fd)
    except OSError as exc:
        raise write_error(target, exc) from exc
    tmp_path = Path(tmp)
    try:
        os.chmod(tmp_path, 0o666 & ~_UMASK)
        yield tmp_path
        if durable:
            with open(tmp_path, "rb") as handle:
                os.fsync(handle.fileno())
        os.replace(tmp_path, target)
    except OSError as exc:
        raise write_error(target, exc) from exc
    finally:
        with contextlib.suppress(OSError):
            tmp_path.unlink(missing_ok=True)


#: Characters ``tempfile.mkstemp`` puts between the prefix and the suffix.
_RANDOM_CHARACTERS = 8
#: The longest file name when the file system does not say (``NAME_MAX`` of ext4, APFS, NTFS).
_NAME_MAX = 255


def temporary_prefix(target: Path) -> str:
    """The prefix of ``target``'s temporary name: ``.<name>.``, its name cut so that the whole
    temporary name (``.<name>.<8 random characters>.tmp``) fits the file system's limit.

    A legal name of 255 bytes would otherwise give a temporary name too long to create. The cut
    is made on a character boundary (UTF-8); temporaries are told apart by their random part.
    """
    try:
        limit = os.pathconf(target.parent, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):  # not POSIX, or the file system does not say
        limit = _NAME_MAX
    room = max(1, min(limit, _NAME_MAX) - len("..") - _RANDOM_CHARACTERS - len(".tmp"))
    name = os.fsencode(target.name)[:room].decode("utf-8", errors="ignore")  # no half character
    return f".{name}."


def write_error(path: str | Path, exc: OSError) -> WriteError:
    """The :class:`WriteError` of an ``OSError`` raised while writing ``path``: the path and the cause."""
    cause = exc.strerror or str(exc) or type(exc).__name__
    return WriteError(f"cannot write {path}: {cause}; check that the folder exists, is writable and "
                      "has free space")


def check_writable(folder: str | Path) -> None:
    """Fail now, before any work, with a :class:`WriteError` if a file cannot be created in ``folder``
    (read-only, full, not a folder), making none: the folders made to check it are removed again."""
    path = Path(folder)
    missing = [p for p in (path, *path.parents) if not os.path.exists(p)]  # the deepest first
    try:
        with atomic_path(path / ".nudge-write-check") as tmp:
            tmp.write_bytes(b"")
        with contextlib.suppress(OSError):
            (path / ".nudge-write-check").unlink()
    finally:
        for made in missing:
            with contextlib.suppress(OSError):
                made.rmdir()


def remove_temporaries(folders: Iterable[Path]) -> None:
    """Remove the temporaries (:func:`atomic_path`'s ``.<name>.<random>.tmp``) that writers killed
    mid-write left in ``folders`` (missing folders are skipped). The caller holds the folder's lock,
    so no live writer owns them."""
    for folder in folders:
        if folder.is_dir():
            for tmp in folder.glob(".*.tmp"):
                tmp.unlink(missing_ok=True)


def write_text_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically (UTF-8, newlines as given)."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8", newline="")


def write_bytes_atomic(path: str | Path, data: bytes, durable: bool = True) -> None:
    """Write ``data`` to ``path`` atomically, byte for byte (``durable``: see :func:`atomic_path`)."""
    with atomic_path(path, durable) as tmp:
        tmp.write_bytes(data)


def json_text(data: Any) -> str:
    """``data`` as the toolkit writes JSON files: indented by 2, one newline at the end."""
    return json.dumps(data, indent=2) + "\n"


def write_json_atomic(path: str | Path, data: Any) -> None:
    """Write ``data`` as indented JSON (:func:`json_text`) to ``path`` atomically."""
    write_text_atomic(path, json_text(data))


def write_parquet_atomic(path: str | Path, frame: pd.DataFrame) -> str:
    """Write ``frame`` to ``path`` as Parquet atomically (no index); the file's SHA-256 (hex)."""
    with atomic_path(path) as tmp:
        frame.to_parquet(tmp, index=False)
        return file_sha256(tmp)  # the block's end renames it into place


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


def provenance() -> dict[str, Any]:
    """What every manifest (a run's, a batch's) records of its making: ``versions``, ``created``."""
    return {"versions": library_versions(), "created": utc_now()}


def new_manifest(config: ExperimentConfig, seed: int, participants: int,
                 trials_per_participant: int) -> dict[str, Any]:
    """The keys a run's first ``manifest.json`` opens with, in this order (``nudge simulate`` and
    ``nudge study`` add theirs after): the experiment and its resolved configuration, the seed, the
    participants, the trials per participant, :func:`provenance` and the (empty) ``timings_s``."""
    return {"experiment": config.experiment.name, "config": config.model_dump(mode="json"), "seed": seed,
            "participants": participants, "trials_per_participant": trials_per_participant, **provenance(),
            "timings_s": {}}


def prepare_mode(path: Path, held: str | None, resume: bool, force: bool, *, kind: str = "run",
                 own_file: Callable[[str], bool] = LOCK.__eq__, can_force: bool = True,
                 resume_first: bool = False, started: bool = False) -> str:
    """The rule of every command that prepares a folder to write a run or a batch into.

    A folder that holds a ``kind`` (``held`` describes it, e.g. ``"paper, complete"``) is refused
    unless ``resume`` (``"resume"``: the caller checks it is the same work) or ``force``
    (``"replace"``: the caller removes the old work). A folder holding other files (than those
    ``own_file`` names: the lock) is refused unless ``force`` (``"overwrite"``). ``resume`` with
    nothing there is refused, and ``resume`` with ``force`` always (they contradict). Else ``"new"``.

    Parameters
    ----------
    can_force
        Whether the command has ``--force`` (``nudge study`` has not): the refusal offers it.
    resume_first
        Refuse ``resume`` into a folder without a ``kind`` before looking at its contents
        (``nudge study``'s order: "nothing to resume" rather than "not empty").
    started
        Only the start of this same work is there (:func:`only_a_start`): the refusal offers ``--resume``.
    """
    if resume and force:  # neither may win quietly: one keeps the finished work, the other deletes it
        raise RunFolderError(f"{path}: --resume and --force contradict each other (--resume keeps the "
                             f"{kind}'s finished work, --force deletes it); use --resume alone to finish the "
                             f"{kind}, or --force alone to start it afresh")
    if held is not None:
        if resume:
            return "resume"
        if not force:
            raise RunFolderError(f"{path}: already holds a {kind} ({held}); use --resume to finish it, "
                                 "--force to replace it, or choose another --out")
        return "replace"
    occupied = path.exists() and any(not own_file(p.name) for p in path.iterdir())
    if resume and (resume_first or not occupied):
        raise RunFolderError(f"{path}: nothing to resume (no {kind} there); drop --resume")
    if occupied and not force:
        refused = (f"holds only the start of this {kind} (killed before its manifest); use --resume to start "
                   "it, or " if started else "exists and is not empty; ") + "choose another --out"
        raise RunFolderError(f"{path}: {refused}" + (" or use --force" if can_force else ""))
    return "overwrite" if occupied else "new"


def resume_command(words: Sequence[str], target: str | Path, options: Sequence[str] = ()) -> str:
    """The command line suggested to finish interrupted work: ``nudge WORDS --out TARGET OPTIONS
    --resume``, each word quoted for the shell (every resume command the toolkit prints is built here).
    A folder starting with ``-`` (``--out=-dash``) is ``./-dash`` in each word naming it or a file in it."""
    dash = str(target) if str(target).startswith("-") else ""  # else read as an option
    shown = [f"./{w}" if dash and (w == dash or (w.startswith(dash) and w[len(dash)] in "/" + os.sep)) else w
             for w in (*words, "--out", str(target), *options)]
    return shell_words(["nudge", *shown, "--resume"])


def forced_command(resume: str) -> str | None:
    """The command :func:`resume_command` built, with ``--force`` in place of ``--resume``: the same
    work started afresh over the old (``None`` for a command not built there: a Python call)."""
    return resume.removesuffix("--resume") + "--force" if resume.startswith("nudge ") and \
        resume.endswith(" --resume") else None


def simulate_resume_command(experiment: str, target: str | Path, seed: int | None = None,
                            participants: int | None = None, workers: int | None = None,
                            overrides: Sequence[str] = (), command: str = "simulate", confirm: bool = False,
                            people: str | None = None, plan: str | None = None,
                            scheduler: str | None = None) -> str:
    """The ``nudge simulate`` (or ``run``) command that resumes a study into ``target`` with the same
    choices (``--yes`` when ``confirm`` let a study above the size limit run; ``people``: ``--people``;
    ``plan``: ``nudge run``'s ``--plan``; ``workers``: the ``--workers`` typed, 1 too (else the variable
    DASK_SCHEDULER_ADDRESS would win); ``scheduler``: the ``--scheduler`` typed, not the variable's)."""
    options = ["--yes"] if confirm else []
    for flag, value in (("--seed", seed), ("--participants", participants), ("--plan", plan),
                        ("--workers", workers), ("--people", people),
                        ("--scheduler", scheduler)):
        options += [flag, str(value)] if value is not None else []
    options += [word for override in overrides for word in ("--set", override)]
    return resume_command([command, experiment], target, options)


def study_resume_command(experiment: str, participant_id: str, folder: str | Path, port: int | None = None,
                         condition_order: str | None = None, seed: int | None = None,
                         overrides: Sequence[str] = ()) -> str:
    """The ``nudge study`` command that continues a session: the same experiment, folder, seed,
    condition order and ``--set`` values (the folder refuses other ones), and ``--resume``."""
    options: list[str] = []
    for flag, value in (("--port", port), ("--condition-order", condition_order), ("--seed", seed)):
        options += [flag, str(value)] if value is not None else []
    for item in overrides:
        options += ["--set", item]
    return resume_command(["study", experiment, "--participant", participant_id], folder, options)


#: What marks a folder as a run folder, any one of them: the tables' folders, the manifest, the
#: resolved experiment.
RUN_FOLDER_MARKERS = ("trials", "steps", MANIFEST, CONFIG)


def is_run_folder(path: str | Path) -> bool:
    """Whether ``path`` is a folder that holds (part of) a run: one of :data:`RUN_FOLDER_MARKERS`.

    The one test of "is this a run folder" (``nudge analyze`` tells a run folder from a metrics
    table with it). :meth:`RunFolder.is_run` asks the narrower question whether the run has a
    manifest to read.
    """
    path = Path(path)
    return path.is_dir() and any((path / marker).exists() for marker in RUN_FOLDER_MARKERS)


class RunFolder(RunRecord):
    """A run folder on disk: what :class:`~nudgecli.run_folder_record.RunRecord` reads and checks,
    and the reading of its tables, its preparation, writing and resumption.

    Parameters
    ----------
    path
        The folder.
    """

    # --- reading ------------------------------------------------------------------------------

    def check_complete(self) -> dict[str, Any]:
        """The manifest of a complete run: every participant's parts present and readable.

        Raises
        ------
        RunFolderError
            The run is still running or was interrupted, or parts are missing or unreadable:
            names them and the command that restores them.
        """
        manifest = self.read_manifest()
        if manifest.get("executor") == "live":
            return self._check_live(manifest)
        self.check_own_manifest(manifest)  # another run's: never advise a resume that recomputes the parts
        state = reader_state(self.path, manifest)  # one being written: wait, never a resume (it is in use)
        missing = self.missing_parts(self.participant_count(manifest))
        fix = self.resume_command(manifest)
        if missing:
            listed = "; ".join(f"participant {p}: {', '.join(parts)}"
                               for p, parts in sorted(missing.items())[:5])
            more = f" and {len(missing) - 5} more participants" if len(missing) > 5 else ""
            raise RunFolderError(f"{self.path} is incomplete: {listed}{more}; "
                                 f"{repair_advice(self.path, manifest, fix, 'restore')}")
        if manifest.get("status") != "complete":
            finish = repair_advice(self.path, manifest, fix, "finish it")
            raise RunFolderError(f"{self.path}: the run {state} (all parts are "
                                 f"there but it did not finish); {finish}")
        self.check_vouched(manifest)
        return manifest

    def _check_live(self, manifest: dict[str, Any]) -> dict[str, Any]:
        """:meth:`check_complete` of a ``nudge study`` folder: its layouts are readable, every
        participant with recorded trials has readable trials and steps parts (rewritten after each
        trial), and a finished one its participants part, each vouched for as a simulated run's
        (:meth:`check_vouched`); a session still under way is analysed as far as it got."""
        layouts = self.path / LAYOUTS
        if not readable_parquet(layouts):
            state = "unreadable" if layouts.is_file() else "missing"
            raise RunFolderError(f"{self.path} is incomplete: {LAYOUTS} ({state}); "
                                 f"{self.rebuild_layouts_hint(manifest)}")
        missing = self._unusable_parts(self.live_parts(manifest))
        if missing:
            listed = "; ".join(f"participant {p}: {', '.join(parts)}" for p, parts in sorted(missing.items()))
            names = [part.split(" (")[0] for parts in missing.values() for part in parts]
            raise RunFolderError(f"{self.path} is incomplete: {listed}; {self.restore_from_backup(names)}")
        self.check_vouched(manifest)
        self.check_live_trials(manifest)  # read as far as the manifest lists each participant's trials
        return manifest

    def read_table(self, kind: str, columns: Sequence[str] | None = None,
                   participants: Collection[int] | None = None) -> pd.DataFrame:
        """The parts of ``kind`` (``trials``, ``steps`` or ``participants``) concatenated in order.

        With a manifest, exactly the parts of the participants it promises are read (strays are
        left out: :meth:`stray_parts`), and each part whose SHA-256 the manifest recorded is
        verified against it; without one, every part on disk of a folder of parts alone (assembled
        by hand), while a run's folder that lost its manifest is refused
        (:meth:`lost_manifest_error`).

        Parameters
        ----------
        kind
            The table.
        columns
            Only these columns (every part must have them); ``None`` reads all.
        participants
            Only these participants' parts; ``None`` reads every part.

        Raises
        ------
        RunFolderError
            No part yet (saying what to run), or a part changed since it was written (naming it
            and the command that restores it).
        DataError
            A part is unreadable or lacks one of ``columns``.
        """
        manifest = self.manifest_to_read() if self.is_run() else None
        if (lost := self.lost_manifest_error()) is not None:
            raise lost
        expected = self.manifest_participants(manifest) if manifest is not None else None
        if expected is None:  # every part on disk, of the participants asked
            found = numbered_parts(self.path / kind)  # strays are no parts (unrecorded_note names them)
            parts = [(i, p) for i, p in found.items() if participants is None or i in participants]
        else:  # the parts the manifest promises, of the participants asked (no other one looked for)
            asked = [index for index in expected if participants is None or index in participants]
            parts = [(index, part) for index in asked if (part := self.part_path(kind, index)).is_file()]
        if not parts:
            raise RunFolderError(self.no_parts_message(kind, manifest))
        sums = self.checksums_to_read(manifest) if manifest is not None else {}
        frames = []
        for index, part in parts:
            try:
                data = part.read_bytes()
            except OSError as exc:
                raise DataError(f"{part}: cannot be read ({exc.strerror or exc})") from None
            recorded = sums.get(index, {}).get(kind)
            if recorded is not None and hashlib.sha256(data).hexdigest() != recorded:
                raise RunFolderError(
                    f"{self.path}: {kind}/{part.name} changed since it was written (its SHA-256 differs "
                    f"from the one in the manifest); {self.part_fix(manifest, part, 'restore it')}")
            try:
                names = parquet_column_names(data)
                missing = [c for c in columns or () if c not in names]
                # a part with no SHA-256 recorded may be damaged past its footer: read it here too
                frame = None if missing else read_parquet(data, columns)
            except Exception as exc:  # pyarrow raises several types for broken files
                cause = " ".join(str(exc).split())  # pyarrow's own lines: one line
                raise DataError(f"{part} is not a readable Parquet file ({type(exc).__name__}: {cause}); "
                                f"{self.part_fix(manifest, part, 'rewrite it')}") from None
            if frame is None:
                resume = self.resume_command(manifest) if manifest is not None else None
                raise DataError(f"{part} lacks the column(s) {', '.join(missing)}; it was written by another "
                                f"version of nudge: {simulate_again(self.path, manifest, resume)}")
            frames.append(frame)
        import pandas as pd

        return pd.concat(frames, ignore_index=True)

    def read_trials(self) -> pd.DataFrame:
        return self.read_table("trials")

    def read_steps(self) -> pd.DataFrame:
        return self.read_table("steps")

    # --- writing ------------------------------------------------------------------------------

    def prepare(self, config: ExperimentConfig, seed: int, participants: int, resume: bool,
                force: bool, log: Callable[[str], None] | None = None) -> str:
        """Make the folder ready for a run; ``"new"`` or ``"resume"``. The rule is :func:`prepare_mode`'s:
        ``resume`` requires the same resolved experiment and seed (``log`` is told of a config.toml put
        back), ``force`` deletes the old run's tables (or the run's file names in a non-empty folder)
        first; a run killed before its manifest starts afresh; a batch's folder is refused."""
        config_text = config.to_toml()
        refuse_links(self.path)  # a linked part folder would have the run written into another folder
        manifest = self.read_manifest() if self.is_run() else None
        self.refuse_live_sessions(manifest)  # a person's sessions: neither resumed nor replaced
        self.refuse_other_kind("run")  # a batch's: --force would leave the batch beside the run
        # killed before its manifest: start it afresh (before its config.toml: a plain rerun too)
        own_start = manifest is None and not force and only_a_start(self.path, config_text)
        start = own_start and (resume or not (self.path / CONFIG).is_file())
        if start:
            self._remove_temporaries()
        elif manifest is None and not force and (refusal := self.other_start_error(config)) is not None:
            raise refusal  # another run's start, or a --force cut short: a resume would simulate that run
        held = (None if manifest is None else
                f"{manifest.get('experiment')}, {manifest.get('status', 'unknown')}")
        mode = "new" if start else prepare_mode(self.path, held, resume, force, started=own_start)
        if manifest is not None and mode == "resume":
            self.check_own_manifest(manifest, seed)  # another run's, or a seed other than its parts'
            self.participant_count(manifest)  # a damaged count is named first: no command resumes it
            differences = self.resume_differences(manifest, config, seed, participants)
            if differences:
                shown = "; ".join(differences[:8]) + (f"; and {len(differences) - 8} more"
                                                      if len(differences) > 8 else "")
                # another version's run: its own resume is refused here too (repair_advice says what works)
                fix = repair_advice(self.path, manifest, self.resume_command(manifest), "resume it") \
                    if other_version(manifest) is not None else \
                    f"resume it with its own: `{self.resume_command(manifest)}`, or use --force to replace it"
                raise RunFolderError(f"{self.path}: cannot resume with settings different from those the run "
                                     f"started with ({shown}); {self._edited_config_hint(manifest)}{fix}")
            self._remove_temporaries()
            # the manifest's experiment is the run's: put back an edited or lost config.toml
            if (warning := self.config_toml_warning(config)) is not None:
                if log is not None:
                    log(f"Warning: {warning}")
                write_text_atomic(self.path / CONFIG, config_text)
            return "resume"
        if mode in ("replace", "overwrite"):
            self._clear(manifest)
        write_text_atomic(self.path / CONFIG, config_text)
        return "new"

    def _remove_temporaries(self) -> None:
        """Remove the temporary files of an interrupted writer (``.<name>.<random>.tmp``): the lock
        is held, so no live writer owns them."""
        calibration = sorted((self.path / CALIBRATION_DIR).glob("participant-*"))
        parts = [self.path / kind for kind in PART_KINDS]  # and a killed plot's figures' temporaries
        remove_temporaries((self.path, self.path / PEOPLE_DIR, self.path / FIGURES_DIR, *parts, *calibration))

    def _clear(self, manifest: dict[str, Any] | None) -> None:
        """Remove what a run writes (only the run's own files and folders; of ``people/``, only the
        copy the old run's ``manifest`` records: a folder that is not a run may keep the person's
        own people files there). The analysis and figures go first, the manifest and config.toml last:
        killed midway, it is a damaged run or a start, never an analysis without its run."""
        self._remove_temporaries()
        remove_run_analysis(self.path)  # the old run's figures would stand beside the new run's tables
        for kind in PART_KINDS:
            folder = self.path / kind
            if folder.is_dir():
                for p in folder.glob("*.parquet"):
                    p.unlink()
        for name in (PARTICIPANTS, LAYOUTS):
            (self.path / name).unlink(missing_ok=True)
        from nudgecli.sim.people_file import MANIFEST_KEY as PEOPLE_KEY
        from nudgecli.sim.people_file import remove_copy
        from nudgecli.sim.policy_files import MANIFEST_KEY as POLICY_FILES_KEY
        from nudgecli.sim.policy_files import remove_policy_copies

        remove_copy(self.path, None if manifest is None else manifest.get(PEOPLE_KEY))
        remove_policy_copies(self.path, None if manifest is None else manifest.get(POLICY_FILES_KEY))
        for log in (self.path / CALIBRATION_DIR).glob("participant-*/*.csv"):
            log.unlink()
        for folder in (self.path / CALIBRATION_DIR).glob("participant-*"):
            folder.rmdir()
        if manifest is not None and manifest.get("plan") == PLAN_COPY:  # its copy, never a file of one's own
            (self.path / PLAN_COPY).unlink(missing_ok=True)  # before config.toml: left, it is no start
        for name in (MANIFEST, CONFIG):  # from here on the folder holds only a start
            (self.path / name).unlink(missing_ok=True)

    def calibration_dir(self, participant: int) -> Path:
        """Where a participant's simulated calibration logs go (:mod:`nudgecli.run_folder_calibration`)."""
        return calibration_dir(self.path, participant)

    def write_manifest(self, manifest: dict[str, Any]) -> None:
        write_json_atomic(self.manifest_path, manifest)

    def write_layouts(self, layouts: pd.DataFrame) -> str:
        """Write ``layouts.parquet``; its SHA-256 (hex), for the manifest."""
        return write_parquet_atomic(self.path / LAYOUTS, layouts)

    def write_participant_parts(self, participant: int, trials: pd.DataFrame, steps: pd.DataFrame,
                                record: pd.DataFrame) -> dict[str, str]:
        """Write one participant's checkpoint; the participants part last marks it complete.

        Returns the SHA-256 of each part written (kind -> hex), for the manifest.

        All three are written to temporary files first and renamed into place only when all
        three are on disk, so a write error (full disk) leaves none of them; a crash between
        the renames leaves the participant incomplete (no participants part), and
        ``--resume`` recomputes it.
        """
        name = part_name(participant)
        sums: dict[str, str] = {}
        with atomic_path(self.path / "participants" / name) as record_tmp, \
                atomic_path(self.path / "steps" / name) as steps_tmp, \
                atomic_path(self.path / "trials" / name) as trials_tmp:
            for kind, frame, tmp in (("trials", trials, trials_tmp), ("steps", steps, steps_tmp),
                                     ("participants", record, record_tmp)):
                try:
                    frame.to_parquet(tmp, index=False)
                    sums[kind] = file_sha256(tmp)
                except OSError as exc:
                    raise write_error(self.part_path(kind, participant), exc) from exc
        return sums

    def write_participants_table(self) -> str:
        """Combine the participants' parts into ``participants.parquet``; its SHA-256, for the manifest."""
        return write_parquet_atomic(self.path / PARTICIPANTS, self.read_table("participants"))
