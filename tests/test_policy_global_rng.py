"""A researcher's policy that draws from numpy's or Python's global random generator
(``np.random.randint``, ``random.random``) makes the tables of one seed differ from run to run and
with ``--workers``: the run says so once, as a ``Warning:`` line naming the conditions and policies
and ``view.rng`` as the fix, and keeps its tables as simulated (docs/policies.md)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from cli_helpers import nudge
from policy_helpers import policy_experiment

from nudgecli.store import RunFolder

POLICY = """
import random

import numpy as np

from nudgecli.sim.policy_interface import Assistance, AutonomyTurn


class Mine:
    infers = True
    takes_turns = False

    def assist(self, view):
        DRAW
        return Assistance(view.u_h)

    def start_turn(self, view):
        return AutonomyTurn.stay()
"""


def _run(tmp_path: Path, name: str, draw: str, *options: str) -> tuple[str, pd.DataFrame]:
    experiment = policy_experiment(tmp_path / name, {"mine": "mymodule:Mine"},
                                   modules={"mymodule.py": POLICY.replace("DRAW", draw)}, participants=2)
    result = nudge("simulate", experiment, "--out", tmp_path / name / "run", *options)
    assert result.exit_code == 0, result.output
    return result.output, RunFolder(tmp_path / name / "run").read_trials()


@pytest.mark.parametrize("workers", ["1", "2"])
@pytest.mark.parametrize("draw", ["np.random.randint(0, 10)", "random.random()"])
def test_a_policy_drawing_from_a_global_generator_is_one_warning_naming_it_and_view_rng(
        tmp_path: Path, draw: str, workers: str) -> None:
    output, trials = _run(tmp_path, "drawing", draw, "--workers", workers)
    warnings = [line for line in output.splitlines() if line.startswith("Warning:")]
    assert len(warnings) == 1, output
    assert "condition 'mine' (policy mymodule:Mine)" in warnings[0] and "view.rng" in warnings[0]
    assert "global random generator" in warnings[0] and "Error" not in output
    # the draw is unused: the tables are those of the same policy without it (the check changes nothing)
    quiet_output, quiet = _run(tmp_path, "quiet", "pass", "--workers", workers)
    assert "Warning:" not in quiet_output, quiet_output
    pd.testing.assert_frame_equal(trials, quiet, check_exact=True)
