"""``--match SIMULATED=REAL`` pairs conditions one to one: a REAL label the real table lacks is
refused with a "did you mean" (as an unknown SIMULATED one is), and so are two pairings that name
one real condition (their trials would be pooled). A simulated condition left unpaired whose name
a pairing gives another is left out, with a note, rather than pooled with it."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from nudgecli import api
from nudgecli.api.tables import parse_matches
from nudgecli.cli import main
from nudgecli.errors import ConfigError, DataError
from nudgecli.report.compare import align_conditions


def table(conditions: dict[str, int], prefix: str = "p") -> pd.DataFrame:
    """A metrics table of 2 participants with ``trials`` trials in each condition (completion_time:
    the row's number, so which rows were kept can be read off)."""
    rows = [(f"{prefix}{person}", condition, trial)
            for condition, trials in conditions.items() for person in range(2) for trial in range(trials)]
    frame = pd.DataFrame(rows, columns=["participant", "condition", "trial"])
    return frame.assign(completion_time=np.arange(len(frame), dtype=float))


SIMULATED = table({"disambiguation": 4, "control": 4})  # 8 trials each
REAL = table({"disambiguation": 3, "control": 3}, prefix="r")


def test_a_real_label_the_real_table_lacks_is_refused_with_did_you_mean() -> None:
    with pytest.raises(DataError, match=r"^--match control=contrl: the real table \(real.csv\) has no "
                                        r"condition 'contrl' \(did you mean 'control'\?\); its conditions: "
                                        r"disambiguation, control$"):
        align_conditions(SIMULATED, REAL, {"control": "contrl"}, names=("sim.csv", "real.csv"))
    with pytest.raises(DataError, match="has no condition 'nope'; its conditions"):
        align_conditions(SIMULATED, REAL, {"control": "nope"})


def test_two_matches_naming_one_real_condition_are_refused() -> None:
    real_one = table({"pooled": 3}, prefix="r")
    with pytest.raises(DataError, match=r"^--match disambiguation=pooled --match control=pooled: the "
                                        r"simulated conditions 'disambiguation' and 'control' of sim.csv "
                                        r"would all be compared as the real condition 'pooled'"):
        align_conditions(SIMULATED, real_one, {"disambiguation": "pooled", "control": "pooled"},
                         names=("sim.csv", "real.csv"))
    with pytest.raises(DataError, match=r"^--match disambiguation=control --match control=control: "):
        align_conditions(SIMULATED, REAL, {"disambiguation": "control", "control": "control"})


def test_an_unmatched_condition_whose_name_a_match_takes_is_left_out_with_a_note() -> None:
    # a real table with control alone: the simulated disambiguation is compared with it, and the
    # simulated control (8 trials, rows 8-15), which would have been pooled with it, is left out
    real_control = table({"control": 3}, prefix="r")
    notes: list[str] = []
    sim, real, shared = align_conditions(SIMULATED, real_control, {"disambiguation": "control"},
                                         names=("sim.csv", "real.csv"), notes=notes)
    assert shared == ["control"] and real.equals(real_control)
    assert list(sim["condition"]) == ["control"] * 8 and list(sim["completion_time"]) == list(range(8))
    assert notes == ["condition 'control' of the simulated source (sim.csv) is left out: --match "
                     "disambiguation=control compares 'disambiguation' as the real 'control'; pair it with "
                     "--match control=REAL to compare it too"]
    # the real table's own disambiguation, its simulated one matched away, is noted as unpaired
    notes.clear()
    sim, _, shared = align_conditions(SIMULATED, REAL, {"disambiguation": "control"}, notes=notes)
    assert shared == ["control"] and sorted(sim["completion_time"]) == list(range(8))
    assert notes[0] == ("condition 'disambiguation' of the real table (real) is not compared: --match "
                        "disambiguation=control compares the simulated 'disambiguation' as the real "
                        "'control'; pair it with --match SIMULATED=disambiguation")
    assert notes[1].startswith("condition 'control' of the simulated source (simulated) is left out")


def test_pairings_one_to_one_are_kept_as_given() -> None:
    # a swap: the simulated disambiguation trials (rows 0-7) are compared as the real control
    sim, real, shared = align_conditions(SIMULATED, REAL, {"disambiguation": "control",
                                                           "control": "disambiguation"})
    assert shared == ["disambiguation", "control"] and len(real) == len(REAL)
    as_control = sim.loc[sim["condition"] == "control", "completion_time"]
    assert sorted(as_control) == list(range(8)) and len(sim) == 16
    # a condition paired with itself changes nothing
    sim, _, shared = align_conditions(SIMULATED, REAL, {"control": "control"})
    assert shared == ["disambiguation", "control"] and sim.equals(SIMULATED)


def test_the_cli_refuses_both_in_one_line_and_writes_nothing(tmp_path: Path) -> None:
    SIMULATED.to_csv(tmp_path / "sim.csv", index=False)
    REAL.to_csv(tmp_path / "real.csv", index=False)
    sources = [str(tmp_path / "sim.csv"), str(tmp_path / "real.csv")]
    for matches in (["control=nope"], ["disambiguation=control", "control=control"]):
        given = [word for match in matches for word in ("--match", match)]
        result = CliRunner().invoke(main, ["compare", *sources, *given, "--resamples", "0",
                                           "--out", str(tmp_path / "o")])
        assert result.exit_code == 1, result.output
        assert result.stderr.startswith("Error: --match ") and result.stderr.count("\n") == 1, result.stderr
        assert not (tmp_path / "o").exists()


def test_the_cli_compares_the_matched_condition_and_notes_the_one_left_out(tmp_path: Path) -> None:
    SIMULATED.to_csv(tmp_path / "sim.csv", index=False)
    table({"control": 3}, prefix="r").to_csv(tmp_path / "real.csv", index=False)
    sources = [str(tmp_path / "sim.csv"), str(tmp_path / "real.csv")]
    result = CliRunner().invoke(main, ["compare", *sources, "--match", "disambiguation=control",
                                       "--resamples", "0", "--format", "csv"])
    assert result.exit_code == 0, result.output
    notes = [line for line in result.stderr.splitlines(True) if line.startswith("Note: condition ")]
    assert notes == [(f"Note: condition 'control' of the simulated source ({tmp_path / 'sim.csv'}) is "
                      "left out: --match disambiguation=control compares 'disambiguation' as the real "
                      "'control'; pair it with --match control=REAL to compare it too\n")]
    compared = pd.read_csv(io.StringIO(result.stdout))
    assert list(compared["condition"]) == ["control"] and list(compared["n_simulated"]) == [8]


def test_a_simulated_condition_matched_twice_is_refused_naming_both() -> None:
    # the last pairing silently won before: control was compared as the real control
    with pytest.raises(ConfigError, match=r"^--match control=disambiguation --match control=control: the "
                                          r"simulated condition 'control' is matched twice, with "
                                          r"'disambiguation' and 'control'; keep the --match you mean$"):
        parse_matches(["control=disambiguation", "none=x", "control=control"])
    assert parse_matches(["control=control", "control=control"]) == {"control": "control"}  # one pairing
    with pytest.raises(ConfigError, match=r"^--match 'a=no help' --match a=none: "):
        parse_matches(["a=no help", "a=none"])  # quoted as a shell takes it


def test_a_match_of_the_wrong_type_names_the_argument_of_the_function_called(tmp_path: Path) -> None:
    # parse_matches' argument is matches=, compare's is match=: each message names the one given
    with pytest.raises(ConfigError, match=r"^matches=3: matches= takes a list of texts"):
        parse_matches(3)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"^match=3: match= takes a list of texts"):
        api.compare(tmp_path / "sim.csv", tmp_path / "real.csv", match=3)  # type: ignore[arg-type]


def test_the_cli_refuses_a_simulated_condition_matched_twice_in_one_line(tmp_path: Path) -> None:
    SIMULATED.to_csv(tmp_path / "sim.csv", index=False)
    REAL.to_csv(tmp_path / "real.csv", index=False)
    result = CliRunner().invoke(main, ["compare", str(tmp_path / "sim.csv"), str(tmp_path / "real.csv"),
                                       "--match", "control=disambiguation", "--match", "control=control",
                                       "--resamples", "0", "--out", str(tmp_path / "o")])
    assert result.exit_code == 1, result.output
    assert result.stderr.startswith("Error: --match control=disambiguation --match control=control: ")
    assert result.stderr.count("\n") == 1 and not (tmp_path / "o").exists()
