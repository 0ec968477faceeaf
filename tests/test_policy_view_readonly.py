"""A policy's ``view`` is the session itself: the belief it hands out is read-only, so a policy that
writes into ``view.belief`` is one policy error (docs/policies.md), never a corrupted inference."""

from __future__ import annotations

import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from nudgecli.cli import main

POLICY = """
from nudgecli.sim.policy_interface import Assistance, AutonomyTurn

class Writer:
    infers = True
    takes_turns = {takes_turns}

    def assist(self, view):
        {assist}
        return Assistance(view.u_h)

    def start_turn(self, view):
        {start_turn}
        return AutonomyTurn.stay()
"""

EXPERIMENT = """
[experiment]
name = "writer"

[study]
participants = 1
conditions = ["control", "writer"]
goal_counts = [3]
corners = ["tr"]
start_modes = ["x"]
blocks_per_condition = 1

[policies.writer]
factory = "writermodule:Writer"
"""


def _simulate(tmp_path: Path, *, assist: str = "pass", start_turn: str = "pass",
              takes_turns: bool = False) -> tuple[Path, object]:
    (tmp_path / "writermodule.py").write_text(textwrap.dedent(POLICY).format(
        assist=assist, start_turn=start_turn, takes_turns=takes_turns))
    (tmp_path / "writer.toml").write_text(EXPERIMENT)
    sys.modules.pop("writermodule", None)  # each test's module is its own
    out = tmp_path / "run"
    return out, CliRunner().invoke(main, ["simulate", str(tmp_path / "writer.toml"), "--out", str(out)])


@pytest.mark.parametrize(("hook", "takes_turns"), [("assist", False), ("start_turn", True)])
def test_writing_into_the_views_belief_is_one_policy_error_line(tmp_path: Path, hook: str,
                                                               takes_turns: bool) -> None:
    _, result = _simulate(tmp_path, **{hook: "view.belief[:] = 0"}, takes_turns=takes_turns)
    assert result.exit_code == 1, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert len(errors) == 1 and "Traceback" not in result.output, result.output
    assert "condition 'writer' (policy writermodule:Writer)" in errors[0]
    assert f"{hook} raised ValueError" in errors[0] and "read-only" in errors[0]


def test_every_belief_a_policy_sees_is_read_only_and_still_the_posterior(tmp_path: Path) -> None:
    # the policy refuses a writable belief, and one that is no distribution: the flag is set on
    # the first belief and on every update, and setting it changes no value
    check = ("assert not view.belief.flags.writeable, 'writable'; "
             "assert abs(float(view.belief.sum()) - 1.0) < 1e-9 and (view.belief >= 0).all(), 'not a belief'")
    out, result = _simulate(tmp_path, assist=check, start_turn=check, takes_turns=True)
    assert result.exit_code == 0, result.output
    assert (out / "trials").exists()


def test_a_read_only_belief_still_reads_as_numpy_reads_any_array() -> None:
    # the protocol and the built-in policies only read the belief: copying, argmax and arithmetic
    # of a read-only array give new arrays, as for a writable one
    belief = np.array([0.2, 0.5, 0.3])
    belief.setflags(write=False)
    assert int(np.argmax(belief)) == 1
    assert (belief * 2).flags.writeable and belief.copy().flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        belief[0] = 1.0
