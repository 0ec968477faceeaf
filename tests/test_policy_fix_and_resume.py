"""A run stopped by its policy raising in the first participant resumes with the fixed policy: no
participant finished, so nothing would be mixed, and the run takes the code the experiment imports
now (its copies replaced, a Note says so); once a participant has finished, an edited module is
refused as before (tests/test_policy_copy.py), naming --force (docs/policies.md)."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
from cli_helpers import nudge, one_error_line
from policy_helpers import policy_experiment

from nudgecli.store import RunFolder

POLICY = """
from nudgecli.sim.policy_interface import Assistance, AutonomyTurn


class Mine:
    infers = True
    takes_turns = False

    def assist(self, view):
        if view.step > 3:
            BUG
        return Assistance(view.u_h)

    def start_turn(self, view):
        return AutonomyTurn.stay()
"""


def _experiment(folder: Path, bug: str) -> Path:
    return policy_experiment(folder, {"mine": "mypol.mine:Mine"},
                             modules={"mypol/__init__.py": "", "mypol/mine.py": POLICY.replace("BUG", bug)})


def test_a_policy_that_raised_before_any_participant_finished_is_fixed_and_resumed(tmp_path: Path) -> None:
    experiment = _experiment(tmp_path / "exp", "1 / 0")
    run = tmp_path / "R"
    failed = nudge("simulate", experiment, "--out", run)
    assert failed.exit_code == 1
    assert "ZeroDivisionError" in one_error_line(failed.output)
    assert json.loads((run / "manifest.json").read_text())["completed"] == []
    _experiment(tmp_path / "exp", "pass")  # the policy fixed
    resumed = nudge("simulate", experiment, "--out", run, "--resume")
    assert resumed.exit_code == 0, resumed.output
    assert "no participant had finished" in resumed.output
    assert (run / "mypol" / "mine.py").read_text() == (tmp_path / "exp" / "mypol" / "mine.py").read_text()
    fresh = tmp_path / "fresh"
    assert nudge("simulate", _experiment(tmp_path / "exp2", "pass"), "--out", fresh).exit_code == 0
    pd.testing.assert_frame_equal(RunFolder(run).read_trials(), RunFolder(fresh).read_trials())
    # finished participants: another edit would mix two policies
    _experiment(tmp_path / "exp", "pass  # edited")
    refused = nudge("simulate", experiment, "--out", run, "--resume")
    assert refused.exit_code == 1
    line = one_error_line(refused.output)
    assert "mix two policies" in line and "--force" in line, line
