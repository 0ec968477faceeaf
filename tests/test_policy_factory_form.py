"""A policy's factory written in another form than ``module:attribute`` is one Error line in the
house's words with the likeliest meaning as its example, not pydantic's pattern."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from nudgecli.cli import main

EXPERIMENTS = Path(__file__).resolve().parents[1] / "experiments"


@pytest.mark.parametrize(("factory", "example"), [
    ("mypol/turns:X", "mypol.turns:X"), ("mypol.turns.GoToLeader", "mypol.turns:GoToLeader"),
    ("mypol/turns.py:GoTo", "mypol.turns:GoTo"), ("x", "mypolicies:Mine"), ("", "mypolicies:Mine"),
])
def test_a_factory_not_written_module_colon_attribute_is_one_error_line(tmp_path: Path, factory: str,
                                                                       example: str) -> None:
    shutil.copy(EXPERIMENTS / "custom-policy.toml", tmp_path / "exp.toml")
    shutil.copytree(EXPERIMENTS / "policies", tmp_path / "policies")
    result = CliRunner().invoke(main, ["simulate", str(tmp_path / "exp.toml"), "--out", str(tmp_path / "run"),
                                       "--set", f'policies.threshold.factory="{factory}"'])
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert result.exit_code == 1 and len(errors) == 1, result.output
    assert (f"policies.threshold.factory: {factory!r} does not name a policy as module:attribute"
            in errors[0]), errors[0]
    assert f"e.g. {example!r}" in errors[0] and "should match pattern" not in errors[0], errors[0]
