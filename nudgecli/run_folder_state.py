"""How a run folder stands after its writer stopped: only the start of a run (killed before its
manifest), or a run whose manifest says running (still running, or killed: whether a live process
holds its lock). Read by :class:`nudgecli.run_folder_record.RunRecord` and
:class:`nudgecli.store.RunFolder`."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from nudgecli.run_folder_names import CONFIG, LAYOUTS, LOCK, PART_KINDS, PEOPLE_DIR

#: The folders a run makes before its manifest, and ``--force`` empties: empty, part of a start.
_EMPTIED = (*PART_KINDS, "calibration")


def only_a_start(folder: Path, config_text: str | None = None) -> bool:
    """Whether ``folder`` holds only the start of a run (of the one whose config.toml is
    ``config_text``; ``None``: any), left by a run killed before it wrote its manifest: its
    config.toml, perhaps its layouts, temporaries, and empty part and calibration folders (a
    ``--force`` killed after clearing the old run leaves those); never a folder holding a file of
    the person's own."""
    config_path = folder / CONFIG
    if not config_path.is_file():
        return False
    if config_text is not None and config_path.read_text(encoding="utf-8") != config_text:
        return False
    return all(p.name in (CONFIG, LAYOUTS, LOCK, PEOPLE_DIR) or p.name.endswith(".tmp")
               or (p.name in _EMPTIED and p.is_dir() and not any(p.iterdir())) for p in folder.iterdir())


def run_state(folder: Path, manifest: Mapping[str, Any]) -> str:
    """How an unfinished run stands, for a message: ``is running`` while another live process
    holds its lock (:func:`nudgecli.locks.run_lock`), ``was interrupted`` where its manifest says
    running but none does (it was killed), else ``is <status>``."""
    state = str(manifest.get("status", "not finished"))
    if state != "running":
        return f"is {state}"
    from nudgecli.locks import held_by_another_process  # locks builds on store, which builds on this module

    # this command's own lock (it reads the run) is no other writer's
    return "is running" if held_by_another_process(folder) else "was interrupted"
