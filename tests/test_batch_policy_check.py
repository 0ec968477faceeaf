"""A batch of a researcher's own policy checks the policy before any work, as ``nudge simulate`` and
``nudge sweep`` do: a parameter the policy refuses is one Error line and no batch folder."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from tests.test_custom_policy import _one_error_line

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "experiments" / "custom-policy.toml"
#: the shipped threshold policy refuses a weight outside [0, 1] (experiments/policies/threshold.py)
REFUSED = "policies.threshold.params.weight=2"
COMMANDS = {
    "replicate": ["replicate", str(EXAMPLE), "-R", "2", "--participants", "2"],
    "power": ["power", str(EXAMPLE), "-R", "2", "--participants", "2,4"],
}


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_batch_refuses_a_value_its_policy_refuses_before_a_folder_exists(tmp_path, command):
    out = tmp_path / "batch"
    result = CliRunner().invoke(main, [*COMMANDS[command], "--set", REFUSED, "--out", str(out)])
    _one_error_line(result, "condition 'threshold'", "policies.threshold:ThresholdAssist",
                    "weight must lie in [0, 1], got 2")
    assert not out.exists()


@pytest.mark.parametrize("flag", ["--force", "--resume"])
def test_a_refused_value_leaves_an_existing_batch_as_it_was(tmp_path, flag):
    out = tmp_path / "batch"
    made = CliRunner().invoke(main, [*COMMANDS["replicate"][:2], "-R", "1", "--participants", "2",
                                     "--out", str(out)])
    assert made.exit_code == 0, made.output
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    result = CliRunner().invoke(main, [*COMMANDS["replicate"], "--set", REFUSED, "--out", str(out), flag])
    _one_error_line(result, "weight must lie in [0, 1], got 2")
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before


@pytest.mark.parametrize("command", ["simulate", "run"])
def test_a_run_refuses_a_value_its_policy_refuses_before_a_folder_exists(tmp_path, command):
    out = tmp_path / "run"
    result = CliRunner().invoke(main, [command, str(EXAMPLE), "--participants", "2", "--set", REFUSED,
                                       "--out", str(out)])
    _one_error_line(result, "condition 'threshold'", "weight must lie in [0, 1], got 2")
    assert not out.exists()
