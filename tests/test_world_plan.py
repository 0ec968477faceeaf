"""The default analysis plan follows the world: a CIAA run whose experiment is not named like a plan
preset is analysed with the ``ciaa-teleop`` plan (its measures), not the paper's."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.config_files import list_presets, resolve_plan
from nudgecli.report.analysis import plan_of_source


@pytest.mark.parametrize(("given", "experiment", "world", "expected"), [
    (None, "my-ciaa", "ciaa", "ciaa-teleop"),  # no plan of the experiment's name: the world's plan
    (None, "study-code", "ciaa", "study-code"),  # the plan named like the experiment wins
    ("paper", "my-ciaa", "ciaa", "paper"),  # the plan given wins
    (None, "my-study", "grid", "paper"),  # the paper's world: paper
    (None, "my-study", None, "paper"),
])
def test_the_default_plan_follows_the_world(given: str | None, experiment: str, world: str | None,
                                            expected: str) -> None:
    assert resolve_plan(given, experiment=experiment, world=world) == expected


def _renamed_ciaa(tmp_path: Path) -> Path:
    text = list_presets("experiments")["ciaa-teleop"].read_text()
    path = tmp_path / "my-ciaa.toml"
    path.write_text(text.replace('name = "ciaa-teleop"', 'name = "my-ciaa"').replace(
        "participants = 10", "participants = 2"))
    return path


def test_a_renamed_ciaa_run_is_analysed_with_the_ciaa_plan(tmp_path: Path) -> None:
    out = tmp_path / "myc"
    result = CliRunner().invoke(main, ["run", str(_renamed_ciaa(tmp_path)), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "'ciaa-teleop' plan" in result.output
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["plan"] == "ciaa-teleop"
    metrics = [entry["metric"] for entry in json.loads((out / "stats.json").read_text())["metrics"]]
    assert "first_input_latency" in metrics and "active_input_fraction" in metrics
    assert "assistance_engagement" not in metrics and "human_turns" not in metrics
    # a manifest without a recorded plan (an older run): the plan of its world, too
    del manifest["plan"]
    (out / "manifest.json").write_text(json.dumps(manifest))
    assert plan_of_source(out) == "ciaa-teleop"
