"""``--match SIMULATED=REAL`` pairs conditions one to one: a REAL label the real table lacks is
refused with a "did you mean" (as an unknown SIMULATED one is), and so is a pairing that would
compare two simulated conditions as one real condition (their trials pooled)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.errors import DataError
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


def test_two_simulated_conditions_paired_with_one_real_one_are_refused() -> None:
    # the real table's own `control` would take the simulated control and disambiguation: 16 trials
    with pytest.raises(DataError, match=r"^--match disambiguation=control: the simulated conditions "
                                        r"'disambiguation' and 'control' of sim.csv would all be compared as "
                                        r"the real condition 'control'.*--match control=REAL pairs "
                                        r"'control'"):
        align_conditions(SIMULATED, REAL, {"disambiguation": "control"}, names=("sim.csv", "real.csv"))
    real_one = table({"pooled": 3}, prefix="r")
    with pytest.raises(DataError, match=r"^--match disambiguation=pooled --match control=pooled: the "
                                        r"simulated conditions 'disambiguation' and 'control'"):
        align_conditions(SIMULATED, real_one, {"disambiguation": "pooled", "control": "pooled"})


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
    for match in ("control=nope", "disambiguation=control"):
        result = CliRunner().invoke(main, ["compare", *sources, "--match", match, "--resamples", "0",
                                           "--out", str(tmp_path / "o")])
        assert result.exit_code == 1, result.output
        assert result.stderr.startswith("Error: --match ") and result.stderr.count("\n") == 1, result.stderr
        assert not (tmp_path / "o").exists()
