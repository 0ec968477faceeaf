"""What a batch ``--resume`` says: a refused resume names each setting that differs (the wording of
a run's resume), a people file of the same bytes under another name is named as such, and parts
deleted since the batch wrote them are named before they are computed again."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from cli_helpers import files_of, one_error_line
from click.testing import CliRunner
from people_helpers import PEOPLE_BYTES

from nudgecli.cli import main
from nudgecli.runs.batch_folder import batch_differences

REPLICATE = ("replicate", "smoke", "-R", "2", "--seed", "9", "--participants", "2",
             "--set", "disambiguation.window=5")
TABLES = ("replications.csv", "conditions.csv", "summary.csv")


def invoke(*args: str | Path):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def batch(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("finished") / "batch"
    made = invoke(*REPLICATE, "--out", folder)
    assert made.exit_code == 0, made.output
    return folder


def _point(participants: list[int], study: str = "aa", **parameters: float) -> dict:
    return {"index": 0, "parameters": parameters, "participants": participants, "study": study}


def _described(*points: dict, seed: int = 9, replications: int = 6) -> dict:
    return {"kind": "replicate", "replications": replications, "seed": seed,
            "points": [dict(p, index=i) for i, p in enumerate(points)], "experiment": "paper"}


# --- naming each setting that differs ----------------------------------------------------------


def test_the_differences_of_a_one_point_batch_are_named_by_their_setting() -> None:
    recorded = _described(_point([3]))
    assert batch_differences(recorded, recorded) == []
    assert batch_differences(recorded, _described(_point([4]))) == [
        "participants: [3] in batch.json, [4] now"]
    assert batch_differences(recorded, _described(_point([3]), seed=7, replications=2)) == [
        "replications: 6 in batch.json, 2 now", "seed: 9 in batch.json, 7 now"]
    # a tuple is what Batch.describe gives, a list what batch.json holds: the same setting
    now = _described(_point([3]))
    now["points"][0]["participants"] = (3,)
    assert batch_differences(recorded, now) == []


def test_a_sweeps_differences_are_named_by_point_and_a_changed_experiment_says_so() -> None:
    recorded = _described(_point([4], **{"inference.kappa": 0.5}), _point([4], **{"inference.kappa": 0.8}))
    now = _described(_point([4], **{"inference.kappa": 0.5}), _point([4], **{"inference.kappa": 0.7}))
    assert batch_differences(recorded, now) == [
        "point 1.parameters.inference.kappa: 0.8 in batch.json, 0.7 now"]
    (study,) = batch_differences(_described(_point([3], "aa")), _described(_point([3], "bb")))
    assert study.startswith('study: "aa" in batch.json, "bb" now') and "experiment" in study


def test_a_refused_resume_names_the_participant_count_alone_and_touches_nothing(tmp_path, batch) -> None:
    folder = tmp_path / "batch"
    shutil.copytree(batch, folder)
    before = files_of(folder)
    changed = [*REPLICATE[:-3], "3", *REPLICATE[-2:]]  # --participants 3
    result = invoke(*changed, "--out", folder, "--resume")
    assert result.exit_code == 1
    line = one_error_line(result.output)
    assert "(participants: [2] in batch.json, [3] now)" in line
    # the differences, before the command that resumes the batch (which names every setting)
    differences = line.split("holds a different batch (")[1].split("); resume it")[0]
    assert differences == "participants: [2] in batch.json, [3] now"
    assert files_of(folder) == before


def test_a_people_file_of_the_same_bytes_under_another_name_is_named_as_such(tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    Path("people.csv").write_bytes(PEOPLE_BYTES)
    Path("people_copy.csv").write_bytes(PEOPLE_BYTES)
    replicate = ("replicate", "smoke", "-R", "1", "--participants", "2", "--out", "b")
    assert invoke(*replicate, "--people", "people.csv").exit_code == 0
    before = files_of(tmp_path / "b")
    result = invoke(*replicate, "--people", "people_copy.csv", "--resume")
    assert result.exit_code == 1
    line = one_error_line(result.output)
    assert "people_copy.csv holds the same bytes" in line and "only its name differs" in line
    assert "resume with --people people.csv" in line
    assert files_of(tmp_path / "b") == before


# --- naming the parts computed again -----------------------------------------------------------


def test_parts_deleted_since_they_were_written_are_named_and_computed_again(tmp_path, batch) -> None:
    folder = tmp_path / "batch"
    shutil.copytree(batch, folder)
    task = sorted((folder / "tasks").glob("*/part-0001.parquet"))[0]
    analysis = sorted((folder / "analyses").glob("*.json"))[-1]
    task.unlink()
    analysis.unlink()
    result = invoke(*REPLICATE, "--out", folder, "--resume")
    assert result.exit_code == 0, result.output
    named = f"{task.relative_to(folder).as_posix()}, analyses/{analysis.name}: missing"
    assert named in result.stderr
    assert "(2 tasks computed now)" in result.stderr
    for table in TABLES:
        assert (folder / table).read_bytes() == (batch / table).read_bytes(), table


def test_a_new_batch_warns_of_nothing_missing(tmp_path) -> None:
    # the parts of tasks not yet computed are not missing: only what the record holds can be
    result = invoke("replicate", "smoke", "-R", "1", "--participants", "2", "--out", tmp_path / "b")
    assert result.exit_code == 0, result.output
    assert "Warning" not in result.stderr
