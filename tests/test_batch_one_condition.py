"""A batch of an experiment whose studies hold a single condition (the CIAA world's
``no_assistance``) is refused before anything is simulated: every table of ``replicate``, ``power``
and ``sweep`` is of pairs of conditions. It was simulated to its end, then crashed making the tables
(a KeyError) and left a batch recorded as complete."""

from __future__ import annotations

from pathlib import Path

import pytest
from batch_helpers import an_old_batch
from cli_helpers import files_of, nudge, one_error_line
from people_helpers import PEOPLE_BYTES

from nudgecli.errors import ConfigError

CIAA = Path("experiments/ciaa-teleop.toml")
SWEEP = """experiment = "{experiment}"
replications = 2

[parameters]
"world.snap_tolerance" = {{ values = [0.1, 0.2] }}
"""


def _sweep_file(folder: Path, experiment: str = "ciaa-teleop") -> Path:
    path = folder / "one-condition.toml"
    path.write_text(SWEEP.format(experiment=experiment), encoding="utf-8")
    return path


def _commands(folder: Path, experiment: str = "ciaa-teleop") -> dict[str, tuple[str, ...]]:
    return {"replicate": ("replicate", experiment, "-R", "2", "--participants", "2"),
            "power": ("power", experiment, "--participants", "2,3", "-R", "2"),
            "sweep": ("sweep", str(_sweep_file(folder, experiment)))}


def _refused(args: tuple[str | Path, ...], kind: str) -> str:
    result = nudge(*args)
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    assert 'world.ciaa_conditions = ["no_assistance"]' in line, line
    assert f"nudge {kind} has no pair of conditions" in line, line
    assert "two or more conditions" in line and "nothing was simulated" in line, line
    return line


@pytest.mark.parametrize("kind", ["replicate", "power", "sweep"])
def test_a_batch_of_one_condition_is_refused_before_a_folder_is_made(tmp_path: Path, kind: str) -> None:
    out = tmp_path / "batch"
    line = _refused((*_commands(tmp_path)[kind], "--out", out), kind)
    assert "ciaa-teleop.toml" in line, line
    assert not out.exists()


@pytest.mark.parametrize("kind", ["replicate", "power", "sweep"])
def test_a_renamed_copy_of_the_experiment_is_refused_naming_the_copy(tmp_path: Path, kind: str) -> None:
    copy = tmp_path / "mine.toml"
    copy.write_text(CIAA.read_text(encoding="utf-8"), encoding="utf-8")
    out = tmp_path / "batch"
    line = _refused((*_commands(tmp_path, str(copy))[kind], "--out", out), kind)
    assert str(copy) in line, line
    assert not out.exists()


@pytest.mark.parametrize("kind", ["replicate", "power"])
def test_a_batch_of_one_condition_with_people_is_refused(tmp_path: Path, kind: str) -> None:
    people = tmp_path / "people.csv"
    people.write_bytes(PEOPLE_BYTES)
    out = tmp_path / "batch"
    _refused((*_commands(tmp_path)[kind], "--people", people, "--out", out), kind)
    assert not out.exists()


@pytest.mark.parametrize("kind", ["replicate", "power", "sweep"])
def test_a_refused_batch_leaves_the_batch_it_would_replace_untouched(tmp_path: Path, kind: str) -> None:
    out = tmp_path / "batch"
    out.mkdir()
    an_old_batch(out, kind)
    before = files_of(out)
    _refused((*_commands(tmp_path)[kind], "--out", out, "--force"), kind)
    assert files_of(out) == before


def test_the_python_api_raises_the_same_refusal(tmp_path: Path) -> None:
    import nudgecli

    with pytest.raises(ConfigError, match="has no pair of conditions"):
        nudgecli.replicate("ciaa-teleop", 2, participants=2)
    with pytest.raises(ConfigError, match="has no pair of conditions"):
        nudgecli.power("ciaa-teleop", [2, 3], 2, out=tmp_path / "power")
    with pytest.raises(ConfigError, match="has no pair of conditions"):
        nudgecli.sweep(_sweep_file(tmp_path), out=tmp_path / "sweep")
    assert not (tmp_path / "power").exists() and not (tmp_path / "sweep").exists()


def test_a_batch_of_two_conditions_is_not_refused() -> None:
    from nudgecli.config import load_experiment
    from nudgecli.runs.batch_kinds import check_pairs

    check_pairs(load_experiment("smoke"), "replicate", "experiments/smoke.toml")
