"""A ``--force`` that replaces a run of a plan file, killed while it clears the old run, never leaves
the old run's plan copy (``plan.toml``) without its ``config.toml``: such a folder is no start, and
every command into it but ``--force`` was refused (``exists and is not empty``)."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest
from cli_helpers import dies_at_unlink, nudge

from nudgecli.run_folder_config import PLAN_SHA256_KEY
from nudgecli.run_folder_names import CONFIG, MANIFEST, PLAN_COPY

ROOT = Path(__file__).resolve().parents[1]
#: The options of ``analysed_smoke_run`` (tests/conftest.py).
SMOKE = ("smoke", "--participants", "2", "--seed", "5")


@pytest.fixture()
def run_of_a_plan_file(analysed_smoke_run: Path, tmp_path: Path) -> Path:
    """The smoke run as ``nudge run smoke --plan analysis/paper.toml`` leaves it: its plan's copy kept."""
    run = Path(shutil.copytree(analysed_smoke_run, tmp_path / "run"))
    data = (ROOT / "analysis" / "paper.toml").read_bytes()
    (run / PLAN_COPY).write_bytes(data)
    manifest = json.loads((run / MANIFEST).read_text())
    manifest.update({"plan": PLAN_COPY, PLAN_SHA256_KEY: hashlib.sha256(data).hexdigest()})
    (run / MANIFEST).write_text(json.dumps(manifest))
    return run


#: Killed as it removes the old run's config.toml, and as it removes its plan copy.
@pytest.mark.parametrize("dies_at", [CONFIG, PLAN_COPY])
def test_a_force_killed_while_clearing_never_leaves_the_plan_copy_without_config(
        run_of_a_plan_file: Path, monkeypatch: pytest.MonkeyPatch, dies_at: str) -> None:
    run = run_of_a_plan_file
    with dies_at_unlink(monkeypatch, run / dies_at):
        assert nudge("simulate", *SMOKE, "--force", "--out", run).exit_code == 130
    # was: plan.toml left after config.toml, the manifest gone: no start, and no run either
    assert (run / CONFIG).is_file() or not (run / PLAN_COPY).exists()
    if not (run / MANIFEST).exists():  # only a start: the command with --resume starts it afresh
        result = nudge("simulate", *SMOKE, "--out", run, "--resume")
        assert result.exit_code == 0, result.output
    else:  # a damaged run: --force replaces it
        assert nudge("simulate", *SMOKE, "--force", "--out", run).exit_code == 0
