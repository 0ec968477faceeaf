"""The batch folder: its manifest's name, the part files of its tasks, their record, and the
prepare rule.

Every result of a batch is written by the process that runs it as an atomic part file: a
participant task's per-trial metrics under ``tasks/<study>/``, an analysis's statistics under
``analyses/``. Each part's SHA-256 is appended to the batch's record, ``checksums.sha256``
(:class:`~nudgecli.runs.part_record.PartRecord`), once the part is in place. ``--resume`` keeps
exactly the parts the record vouches for (and that are readable: :func:`readable_stats` for an
analysis) and computes the others again: a missing, truncated or edited part, or one copied in from
another batch, never reaches the batch's tables; an interrupted batch finishes without recomputing
a finished task. The graph and its execution are in :mod:`nudgecli.runs.batch`.
"""

from __future__ import annotations

import contextlib
import io
import json
import shutil
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nudgecli.errors import RunFolderError
from nudgecli.parquet_reader import read_parquet
from nudgecli.recording_digests import RECORDINGS_DIFFER, RECORDINGS_KEY, compared
from nudgecli.run_folder_names import BATCH_MANIFEST, FIGURES_DIR, LOCK, PEOPLE_DIR
from nudgecli.run_folder_record import (
    RunRecord,
    experiment_differences,
    json_kind,
    part_name,
)
from nudgecli.run_folder_state import refuse_links
from nudgecli.runs.part_record import PART_RECORD, Log, PartRecord  # noqa: F401 - the batch folder's names
from nudgecli.sim.people_file import MANIFEST_KEY as PEOPLE_KEY
from nudgecli.sim.people_file import People, keep_copy, remove_copy
from nudgecli.sim.policy_files import MANIFEST_KEY as POLICY_FILES_KEY
from nudgecli.sim.policy_files import SOURCES_KEY as POLICY_SOURCES_KEY
from nudgecli.sim.policy_files import (
    check_copies_placeable,
    keep_policy_copies,
    loaded_policy_files,
    outside_policy_sources,
    policy_record,
    remove_policy_copies,
)
from nudgecli.sim.policy_registry import policy_specs
from nudgecli.store import (
    prepare_mode,
    remove_temporaries,
    write_error,
    write_json_atomic,
)

if TYPE_CHECKING:  # pandas loads on first use, after a batch has started its workers
    import pandas as pd

    from nudgecli.runs.batch import Batch
    from nudgecli.runs.sweep import SweepFile

#: Every table a batch kind writes (``<stem>.csv`` in the folder: :mod:`nudgecli.runs.batch_kinds`
#: writes no other), and every figure (``figures/<stem>.png``): replacing a batch removes them all,
#: whichever kind it was, and a batch refuses an input of one of these names.
BATCH_TABLES = ("replications", "conditions", "summary", "power", "smallest_n", "sweep", "points",
                "sensitivity")
BATCH_FIGURES = ("forest", "power", "sweep", "sensitivity")
#: The batch folder's own folders, which a policy package of the same name would write into.
BATCH_FOLDERS = frozenset({"tasks", "analyses", PEOPLE_DIR, FIGURES_DIR})
#: A replicate's or power's own experiment (resolved: its ``--set`` applied) and analysis plan,
#: kept in the folder as a run keeps its ``config.toml``: the experiment imports the policy copies
#: beside it, so the batch resumes from its folder alone (:func:`kept_inputs`).
EXPERIMENT_COPY = "experiment.toml"
PLAN_COPY = "plan.toml"
#: A sweep's own sweep file, naming those two (its experiment file kept byte for byte: :func:`sweep_inputs`).
SWEEP_COPY = "sweep.toml"
#: What a batch writes in its folder, its tables too (renamed into place, which would replace a link
#: silently): a link in their place is refused (:func:`refuse_links`).
BATCH_OWN = (*sorted(BATCH_FOLDERS), BATCH_MANIFEST, PART_RECORD, EXPERIMENT_COPY, PLAN_COPY, SWEEP_COPY,
             *(f"{stem}.csv" for stem in BATCH_TABLES))
#: ``batch.json``'s record of those two files: ``{name: SHA-256}``.
INPUTS_KEY = "inputs"
@dataclass(frozen=True)
class PolicyCopies:
    """The policy modules of a researcher's own that a batch's experiments import from their folder,
    which the batch folder keeps, as a run folder does (:mod:`nudgecli.sim.policy_files`): each
    file's exact copy under its relative path (``policies/threshold.py``) and its SHA-256 in
    ``batch.json`` (:meth:`record`, beside the batch's description, not in it: what a resume
    compares as settings is as before, and a batch of an older nudge, which kept none, resumes).

    Attributes
    ----------
    files
        Relative path -> the file's bytes (:func:`~nudgecli.sim.policy_files.loaded_policy_files`).
    source
        The folder they are imported from (the experiment file's), to name a file that differs.
    inputs
        A batch's own experiment and plan (or a sweep's sweep file), by file name -> their bytes.
    sources
        The digests of the policies imported from elsewhere (a module on ``sys.path``, a class of
        the calling script), compared on resume, not copied, as a run's
        (:func:`~nudgecli.sim.policy_files.outside_policy_sources`).
    """

    files: Mapping[str, bytes] = field(default_factory=dict)
    source: str | None = None
    inputs: Mapping[str, bytes] = field(default_factory=dict)
    sources: Mapping[str, str] = field(default_factory=dict)

    def record(self) -> dict[str, dict[str, str]]:
        """``batch.json``'s entries of the copies (``policy_files``: relative path -> SHA-256;
        ``inputs``, :data:`INPUTS_KEY`) and of the policies imported from elsewhere
        (``policy_sources``: module -> SHA-256); none without them."""
        return {**({POLICY_FILES_KEY: policy_record(self.files)} if self.files else {}),
                **({INPUTS_KEY: policy_record(self.inputs)} if self.inputs else {}),
                **({POLICY_SOURCES_KEY: dict(self.sources)} if self.sources else {})}


def policy_copies(batch: Batch) -> PolicyCopies:
    """What the batch folder keeps of ``batch``'s code and inputs: the policy modules the batch's
    experiments (one per design point) import from their folder and, for a batch of one point
    (replicate, power), the experiment and the plan (:data:`EXPERIMENT_COPY`, :data:`PLAN_COPY`):
    a resume reads them from the folder, wherever it is run and whatever became of the files
    typed, and they import the policy copies again.

    Points whose policies name the same factories import the same modules (a sweep over a policy's
    parameters), so each set of factories is loaded once. A sweep keeps its sweep file and the
    experiment file it names instead (``batch.inputs``, :func:`sweep_inputs`), and the plan.

    Raises
    ------
    PolicyError
        A module that does not import.
    ConfigError
        A policy package named like one of the batch folder's own (:data:`BATCH_FOLDERS`).
    """
    from nudgecli.config_files import dump_toml

    files: dict[str, bytes] = {}
    sources: dict[str, str] = {}
    source: str | None = None
    loaded: set[tuple[str | None, tuple[str, ...]]] = set()
    for config in (point.config for point in batch.points):
        factories = (config.policy_search_path, tuple(spec.factory for spec in policy_specs(config)))
        if factories in loaded:
            continue
        loaded.add(factories)
        files.update(loaded_policy_files(config, BATCH_FOLDERS, "batch"))
        sources.update(outside_policy_sources(config))
        source = source or config.policy_search_path
    plan = dump_toml(batch.plan.model_dump(mode="json", exclude_none=True)).encode("utf-8")
    sources = dict(sorted(sources.items()))
    if batch.kind == "sweep":  # its inputs (none: a Batch made by hand, as a test makes one)
        return PolicyCopies(files, source if files else None,
                            {**batch.inputs, PLAN_COPY: plan} if batch.inputs else {}, sources)
    return PolicyCopies(files, source, {EXPERIMENT_COPY: batch.points[0].config.to_toml().encode("utf-8"),
                                        PLAN_COPY: plan}, sources)


def sweep_inputs(spec: SweepFile, experiment: Path) -> dict[str, bytes]:
    """What a sweep's folder keeps of its inputs besides its plan: its sweep file (``spec``, as
    validated: each parameter a table, in the design's order; :data:`SWEEP_COPY`) naming the kept
    experiment and plan, and the ``experiment`` file it names, byte for byte
    (:data:`EXPERIMENT_COPY`: a sweep's set and parameters apply to it as written)."""
    from nudgecli.config_files import dump_toml

    written = spec.model_dump(mode="json", exclude_none=True)
    sweep = dump_toml({**written, "experiment": EXPERIMENT_COPY, "plan": PLAN_COPY})
    return {SWEEP_COPY: sweep.encode("utf-8"), EXPERIMENT_COPY: experiment.read_bytes()}


def kept_inputs(folder: Path, manifest: Mapping[str, Any] | None = None) -> dict[str, Path]:
    """The experiment and plan ``folder``'s batch keeps (``{"experiment": FOLDER/experiment.toml,
    "plan": FOLDER/plan.toml}``), or a sweep its sweep file (``{"sweep_file": FOLDER/sweep.toml}``,
    which names them), each where its ``batch.json`` records it and it is there; empty otherwise (a
    batch of an older nudge). A resume of them works from any folder (and imports the batch's own
    policy copies): what the command that resumes the batch names. ``manifest``: the ``batch.json``
    its caller read (read here where not given)."""
    old = manifest if manifest is not None else read_manifest(folder / BATCH_MANIFEST)[0]
    recorded = old.get(INPUTS_KEY) if old is not None else None
    if not isinstance(recorded, Mapping):
        return {}
    if SWEEP_COPY in recorded:
        return {"sweep_file": folder / SWEEP_COPY} if (folder / SWEEP_COPY).is_file() else {}
    return {label: folder / name for label, name in (("experiment", EXPERIMENT_COPY), ("plan", PLAN_COPY))
            if name in recorded and (folder / name).is_file()}


def task_part(folder: Path, study: str, participant: int) -> Path:
    """The part file of a participant task."""
    return folder / "tasks" / study / part_name(participant)


def analysis_part(folder: Path, analysis: str) -> Path:
    """The part file of an analysis."""
    return folder / "analyses" / f"{analysis}.json"


def readable_stats(path: Path) -> bool:
    """Whether ``path`` holds an analysis's stats document: a JSON object with a list of
    ``conditions`` and of ``metrics`` (anything else, e.g. a damaged or edited file, is
    recomputed by ``--resume``)."""
    if not path.is_file():
        return False
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(document, dict) and isinstance(document.get("conditions"), list) and \
        isinstance(document.get("metrics"), list) and all(isinstance(m, dict) for m in document["metrics"])


def read_json(path: Path) -> dict[str, Any]:
    return json.loads(path.read_text(encoding="utf-8"))


def read_study_metrics(folder: Path, study: str, participants: int,
                       kept: Mapping[int, pd.DataFrame] | None = None) -> pd.DataFrame:
    """The per-trial metrics of a study's first ``participants``, in participant order.

    ``kept`` holds parts this process has just written, by participant (the frames it wrote,
    equal to what reading them gives); the others are read from their files.
    """
    import pandas as pd

    kept = kept or {}
    frames = [kept.get(i) for i in range(participants)]
    frames = [read_parquet(task_part(folder, study, i)) if f is None else f for i, f in enumerate(frames)]
    return pd.concat(frames, ignore_index=True)


def parquet_bytes(frame: pd.DataFrame) -> bytes:
    """The bytes of ``frame`` as a Parquet file (no index), as
    :func:`~nudgecli.store.write_parquet_atomic` writes it."""
    buffer = io.BytesIO()
    frame.to_parquet(buffer, index=False)
    return buffer.getvalue()


def output_files(folder: Path) -> list[Path]:
    """Every table and figure a batch of any kind writes in ``folder`` (:data:`BATCH_TABLES`,
    :data:`BATCH_FIGURES`), there or not."""
    return ([folder / f"{stem}.csv" for stem in BATCH_TABLES]
            + [folder / FIGURES_DIR / f"{stem}.png" for stem in BATCH_FIGURES])


def remove_outputs(folder: Path) -> None:
    """Remove what a batch of any kind wrote in ``folder``: its parts (``tasks/``, ``analyses/``),
    its tables and figures (:func:`output_files`) and the temporaries of their writers. Other files
    stay, as they do in a replaced run folder: a user's notes, a figure of their own (``figures/``
    goes only where nothing else is left in it).

    Raises
    ------
    WriteError
        A table or figure cannot be removed (names it and the cause).
    """
    for name in ("tasks", "analyses"):
        shutil.rmtree(folder / name, ignore_errors=True)
    remove_temporaries((folder, folder / FIGURES_DIR))  # the batch's lock is held: no live writer owns them
    for path in output_files(folder):
        try:
            path.unlink(missing_ok=True)
        except OSError as exc:
            raise write_error(path, exc) from exc
    with contextlib.suppress(OSError):
        (folder / FIGURES_DIR).rmdir()


def check_inputs_kept(folder: Path, inputs: Iterable[tuple[str, object]], force: bool = False) -> None:
    """Refuse a batch into ``folder`` that would write over, or remove, one of the files it reads.

    The rule of every command (:func:`nudgecli.outputs.check_not_an_input`: no output replaces an
    input) applied before any work to every file a batch writes in its folder or removes there
    when it replaces another batch: ``batch.json``, its record, every table and figure of any
    batch kind (:func:`output_files`), the parts under ``tasks/`` and ``analyses/`` and, with
    ``force``, the experiment and plan the old batch keeps (its ``inputs``, :data:`INPUTS_KEY`:
    replacing it removes them; a resume never writes over them, so it may name them). The copy of
    the people file a batch keeps (``people/<its name>``) is not one of them: a resume may name it
    (:func:`nudgecli.sim.people_file.keep_copy` never writes over it with other bytes).

    Parameters
    ----------
    folder
        The batch folder (``--out``).
    inputs
        ``(how the user gave it, what they gave)``: ``("--people", "p.csv")``; what is not an
        existing file (a preset's name, a loaded plan, ``None``) is skipped.
    force
        ``--force``: the batch replaces the one in ``folder``, and removes its kept inputs.

    Raises
    ------
    WriteError
        An output is (the same file as) an input: names both, and how the input was given.
    """
    from nudgecli.outputs import check_not_an_input, command_inputs, declare_input

    with command_inputs():
        for label, path in inputs:
            if isinstance(path, str | Path):
                declare_input(f"{label} {path}", path)
        parts = [p for name in ("tasks", "analyses") for p in (folder / name).rglob("*")]
        old, _ = read_manifest(folder / BATCH_MANIFEST)  # what a replacement removes of its inputs:
        kept = old.get(INPUTS_KEY) if old is not None and (force or replacing(old)) else None
        removed = [folder / str(name) for name in kept] if isinstance(kept, Mapping) else []
        for target in (folder / BATCH_MANIFEST, folder / PART_RECORD, *output_files(folder), *parts,
                       *removed):
            check_not_an_input(target)



def read_manifest(manifest: Path) -> tuple[dict[str, Any] | None, str | None]:
    """The batch folder's manifest (``batch.json``) and what damages it, if anything.

    Returns
    -------
    tuple
        ``(None, None)`` where there is no manifest; ``(document, None)`` for a JSON object with a
        ``batch`` object (the description a resume compares); ``(None, damage)`` for anything
        else, ``damage`` saying what is wrong (not JSON, not an object, no ``batch`` object).
    """
    if not manifest.is_file():
        return None, None
    try:
        document = json.loads(manifest.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:  # UnicodeDecodeError is a ValueError
        return None, f"not readable as JSON: {exc}"
    if not isinstance(document, dict):
        return None, f"{json_kind(document)}, not a JSON object"
    described = document.get("batch")
    if not isinstance(described, dict):
        shown = "missing" if described is None else \
            f"{json_kind(described)}, not an object"
        return None, f'its "batch" entry, the description of the batch, is {shown}'
    return document, None


def recorded_people(folder: Path, kind: str | None = None) -> tuple[bool, Any]:
    """Whether ``folder``'s ``batch.json`` describes a batch (:func:`read_manifest`: absent,
    damaged or :func:`replacing`, it does not; nor one of another ``kind`` where given), and the
    people file's entry its description records (``None``: a batch of the population's people;
    anything else as read). The one reading of it, for the resume check
    (:func:`nudgecli.sim.people_file.check_same_people`) and the resume command's ``--people``
    (:mod:`nudgecli.api.resuming`): a batch a ``--force`` was removing is no longer there."""
    old, _ = read_manifest(folder / BATCH_MANIFEST)
    if old is None or replacing(old) or kind not in (None, old["batch"].get("kind")):
        return False, None
    return True, old["batch"].get(PEOPLE_KEY)


def _by_point(description: Mapping[str, Any], lift: bool) -> dict[str, Any]:
    """``description`` with its ``points`` list keyed by point (``point 3``), or, with ``lift`` (a
    batch of one point: replicate, power), that point's fields at the top (``participants``)."""
    keyed = {key: value for key, value in description.items() if key != "points"}
    points = description.get("points")
    if not isinstance(points, list):
        return {**keyed, "points": points}
    if lift:
        return {**keyed, **{key: value for key, value in points[0].items() if key != "index"}}
    return {**keyed, **{f"point {point.get('index', i) if isinstance(point, dict) else i}": point
                        for i, point in enumerate(points)}}


#: Settings of a batch's description that a batch of an older nudge did not record (a power batch's
#: ``target``, the power its ``smallest_n.csv`` reads): where ``batch.json`` lacks one, a resume takes
#: the one given now, as it did then, and records it.
LATER_SETTINGS = ("target",)


def batch_differences(recorded: Mapping[str, Any], current: Mapping[str, Any]) -> list[str]:
    """What differs between the batch ``batch.json`` describes and the one asked now, one
    ``key: OLD in batch.json, NEW now`` each (the wording of a run's resume,
    :func:`nudgecli.run_folder_record.experiment_differences`).

    A point's fields are named by point (``point 2.parameters.inference.kappa``), or plainly where
    both batches have one point (``participants``). A point's ``study`` is a digest of its
    experiment (every setting but the participant count), which ``batch.json`` does not hold:
    where it differs, the difference says so. A recorded point without its recordings' digests
    (a batch of an older nudge) has them not compared (:func:`nudgecli.recording_digests.compared`),
    nor one of :data:`LATER_SETTINGS` it lacks.

    Parameters
    ----------
    recorded
        The manifest's ``batch`` description.
    current
        The description of the batch now (:meth:`nudgecli.runs.batch.Batch.describe`).
    """
    current = {key: value for key, value in current.items() if key not in LATER_SETTINGS or key in recorded}
    points = (recorded.get("points"), current.get("points"))
    if isinstance(points[0], list) and isinstance(points[1], list):
        current = {**current, "points": [
            compared(was, point) if isinstance(was, Mapping) and isinstance(point, Mapping) else point
            for was, point in zip(points[0], points[1], strict=False)] + points[1][len(points[0]):]}
    lift = all(isinstance(p, list) and len(p) == 1 and isinstance(p[0], dict) for p in points)
    notes = {"study": "a digest of the experiment's settings: the experiment or a --set differs",
             RECORDINGS_KEY: RECORDINGS_DIFFER.format(what="batch")}
    return [f"{difference} ({notes[key]})" if (key := difference.split(":")[0].split(".")[-1]) in notes
            else difference
            for difference in experiment_differences(_by_point(recorded, lift), _by_point(current, lift),
                                                     BATCH_MANIFEST)]


def check_kept_inputs(folder: Path, recorded: object, inputs: Mapping[str, bytes]) -> None:
    """:func:`nudgecli.runs.batch_trust.check_kept_inputs`: the kept experiment and plan as written."""
    from nudgecli.runs.batch_trust import check_kept_inputs as check  # which builds on this module

    check(folder, recorded, inputs)


def prepare_folder(folder: Path, description: dict[str, Any], resume: bool, force: bool,
                   people: People | None = None, policies: PolicyCopies | None = None) -> str:
    """Make ``folder`` ready for the batch; ``"new"`` or ``"resume"`` (same description required).

    The rule is the run folder's (:func:`nudgecli.store.prepare_mode`); a folder that is not empty
    but holds no batch is written into with ``force``, not cleared. Once the folder is accepted it
    keeps the batch's ``people`` file and its ``policies``' modules, byte for byte
    (:func:`nudgecli.sim.people_file.keep_copy`, :func:`nudgecli.sim.policy_files.keep_policy_copies`;
    a resume puts back a missing copy). A batch of one point keeps its experiment and plan as well
    (``policies.inputs``, :func:`policy_copies`): a resume puts back a lost one and never writes over
    one there (it may be what the resume read). Replacing a batch removes all it wrote
    (:func:`remove_outputs`) and the copies (and inputs) its manifest records; a damaged manifest
    (:func:`read_manifest`) is refused unless ``force``, which replaces its batch.

    Raises
    ------
    RunFolderError
        A link in place of what the batch writes (:data:`BATCH_OWN`) or a person's live sessions (a
        ``nudge study`` folder), both even with ``force``; a batch (neither ``resume`` nor ``force``),
        ``resume`` with ``force``, another batch to resume, a damaged manifest or other files unforced.
    DataError
        A resume whose policy modules differ from those ``batch.json`` records (names the file:
        the batch would mix two policies), before anything is touched.
    RunFolderError
        A policy copy's path holds a file of the person's own
        (:func:`~nudgecli.sim.policy_files.check_copies_placeable`), before anything is touched.
    """
    policies = policies or PolicyCopies()
    refuse_links(folder, BATCH_OWN)  # a linked tasks/ would have --force replace another batch's parts
    record = RunRecord(folder)  # a person's sessions (a nudge study folder): never written into, even forced
    record.refuse_live_sessions(record.read_manifest() if record.is_run() else None, "write the batch")
    record.refuse_other_kind("batch")  # a run's folder: --force would leave the run beside the batch
    manifest = folder / BATCH_MANIFEST
    old, damage = read_manifest(manifest)
    if damage is not None and not force:  # a batch is there, but what it was is lost: only --force helps
        raise RunFolderError(f"{manifest}: damaged ({damage}); which batch the folder holds is unknown, "
                             "so it cannot be resumed: use --force to replace it (its tasks are computed "
                             "again), or choose another --out")
    held = "its batch.json damaged" if damage is not None else \
        None if old is None else f"{old['batch'].get('kind')}, {old.get('status')}"
    # killed before its batch.json, or a --force killed while it removed the old batch: only a start,
    # started afresh (--resume with --force: the rule refuses the pair)
    start = not (resume and force) and \
        (replacing(old) or (held is None and _start_again(folder, people, policies)))
    mode = "replace" if start and old is not None else "new" if start else \
        prepare_mode(folder, held, resume, force, kind="batch")
    copies, inputs = (None, None) if old is None else (old.get(POLICY_FILES_KEY), old.get(INPUTS_KEY))
    if old is not None and mode == "resume":
        from nudgecli.runs.batch_resume import check_same_policies, refuse_another_kind, resume_advice
        from nudgecli.runs.batch_trust import check_plan_not_edited

        refuse_another_kind(folder, old, description)  # first: the rest follows
        check_kept_inputs(folder, inputs, policies.inputs)  # before the settings: one may be what resumes it
        if differences := batch_differences(old["batch"], description):
            check_plan_not_edited(folder, old, policies.inputs, differences)  # else the same advice again
            shown = "; ".join(differences[:8]) + (f"; and {len(differences) - 8} more"
                                                  if len(differences) > 8 else "")
            raise RunFolderError(f"{folder}: holds a different batch ({shown}); resume it with the same "
                                 f"settings{resume_advice(folder, old)}, or use --force")
        check_same_policies(folder, old, policies)
    # before anything is removed: a copy's path holding a file of the person's own stops the batch
    check_copies_placeable(policies.files, folder, copies, "batch")
    if old is not None and mode == "resume":
        # what writers killed mid-write left (the batch's lock is held: no live writer owns them)
        own = [folder / name for name in ("tasks", "analyses", FIGURES_DIR, PEOPLE_DIR)]
        remove_temporaries((folder, *own, *(folder / "tasks").glob("*/")))
        keep_copy(people, folder)
        keep_policy_copies(policies.files, folder)
        # a lost experiment or plan is put back; one there is the batch's (it may be what resumes it)
        keep_policy_copies({n: d for n, d in policies.inputs.items() if not (folder / n).exists()}, folder)
        return "resume"
    check_copies_placeable(policies.inputs, folder, inputs, "batch", "input")
    if mode == "replace":  # every output of the old batch goes, before any work: none outlives it
        _remove_old_batch(folder, old, copies, inputs)
    (folder / PART_RECORD).unlink(missing_ok=True)  # a new batch: no line left there vouches for a part
    folder.mkdir(parents=True, exist_ok=True)
    keep_copy(people, folder)
    keep_policy_copies({**policies.files, **policies.inputs}, folder)
    return "new"


#: ``batch.json``'s status while ``--force`` removes the batch it describes (:func:`replacing`).
REPLACING = "replacing"


def replacing(old: Mapping[str, Any] | None) -> bool:
    """Whether ``old`` (a folder's ``batch.json``) records a batch that a ``--force`` was removing
    when it was killed: the folder holds only a start, whatever is left of the old batch's outputs
    (any command into it finishes their removal and starts its batch afresh)."""
    return old is not None and old.get("status") == REPLACING


def _remove_old_batch(folder: Path, old: Mapping[str, Any] | None, copies: object, inputs: object) -> None:
    """Remove the batch that ``--force`` replaces in ``folder`` (``old``: its ``batch.json``, None
    where damaged; ``copies`` and ``inputs``: the policy copies and inputs it records): its outputs
    (:func:`remove_outputs`), its people copy, policy copies, inputs, part record and ``batch.json``.

    ``batch.json`` is marked :data:`REPLACING` first and goes last: a kill in between leaves a folder
    that reads as a start (:func:`replacing`), never an old table beside a record that says
    ``complete``, nor a batch whose inputs are gone to be resumed."""
    manifest = folder / BATCH_MANIFEST
    if old is not None and not replacing(old):
        write_json_atomic(manifest, {**old, "status": REPLACING})
    remove_outputs(folder)
    # of people/, the old batch's copy of its people file goes; other files there stay
    described = None if old is None else old.get("batch")
    remove_copy(folder, described.get(PEOPLE_KEY) if isinstance(described, dict) else None)
    remove_policy_copies(folder, copies)
    remove_policy_copies(folder, inputs)
    (folder / PART_RECORD).unlink(missing_ok=True)  # before batch.json: what is left is only a start
    manifest.unlink(missing_ok=True)


def _start_files(folder: Path, people: People | None, policies: PolicyCopies) -> dict[str, bytes]:
    """What :func:`prepare_folder` writes of a new batch before its ``batch.json``, by path in
    ``folder``: its people copy, its policy copies and its kept inputs."""
    from nudgecli.sim.people_file import copy_path

    files = {**policies.files, **policies.inputs}
    if people is not None and people.data:
        files[copy_path(folder, people.record()).relative_to(folder).as_posix()] = people.data
    return files


def _start_again(folder: Path, people: People | None, policies: PolicyCopies) -> bool:
    """Whether ``folder`` holds :func:`only_a_start`; if so, its writers' temporaries are removed (the
    batch's lock is held: no live writer owns them) and the batch starts afresh."""
    if not only_a_start(folder, people, policies):
        return False
    remove_temporaries((folder, *{(folder / name).parent for name in _start_files(folder, people, policies)}))
    return True


def only_a_start(folder: Path, people: People | None, policies: PolicyCopies) -> bool:
    """Whether ``folder`` holds only the start of this very batch, left by a batch killed before it
    wrote its ``batch.json`` (a new one, or a ``--force`` replacing another whose old batch was
    already removed): its lock, some of :func:`_start_files` each with this batch's bytes, and the
    temporaries of their writers (``.<name>.<random>.tmp``). Such a folder starts the batch afresh,
    on ``--resume`` or the same command, as a run folder killed before its manifest does
    (:meth:`nudgecli.store.RunRecord._only_a_start`); a file of the person's own (another name, or
    other bytes at a copy's path) keeps the folder refused."""
    if not folder.is_dir():
        return False
    files = _start_files(folder, people, policies)
    folders = {parent for name in files for parent in (folder / name).parents if folder in parent.parents}
    entries = [p for p in folder.rglob("*") if p.name != LOCK or p.parent != folder]
    for path in entries:
        name = path.relative_to(folder).as_posix()
        temporary = path.name.startswith(".") and path.name.endswith(".tmp") and \
            (path.parent == folder or path.parent in folders)
        if path.is_dir() and not path.is_symlink():
            if path not in folders:
                return False
        elif not (temporary and path.is_file()) and not (
                name in files and path.is_file() and path.read_bytes() == files[name]):
            return False
    return bool(entries)
