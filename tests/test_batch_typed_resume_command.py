"""The hint after Ctrl-C of a batch command names the command that resumes it, built by
``runs.batch_resume.typed_resume_command`` (the one owner beside the refusals' builder): the options
as typed, or, where the folder keeps its inputs, those in place of the experiment, ``--plan`` and
``--set`` typed."""

from __future__ import annotations

import json
from pathlib import Path

from nudgecli.runs.batch_folder import BATCH_MANIFEST, EXPERIMENT_COPY, INPUTS_KEY, PLAN_COPY
from nudgecli.runs.batch_resume import typed_resume_command

TYPED = [("replications", ["--replications", "3"]), ("plan", ["--plan", "mine.toml"]),
         ("overrides", ["--set", "study.seed=2"]), ("out", ["--out", "elsewhere"]), ("force", ["--force"])]


def test_a_folder_without_kept_inputs_is_resumed_with_the_options_as_typed(tmp_path: Path) -> None:
    folder = tmp_path / "batch"
    assert typed_resume_command(folder, "replicate", [("experiment", "smoke")], TYPED) == (
        f"nudge replicate smoke --replications 3 --plan mine.toml --set study.seed=2 --out {folder} --resume")


def test_a_folder_that_keeps_its_inputs_is_resumed_with_them(tmp_path: Path) -> None:
    folder = tmp_path / "batch"
    folder.mkdir()
    for name in (EXPERIMENT_COPY, PLAN_COPY):
        (folder / name).write_text("", encoding="utf-8")
    recorded = {"batch": {"kind": "replicate"}, INPUTS_KEY: {EXPERIMENT_COPY: "x", PLAN_COPY: "y"}}
    (folder / BATCH_MANIFEST).write_text(json.dumps(recorded), encoding="utf-8")
    assert typed_resume_command(folder, "replicate", [("experiment", "smoke")], TYPED) == (
        f"nudge replicate {folder / EXPERIMENT_COPY} --plan {folder / PLAN_COPY} --replications 3 "
        f"--out {folder} --resume")
