"""``twins_of_sources`` reads a run folder's experiment once (with its cells) and builds the cells'
arrays once (the habits measured and the reactions' releases read from the same arrays)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from nudgecli.report import habit_cells, habits, twin_sources


def _counted(monkeypatch: pytest.MonkeyPatch, name: str, *modules: Any) -> list[int]:
    """Count the calls of ``name`` as each of ``modules`` calls it."""
    calls: list[int] = []
    original = getattr(modules[0], name)

    def counting(*args: Any, **kwargs: Any) -> Any:
        calls.append(1)
        return original(*args, **kwargs)

    for module in modules:
        monkeypatch.setattr(module, name, counting)
    return calls


def test_a_run_folders_experiment_and_cell_arrays_are_built_once(analysed_smoke_run: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    experiments = _counted(monkeypatch, "run_experiment", habit_cells, twin_sources)
    arrays = _counted(monkeypatch, "cell_arrays", habits, twin_sources)
    assert len(twin_sources.twins_of_sources([analysed_smoke_run])) == 2  # its two participants
    assert (len(experiments), len(arrays)) == (1, 1)
