"""``nudge run`` without ``--plan`` checks the plan it will analyse with (the one named like the
experiment, else ``paper``) against the experiment's conditions before simulating anything, and a
plan that cannot analyse them is refused with the fix: a plan of one's own, given with ``--plan``."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

from nudgecli.config import load_experiment
from nudgecli.errors import ConfigError
from nudgecli.runs.study import checked_default_plan

ROOT = Path(__file__).resolve().parents[1]
SMALL = ("--participants", "1", "--set", "study.blocks_per_condition=1", "--set", "study.goal_counts=[3]",
         "--set", 'study.corners=["tr"]', "--set", 'study.start_modes=["x"]',
         "--set", "study.shared_layouts=1")


def test_run_refuses_a_default_plan_that_cannot_analyse_the_conditions_before_simulating(
        my_study: Path, tmp_path: Path) -> None:
    refused = nudge("run", my_study, *SMALL, "--out", tmp_path / "run1")
    assert refused.exit_code == 1
    line = one_error_line(refused.stderr)
    assert line.startswith("Error: paper: conditions names 'control'")
    assert "no analysis plan is named like experiment 'my-study'" in line
    assert "analysis/custom-policy.toml" in line and "--plan" in line
    assert 'conditions = ["disambiguation", "blending", "threshold"]' in line
    assert not (tmp_path / "run1").exists()  # nothing simulated, no folder left


def test_the_fix_the_refusal_names_works(my_study: Path, tmp_path: Path) -> None:
    plan = ROOT / "analysis" / "custom-policy.toml"
    done = nudge("run", my_study, *SMALL, "--plan", plan, "--out", tmp_path / "run1")
    assert done.exit_code == 0, done.output
    assert (tmp_path / "run1" / "stats.json").is_file()


def test_the_default_plan_is_the_one_named_like_the_experiment_else_paper(my_study: Path) -> None:
    assert checked_default_plan(load_experiment(str(ROOT / "experiments" / "custom-policy.toml"))).name == \
        "custom-policy"
    assert checked_default_plan(load_experiment("smoke")).name == "paper"
    with pytest.raises(ConfigError, match="so it is the default"):
        checked_default_plan(load_experiment(str(my_study)))
    # a plan named like the experiment that does not fit is refused too, saying which it is
    custom = load_experiment(str(ROOT / "experiments" / "custom-policy.toml"),
                             ["study.conditions=[\"disambiguation\", \"control\", \"threshold\"]"])
    with pytest.raises(ConfigError, match="it is the plan named like the experiment"):
        checked_default_plan(custom)
