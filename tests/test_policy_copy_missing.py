"""A resume of a run whose copy of a policy module was deleted (``rm R/mypol/quiet.py``) says the
copy is missing and how to restore it (the command that started the run writes it again), as one
``Error:`` line; the command that started the run, resumed, restores it (docs/policies.md)."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line
from policy_helpers import QUIET_POLICY, policy_experiment

POLICY = QUIET_POLICY


def test_a_resume_without_the_runs_policy_copy_says_it_is_missing_and_how_to_restore_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    experiment = policy_experiment(tmp_path / "exp", {"quiet": "mypol.quiet:Quiet"},
                                   modules={"mypol/__init__.py": "", "mypol/quiet.py": POLICY})
    monkeypatch.chdir(tmp_path)
    run = tmp_path / "R"
    assert nudge("simulate", experiment, "--out", run).exit_code == 0
    copy = run / "mypol" / "quiet.py"
    kept = copy.read_bytes()
    copy.unlink()
    refused = nudge("simulate", run / "config.toml", "--out", run, "--resume")
    assert refused.exit_code == 1, refused.output
    line = one_error_line(refused.output)
    assert "no longer imports" not in line and "delete it" not in line, line
    assert f"{copy}" in line and "missing" in line, line
    assert f"nudge simulate EXPERIMENT --out {run} --resume" in line, line
    restored = nudge("simulate", experiment, "--out", run, "--resume")
    assert restored.exit_code == 0, restored.output
    assert copy.read_bytes() == kept


def test_a_deleted_copy_whose_module_imports_from_sys_path_is_still_a_missing_copy(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    experiment = policy_experiment(tmp_path / "exp", {"quiet": "mypol.quiet:Quiet"},
                                   modules={"mypol/__init__.py": "", "mypol/quiet.py": POLICY})
    run = tmp_path / "R"
    assert nudge("simulate", experiment, "--out", run).exit_code == 0
    (run / "mypol" / "quiet.py").unlink()
    monkeypatch.syspath_prepend(str(tmp_path / "exp"))  # as `python -m nudgecli` typed in exp/ finds it
    refused = nudge("simulate", run / "config.toml", "--out", run, "--resume")
    assert refused.exit_code == 1, refused.output
    line = one_error_line(refused.output)
    assert "no longer imports" not in line and "delete it" not in line, line
    copy = run / "mypol" / "quiet.py"
    assert f"{copy}: the run's copy of its policy module mypol/quiet.py is missing" in line, line
