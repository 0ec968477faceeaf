"""``nudge habits`` and ``nudge fit-people`` inputs checked: a ``--compare`` reference's values, a
TOML file given as a source, a habits table's repeated columns, and a batch folder's advice."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

from nudgecli.errors import DataError
from nudgecli.report.habits import load_reference


def test_a_batch_folder_with_people_is_advised_with_its_people_and_participants(tmp_path: Path) -> None:
    # before: `nudge simulate BATCH/experiment.toml --out RUN`, which simulates the population's
    # people, not the batch's
    batch = tmp_path / "batch"
    (batch / "tasks").mkdir(parents=True)
    (batch / "people").mkdir()
    (batch / "people" / "twins.csv").write_text("person\n")
    (batch / "experiment.toml").write_text("")
    (batch / "batch.json").write_text(json.dumps({
        "batch": {"kind": "replicate", "points": [{"index": 0, "participants": [4]}],
                  "people": {"file": "/elsewhere/twins.csv"}},
        "inputs": {"experiment.toml": "x"}}))
    result = nudge("habits", batch)
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    assert (f"(`nudge simulate {batch / 'experiment.toml'} --out RUN --participants 4 --people "
            f"{batch / 'people' / 'twins.csv'}`)") in line


@pytest.mark.parametrize(("second", "positions"), [("median", "5 and 6"), ("Median", "5 and 6")])
def test_a_habits_table_with_a_repeated_column_is_refused(tmp_path: Path, second: str,
                                                          positions: str) -> None:
    # before: a second `median` was dropped unsaid; `Median` gave a multi-line pandas Series message
    table = tmp_path / "habits.csv"
    table.write_text(f"scope,participant,habit,n,median,{second}\n"
                     "participant,A,soft_blow,12,0.5,0.9\n")
    result = nudge("fit-people", table, "--out", tmp_path / "people.csv")
    assert result.exit_code == 1, result.output
    assert one_error_line(result.output) == (
        f"Error: {table}: more than one column of one name: 'median' (columns {positions}); rename or "
        "remove the repeats so that each column has its own name")
    assert not (tmp_path / "people.csv").exists()


def reference_file(tmp_path: Path, habit: str, **entry: object) -> Path:
    """A ``--compare`` reference of one habit: a valid entry with ``entry``'s fields replaced."""
    valid: dict[str, object] = {"unit": "s", "pooled": {"median": 2.0}, "people": [1.75, 2.65]}
    path = tmp_path / "ref.json"
    path.write_text(json.dumps({"habits": {habit: {**valid, **entry}}}))
    return path


@pytest.mark.parametrize(("habit", "entry", "message"), [
    ("first_command_latency", {"people": [2.65, 1.75]},
     "first_command_latency: people [2.65, 1.75] is the wrong way round; give the range as [min, max]"),
    ("first_command_latency", {"unit": "ms", "pooled": {"median": 2000}, "people": [1750, 2650]},
     "first_command_latency: unit 'ms'; nudge measures it in 's'; give the figures in 's'"),
    ("first_command_latency", {"pooled": {"median": -0.5}},
     "first_command_latency: the pooled median -0.5 is negative; habits are durations or shares"),
    ("share_pauses_over_1s", {"unit": "share", "pooled": {"median": 39}, "people": None},
     "share_pauses_over_1s: the pooled median 39 is above 1, and a share is 0-1 (a percent? 39 / 100 is "
     "0.39); give the share as a fraction"),
    ("share_pauses_over_1s", {"unit": "share", "pooled": {"median": 0.3}, "people": [0.1, 1e999]},
     "share_pauses_over_1s: the people max inf is infinite; give the measured share"),
])
def test_a_reference_with_values_no_habit_has_is_refused(tmp_path: Path, habit: str, entry: dict[str, object],
                                                         message: str) -> None:
    # before: only "is it a number" was checked: the source was "outside" its own reversed range,
    # milliseconds were compared as seconds, a percent as a share
    path = reference_file(tmp_path, habit, **entry)
    with pytest.raises(DataError) as raised:
        load_reference(str(path))
    assert str(raised.value) == f"{path}: {message}"


def test_a_reference_of_the_habits_own_units_and_a_pooled_only_share_is_read(tmp_path: Path) -> None:
    path = reference_file(tmp_path, "share_pauses_over_1s", unit="share", pooled={"median": 0.4}, people=None)
    assert load_reference(str(path))["habits"]["share_pauses_over_1s"]["pooled"]["median"] == 0.4
    assert load_reference(str(reference_file(tmp_path, "soft_blow")))["habits"]["soft_blow"]["people"] == \
        [1.75, 2.65]


@pytest.mark.parametrize(("name", "text"), [
    ("t.toml", "[study]\nrate_hz = 10\n"),
    ("plan.txt", "# a plan\n\n[[contrasts]]\nname = 'a'\n"),
    ("noheader", "name = \"pilot\"\n[study]\n"),
])
def test_a_toml_file_is_named_as_toml_with_what_to_give(tmp_path: Path, name: str, text: str) -> None:
    # before: "a JSON file" (a leading `[` read as JSON), with advice that fails
    path = tmp_path / name
    path.write_text(text)
    habits = one_error_line(nudge("habits", path).output)
    assert habits == (
        f"Error: {path}: a TOML file (an experiment or plan file), not a source; habits reads a run "
        "folder or a real log's CSV (t, trial, label, x, y, theta, mode_switch); to measure an "
        f"experiment's people, simulate it and give the run: nudge simulate {path} --out RUN, then "
        "nudge habits RUN")
    fit = one_error_line(nudge("fit-people", path, "--out", tmp_path / "people.csv").output)
    assert fit.startswith(f"Error: {path}: a TOML file (an experiment or plan file), not a source; "
                          "fit-people reads a run folder"), fit
    assert fit.endswith("then nudge fit-people RUN --out people.csv"), fit


def test_a_runs_config_toml_names_the_run_folder(tmp_path: Path) -> None:
    (tmp_path / "manifest.json").write_text("{}")
    config = tmp_path / "config.toml"
    config.write_text("[study]\n")
    line = one_error_line(nudge("habits", config).output)
    assert line.startswith(f"Error: {config}: a TOML file (an experiment or plan file), not a source; "), line
    assert line.endswith("for the run this file belongs to, give the run folder itself: "
                         f"nudge habits {tmp_path}")


@pytest.mark.parametrize("text", ["[1, 2]\n", "[true]\n", "[\n  {\"a\": 1}\n]\n"])
def test_a_json_array_is_still_json(tmp_path: Path, text: str) -> None:
    path = tmp_path / "h.json"
    path.write_text(text)
    assert "a JSON file" in one_error_line(nudge("habits", path).output)
