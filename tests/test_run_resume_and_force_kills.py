"""A run's resume and its ``--force`` replacement after a kill or Ctrl-C at a write boundary:
``nudge run --resume`` analyses with the plan the manifest records and its Ctrl-C hint names
``--plan``; a folder killed before its manifest (or its config.toml) is advised and restarted by
the command that works; a ``--force`` killed while it clears the old run never leaves the old
analysis without its run."""

from __future__ import annotations

import json
import shlex
import shutil
from pathlib import Path
from types import SimpleNamespace

import pandas as pd
import pytest
from cli_helpers import dies_at_unlink, nudge, one_error_line

import nudgecli.api
from nudgecli.run_folder_names import CONFIG, LOCK, MANIFEST, METRICS_CSV, PARTICIPANTS, STATS_JSON
from nudgecli.store import RunFolder

#: The options of ``analysed_smoke_run`` (tests/conftest.py).
SMOKE = ("smoke", "--participants", "2", "--seed", "5")


@pytest.fixture()
def run(analysed_smoke_run: Path, tmp_path: Path) -> Path:
    return Path(shutil.copytree(analysed_smoke_run, tmp_path / "run"))


def _interrupt_line(output: str) -> str:
    (line,) = [x for x in output.splitlines() if x.startswith("Interrupted")]
    return line


# --- 1. a resumed `nudge run` keeps its plan --------------------------------------------------

def test_a_run_resumed_without_plan_is_analysed_with_the_plan_its_manifest_records(
        run: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    manifest = json.loads((run / MANIFEST).read_text())
    (run / MANIFEST).write_text(json.dumps({**manifest, "plan": "study-code"}))  # `run --plan study-code`
    analysed: list[object] = []

    def analyze(source: Path, plan: str) -> SimpleNamespace:
        analysed.append(plan)
        return SimpleNamespace(out=source, notes=[])

    monkeypatch.setattr("nudgecli.report.analysis.analyze", analyze)
    monkeypatch.setattr("nudgecli.report.plotting.plot_folder", lambda *a, **k: [])
    nudgecli.api.analyze_and_plot(run)  # what `nudge run ... --resume` does after simulating
    assert analysed == ["study-code"]
    nudgecli.api.analyze_and_plot(run, plan="paper")  # a --plan given: that one
    assert analysed[-1] == "paper"


#: Ctrl-C before the run's manifest (only its start written), and in its first participant's parts.
@pytest.mark.parametrize("interrupted_in", ["write_layouts", "write_participant_parts"])
def test_the_ctrl_c_hint_of_run_offers_run_with_its_plan(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                         interrupted_in: str) -> None:
    def interrupted(*_: object) -> str:
        raise KeyboardInterrupt

    monkeypatch.setattr(RunFolder, interrupted_in, interrupted)
    result = nudge("run", "smoke", "--participants", "1", "--seed", "3", "--plan", "study-code",
                   "--out", tmp_path / "run")
    assert result.exit_code == 130, result.output
    line = _interrupt_line(result.output)
    simulate, run_too = line.split(" (or, to analyse and plot too: ")  # was: simulate alone, before any
    assert "nudge simulate smoke" in simulate and "--plan" not in simulate, line
    words = shlex.split(run_too.rstrip(")"))
    assert words[:3] == ["nudge", "run", "smoke"] and words[-1] == "--resume", line
    assert words[words.index("--plan") + 1] == "study-code", line  # was: no --plan


# --- 3. a run killed before its manifest ------------------------------------------------------

def _killed_before_manifest(folder: Path) -> None:
    """What a run killed as it wrote its layouts leaves: its config.toml and a layouts temporary."""
    for entry in folder.iterdir():
        if entry.name != CONFIG:
            shutil.rmtree(entry) if entry.is_dir() else entry.unlink()
    (folder / ".layouts.parquet.a1b2c3d4.tmp").write_bytes(b"half")


def test_analyze_and_plot_of_a_run_killed_before_its_manifest_name_its_config(run: Path) -> None:
    _killed_before_manifest(run)
    advice = {one_error_line(nudge(command, run).output) for command in ("analyze", "plot")}
    assert len(advice) == 1, advice  # plot says what analyze says
    (line,) = advice
    command = shlex.split(line.split("start it again with `", 1)[1].split("`", 1)[0])
    assert command == ["nudge", "simulate", str(run / CONFIG), "--out", str(run), "--resume"], line
    result = nudge(*command[1:])
    assert result.exit_code == 0, result.output
    assert json.loads((run / MANIFEST).read_text())["status"] == "complete"


# --- 4. --force killed while it clears the old run ------------------------------------------

@pytest.mark.parametrize("dies_at", [PARTICIPANTS, MANIFEST, CONFIG])
def test_a_force_killed_while_clearing_never_leaves_the_old_analysis_without_its_run(
        run: Path, monkeypatch: pytest.MonkeyPatch, dies_at: str) -> None:
    with dies_at_unlink(monkeypatch, run / dies_at):
        assert nudge("simulate", "smoke", "--seed", "9", "--force", "--out", run).exit_code == 130
    assert (run / METRICS_CSV).exists() is False and (run / STATS_JSON).exists() is False
    assert nudge("plot", run).exit_code == 1  # was: exit 0, the old run's metrics drawn


# --- 5. a run killed as it wrote its config.toml -----------------------------------------------

@pytest.mark.parametrize("resume", [True, False])
def test_a_folder_holding_only_the_config_temporary_is_a_start(tmp_path: Path, resume: bool) -> None:
    out = tmp_path / "run"
    out.mkdir()
    (out / ".config.toml.x1y2z3w4.tmp").write_text("[experiment]\n")
    (out / LOCK).write_text("")
    args = ["simulate", "smoke", "--participants", "1", "--seed", "7", "--out", out]
    result = nudge(*args, *(["--resume"] if resume else []))
    assert result.exit_code == 0, result.output  # was: exists and is not empty; use --force
    assert not list(out.glob(".*.tmp")) and (out / CONFIG).is_file()
    assert not pd.read_parquet(out / PARTICIPANTS).empty


def test_a_temporary_beside_a_file_of_ones_own_is_no_start(tmp_path: Path) -> None:
    out = tmp_path / "run"
    out.mkdir()
    (out / ".config.toml.x1y2z3w4.tmp").write_text("[experiment]\n")
    (out / "notes.txt").write_text("mine")
    result = nudge("simulate", "smoke", "--participants", "1", "--seed", "7", "--out", out, "--resume")
    assert "exists and is not empty" in one_error_line(result.output)
    assert (out / "notes.txt").read_text() == "mine"
