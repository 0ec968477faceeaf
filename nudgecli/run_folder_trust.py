"""Whether a run folder's manifest and ``config.toml`` agree with each other before a command is
advised or a resume trusts them: a manifest copied in from another run, a manifest whose ``seed``
differs from the seed its own experiment records, a ``config.toml`` damaged or edited since.

:class:`nudgecli.run_folder_record.RunRecord` calls these; they read and never write.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nudgecli.config import ExperimentConfig, experiment_from_toml
from nudgecli.errors import NudgeError, RunFolderError
from nudgecli.run_folder_config import experiment_differences
from nudgecli.run_folder_names import CONFIG, MANIFEST

if TYPE_CHECKING:  # the record builds on this module
    from nudgecli.run_folder_record import RunRecord


def parsed_config(folder: Path) -> ExperimentConfig | None:
    """The experiment in ``folder/config.toml``, or ``None`` where it is missing or does not parse."""
    path = folder / CONFIG
    try:
        return experiment_from_toml(path.read_text(encoding="utf-8"), str(path))
    except (NudgeError, OSError, ValueError):
        return None


def own_config(folder: Path, manifest: Mapping[str, Any]) -> Path | None:
    """``folder/config.toml`` where a command may name it for the run: it parses and holds the
    experiment the manifest records (a manifest of an older nudge records none: it parses); ``None``
    where it is missing, damaged or edited (a resume naming it would fail, or be refused)."""
    on_disk = parsed_config(folder)
    if on_disk is None:
        return None
    recorded = manifest.get("config")
    if isinstance(recorded, Mapping) and experiment_differences(recorded, on_disk.model_dump(mode="json")):
        return None
    return folder / CONFIG


def advised_experiment(folder: Path, manifest: Mapping[str, Any] | None) -> str:
    """The experiment a command advised for the run names: its ``config.toml`` (:func:`own_config`),
    else the experiment the manifest names (a resume writes ``config.toml`` again from the manifest),
    else ``EXPERIMENT``."""
    if manifest is None:
        return str(folder / CONFIG) if parsed_config(folder) is not None else "EXPERIMENT"
    if (path := own_config(folder, manifest)) is not None:
        return str(path)
    return str(manifest.get("experiment") or "EXPERIMENT")


def _own_seed(experiment: object) -> int | None:
    """The seed of the experiment a manifest names, as it stands without ``--seed`` (``None`` where it
    cannot be read: a file moved or gone)."""
    from nudgecli.config import load_experiment

    if not isinstance(experiment, str):
        return None
    try:
        return load_experiment(experiment).experiment.seed
    except (NudgeError, OSError, ValueError):
        return None


def differing_seeds(manifest: Mapping[str, Any]) -> tuple[int, int] | None:
    """``(seed, config.experiment.seed)`` of a manifest where the two differ, ``None`` where they agree.

    This nudge records the seed used in both; they differ where the manifest was edited by hand, or in
    a run of an older nudge made with ``--set experiment.seed=A --seed B`` (it recorded ``A`` in the
    experiment, ``B`` as the seed its parts were made with). Only a resume needs the seed: the parts of
    a complete run are vouched for by their SHA-256. A run made before ``config.toml`` recorded its
    ``--seed`` without ``--set experiment.seed`` (its experiment holds the seed of the experiment the
    manifest names) is not one of these, nor one whose experiment can no longer be read to tell."""
    recorded, seed = manifest.get("config"), manifest.get("seed")
    if not isinstance(recorded, Mapping) or not isinstance(recorded.get("experiment"), Mapping):
        return None
    experiment_seed = recorded["experiment"].get("seed")
    if not isinstance(seed, int) or not isinstance(experiment_seed, int) or seed == experiment_seed:
        return None
    own = _own_seed(manifest.get("experiment"))
    if own is None or own == experiment_seed:  # a run from before config.toml recorded its --seed
        return None
    return seed, experiment_seed


def _drawn_agreement(config: ExperimentConfig, index: int, row: Mapping[str, Any],
                     seeds: tuple[int, int]) -> list[int]:
    """Of ``seeds``, those whose draw of participant ``index`` (the population draw, no simulation)
    agrees with ``row`` (its participants part) in a value the two seeds draw differently (a value
    a twin or a physiology log replaced agrees with neither)."""
    from nudgecli.rng import generator, seed_key
    from nudgecli.sim.participants import draw_participant

    drawn = [draw_participant(config.population, index, generator(seed, "participant", index, "physiology"),
                              key=seed_key("participant", index)).to_record() for seed in seeds]
    telling = [name for name, value in drawn[0].items() if value != drawn[1].get(name)]
    return [seed for seed, record in zip(seeds, drawn, strict=True)
            if any(record[name] == row.get(name) for name in telling)]


def parts_seed(record: RunRecord, manifest: Mapping[str, Any], seeds: tuple[int, int]) -> int | None:
    """Which of ``seeds`` the run's parts were made with, told by the first participant whose
    participants part survives with the SHA-256 the manifest records; ``None`` where none survives,
    or the draws of neither (or both) agree with it."""
    import hashlib

    from nudgecli.parquet_reader import read_parquet

    try:
        config = ExperimentConfig.model_validate(manifest.get("config"))
        sums = record.recorded_checksums(manifest)
    except (NudgeError, ValueError):
        return None
    for index, kinds in sorted(sums.items()):
        try:
            data = record.part_path("participants", index).read_bytes()
            if hashlib.sha256(data).hexdigest() != kinds.get("participants"):
                continue  # changed since written: it vouches for nothing
            row = read_parquet(data).to_dict(orient="records")[0]
        except Exception:  # gone, or unreadable (pyarrow raises several types): the next one
            continue
        agreeing = _drawn_agreement(config, index, row, seeds)
        return agreeing[0] if len(agreeing) == 1 else None
    return None


def differing_seeds_error(record: RunRecord, manifest: Mapping[str, Any], lead: str,
                          resume_seed: int | None = None) -> RunFolderError | None:
    """The refusal to resume (or to advise a resume of) the run of ``record`` whose manifest's two
    seeds differ (:func:`differing_seeds`), ``None`` where they agree, or where ``resume_seed`` is the
    manifest's seed and the parts were made with it (:func:`parts_seed`). ``lead`` says what was
    refused. The manifest's seed is the one an older nudge's run made its parts with; a resume with it
    is printed only where a surviving participants part was drawn with it, as a hand-edited manifest's
    parts were not (a resume would simulate participants of another seed beside them). Neither seed is
    set back (either would corrupt one of the two kinds of run)."""
    if (seeds := differing_seeds(manifest)) is None:
        return None
    seed, experiment_seed = seeds
    made = parts_seed(record, manifest, seeds)
    if made == seed and resume_seed == seed:
        return None
    told = (f"{record.manifest_path} records seed {seed} but config.experiment.seed = {experiment_seed} "
            "(the manifest was edited by hand, or the run was made by an older nudge with --set "
            "experiment.seed and --seed); nothing was resumed; put back the run's own "
            f"{MANIFEST} from a copy")
    if made != seed:
        why = "no participants part survives to tell which seed its parts were made with" if made is None \
            else f"its participants parts were not made with seed {seed}, so no resume can finish it"
        return RunFolderError(f"{lead}: {told} ({why})")
    return RunFolderError(f"{lead}: {told}, or, for such an older run, resume with the seed its parts were "
                          f"made with (--seed {seed}): `{record.resume_command(manifest)}`")


def other_run_error(record: RunRecord, manifest: Mapping[str, Any]) -> RunFolderError | None:
    """The refusal of a manifest that is another run's (copied over this one's): ``config.toml`` holds
    another experiment or seed than it records, and no part on disk has the SHA-256 it records (an
    edited config.toml beside matching parts is ``RunRecord._edited_config_hint``'s); ``None`` otherwise."""
    from nudgecli.run_folder_record import file_sha256

    recorded = manifest.get("config")
    on_disk = parsed_config(record.path) if isinstance(recorded, Mapping) else None
    if on_disk is None or not isinstance(recorded, Mapping):
        return None
    differences = experiment_differences(recorded, on_disk.model_dump(mode="json"))
    sums = record.recorded_checksums(manifest) if differences else {}
    parts = [(record.part_path(kind, index), digest) for index, kinds in sums.items()
             for kind, digest in kinds.items() if record.part_path(kind, index).is_file()]
    if not parts or any(file_sha256(part) == digest for part, digest in parts):
        return None
    shown = "; ".join(differences[:3]).replace(" now", f" in {CONFIG}")
    return RunFolderError(f"{record.manifest_path} is not this run's: {CONFIG} differs from the experiment "
                          f"it records ({shown}) and none of the {len(parts)} part(s) has the SHA-256 it "
                          f"records (copied in from another run?); put back the run's own {MANIFEST} "
                          "from a copy (a --resume would simulate every part again as the other run's)")
