"""Three small mends: ``participant_medians.csv`` names each row's simulated condition, a
one-column ``compare.png`` keeps its legend inside the figure, and a file's inconsistency that
its ``--set`` overrides mend is taken (docs/people.md, docs/baselines.md)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from nudgecli.config import load_experiment
from nudgecli.errors import ConfigError
from nudgecli.report.compare import CompareOptions, compare_sources, compare_tables, participant_medians
from nudgecli.report.compare_figure import build_compare_figure
from tests.test_policies import POLICY_TOML

BLENDING = '[blending]\ngate = "gap"\ngap = 0.4\n'


def trials(prefix: str, conditions: list[str], seed: int) -> pd.DataFrame:
    """A small metrics table: 4 participants, 4 trials each per condition."""
    rng = np.random.default_rng(seed)
    n = 16 * len(conditions)
    return pd.DataFrame({"participant": [f"{prefix}{i % 4}" for i in range(n)],
                         "condition": [c for c in conditions for _ in range(16)],
                         "completion_time": rng.normal(20.0, 3.0, n)})


# --- 1. participant_medians.csv names the simulated condition ------------------------------------

def test_participant_medians_name_the_simulated_condition_of_a_match(tmp_path: Path) -> None:
    simulated, real = tmp_path / "sim.csv", tmp_path / "real.csv"
    trials("s", ["disambiguation", "none"], 1).to_csv(simulated, index=False)
    trials("r", ["control"], 2).to_csv(real, index=False)
    result = compare_sources(simulated, real, condition_map={"disambiguation": "control"},
                             options=CompareOptions(resamples=0), notes=[])
    medians = result.medians
    assert list(medians.columns) == ["source", "metric", "condition", "simulated_condition", "real_condition",
                                     "participant", "n", "median"]
    assert set(medians["condition"]) == set(medians["real_condition"]) == {"control"}
    assert set(medians["simulated_condition"]) == {"disambiguation"}  # on the real people's rows too
    assert set(medians["source"]) == {"simulated", "real"}
    # a condition compared under its own name is its own simulated condition
    alone = participant_medians(trials("s", ["none"], 3), trials("r", ["none"], 4), ["completion_time"])
    assert set(alone["simulated_condition"]) == {"none"}


# --- 2. a one-column compare figure keeps its legend inside ---------------------------------------

@pytest.mark.parametrize("conditions", [["none"], ["none", "blending"]])
def test_the_compare_figures_legend_lies_inside_the_figure(conditions: list[str]) -> None:
    simulated, real = trials("s", conditions, 5), trials("r", conditions, 6)
    comparison = compare_tables(simulated, real, ["completion_time"], conditions, CompareOptions(resamples=0))
    figure = build_compare_figure({"simulated": simulated, "real": real}, comparison,
                                  participant_medians(simulated, real, ["completion_time"]))
    figure.canvas.draw()
    legend, frame = figure.legends[0].get_window_extent(), figure.bbox
    assert frame.x0 <= legend.x0 and legend.x1 <= frame.x1, (legend, frame)
    assert frame.y0 <= legend.y0 and legend.y1 <= frame.y1, (legend, frame)


# --- 3. --set mends a file's inconsistency -------------------------------------------------------

def test_a_files_gap_without_its_gate_is_mended_by_setting_the_gate(tmp_path: Path) -> None:
    path = tmp_path / "mine.toml"
    path.write_text(POLICY_TOML.replace(BLENDING, '[blending]\ngate = "none"\ngap = 0.3\n'))
    with pytest.raises(ConfigError, match=rf'^{path}: blending\.gap: 0\.3 is not used with gate = "none"'):
        load_experiment(str(path))
    mended = load_experiment(str(path), ["blending.gate=gap"])
    assert mended.blending is not None and (mended.blending.gate, mended.blending.gap) == ("gap", 0.3)
    # overrides that do not mend it: the refusal still names the file
    with pytest.raises(ConfigError, match=rf"^{path}: blending\.gap: 0\.3 is not used"):
        load_experiment(str(path), ["study.participants=2"])


def test_a_fault_of_the_overrides_own_still_names_the_set(tmp_path: Path) -> None:
    path = tmp_path / "mine.toml"
    path.write_text(POLICY_TOML)
    with pytest.raises(ConfigError, match=r"^--set blending\.gate=none: blending\.gap: 0\.4 is not used"):
        load_experiment(str(path), ["blending.gate=none", "blending.gap=0.4"])


def test_a_mended_file_with_a_fault_of_the_overrides_own_names_the_set(tmp_path: Path) -> None:
    path = tmp_path / "mine.toml"
    path.write_text(POLICY_TOML.replace(BLENDING, '[blending]\ngate = "none"\ngap = 0.3\n'))
    # the gate set mends the file; what remains is the other override's, not the file's old refusal
    with pytest.raises(ConfigError, match=r"^--set study\.participants=0: study\.participants: ") as caught:
        load_experiment(str(path), ["blending.gate=gap", "study.participants=0"])
    assert "blending.gap" not in str(caught.value)


def test_a_mended_file_with_another_fault_of_its_own_names_the_file_and_that_fault(tmp_path: Path) -> None:
    path = tmp_path / "mine.toml"
    path.write_text(POLICY_TOML.replace(BLENDING, '[blending]\ngate = "none"\ngap = 0.3\n')
                    .replace("time_limit_s = 60.0", "time_limit_s = -1.0"))
    with pytest.raises(ConfigError, match=rf"^{path}: study\.time_limit_s: ") as caught:
        load_experiment(str(path), ["blending.gate=gap"])
    message = str(caught.value)
    assert "blending.gap" not in message and "more problem" not in message  # the mended one is no problem
