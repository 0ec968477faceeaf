"""Small user-facing fixes through the command line: a run's participant labels print as integers
in ``nudge habits --format csv`` and in ``nudge compare``'s files (a real source's labels as
written), and the resume command a
damaged run folder names carries the run's ``--people`` file, and ``nudge fit-people`` prints the
count of fitted parameters the API returns."""

from __future__ import annotations

import csv
import io
import json
import shlex
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_helpers import copy_run, one_error_line
from click.testing import CliRunner

import nudgecli
from nudgecli.cli import main

PILOT = Path(__file__).resolve().parents[1] / "experiments" / "pilots" / "pilot-1.csv"


def nudge(*args: str):
    return CliRunner().invoke(main, [*args])


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two simulated participants of the smoke experiment (labels 0 and 1)."""
    out = tmp_path_factory.mktemp("labels") / "run"
    result = nudge("simulate", "smoke", "--participants", "2", "--seed", "3", "--out", str(out))
    assert result.exit_code == 0, result.output
    return out


def csv_cells(text: str) -> pd.DataFrame:
    """A CSV's cells as written (no number parsing, empty cells as '')."""
    return pd.read_csv(io.StringIO(text), dtype=str, keep_default_na=False)


# --- 1. nudge habits --format csv ----------------------------------------------------------------


@pytest.mark.parametrize("by", ["participant", "trial"])
def test_habits_csv_writes_a_runs_labels_as_integers(smoke_run: Path, by: str) -> None:
    result = nudge("habits", str(smoke_run), "--format", "csv", "--by", by)
    assert result.exit_code == 0, result.output
    cells = csv_cells(result.stdout)
    units = cells[cells["scope"] == by]
    trials = pd.read_parquet(smoke_run / "trials")
    # the labels as the run's own trials table holds them, printed by Python's int -> str
    assert set(units["participant"]) == {str(int(p)) for p in trials["participant"].unique()}
    if by == "trial":
        assert set(units["trial"]) <= {str(int(t)) for t in trials["trial"].unique()}
        assert len(units[["participant", "trial"]].drop_duplicates()) == len(trials)
    pooled = cells[cells["scope"] == "pooled"]
    assert len(pooled) and set(pooled["participant"]) == {""}  # pooled rows have no unit
    # the figures are untouched: the same numbers as the API's units table
    numbers = pd.read_csv(io.StringIO(result.stdout))
    assert np.allclose(numbers.loc[numbers["scope"] == by, "median"].to_numpy(dtype=float),
                       units["median"].astype(float).to_numpy(), equal_nan=True)


def test_habits_csv_keeps_a_real_logs_labels_as_written(tmp_path: Path) -> None:
    rows = [(0.0, "Zero Band"), (0.5, "Soft Puff"), (1.2, "Zero Band"), (2.0, "Soft Sip"),
            (3.0, "input stopped")]
    body = "".join(f"{t},{trial},{label},22.5,5,0,0,6,{who}\n"
                   for who in ("07", "P2") for trial in (1, 2) for t, label in rows)
    log = tmp_path / "log.csv"
    log.write_text("t,trial,label,x,y,theta,mode_switch,layout,participant\n" + body)
    result = nudge("habits", str(log), "--format", "csv", "--by", "trial")
    assert result.exit_code == 0, result.output
    units = csv_cells(result.stdout).query("scope == 'trial'")
    assert set(units["participant"]) == {"07", "P2"} and set(units["trial"]) == {"1", "2"}


def test_compare_writes_a_runs_labels_as_integers_and_a_real_tables_as_written(smoke_run: Path,
                                                                              tmp_path: Path) -> None:
    trials = pd.read_parquet(smoke_run / "trials")
    real = tmp_path / "real.csv"  # the run's own trials, labelled as a real study might label them
    trials.assign(participant="P" + trials["participant"].astype(str)).to_csv(real, index=False)
    out = tmp_path / "compare"
    result = nudge("compare", str(smoke_run), str(real), "--resamples", "0", "--format", "json",
                   "--out", str(out), "--formats", "png")
    assert result.exit_code == 0, result.output
    expected = {"simulated": {str(int(p)) for p in trials["participant"].unique()},
                "real": {f"P{int(p)}" for p in trials["participant"].unique()}}
    medians = csv_cells((out / "participant_medians.csv").read_text())
    printed = json.loads(result.stdout)["participant_medians"]
    for source, labels in expected.items():
        assert set(medians.loc[medians["source"] == source, "participant"]) == labels
        assert {row["participant"] for row in printed if row["source"] == source} == labels  # text, not 0


# --- 2. the resume command of a damaged run folder -----------------------------------------------


def damaged_run_resume(run: Path) -> list[str]:
    """Remove participant 1's trials part of ``run``; the words of the command ``nudge analyze``'s
    error names to restore it."""
    (run / "trials" / "part-0001.parquet").unlink()
    refused = nudge("analyze", str(run))
    assert refused.exit_code == 1
    line = one_error_line(refused.stderr)
    assert "is incomplete" in line and line.count("`") == 2
    return shlex.split(line.split("`")[1])


def test_the_resume_command_of_a_run_with_people_names_the_people_file(
        smoke_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # the people file is where the commands are typed
    assert nudge("fit-people", str(smoke_run), "--out", "people.csv").exit_code == 0
    made = nudge("simulate", "smoke", "--participants", "2", "--seed", "4", "--people", "people.csv",
                 "--out", "run")
    assert made.exit_code == 0, made.output
    recorded = json.loads(Path("run/manifest.json").read_text())["people"]["file"]
    words = damaged_run_resume(Path("run"))
    assert words[:2] == ["nudge", "simulate"] and words[-1] == "--resume"
    # the copy the run keeps, by the folder's path as typed (tests/test_people_copy.py: from elsewhere)
    assert recorded == "people.csv"
    assert words[words.index("--people") + 1] == str(Path("run") / "people" / recorded)
    # the printed command is one the people check accepts: it restores the run
    resumed = nudge(*words[1:])
    assert resumed.exit_code == 0, resumed.output
    assert nudge("analyze", "run").exit_code == 0


def test_the_resume_command_of_a_run_without_people_names_none(smoke_run: Path, tmp_path: Path) -> None:
    run = copy_run(smoke_run, tmp_path / "run")
    words = damaged_run_resume(run)
    assert "--people" not in words
    assert nudge(*words[1:]).exit_code == 0


# --- 3. nudge fit-people's count of fitted parameters ---------------------------------------------


def test_fit_people_prints_the_count_of_fitted_parameters_the_api_returns(tmp_path: Path) -> None:
    partial = tmp_path / "one-habit.csv"  # one habit: its person draws every other parameter
    partial.write_text("scope,participant,habit,n,median,q25,q75\n"
                       "participant,P1,first_command_latency,12,2.0,1.8,2.2\n")
    sources = [str(PILOT), str(partial)]
    found = nudgecli.fit_people(sources)
    printed = nudge("fit-people", *sources, "--out", str(tmp_path / "people.csv"))
    assert printed.exit_code == 0, printed.output
    assert printed.stdout == found.text() + "\n"
    # the count: the people file's filled parameter cells, read independently of the API
    with open(tmp_path / "people.csv", newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    parameters = [name for name in rows[0] if name not in ("person", "source", "participant",
                                                           "from_population")]
    filled = [sum(row[name] != "" for name in parameters) for row in rows]
    assert list(found.fitted) == filled and filled[-1] == 1 and filled[0] > 1
    for line, count in zip(printed.stdout.splitlines(), filled, strict=True):
        assert f": {count} parameter(s) from their habits; " in line
