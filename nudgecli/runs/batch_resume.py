"""The command that resumes a batch folder, as its refusals name it and as the hint after Ctrl-C
names it: one owner of its wording for ``replicate``, ``power`` and ``sweep`` alike (a refused
``--resume`` names the full command that would resume the batch, not ``nudge KIND ... --resume``).

A refusal builds it from the folder's ``batch.json`` (:func:`batch_resume_command`); the hint after
Ctrl-C from the command as typed (:func:`typed_resume_command`), its ``batch.json`` perhaps not
written yet. Either names the inputs the folder keeps in place of those typed
(:func:`~nudgecli.runs.batch_folder.kept_inputs`) and is printed by
:func:`~nudgecli.store.resume_command`."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from nudgecli.config_files import read_toml
from nudgecli.errors import ConfigError, DataError, RunFolderError
from nudgecli.run_folder_state import resume_scheduler
from nudgecli.runs.batch_folder import BATCH_MANIFEST, PolicyCopies, kept_inputs, read_manifest
from nudgecli.sim.people_file import MANIFEST_KEY as PEOPLE_KEY
from nudgecli.sim.people_file import resume_people
from nudgecli.sim.policy_files import MANIFEST_KEY as POLICY_FILES_KEY
from nudgecli.sim.policy_files import SOURCES_KEY as POLICY_SOURCES_KEY
from nudgecli.sim.policy_files import check_same_policy_files, check_same_policy_sources
from nudgecli.store import resume_command


def batch_resume_command(folder: Path, manifest: Mapping[str, Any], missing: str | None = None) -> str | None:
    """The command that resumes the batch in ``folder`` (``manifest``: its ``batch.json``, whose
    ``batch`` describes it) from the inputs the
    folder keeps (:func:`~nudgecli.runs.batch_folder.kept_inputs`), so it works from any folder and
    imports the batch's own policy copies:

    - a sweep: ``nudge sweep FOLDER/sweep.toml --out FOLDER --resume``, with ``--replications``
      and ``--seed`` where the description holds others than the sweep file (typed then);
    - a replicate or power batch: ``nudge replicate FOLDER/experiment.toml --replications R --seed S
      --participants N --plan FOLDER/plan.toml --out FOLDER --resume`` (power: its counts and
      ``--target``), with ``--people`` naming the folder's copy of its people file.

    Either names ``--scheduler ADDRESS`` where the batch's last run was on a dask scheduler
    (:func:`~nudgecli.run_folder_state.resume_scheduler`: ``batch.json`` records no address).

    ``None`` for a batch of an older nudge (no inputs kept: its ``--set`` values are lost), or one
    whose experiment or sweep file copy is gone, unless ``missing`` names the word that stands for
    it (:func:`resume_advice`).
    """
    recorded = manifest["batch"]
    kept, kind = kept_inputs(folder, manifest), recorded.get("kind")
    if kind == "sweep" and ("sweep_file" in kept or missing):
        try:
            written = read_toml(kept["sweep_file"])
        except (KeyError, ConfigError):  # unreadable: name both settings
            written = {}
        options = [word for key in ("replications", "seed")
                   if key in recorded and recorded[key] != written.get(key)
                   for word in (f"--{key}", str(recorded[key]))]
        options += ["--scheduler", scheduler] if (scheduler := resume_scheduler(manifest)) else []
        return resume_command(["sweep", str(kept.get("sweep_file", missing))], folder, options)
    if kind not in ("replicate", "power") or ("experiment" not in kept and not missing):
        return None
    points = recorded.get("points")
    counts = points[0].get("participants", []) if isinstance(points, list) and points and \
        isinstance(points[0], Mapping) else []
    options = [word for key in ("replications", "seed") if key in recorded
               for word in (f"--{key}", str(recorded[key]))]
    options += ["--participants", ",".join(map(str, counts))] if counts else []
    options += ["--plan", str(kept["plan"])] if "plan" in kept else []
    options += ["--target", str(recorded["target"])] if kind == "power" and "target" in recorded else []
    people = recorded.get(PEOPLE_KEY)
    named = resume_people(folder, people, str(people.get("file"))) if isinstance(people, dict) else None
    options += ["--people", named] if named else []
    options += ["--scheduler", scheduler] if (scheduler := resume_scheduler(manifest)) else []
    return resume_command([str(kind), str(kept.get("experiment", missing))], folder, options)


def typed_resume_command(folder: Path, command: str, arguments: Sequence[tuple[str, str]],
                         options: Sequence[tuple[str, Sequence[str]]]) -> str:
    """The command that resumes the batch ``command`` (``replicate``, ``power``, ``sweep``) interrupted
    while writing ``folder``, from the command as typed: its ``arguments`` (name, value), the
    ``options`` given on the command line (name, their words), ``--out folder`` and ``--resume``
    (``--out``, ``--resume`` and ``--force`` left out: ``--force`` would delete what was finished).
    Where the folder keeps its inputs (:func:`~nudgecli.runs.batch_folder.kept_inputs`: a replicate
    or power batch's experiment and plan, a sweep's sweep file), it names those instead, and no
    ``--plan`` or ``--set`` typed (the kept experiment is the resolved one): they import the batch's
    own policy copies, so the command works from any folder, the inputs moved or gone."""
    kept = {name: str(path) for name, path in kept_inputs(folder).items()}
    words = [kept.get(name, value) for name, value in arguments]
    words += ["--plan", kept["plan"]] if "plan" in kept else []
    for name, given in options:
        if name not in ("out", "resume", "force") and not (kept and name in ("plan", "overrides")):
            words += given
    return resume_command([command, *words], folder)


def resume_advice(folder: Path, manifest: Mapping[str, Any]) -> str:
    """`` (`nudge KIND ... --out FOLDER --resume`)``: :func:`batch_resume_command` as a refusal
    names it after its fix. Where the folder's copy of the experiment (a sweep's file) is gone, the
    command names ``EXPERIMENT`` (``SWEEP_FILE``) in its place and says so; empty for a batch of
    another kind."""
    if (command := batch_resume_command(folder, manifest)) is not None:
        return f" (`{command}`)"
    word = "SWEEP_FILE" if manifest["batch"].get("kind") == "sweep" else "EXPERIMENT"
    if (command := batch_resume_command(folder, manifest, missing=word)) is None:
        return ""
    return f" (`{command}`, {word} the file it ran: the folder keeps no copy of it)"


def with_resume_command(message: str, folder: Path, manifest: Mapping[str, Any] | None = None) -> str:
    """``message`` (a refusal of another module's, whose fix is to resume once its cause is put
    right) and ``; the command that resumes the batch: `...```: :func:`batch_resume_command` of the
    batch ``folder``'s ``batch.json`` describes (``manifest``: as its caller read it; read here where
    not given), where there is one."""
    old = manifest if manifest is not None else read_manifest(folder / BATCH_MANIFEST)[0]
    command = None if old is None else batch_resume_command(folder, old)
    return message if command is None else f"{message}; the command that resumes the batch: `{command}`"


def refuse_another_kind(folder: Path, old: Mapping[str, Any], description: Mapping[str, Any]) -> None:
    """Refuse to resume the batch in ``folder`` (``old``: its ``batch.json``) as a batch of another
    kind than it is, naming the command that resumes it (:func:`batch_resume_command`)."""
    if (was := old["batch"].get("kind")) != description.get("kind"):
        command = batch_resume_command(folder, old) or f"nudge {was} ... --resume"
        raise RunFolderError(f"{folder}: holds a {was} batch, not a {description.get('kind')} batch; "
                             f"resume it with `{command}`, or use --force to replace it")


def check_same_policies(folder: Path, old: Mapping[str, Any], policies: PolicyCopies) -> None:
    """Refuse to resume the batch in ``folder`` (its ``batch.json``, ``old``) with other policy code
    than it was simulated with: its copies' modules
    (:func:`~nudgecli.sim.policy_files.check_same_policy_files`) and the policies imported from
    elsewhere (:func:`~nudgecli.sim.policy_files.check_same_policy_sources`), as a run's resume."""
    try:
        check_same_policy_files(old.get(POLICY_FILES_KEY), policies.files, policies.source, folder, "batch")
        check_same_policy_sources(old.get(POLICY_SOURCES_KEY), policies.sources, folder, "batch")
    except DataError as exc:  # named with the command that resumes the batch once the module is back
        raise DataError(with_resume_command(str(exc), folder, old)) from None


__all__ = ["batch_resume_command", "check_same_policies", "refuse_another_kind", "resume_advice",
           "typed_resume_command", "with_resume_command"]
