"""A Sobol sweep's ``samples``: one that is no power of 2 is told as one Note (scipy's raw
UserWarning, with its source line, leaked before), and fewer than 2 is refused (SALib bootstraps the
base samples for its intervals, and one sample gave every index a conf of 0)."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest
from batch_helpers import notes_a_sweep_tells

from nudgecli.errors import ConfigError
from nudgecli.runs.sweep import Design, design_notes, load_sweep

SWEEP = ('experiment = "smoke"\nreplications = 1\nset = ["study.participants=2"]\n'
         '[design]\nmethod = "sobol"\nsamples = {samples}\n[parameters]\n'
         '"inference.kappa" = {{ low = 0.6, high = 0.7 }}\n')


def sweep_file(tmp_path: Path, samples: int) -> Path:
    path = tmp_path / "sweep.toml"
    path.write_text(SWEEP.format(samples=samples))
    return path


def test_samples_not_a_power_of_2_is_one_note_and_no_warning(tmp_path: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # scipy's warning would fail the load
        loaded = load_sweep(str(sweep_file(tmp_path, 6)))
    assert loaded.notes == ("design.samples = 6: a Sobol design is balanced only for a power of 2 base "
                            "samples; use 4 or 8",)
    assert len(loaded.points) == 6 * (1 + 2)


def test_the_note_goes_to_the_batch_which_tells_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    assert notes_a_sweep_tells(sweep_file(tmp_path, 3), tmp_path / "out", monkeypatch) == (
        "design.samples = 3: a Sobol design is balanced only for a power of 2 base samples; use 2 or 4",)


def test_a_power_of_2_or_another_method_has_no_note() -> None:
    assert design_notes(Design(method="sobol", samples=8)) == ()
    assert design_notes(Design(method="morris", samples=6)) == ()
    assert design_notes(Design(method="grid", samples=3)) == ()


def test_one_sobol_sample_is_one_error_line(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as raised:
        load_sweep(str(sweep_file(tmp_path, 1)))
    message = str(raised.value)
    assert "\n" not in message and "design.samples" in message and "at least 2" in message
    assert Design(method="morris", samples=2).samples == 2  # Morris: two trajectories are a design
