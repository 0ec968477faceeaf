"""``nudge sweep`` tells the Note that ``simulate``, ``run``, ``replicate`` and ``power`` tell of a
``[policies.NAME]`` section no condition runs (docs/policies.md), once for the sweep, not once a
design point, and only of a section that no point runs."""

from __future__ import annotations

from pathlib import Path

import pytest
from batch_helpers import notes_a_sweep_tells
from policy_helpers import QUIET_POLICY, policy_experiment

from nudgecli.runs.sweep import load_sweep

ROOT = Path(__file__).resolve().parents[1]
NOTE = ("[policies.spare] (quiet:Quiet) is not in study.conditions, so not run (nor imported or checked); "
        "list it in study.conditions to run it")


def _sweep(tmp_path: Path, parameter: str) -> Path:
    """A grid sweep of ``parameter`` (a ``[parameters]`` line) over an experiment of two policies,
    ``mine`` and ``spare``, whose conditions list only ``mine`` (its plan the shipped custom-policy
    plan for them)."""
    policy_experiment(tmp_path, {"mine": "quiet:Quiet", "spare": "quiet:Quiet"},
                      conditions=["control", "mine"], modules={"quiet.py": QUIET_POLICY}, participants=2)
    plan = (ROOT / "analysis" / "custom-policy.toml").read_text()
    (tmp_path / "plan.toml").write_text(plan.replace('name = "custom-policy"', 'name = "mine"').replace(
        '["disambiguation", "blending", "threshold"]', '["control", "mine"]'))
    path = tmp_path / "sweep.toml"
    path.write_text('experiment = "mine.toml"\nplan = "plan.toml"\nreplications = 1\n'
                    f'[design]\nmethod = "grid"\n[parameters]\n{parameter}\n')
    return path


def test_a_sweep_tells_the_note_once_to_its_batch(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    sweep = _sweep(tmp_path, '"inference.kappa" = [0.6, 0.7]')
    told = notes_a_sweep_tells(sweep, tmp_path / "out", monkeypatch)
    assert told == (NOTE,)  # was: () (the note of no point told)


def test_a_section_some_point_runs_has_no_note(tmp_path: Path) -> None:
    swept = '"study.conditions" = [["control", "mine"], ["control", "spare"]]'
    assert load_sweep(str(_sweep(tmp_path, swept))).notes == ()
