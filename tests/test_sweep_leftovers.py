"""Sweep leftovers: a Morris design of one trajectory is refused (SALib's sigma over one trajectory
is NaN), as a Sobol design of one base sample is; a sweep point whose studies hold one participant
is refused before any work, as ``replicate`` and ``power`` refuse one; the Python API says that
``resume`` and ``force`` together are refused."""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import Any

import pytest

import nudgecli.api as api
from nudgecli.errors import ConfigError
from nudgecli.runs import batch_kinds
from nudgecli.runs.sweep import Design, load_sweep
from nudgecli.runs.sweep_file import MIN_MORRIS_TRAJECTORIES


def write_sweep(tmp_path: Path, fixed: str, design: str, parameters: str) -> Path:
    path = tmp_path / "sweep.toml"
    path.write_text(f'experiment = "smoke"\nreplications = 1\nset = [{fixed}]\n[design]\n{design}\n'
                    f"[parameters]\n{parameters}\n", encoding="utf-8")
    return path


def test_one_morris_trajectory_is_one_error_line(tmp_path: Path) -> None:
    path = write_sweep(tmp_path, '"study.participants=2"', 'method = "morris"\nsamples = 1',
                       '"inference.kappa" = { low = 0.6, high = 0.7 }')
    with pytest.raises(ConfigError) as raised:
        load_sweep(str(path))
    message = str(raised.value)
    assert "\n" not in message and "design.samples" in message and "at least 2 trajectories" in message
    assert Design(method="morris", samples=MIN_MORRIS_TRAJECTORIES).samples == 2


def refuse_any_work(monkeypatch: pytest.MonkeyPatch) -> None:
    def no_batch(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("the batch ran: the point of one participant was not refused before it")

    monkeypatch.setattr(batch_kinds, "run_batch", no_batch)


@pytest.mark.parametrize(("fixed", "parameters", "point"), [
    ('"study.participants=1"', '"inference.kappa" = [0.6, 0.7]', "design point 0 (inference.kappa=0.6)"),
    ("", '"study.participants" = [2, 1]', "design point 1 (study.participants=1)"),
])
def test_a_sweep_point_of_one_participant_is_refused_naming_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fixed: str, parameters: str, point: str) -> None:
    refuse_any_work(monkeypatch)
    path = write_sweep(tmp_path, fixed, 'method = "grid"', parameters)
    with pytest.raises(ConfigError) as raised:
        batch_kinds.sweep(str(path), tmp_path / "out")
    message = str(raised.value)
    assert "\n" not in message and point in message and "study.participants = 1" in message
    assert "at least 2" in message and not (tmp_path / "out").exists()


@pytest.mark.parametrize("function", [api.simulate, api.replicate])
def test_the_api_says_resume_with_force_is_refused(function: Any) -> None:
    doc = inspect.getdoc(function) or ""
    said = doc[doc.index("resume, force"):].split("\n\n")[0]
    assert "refused" in said, said
