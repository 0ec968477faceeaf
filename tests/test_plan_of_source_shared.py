"""``nudgecli.plan_of`` takes the plan of a source from ``plan_of_source``, the analysis's one rule,
taking a damaged manifest as none (plotting says what is wrong) where the analysis refuses it."""

from __future__ import annotations

from pathlib import Path

import pytest

from nudgecli.api import plan_of
from nudgecli.errors import RunFolderError
from nudgecli.report.recorded_plans import plan_of_source


def test_plan_of_a_folder_whose_manifest_is_damaged_is_the_default_where_analysis_refuses(tmp_path: Path):
    (tmp_path / "manifest.json").write_text("{not json", encoding="utf-8")
    assert plan_of(tmp_path) == plan_of_source(tmp_path, damaged_manifest=True) == "paper"
    with pytest.raises(RunFolderError, match="unreadable manifest"):
        plan_of_source(tmp_path)


def test_plan_of_a_given_plan_is_that_plan(tmp_path: Path):
    (tmp_path / "manifest.json").write_text("{not json", encoding="utf-8")
    # a plan other than the default ("paper"), so that a given plan ignored is seen
    assert plan_of(tmp_path, "baselines") == "baselines"
