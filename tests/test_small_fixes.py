"""The physiology-log example of docs/people.md runs as written, a truncated calibration stream warns,
config errors print plain numbers."""

from __future__ import annotations

import itertools
import re
import shlex
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from pydantic import ValidationError

from nudgecli.cli import main
from nudgecli.config import ExperimentConfig, load_experiment
from nudgecli.config_files import format_validation_error
from nudgecli.runs.study import run_study
from nudgecli.sim.calibration_profile import fit_calibration_dir

PEOPLE_DOC = Path(__file__).resolve().parents[1] / "docs" / "people.md"  # the physiology-log example
PILOT = Path(__file__).resolve().parents[2] / "shared" / "data" / "calibration" / "andrewtest"


@pytest.fixture(scope="module")
def pilot_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """What the physiology example's first command makes (`nudge simulate smoke --out results/pilot`), in a
    scratch working directory."""
    cwd = tmp_path_factory.mktemp("cwd")
    run_study(load_experiment("smoke"), cwd / "results" / "pilot")
    return cwd


def test_the_readme_physiology_example_works_with_the_toolkits_own_logs(pilot_run, monkeypatch):
    text = PEOPLE_DOC.read_text(encoding="utf-8")
    commands = re.findall(r"^nudge simulate .*$", text, flags=re.MULTILINE)
    make, use = next((a, b) for a, b in itertools.pairwise(commands) if "physiology_logs" in b)
    assert shlex.split(make)[1:] == ["simulate", "smoke", "--out", "results/pilot"]
    args = shlex.split(use)[1:]
    assert args[1] == "paper"
    monkeypatch.chdir(pilot_run)
    # the example's --set as written, on the smoke preset and one participant to stay fast
    result = CliRunner().invoke(main, ["simulate", "smoke", "--participants", "1", "--out", "with-logs",
                                       *args[2:]])
    assert result.exit_code == 0, result.output
    recorded = pd.read_parquet(pilot_run / "with-logs" / "participants.parquet")
    drawn = pd.read_parquet(pilot_run / "results" / "pilot" / "participants.parquet")
    assert not recorded.iloc[0].equals(drawn.iloc[0])  # participant 0 took the logged physiology


def test_a_truncated_label_stream_warns_and_a_complete_one_does_not(pilot_run, tmp_path):
    folder = pilot_run / "results" / "pilot" / "calibration" / "participant-0001"
    assert not [w for w in fit_calibration_dir(folder).warnings if "truncated" in w]
    cut = tmp_path / "cut"
    cut.mkdir()
    for log in folder.iterdir():
        (cut / log.name).write_bytes(log.read_bytes())
    stream = pd.read_csv(cut / "distortion_stream.csv", keep_default_na=False)
    stream.iloc[: len(stream) * 2 // 3].to_csv(cut / "distortion_stream.csv", index=False)
    warnings = [w for w in fit_calibration_dir(cut).warnings if "truncated" in w]
    assert len(warnings) == 1 and "distortion_stream.csv" in warnings[0]
    counted = re.search(r": (\d+) samples during the prompts", warnings[0])
    assert counted is not None and int(counted.group(1)) <= len(stream) * 2 // 3
    result = CliRunner().invoke(main, ["fit", str(cut), "--out", str(tmp_path / "p.json")])
    assert result.exit_code == 0 and "Warning: " in result.stderr and "truncated" in result.stderr


def test_a_real_pilot_stream_does_not_warn():
    if not (PILOT / "p_phm_given_phi").is_dir():
        pytest.skip(f"the pilot recordings are not here ({PILOT}); they stay outside the project")
    assert not [w for w in fit_calibration_dir(PILOT).warnings if "truncated" in w]


@pytest.mark.parametrize(("data", "shown"), [
    ({"study": {"time_limit_s": np.float64(-150.0)}}, "(got -150.0)"),
    ({"assistance": {"rho3": np.float64(1.5)}}, "(got 1.5)"),
    ({"population": {"rest_s": (np.float64(0.0), np.float64(150.0))}}, "got [0.0, 150.0]"),
])
def test_config_errors_print_plain_numbers(data, shown):
    with pytest.raises(ValidationError) as caught:
        ExperimentConfig.model_validate(data)
    message = format_validation_error(caught.value, "x.toml", ExperimentConfig)
    assert shown in message and "np." not in message
