"""The rest of the commands on the Python API (issue 40): ``fit``, ``fit-people``, ``validate``,
``plot-population`` and ``presets`` each return what their command prints and write the same files,
byte for byte, and bad input raises the command's ``Error:`` message with nothing written."""

from __future__ import annotations

import json
import math
import shutil
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from cli_helpers import one_error_line
from click.testing import CliRunner
from run_builders import hard_puff_mapping

import nudgecli
from nudgecli.cli import main

ROOT = Path(__file__).resolve().parents[1]
PILOTS = ROOT / "experiments" / "pilots"
#: A validation small enough for a test: 2 worlds of 3 goals on a 4 x 5 grid, no Monte-Carlo study.
TINY_VALIDATION: dict[str, Any] = {"simulations": 2, "min_goals": 3, "max_goals": 3, "states": 40,
                                   "mc_queries": 0, "seed": 5}
TINY_FLAGS = ["--simulations", "2", "--min-goals", "3", "--max-goals", "3", "--states", "40",
              "--mc-queries", "0", "--seed", "5"]


def cli(arguments: list[str], code: int = 0) -> Any:
    """``nudge ARGUMENTS`` in this process, expected to exit with ``code``."""
    result = CliRunner().invoke(main, arguments)
    assert result.exit_code == code, result.output
    return result


def cli_error(arguments: list[str]) -> str:
    """The message of the one ``Error:`` line a refused ``nudge ARGUMENTS`` prints (exit 1)."""
    return one_error_line(cli(arguments, code=1).stderr).removeprefix("Error: ")


def files_under(folder: Path) -> list[Path]:
    return sorted(folder.rglob("*"))


# --- presets -------------------------------------------------------------------------------------


def test_presets_lists_every_shipped_file_with_its_description() -> None:
    table = nudgecli.presets()
    assert list(table.columns) == ["kind", "name", "description", "path"]
    # independently: the TOML files on disk and the description each holds
    for kind in ("experiments", "analysis"):
        files = sorted((ROOT / kind).glob("*.toml"))  # the source tree's presets
        rows = table[table["kind"] == kind]
        assert list(rows["name"]) == [path.stem for path in files]
        for row in rows.itertuples(index=False):
            data = tomllib.loads(Path(row.path).read_text(encoding="utf-8"))
            expected = data["experiment"].get("description", "") if kind == "experiments" \
                else data.get("description", "")
            assert row.description == expected
    assert list(table["kind"]) == sorted(table["kind"], key=["experiments", "analysis"].index)
    assert {"paper", "smoke"} <= set(table.loc[table["kind"] == "experiments", "name"])


def test_presets_prints_the_tables_rows_under_their_headings() -> None:
    table = nudgecli.presets()
    lines = cli(["presets"]).stdout.splitlines()
    experiments, plans = lines.index("Experiments:"), lines.index("Analysis plans:")
    assert experiments == 0 and plans == 1 + (table["kind"] == "experiments").sum()
    printed = [(line.split()[0], line[2 + 12 + 1:] if len(line) > 15 else "") for line in lines
               if line.startswith("  ")]
    assert [name for name, _ in printed] == list(table["name"])
    assert [text.strip() for _, text in printed] == [text.strip() for text in table["description"]]


def test_presets_starts_every_description_in_one_column_past_the_longest_name() -> None:
    table = nudgecli.presets()
    longest = max(table["name"], key=len)
    assert len(longest) > 12  # custom-policy: longer than the column was
    rows = [line for line in cli(["presets"]).stdout.splitlines() if line.startswith("  ")]
    starts = {line.index(description) for line, description in zip(rows, table["description"], strict=True)}
    assert starts == {2 + len(longest) + 1}


# --- validate ------------------------------------------------------------------------------------


def test_validate_returns_what_the_command_prints_and_writes(tmp_path: Path) -> None:
    done: list[tuple[int, int]] = []
    result = nudgecli.validate(**TINY_VALIDATION, out=tmp_path / "api",
                               progress=lambda finished, total: done.append((finished, total)))
    printed = cli(["validate", *TINY_FLAGS, "--out", str(tmp_path / "cli")]).stdout
    assert printed == result.text() + "\n"
    assert json.loads(cli(["validate", *TINY_FLAGS, "--format", "json"]).stdout) == result.to_json()
    for name in ("validation.json", "validation.csv"):
        assert (tmp_path / "api" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes()
    assert {path.name for path in result.files} == {path.name for path in (tmp_path / "cli").iterdir()}
    assert done[-1] == (2, 2)
    # the tidy table is validation.csv's, column for column (an independent reading of the file)
    written = pd.read_csv(tmp_path / "api" / "validation.csv")
    pd.testing.assert_frame_equal(result.queries.drop(columns="reading"), written, check_dtype=False)
    assert result.summary()["simulations"] == 2 and (result.queries["reading"] == "dirichlet").all()
    summary = result.summary()
    assert summary["match_rate"] == pytest.approx(float(np.mean(written["match"])))


def test_validate_every_reading_as_the_command(tmp_path: Path) -> None:
    result = nudgecli.validate(**TINY_VALIDATION, all_readings=True, out=tmp_path / "api")
    printed = cli(["validate", *TINY_FLAGS, "--all-readings", "--out", str(tmp_path / "cli")]).stdout
    assert printed == result.text() + "\n"
    api_file, cli_file = tmp_path / "api" / "readings.json", tmp_path / "cli" / "readings.json"
    assert api_file.read_bytes() == cli_file.read_bytes()
    assert set(result.queries["reading"]) == set(nudgecli.api.validation.reading_names())
    assert [record["reading"] for record in result.to_json()] == [
        record["reading"] for record in json.loads((tmp_path / "cli" / "readings.json").read_text())]


@pytest.mark.parametrize(("settings", "flags"), [
    ({"min_goals": 1}, ["--min-goals", "1"]),
    ({"states": 3}, ["--states", "3"]),
    ({"simulations": 10_000, "states": 10_000}, ["--simulations", "10000", "--states", "10000"]),
])
def test_validate_raises_the_commands_message_and_writes_nothing(tmp_path: Path, settings: dict[str, int],
                                                                 flags: list[str]) -> None:
    message = cli_error(["validate", *TINY_FLAGS, *flags, "--out", str(tmp_path / "cli")])
    with pytest.raises(nudgecli.NudgeError) as raised:
        nudgecli.validate(**{**TINY_VALIDATION, **settings}, out=tmp_path / "api")
    assert str(raised.value) == message.replace("pass --yes", "pass yes=True")  # the API's switch
    assert files_under(tmp_path) == []


def test_validate_refuses_a_reading_beside_every_reading() -> None:
    with pytest.raises(nudgecli.NudgeError, match="--reading and --all-readings exclude each other"):
        nudgecli.validate(**TINY_VALIDATION, reading="two-goal", all_readings=True)
    assert "--reading and --all-readings exclude each other" in cli(
        ["validate", *TINY_FLAGS, "--reading", "two-goal", "--all-readings"], code=2).output


# --- fit -----------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def calibration_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One participant's mapping session (every prompt answered Hard Puff), as ``nudge fit`` reads it."""
    return hard_puff_mapping(tmp_path_factory.mktemp("calibration"))


def test_fit_returns_the_profile_the_command_writes(tmp_path: Path, calibration_dir: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    result = nudgecli.fit(calibration_dir, out=tmp_path / "api.json")
    printed = cli(["fit", str(calibration_dir), "--out", str(tmp_path / "cli.json")])
    assert printed.stdout == result.summary + "\n"
    assert (tmp_path / "api.json").read_bytes() == (tmp_path / "cli.json").read_bytes()
    assert json.loads((tmp_path / "api.json").read_text()) == json.loads(json.dumps(result.profile))
    monkeypatch.chdir(tmp_path)
    before = files_under(tmp_path)
    assert nudgecli.fit(calibration_dir).profile == result.profile  # out=None: the same fit, no file
    assert files_under(tmp_path) == before


def test_fit_raises_the_commands_message_and_keeps_the_old_profile(tmp_path: Path,
                                                                   calibration_dir: Path) -> None:
    target = tmp_path / "p.json"
    target.write_text("a profile fitted before\n")
    message = cli_error(["fit", str(calibration_dir), "--out", str(target)])
    with pytest.raises(nudgecli.NudgeError) as raised:
        nudgecli.fit(calibration_dir, out=target)
    assert str(raised.value) == message and "--force" in message
    assert target.read_text() == "a profile fitted before\n"
    nudgecli.fit(calibration_dir, out=target, force=True)
    assert target.read_text() != "a profile fitted before\n"


def test_fit_never_writes_over_one_of_its_logs(tmp_path: Path, calibration_dir: Path) -> None:
    log = next(path for path in sorted(calibration_dir.rglob("*")) if path.is_file())
    before = log.read_bytes()
    message = cli_error(["fit", str(calibration_dir), "--out", str(log), "--force"])
    with pytest.raises(nudgecli.NudgeError) as raised:
        nudgecli.fit(calibration_dir, out=log, force=True)
    assert str(raised.value) == message and log.read_bytes() == before
    # the declaration was that call's alone: a later call with other logs may write there
    copy = tmp_path / "copy"
    shutil.copytree(calibration_dir, copy)
    nudgecli.fit(copy, out=tmp_path / "copy.json")
    copied_log = copy / log.relative_to(calibration_dir)
    nudgecli.fit(calibration_dir, out=copied_log, force=True)
    assert json.loads(copied_log.read_text()) == json.loads(json.dumps(nudgecli.fit(calibration_dir).profile))


# --- fit-people ----------------------------------------------------------------------------------


def test_fit_people_returns_the_people_file_the_command_writes(tmp_path: Path) -> None:
    # a habits table of one habit: its person draws every other parameter from the population
    partial = tmp_path / "one-habit.csv"
    partial.write_text("scope,participant,habit,n,median,q25,q75\n"
                       "participant,P1,first_command_latency,12,2.0,1.8,2.2\n")
    sources = [str(PILOTS / "pilot-1.csv"), str(PILOTS / "pilot-2.csv"), str(partial)]
    table = nudgecli.fit_people(sources, out=tmp_path / "api.csv").table
    printed = cli(["fit-people", *sources, "--out", str(tmp_path / "cli.csv")]).stdout
    assert (tmp_path / "api.csv").read_bytes() == (tmp_path / "cli.csv").read_bytes()
    # the frame is the file, read independently (labels as text, empty cells as NaN)
    written = pd.read_csv(tmp_path / "cli.csv", dtype={"source": str, "participant": str},
                          keep_default_na=False, na_values={name: [""] for name in table.columns[3:-1]})
    pd.testing.assert_frame_equal(table, written, check_dtype=False)
    assert list(table["person"]) == list(range(len(table)))
    assert table.iloc[-1, 3:-1].isna().sum() == len(table.columns) - 5  # one parameter fitted
    # each printed line counts the parameters the file holds and names the ones it leaves empty
    lines = printed.splitlines()
    assert len(lines) == len(table)
    for line, row in zip(lines, written.to_dict(orient="records"), strict=True):
        empty = [name for name in table.columns[3:-1]
                 if isinstance(row[name], float) and math.isnan(row[name])]
        assert line == (f"person {row['person']}: {row['source']} participant {row['participant']}: "
                        f"{len(table.columns) - 4 - len(empty)} parameter(s) from their habits; "
                        f"from the population: {', '.join(empty) or '-'}")


def test_fit_people_without_out_writes_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    table = nudgecli.fit_people(PILOTS / "pilot-1.csv").table
    assert len(table) >= 1 and files_under(tmp_path) == []


def test_fit_people_raises_the_commands_message_and_writes_nothing(tmp_path: Path) -> None:
    source = tmp_path / "habits.csv"
    source.write_text("scope,participant,habit,n,median,q25,q75\n")
    before = files_under(tmp_path)
    message = cli_error(["fit-people", str(source), "--out", str(tmp_path / "cli.csv")])
    with pytest.raises(nudgecli.NudgeError) as raised:
        nudgecli.fit_people([source], out=tmp_path / "api.csv")
    assert str(raised.value) == message and "no participants" in message
    assert files_under(tmp_path) == before


def test_fit_people_replaces_a_people_file_only_with_force(tmp_path: Path) -> None:
    target = tmp_path / "people.csv"
    target.write_text("an older people file\n")
    source = str(PILOTS / "pilot-1.csv")
    message = cli_error(["fit-people", source, "--out", str(target)])
    with pytest.raises(nudgecli.NudgeError) as raised:
        nudgecli.fit_people(source, out=target)
    assert str(raised.value) == message and target.read_text() == "an older people file\n"
    cli(["fit-people", source, "--out", str(target), "--force"])
    assert target.read_text().startswith("person,source,participant,")


# --- plot-population -----------------------------------------------------------------------------


def test_plot_population_returns_the_tables_the_command_prints_and_writes(tmp_path: Path) -> None:
    made = nudgecli.plot_population("smoke", participants=2, seed=4, out=tmp_path / "api", formats="png")
    printed = cli(["plot-population", "smoke", "--participants", "2", "--seed", "4", "--formats", "png",
                   "--format", "csv", "--out", str(tmp_path / "cli")]).stdout
    assert printed == made.coverage.to_csv(index=False)
    for name in ("population.csv", "population_habits.csv"):
        assert (tmp_path / "api" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes()
    pd.testing.assert_frame_equal(made.diagonals, pd.read_csv(tmp_path / "api" / "population.csv"),
                                  check_dtype=False)
    assert [path.name for path in made.files] == ["population.csv", "population_habits.csv", "coverage.txt",
                                                  "population.png"]
    assert made.title == "smoke: 2 simulated participants (seed 4)"
    assert made.figure().axes  # drawn again without writing


def test_plot_population_refuses_a_negative_seed_as_the_other_commands_seed(tmp_path: Path) -> None:
    result = CliRunner().invoke(main, ["plot-population", "smoke", "--seed", "-1",
                                       "--out", str(tmp_path / "cli")])
    assert result.exit_code == 1  # the one line of every command's --seed -1 (tests/test_seed_options.py)
    assert result.stderr == "Error: --seed must be a non-negative integer, got -1\n"
    assert files_under(tmp_path) == []


def test_plot_population_without_out_writes_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    made = nudgecli.plot_population("smoke", participants=2, seed=4)
    assert made.files == [] and files_under(tmp_path) == []
    assert made.diagonals["participant"].nunique() == 2


@pytest.mark.parametrize(("options", "flags"), [
    ({"formats": "png,gif"}, ["--formats", "png,gif"]),
    ({"participants": 100_000}, ["--participants", "100000"]),
    ({"overrides": ["nonsense.key=1"]}, ["--set", "nonsense.key=1"]),
])
def test_plot_population_raises_the_commands_message_and_writes_nothing(
        tmp_path: Path, options: dict[str, Any], flags: list[str]) -> None:
    message = cli_error(["plot-population", "smoke", *flags, "--out", str(tmp_path / "cli")])
    with pytest.raises(nudgecli.NudgeError) as raised:
        nudgecli.plot_population("smoke", **options, out=tmp_path / "api")
    assert str(raised.value) == message.replace("pass --yes", "pass yes=True")  # the API's switch
    assert files_under(tmp_path) == []
