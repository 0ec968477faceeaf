"""``nudge run --resume`` without ``--plan`` checks the plan its analysis will take (the one the
run's manifest records, which ``nudge simulate`` records too, else the default) before it simulates
the rest, and refuses one that cannot analyse the run's conditions as a fresh run does."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

from nudgecli.api.run_plan import check_run_plan
from nudgecli.config import load_experiment
from nudgecli.errors import ConfigError
from nudgecli.run_folder_names import MANIFEST

ROOT = Path(__file__).resolve().parents[1]


def _interrupted_run(folder: Path, plan: str) -> Path:
    """A run folder of my-study interrupted after no participant, whose manifest records ``plan``."""
    folder.mkdir()
    (folder / MANIFEST).write_text(json.dumps({"experiment": "my-study", "plan": plan, "participants": 2,
                                               "status": "interrupted", "completed": []}))
    return folder


def test_a_resume_of_a_simulated_run_whose_recorded_plan_cannot_analyse_it_is_refused_before_simulating(
        my_study: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    run = _interrupted_run(tmp_path / "run", "paper")  # `nudge simulate` records the default plan

    def simulated(*_: object, **__: object) -> None:
        raise AssertionError("simulated before the plan was checked")

    monkeypatch.setattr("nudgecli.api.simulate", simulated)
    line = one_error_line(nudge("run", my_study, "--out", run, "--resume").output)
    assert line.startswith("Error: paper: conditions names 'control'"), line  # was: simulated, then refused
    assert "--plan" in line


def test_a_recorded_plan_that_analyses_the_conditions_is_kept_where_the_default_cannot(
        my_study: Path, tmp_path: Path) -> None:
    experiment = load_experiment(str(my_study))
    fitting = str(ROOT / "analysis" / "custom-policy.toml")  # as an older nudge recorded a plan file
    check_run_plan(experiment, _interrupted_run(tmp_path / "kept", fitting))
    with pytest.raises(ConfigError, match="so it is the default"):  # no run there: the default plan
        check_run_plan(experiment, tmp_path / "fresh")
    refused = _interrupted_run(tmp_path / "other", "baselines")
    with pytest.raises(ConfigError, match=f"it is the plan {refused} records in its {MANIFEST}"):
        check_run_plan(experiment, refused)
