"""A live (``nudge study``) folder holds a person's trials, which no command can make again: its
damaged files are named with advice that keeps them, and nothing simulates over them."""

from __future__ import annotations

import json
import re
import shlex
import shutil
from pathlib import Path

import pytest

pytest.importorskip("aiohttp", reason="the live server needs aiohttp: pip install '.[study]'")

import pandas as pd
from cli_helpers import nudge as _nudge
from live_helpers import played_folder

from nudgecli.run_folder_names import PART_KINDS
from nudgecli.run_folder_record import file_sha256


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    """A live folder: P01 finished (two trials, their questionnaires)."""
    out = tmp_path_factory.mktemp("live") / "study"
    played_folder(out, lambda s: False)
    return out


@pytest.fixture()
def live(recorded, tmp_path) -> Path:
    copy = tmp_path / "study"
    shutil.copytree(recorded, copy)
    return copy


def _one_error(result) -> str:
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert result.exit_code == 1 and len(errors) == 1, result.output
    return errors[0]


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("damage", ["unreadable", "deleted", "deleted, no questionnaires"])
def test_a_live_folder_without_its_manifest_is_never_advised_or_allowed_a_simulation(live, damage):
    manifest = live / "manifest.json"
    if damage == "unreadable":
        manifest.write_text('{"broken\n', encoding="utf-8")
    else:
        manifest.unlink()
    if "questionnaires" in damage:
        (live / "questionnaires.csv").unlink()
    before = _files(live)
    line = _one_error(_nudge("analyze", str(live)))
    assert "put manifest.json back from a copy" in line and "simulate again" not in line, line
    assert "--force" not in line and "nudge simulate" not in line, line
    for command in ("simulate", "run"):
        for flag in ("--force", "--resume"):
            line = _one_error(_nudge(command, str(live / "config.toml"), "--out", str(live), flag))
            assert "live study" in line, line
            assert _files(live) == before, (command, flag)


def _edit_manifest(folder: Path, edit) -> None:
    path = folder / "manifest.json"
    manifest = json.loads(path.read_text(encoding="utf-8"))
    edit(manifest)
    path.write_text(json.dumps(manifest, indent=2), encoding="utf-8")


def _record_checksums(folder: Path) -> None:
    """Record each part's SHA-256 in the manifest, in simulate's key and format (``nudge study``
    records it after each trial)."""
    def edit(manifest: dict) -> None:
        manifest["checksums"] = {key: {kind: file_sha256(part) for kind in PART_KINDS
                                       if (part := folder / kind / f"part-{int(key):04d}.parquet").is_file()}
                                 for key in manifest["live"]}

    _edit_manifest(folder, edit)


def test_a_live_folder_of_an_older_nudge_is_read_with_a_note_that_its_parts_are_unverified(live):
    _edit_manifest(live, lambda manifest: manifest.pop("checksums", None))
    result = _nudge("analyze", str(live))
    assert result.exit_code == 0, result.output
    assert f"Note: {live}: the manifest records no SHA-256 of the parts of 1 participant(s) (written by an " \
           "older nudge); they were read unverified" in result.output


@pytest.mark.parametrize("command", ["analyze", "habits"])
def test_a_live_folders_parts_are_verified_and_a_damaged_one_is_restored_from_a_backup(live, command):
    _record_checksums(live)
    assert _nudge("analyze", str(live)).exit_code == 0  # plot draws the metrics analyze wrote
    result = _nudge(command, str(live))  # habits: nothing to measure in a session without input
    assert "unverified" not in result.output and "SHA-256" not in result.output, result.output
    part = live / "trials" / "part-0001.parquet"
    kept = part.read_bytes()
    changed = pd.read_parquet(part)
    changed.loc[0, "success"] = not changed.loc[0, "success"]
    changed.to_parquet(part, index=False)
    # plot draws the metrics analyze wrote (their checksum verified), the parts only for --trial
    line = _one_error(_nudge(command, str(live), *(["--trial", "1:0"] if command == "plot" else [])))
    assert "trials/part-0001.parquet changed since it was written" in line, line
    assert "restore trials/part-0001.parquet from a backup" in line and "--resume`" not in line, line
    part.unlink()
    line = _one_error(_nudge(command, str(live)))
    assert "trials/part-0001.parquet (missing); restore trials/part-0001.parquet from a backup" in line, line
    assert "--resume`" not in line, line
    part.write_bytes(kept)
    _edit_manifest(live, lambda manifest: manifest["checksums"]["1"].pop("steps"))
    line = _one_error(_nudge(command, str(live)))
    assert "records no SHA-256 of steps/part-0001.parquet" in line and "from a backup" in line, line


@pytest.mark.parametrize("damage", ["deleted", "truncated"])
def test_a_live_folders_layouts_are_checked_and_the_command_named_writes_them_again(live, damage):
    assert _nudge("analyze", str(live)).exit_code == 0
    layouts = live / "layouts.parquet"
    kept = layouts.read_bytes()
    if damage == "deleted":
        layouts.unlink()
    else:
        layouts.write_bytes(kept[:100])
    commands = (("analyze",), ("plot",), ("plot", "--trial", "1:0"), ("habits",))
    lines = [_one_error(_nudge(args[0], str(live), *args[1:])) for args in commands]
    for line in lines:
        assert "layouts.parquet" in line and "--resume" not in line and "--force" not in line, line
    _restore_as_named(live, lines[0], kept)


def test_a_live_folders_layouts_edited_by_hand_are_refused_where_they_are_drawn(live):
    """The manifest records layouts.parquet's SHA-256 as simulate's does (``files``): a file rewritten
    with one goal moved is refused by plot (it drew the moved goal), named with the command that
    writes it again; analyze computes nothing from it, as for a simulated run."""
    layouts = live / "layouts.parquet"
    kept = layouts.read_bytes()
    assert _nudge("analyze", str(live)).exit_code == 0
    frame = pd.read_parquet(layouts)
    poses = list(frame.at[0, "goal_poses"])
    poses[0] += 10.0
    frame.at[0, "goal_poses"] = poses
    frame.to_parquet(layouts, index=False)
    before = _files(live)
    lines = [_one_error(_nudge("plot", str(live), *args)) for args in ((), ("--trial", "1:0"))]
    for line in lines:
        assert "layouts.parquet changed since it was written" in line and "--resume" not in line, line
    assert _files(live) == before
    _restore_as_named(live, lines[0], kept)
    recorded = json.loads((live / "manifest.json").read_text())["files"]
    assert recorded == {"layouts.parquet": file_sha256(layouts)}


def test_a_part_a_stopped_checkpoint_renamed_into_place_is_named_with_the_resume_not_a_backup(live):
    _record_checksums(live)
    part = live / "trials" / "part-0001.parquet"
    pd.read_parquet(part).iloc[:1].to_parquet(part, index=False)  # bytes its manifest does not record

    def stopped(manifest: dict) -> None:  # the checkpoint noted them before renaming (then stopped)
        manifest["live"]["1"].update(status="running", writing_parts={"trials": file_sha256(part)})
        manifest["status"] = "running"

    _edit_manifest(live, stopped)
    line = _one_error(_nudge("analyze", str(live)))
    assert "the session stopped while recording a trial; continue the participant's session with " \
           "`nudge study" in line and "--participant P01" in line and "backup" not in line, line


@pytest.fixture(scope="module")
def under_way(tmp_path_factory) -> Path:
    """A live folder whose study is under way: P01's two trials recorded, the questionnaire of the
    first block (control) answered, the second's (disambiguation) not yet."""
    out = tmp_path_factory.mktemp("live") / "study"
    session = played_folder(out, lambda s: len(s.entry["completed_trials"]) >= 2)
    assert len(session.entry["questionnaire_blocks"]) == 1
    return out


def test_the_answers_of_a_study_under_way_are_analysed_as_far_as_they_got(under_way, tmp_path):
    live = tmp_path / "study"
    shutil.copytree(under_way, live)
    answers = live / "questionnaires.csv"
    result = _nudge("analyze", str(live), "--questionnaires", str(answers))
    assert result.exit_code == 0, result.output
    assert f"Note: {answers}: no answers yet in condition(s) disambiguation of the study under way" \
           in result.output, result.output
    assert (live / "questionnaire_scores.csv").is_file()
    assert _nudge("plot", str(live)).exit_code == 0
    # a finished study's answers missing a condition: analysed in the conditions answered, said so
    _edit_manifest(live, lambda manifest: manifest.update(status="complete"))
    result = _nudge("analyze", str(live), "--questionnaires", str(answers))
    assert result.exit_code == 0, result.output
    assert f"Note: {answers}: no answers in condition(s) disambiguation; the questionnaires are analysed " \
           "in the conditions answered" in result.output, result.output


def test_plot_draws_a_recorded_trial_of_a_study_under_way_and_refuses_one_not_recorded(under_way, tmp_path):
    live = tmp_path / "study"
    shutil.copytree(under_way, live)
    assert _nudge("analyze", str(live)).exit_code == 0
    result = _nudge("plot", str(live), "--trial", "1:1")
    assert result.exit_code == 0 and (live / "figures" / "trajectory.png").is_file(), result.output
    line = _one_error(_nudge("plot", str(live), "--trial", "9:9"))
    assert "--trial 9:9: no such trial in" in line, line


def test_plot_of_a_finished_live_study_names_a_lost_part(live):
    assert _nudge("analyze", str(live)).exit_code == 0
    (live / "steps" / "part-0001.parquet").unlink()
    line = _one_error(_nudge("plot", str(live)))
    assert "steps/part-0001.parquet (missing); restore steps/part-0001.parquet from a backup" in line, line


@pytest.mark.parametrize("batch", [("replicate", "smoke", "-R", "2", "--participants", "2"),
                                   ("power", "smoke", "--participants", "2,3", "-R", "2")])
@pytest.mark.parametrize("flag", ["--force", "--resume"])
@pytest.mark.parametrize("manifest", ["kept", "deleted"])
def test_a_batch_never_writes_into_a_live_folder(live, batch, flag, manifest):
    if manifest == "deleted":
        (live / "manifest.json").unlink()
    before = _files(live)
    line = _one_error(_nudge(*batch, "--out", str(live), flag))
    assert "live" in line and "write the batch into another --out" in line, line
    assert _files(live) == before


def _restore_as_named(live: Path, line: str, kept: bytes) -> None:
    """Run the command ``line`` names to write the layouts again (beside the live folder), put them
    back, and check they are the bytes ``kept`` and that plot draws again."""
    command = re.search(r"`(nudge simulate [^`]*)`", line)
    assert command is not None, line
    assert _nudge(*shlex.split(command.group(1))[1:]).exit_code == 0
    layouts = live / "layouts.parquet"
    shutil.copy(live.with_name(f"{live.name}-layouts") / "layouts.parquet", layouts)
    assert layouts.read_bytes() == kept
    assert _nudge("plot", str(live), "--trial", "1:0").exit_code == 0
