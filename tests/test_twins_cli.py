"""`nudge fit-people` and `--people` through the command line (issue 37): twins of a run folder and of
its habits table alike, exactly those people simulated (cycled), the manifest's record and the
resume it guards, each bad input as one `Error:` line naming the file, the participant and the
field with nothing written, and docs/people.md's pilot-to-power commands as written."""

from __future__ import annotations

import hashlib
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from cli_helpers import one_error_line
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.config import InterfaceSection, load_experiment
from nudgecli.report.twin_sources import source_interface, twins_of_sources
from nudgecli.runs.study import run_study
from nudgecli.sim.people_file import read_people
from nudgecli.sim.twins import TWIN_PARAMETERS

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs" / "people.md"
PILOTS = REPO / "experiments" / "pilots"


def nudge(*args: str):
    return CliRunner().invoke(main, [*args])


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two simulated CIAA participants (a source with known people)."""
    out = tmp_path_factory.mktemp("twins") / "run"
    run_study(load_experiment("ciaa-teleop"), out, seed=3, participants=2)
    return out


def test_twins_of_a_run_folder_and_of_its_habits_table_are_the_same(run_folder: Path, tmp_path: Path) -> None:
    table = nudge("habits", str(run_folder), "--by", "participant", "--format", "csv")
    assert table.exit_code == 0, table.output
    (tmp_path / "habits.csv").write_text(table.stdout)
    result = nudge("fit-people", str(run_folder), str(tmp_path / "habits.csv"),
                   "--out", str(tmp_path / "p.csv"))
    assert result.exit_code == 0, result.output
    people = read_people(tmp_path / "p.csv").twins
    assert len(people) == 4 and [t.source for t in people] == ["run", "run", "habits.csv", "habits.csv"]
    # the table is the run's habits as printed: the same parameters, to the table's digits, but for
    # the reactions, which a run (or a log) gives event by event (the pauses that hide short ones
    # counted: twin_fit.reaction_observations) and a table as medians
    for measured, tabled in zip(people[:2], people[2:], strict=True):
        assert measured.parameters.keys() == tabled.parameters.keys()
        for name, value in measured.parameters.items():
            if name != "event_reaction_s":
                assert tabled.parameters[name] == pytest.approx(value, abs=1e-5), name
        assert tabled.parameters["event_reaction_s"] == pytest.approx(measured.parameters["event_reaction_s"],
                                                                      abs=0.2)
    assert list(people[:2]) == twins_of_sources([run_folder])
    assert result.stdout.splitlines()[3].startswith("person 3: habits.csv participant 1: ")


@pytest.mark.parametrize("preset", ["smoke", "paper"])
def test_twins_of_a_grid_world_run_draw_the_parameters_read_from_stops(tmp_path: Path, preset: str) -> None:
    """The grid world's robot stops at every cell, not at the CIAA task's waypoints the reaction
    and hold-on offsets were derived on: those three parameters are the population's, the others
    are fitted, and the output lists them."""
    out = tmp_path / preset
    run_study(load_experiment(preset), out, seed=11, participants=2)
    twins = twins_of_sources([out])
    assert len(twins) == 2
    stops = {"event_reaction_s", "event_reaction_log_sd", "hold_on_s"}
    for twin in twins:
        assert stops <= set(twin.from_population) and "planning_s" in twin.parameters
    printed = nudge("fit-people", str(out), "--out", str(tmp_path / "people.csv"))
    assert printed.exit_code == 0, printed.output
    assert "from the population: event_reaction_s, event_reaction_log_sd, hold_on_s" in printed.output


def test_simulate_with_people_simulates_exactly_those_people_and_guards_the_resume(run_folder: Path,
                                                                                   tmp_path: Path) -> None:
    people_file = tmp_path / "people.csv"
    assert nudge("fit-people", str(run_folder), "--out", str(people_file)).exit_code == 0
    twins = read_people(people_file).twins
    out = tmp_path / "twins"
    result = nudge("simulate", "ciaa-teleop", "--participants", "3", "--seed", "9",
                   "--people", str(people_file), "--out", str(out))
    assert result.exit_code == 0, result.output
    table = pd.read_parquet(out / "participants.parquet").set_index("index")
    for index in range(3):  # cycled: participant 2 is person 0
        for name, value in twins[index % 2].parameters.items():
            assert table.loc[index, name] == pytest.approx(value), (index, name)
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["people"] == {"file": "people.csv", "people": 2,
                                  "sha256": hashlib.sha256(people_file.read_bytes()).hexdigest()}
    other = tmp_path / "other.csv"
    other.write_text(people_file.read_text().replace("\n1,", "\n1,", 1).replace("run,0", "run,zero", 1))
    for extra in (["--people", str(other)], []):
        refused = nudge("simulate", "ciaa-teleop", "--participants", "3", "--seed", "9", "--out", str(out),
                        "--resume", *extra)
        assert refused.exit_code == 1
        assert "was simulated with --people people.csv" in one_error_line(refused.stderr)
    again = nudge("simulate", "ciaa-teleop", "--participants", "3", "--seed", "9",
                  "--people", str(people_file), "--out", str(out), "--resume")
    assert again.exit_code == 0, again.output


# --- bad input ------------------------------------------------------------------------------------

HEADER = "scope,participant,habit,n,median,q25,q75"


def refused(tmp_path: Path, *args: str) -> str:
    """The one error line of `nudge ARGS`, which must exit 1 with nothing on stdout or new on disk."""
    before = sorted(tmp_path.rglob("*"))
    result = nudge(*args)
    assert result.exit_code == 1 and result.stdout == "", result.output
    assert sorted(tmp_path.rglob("*")) == before
    return one_error_line(result.stderr)


@pytest.mark.parametrize(("rows", "words"), [
    (["pooled,,planning,12,2.0,,"], ["no participants"]),
    (["participant,P1,first_command_latency,0,,,", "participant,P1,soft_blow,0,,,"],
     ["participant 'P1'", "no trials"]),
    (["participant,P1,first_command_latncy,12,2.0,1.8,2.2"],
     ["participant 'P1'", "'first_command_latncy'", "did you mean 'first_command_latency'"]),
    (["participant,P1,first_command_latency,12,-2.0,1.8,2.2"], ["participant 'P1'", "first_command_latency",
                                                               "negative"]),
    (["participant,P1,soft_blow,12,nan,1.8,2.2"], ["participant 'P1'", "soft_blow", "not a number"]),
])
def test_fit_people_refuses_a_bad_habits_table(tmp_path: Path, rows: list[str], words: list[str]) -> None:
    table = tmp_path / "habits.csv"
    table.write_text("\n".join([HEADER, *rows]) + "\n")
    line = refused(tmp_path, "fit-people", str(table), "--out", str(tmp_path / "people.csv"))
    assert str(table) in line
    for word in words:
        assert word in line, line


def test_fit_people_refuses_an_unknown_unit(tmp_path: Path) -> None:
    table = tmp_path / "habits.csv"
    table.write_text("participant,habit,median,unit\nP1,first_command_latency,2000,ms\n")
    line = refused(tmp_path, "fit-people", str(table), "--out", str(tmp_path / "people.csv"))
    for word in (str(table), "participant 'P1'", "first_command_latency", "'ms'"):
        assert word in line, line


def test_fit_people_refuses_a_log_participant_without_input(tmp_path: Path) -> None:
    log = tmp_path / "log.csv"
    rows = ["t,trial,label,x,y,theta,mode_switch,participant",
            "0.0,1,,0,0,0,0,A", "0.5,1,Soft Puff,0,0,0,0,A", "0.8,1,Soft Puff,1,0,0,0,A", "1.2,1,,1,0,0,0,A",
            "0.0,1,,0,0,0,0,B", "1.0,1,Zero Band,0,0,0,0,B"]
    log.write_text("\n".join(rows) + "\n")
    line = refused(tmp_path, "fit-people", str(log), "--out", str(tmp_path / "people.csv"))
    assert all(word in line for word in (str(log), "participant 'B'", "no trial with input")), line


def test_fit_people_refuses_a_source_with_no_participants(tmp_path: Path) -> None:
    table = tmp_path / "habits.csv"
    table.write_text(HEADER + "\n")
    assert "no participants" in refused(tmp_path, "fit-people", str(table), "--out", str(tmp_path / "p.csv"))


@pytest.mark.parametrize(("edit", "new", "words"), [
    (None, None, ["no such people file"]),
    ("hold_on_s,", "hold_on,", ["column 'hold_on'"]),
    (",2.5,", ",99,", ["person 0 (participant 'P1')", "planning_s", "out of its valid range"]),
])
def test_simulate_refuses_a_bad_people_file_before_anything_is_written(
        tmp_path: Path, edit: str | None, new: str | None, words: list[str]) -> None:
    people = tmp_path / "people.csv"
    if edit is not None:
        text = ("person,source,participant," + ",".join(TWIN_PARAMETERS) + ",from_population\n"
                "0,log.csv,P1,2.5" + "," * (len(TWIN_PARAMETERS) - 1) + ","
                + ";".join(TWIN_PARAMETERS[1:]) + "\n")
        assert edit in text
        people.write_text(text.replace(edit, new or "", 1))
    line = refused(tmp_path, "simulate", "ciaa-teleop", "--participants", "1", "--people", str(people),
                   "--out", str(tmp_path / "run"))
    assert str(people) in line
    for word in words:
        assert word in line, line


# --- docs/people.md: from a pilot to a power analysis ------------------------------------------


def _doc_blocks() -> list[list[str]]:
    text = DOCS.read_text(encoding="utf-8")
    part = text[text.index("#### From a pilot to a power analysis"):]
    blocks = re.findall(r"```bash\n(.*?)```", part, re.S)[:2]
    return [[line for line in block.splitlines() if line.strip()] for block in blocks]


def test_the_docs_pilot_to_power_commands_run_as_written(tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    making, pipeline = _doc_blocks()
    shutil.copytree(PILOTS, tmp_path / "experiments" / "pilots")
    monkeypatch.chdir(tmp_path)
    for line in pipeline:
        command, _, target = line.partition(" > ")
        words = shlex.split(command)
        assert words[0] == "nudge", line
        result = nudge(*words[1:])
        assert result.exit_code == 0, (line, result.output)
        if target:
            Path(target.strip()).write_text(result.stdout)
    assert len(read_people("people.csv").twins) == 3
    manifest = json.loads((tmp_path / "power-pilots" / "batch.json").read_text())
    assert manifest["batch"]["people"]["file"] == "people.csv"
    assert (tmp_path / "power-pilots" / "power.csv").is_file()
    # the shipped pilots are made by the block before it
    made = tmp_path / "made"
    made.mkdir()
    monkeypatch.chdir(made)
    for line in making:
        words = shlex.split(line)
        if words[0] == "nudge":
            result = nudge(*words[1:])
            assert result.exit_code == 0, (line, result.output)
            continue
        assert words[:2] == ["PYTHONPATH=.", "python"], line  # the script, from the repository's root
        subprocess.run([sys.executable, str(REPO / words[2]), *words[3:]], cwd=made, check=True,
                       env={**os.environ, "PYTHONPATH": str(REPO)}, capture_output=True)
    shipped = sorted(p.name for p in PILOTS.glob("*.csv"))
    assert sorted(p.name for p in (made / "experiments" / "pilots").glob("*.csv")) == shipped == \
        ["pilot-1.csv", "pilot-2.csv", "pilot-3.csv"]
    for name in shipped:  # the shipped pilots are what today's model makes, byte for byte
        assert (made / "experiments" / "pilots" / name).read_bytes() == (PILOTS / name).read_bytes(), name


def test_a_batch_simulates_its_people_in_every_participant_task(tmp_path: Path) -> None:
    from nudgecli.runs.batch_kinds import replicate

    people = tmp_path / "slow.csv"  # one person who plans 20 s before each trial's first command
    people.write_text("person,source,participant,planning_s,from_population\n0,by hand,slow,20.0,\n")
    replicate("smoke", 1, tmp_path / "batch", participants=2, people=people)
    parts = sorted((tmp_path / "batch" / "tasks").rglob("*.parquet"))
    trials = pd.concat([pd.read_parquet(part) for part in parts])
    # the population's people plan about 2 s, and the shortest smoke trial takes under 20 s with them
    assert len(trials) == 16 and trials["completion_time"].min() >= 30.0


def test_the_resume_command_names_the_people_file() -> None:
    from nudgecli.store import simulate_resume_command

    assert simulate_resume_command("paper", "out dir", people="my people.csv") == \
        "nudge simulate paper --out 'out dir' --people 'my people.csv' --resume"
    assert "--people" not in simulate_resume_command("paper", "out")


def test_the_fit_takes_its_offsets_with_the_source_runs_own_thresholds(run_folder: Path,
                                                                      tmp_path: Path) -> None:
    """A run made with other thresholds: its pulses reach the hard band at other samples, so the
    fit's offsets are taken with its ``[interface]``, not the defaults it assumed before."""
    copy = tmp_path / "run"
    shutil.copytree(run_folder, copy)
    manifest = json.loads((copy / "manifest.json").read_text())
    manifest["config"]["interface"].update(soft_threshold=0.25, hard_threshold=0.7)
    (copy / "manifest.json").write_text(json.dumps(manifest))
    interface, _ = source_interface(copy)
    assert (interface.soft_threshold, interface.hard_threshold) == (0.25, 0.7)
    assert source_interface(run_folder)[0].hard_threshold == InterfaceSection().hard_threshold
    own, assumed = twins_of_sources([copy])[0], twins_of_sources([run_folder])[0]
    assert own.parameters["hard_peak_s"] != assumed.parameters["hard_peak_s"]  # the same habits
