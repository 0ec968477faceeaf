"""``nudgecli.Run.open(path).config`` is the experiment the run's manifest records, as every other
reader of a run takes it: an edited or damaged ``config.toml`` changes nothing read."""

from __future__ import annotations

import shutil
from pathlib import Path

import nudgecli


def test_an_opened_runs_config_is_the_manifests_not_an_edited_config_toml(analysed_smoke_run: Path,
                                                                        tmp_path: Path) -> None:
    run = tmp_path / "run"
    shutil.copytree(analysed_smoke_run, run)
    made = nudgecli.Run.open(run).config
    config = run / "config.toml"
    config.write_text(config.read_text().replace("participants = 2\n", "participants = 5\n"))
    assert "participants = 5\n" in config.read_text()
    assert nudgecli.Run.open(run).config == made
    config.write_text(config.read_text()[:120])  # damaged: the run itself is intact
    opened = nudgecli.Run.open(run)
    assert opened.config == made and opened.config.study.participants == 2
