"""A researcher's policy parameters are finite numbers: nan or inf (in the file, by --set, in a list
or a table) is one Error line naming the key, never the traceback of a run folder that cannot
record it (its config.toml and manifest.json hold the parameters, and JSON has no nan or inf)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from nudgecli.cli import main

EXPERIMENTS = Path(__file__).resolve().parents[1] / "experiments"


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "[0.5, nan]", "{ a = inf }"])
def test_a_parameter_that_is_not_finite_is_one_error_line(tmp_path: Path, value: str) -> None:
    shutil.copy(EXPERIMENTS / "custom-policy.toml", tmp_path / "exp.toml")
    shutil.copytree(EXPERIMENTS / "policies", tmp_path / "policies")
    out = tmp_path / "run"
    result = CliRunner().invoke(main, ["simulate", str(tmp_path / "exp.toml"), "--out", str(out),
                                       "--set", f"policies.threshold.params.weight={value}"])
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert result.exit_code == 1 and len(errors) == 1, result.output
    assert "policies.threshold.params: weight = " in errors[0] and "finite numbers" in errors[0], errors[0]
    assert not out.exists()
