"""A run's or a batch's people file travels with it: the folder keeps an exact copy of the
``--people`` file (``people/<its name>``), the resume command a damaged run prints names that copy
by the folder's path as typed (so it works from any folder), a resume with the copy passes the
people check and one with an edited copy is refused; a batch resumed with its copy gives the
tables of an uninterrupted one, byte for byte."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import pytest
from cli_helpers import one_error_line
from click.testing import CliRunner
from people_helpers import PEOPLE_BYTES, people_typed_here

from nudgecli.cli import main
from nudgecli.sim.people_file import People, keep_copy, read_people

NAME = "my twins.csv"  # a space: the printed command must quote it
SIMULATE = ("simulate", "smoke", "--participants", "2", "--seed", "4")
REPLICATE = ("replicate", "smoke", "-R", "2", "--participants", "2", "--seed", "5")
BATCH_TABLES = ("replications.csv", "conditions.csv", "summary.csv")


def nudge(*args: str):
    return CliRunner().invoke(main, [*args])


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (relative path -> bytes)."""
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture
def typed_here(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    return people_typed_here(tmp_path, monkeypatch, NAME)


def simulated_run(here: Path) -> Path:
    made = nudge(*SIMULATE, "--people", NAME, "--out", "run")
    assert made.exit_code == 0, made.output
    return here / "run"


def printed_resume(run: str) -> list[str]:
    """Damage ``run`` (participant 1's trials part gone); the words of the command ``nudge analyze``
    names to restore it."""
    (Path(run) / "trials" / "part-0001.parquet").unlink()
    refused = nudge("analyze", run)
    assert refused.exit_code == 1
    line = one_error_line(refused.stderr)
    assert "is incomplete" in line and line.count("`") == 2
    return shlex.split(line.split("`")[1])


def test_a_run_keeps_an_exact_copy_of_its_people_file(typed_here: Path) -> None:
    run = simulated_run(typed_here)
    assert (run / "people" / NAME).read_bytes() == PEOPLE_BYTES
    assert [p.name for p in (run / "people").iterdir()] == [NAME]  # nothing else, no temporary left
    recorded = json.loads((run / "manifest.json").read_text())["people"]
    assert recorded["file"] == NAME and recorded["sha256"] == read_people(run / "people" / NAME).sha256


def test_the_printed_resume_command_names_the_copy_and_works_from_another_folder(
        typed_here: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    simulated_run(typed_here)
    elsewhere = tmp_path / "b"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)  # the people file is not here: only the copy's path can work
    words = printed_resume("../a/run")
    assert words[words.index("--people") + 1] == str(Path("../a/run") / "people" / NAME)
    resumed = nudge(*words[1:])
    assert resumed.exit_code == 0, resumed.output
    assert nudge("analyze", "../a/run").exit_code == 0


def test_a_folder_without_a_copy_names_the_recorded_file_as_before(typed_here: Path) -> None:
    run = simulated_run(typed_here)
    (run / "people" / NAME).unlink()  # a run made before folders kept their people file
    words = printed_resume("run")
    assert words[words.index("--people") + 1] == NAME
    assert nudge(*words[1:]).exit_code == 0  # typed where the file is
    assert (run / "people" / NAME).read_bytes() == PEOPLE_BYTES  # the resume kept the copy


def test_a_resume_with_an_edited_copy_is_refused_and_the_original_puts_it_back(typed_here: Path) -> None:
    run = simulated_run(typed_here)
    copy = run / "people" / NAME
    # one more line end: the same people once parsed, other bytes; the SHA-256 refuses them
    copy.write_bytes(PEOPLE_BYTES + b"\r\n")
    assert read_people(copy).twins == read_people(NAME).twins
    refused = nudge(*SIMULATE, "--people", str(copy), "--out", "run", "--resume")
    assert refused.exit_code == 1
    line = one_error_line(refused.stderr)
    assert f"the manifest's {read_people(NAME).sha256[:12]}" in line and "changed since it was kept" in line
    assert f"resume with the file it was simulated with, --people {NAME}" in line
    torn = run / "people" / f".{NAME}.x1y2z3w4.tmp"  # the temporary of a copy whose writer was killed
    torn.write_bytes(PEOPLE_BYTES[:10])
    again = nudge(*SIMULATE, "--people", NAME, "--out", "run", "--resume")
    assert again.exit_code == 0, again.output
    assert copy.read_bytes() == PEOPLE_BYTES and not torn.exists()


def test_a_fresh_run_into_the_folder_is_refused_untouched_and_force_drops_the_copy(typed_here: Path) -> None:
    run = simulated_run(typed_here)
    other = typed_here / "other.csv"
    other.write_bytes(PEOPLE_BYTES.replace(b"3.0", b"4.0"))
    before = snapshot(run)
    refused = nudge(*SIMULATE, "--people", "other.csv", "--out", "run")
    assert refused.exit_code == 1 and "already holds a run" in one_error_line(refused.stderr)
    assert snapshot(run) == before
    replaced = nudge(*SIMULATE, "--out", "run", "--force")  # the population's people now
    assert replaced.exit_code == 0, replaced.output
    assert not (run / "people").exists()


def test_force_into_a_folder_that_is_no_run_keeps_the_persons_own_people_files(typed_here: Path) -> None:
    # --force replaces a run's own files; a people/ folder of a folder that holds no run is the
    # person's (say, their fitted people files), and only the run's copy may land beside them
    own = typed_here / "study" / "people" / "fitted.csv"
    own.parent.mkdir(parents=True)
    own.write_bytes(b"theirs")
    made = nudge(*SIMULATE, "--people", NAME, "--out", "study", "--force")
    assert made.exit_code == 0, made.output
    assert own.read_bytes() == b"theirs"
    assert (typed_here / "study" / "people" / NAME).read_bytes() == PEOPLE_BYTES
    replaced = nudge(*SIMULATE, "--out", "study", "--force")  # now a run: its copy goes, theirs stays
    assert replaced.exit_code == 0, replaced.output
    assert sorted(p.name for p in own.parent.iterdir()) == ["fitted.csv"]


def test_people_made_in_memory_leave_no_copy(tmp_path: Path) -> None:
    keep_copy(People("recovery", "", ()), tmp_path)
    keep_copy(None, tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_a_batch_resumed_with_its_copy_from_another_folder_equals_an_uninterrupted_one(
        typed_here: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    for out in ("whole", "damaged"):
        made = nudge(*REPLICATE, "--people", NAME, "--out", out)
        assert made.exit_code == 0, made.output
        assert (typed_here / out / "people" / NAME).read_bytes() == PEOPLE_BYTES
    damaged = typed_here / "damaged"
    # an interrupted batch: a participant task and an analysis not done, no tables written
    next((damaged / "tasks").glob("*/part-0001.parquet")).unlink()
    next((damaged / "analyses").glob("*.json")).unlink()
    for table in BATCH_TABLES:
        (damaged / table).unlink()
    manifest = json.loads((damaged / "batch.json").read_text())
    (damaged / "batch.json").write_text(json.dumps({**manifest, "status": "interrupted"}))
    monkeypatch.chdir(tmp_path)  # not where the people file is
    copy = Path("a/damaged/people") / NAME
    resumed = nudge(*REPLICATE, "--people", str(copy), "--out", "a/damaged", "--resume")
    assert resumed.exit_code == 0, resumed.output
    assert "(2 tasks computed now)" in resumed.stderr
    for table in BATCH_TABLES:
        assert (damaged / table).read_bytes() == (typed_here / "whole" / table).read_bytes(), table
    assert copy.read_bytes() == PEOPLE_BYTES
    # an edited copy is other people: refused with one line, the batch left as it is
    copy.write_bytes(PEOPLE_BYTES + b"\r\n")
    before = snapshot(damaged)
    refused = nudge(*REPLICATE, "--people", str(copy), "--out", "a/damaged", "--resume")
    assert refused.exit_code == 1
    assert "changed since it was kept" in one_error_line(refused.stderr)
    assert snapshot(damaged) == before
    replaced = nudge(*REPLICATE, "--out", "a/damaged", "--force")  # the population's people now
    assert replaced.exit_code == 0, replaced.output
    assert not (damaged / "people").exists()


def test_a_power_analysis_keeps_its_copy_too(typed_here: Path) -> None:
    made = nudge("power", "smoke", "--participants", "2,3", "-R", "1", "--seed", "6", "--people", NAME,
                 "--out", "power")
    assert made.exit_code == 0, made.output
    assert (typed_here / "power" / "people" / NAME).read_bytes() == PEOPLE_BYTES


def test_force_over_a_manifest_naming_no_file_in_people_replaces_the_run(typed_here: Path) -> None:
    # the manifest is read from disk: a people record naming ".." (edited by hand) is no file to remove
    run = simulated_run(typed_here)
    manifest = json.loads((run / "manifest.json").read_text())
    manifest["people"]["file"] = ".."
    (run / "manifest.json").write_text(json.dumps(manifest))
    replaced = nudge(*SIMULATE, "--out", "run", "--force")
    assert replaced.exit_code == 0, replaced.output
    assert (run / "manifest.json").is_file() and (run / "people" / NAME).read_bytes() == PEOPLE_BYTES


def test_a_batch_replaced_with_force_keeps_the_persons_own_people_files(typed_here: Path) -> None:
    own = typed_here / "study" / "people" / "fitted.csv"
    own.parent.mkdir(parents=True)
    own.write_bytes(b"theirs")
    made = nudge(*REPLICATE, "--people", NAME, "--out", "study", "--force")  # into a folder of theirs
    assert made.exit_code == 0, made.output
    assert (typed_here / "study" / "people" / NAME).read_bytes() == PEOPLE_BYTES
    replaced = nudge(*REPLICATE, "--out", "study", "--force")  # the batch replaced: its copy goes
    assert replaced.exit_code == 0, replaced.output
    assert sorted(p.name for p in own.parent.iterdir()) == ["fitted.csv"] and own.read_bytes() == b"theirs"
