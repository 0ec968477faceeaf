"""A resume into a batch folder that cannot be the batch asked for is one error line saying why, and
touches nothing: a damaged people entry in ``batch.json``, and a folder holding a batch of another
kind (named first, before any setting the two kinds describe differently)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from batch_helpers import REPLICATE, a_finished_replicate
from cli_helpers import files_of, nudge, one_error_line
from people_helpers import PEOPLE_BYTES


@pytest.fixture(scope="module")
def finished(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished replicate batch of the smoke experiment (2 studies of 2 participants)."""
    return a_finished_replicate(tmp_path_factory.mktemp("refusals") / "B")


def refused_untouched(args: tuple[str, ...], folder: Path) -> str:
    before = files_of(folder)
    refused = nudge(*args)
    assert refused.exit_code == 1, refused.output
    assert "Traceback" not in refused.output
    line = one_error_line(refused.output)
    assert files_of(folder) == before
    return line


@pytest.mark.parametrize("entry", [5, {"name": 5}, "people.csv"])
def test_a_damaged_people_entry_is_named(finished: Path, tmp_path: Path, entry: object) -> None:
    batch = Path(shutil.copytree(finished, tmp_path / "B"))
    manifest = json.loads((batch / "batch.json").read_text())
    manifest["batch"]["people"] = entry
    (batch / "batch.json").write_text(json.dumps(manifest))
    line = refused_untouched((*REPLICATE, "--out", str(batch), "--resume"), batch)
    assert line.startswith(f"Error: {batch / 'batch.json'}: its 'batch.people' entry"), line
    assert "damaged" in line and "--force" in line, line


def test_replicate_resume_into_a_power_batch_names_the_kind(tmp_path: Path) -> None:
    people = tmp_path / "p.csv"
    people.write_bytes(PEOPLE_BYTES)
    batch = tmp_path / "P"
    made = nudge("power", "smoke", "--participants", "2,3", "-R", "1", "--people", str(people),
                  "--out", str(batch))
    assert made.exit_code == 0, made.output
    line = refused_untouched((*REPLICATE, "--out", str(batch), "--resume"), batch)
    assert line.startswith(f"Error: {batch}: holds a power batch, not a replicate batch"), line
    assert "was simulated with" not in line, line  # not the people check (its command names --people)
    assert f"resume it with `nudge power {batch / 'experiment.toml'} " in line, line
