"""Nothing in a run folder is taken on trust: its simulated calibration logs are recorded in the
manifest (``calibration_checksums``) and verified wherever they are read (``nudge fit``, a
``population.physiology_logs`` recording, a resume), as its parts are; and an ``--out`` that is
itself a symbolic link, or a link at a batch table's name, is refused like a linked part folder
(:func:`nudgecli.run_folder_state.refuse_links`)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

from nudgecli.errors import RunFolderError
from nudgecli.sim.calibration_readers import read_distortion_session

LOGS = Path("calibration") / "participant-0000"
STREAM = LOGS / "distortion_stream.csv"


@pytest.fixture
def run(analysed_smoke_run: Path, tmp_path: Path) -> Path:
    """A copy of the analysed smoke run (two participants), to damage."""
    copy = tmp_path / "run"
    shutil.copytree(analysed_smoke_run, copy)
    return copy


def _truncate(path: Path) -> None:
    lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
    path.write_text("".join(lines[:-3]), encoding="utf-8")  # still a readable log, three rows short


def test_the_manifest_records_each_calibration_log(run: Path) -> None:
    recorded = json.loads((run / "manifest.json").read_text())["calibration_checksums"]
    assert sorted(recorded) == ["0", "1"]
    assert set(recorded["0"]) == {p.name for p in (run / LOGS).iterdir()}
    assert set(recorded["0"]) >= {"distortion_stream.csv", "mapping_prompts.csv"}


def test_fit_refuses_a_truncated_calibration_log(run: Path, tmp_path: Path) -> None:
    assert nudge("fit", run / LOGS, "--out", tmp_path / "before.json").exit_code == 0
    _truncate(run / STREAM)
    result = nudge("fit", run / LOGS, "--out", tmp_path / "after.json")
    line = one_error_line(result.output)
    assert result.exit_code != 0 and not (tmp_path / "after.json").exists()
    assert f"{run}: {STREAM.as_posix()} changed since it was written (its SHA-256 differs" in line
    assert "--resume" in line


def test_fit_refuses_a_calibration_log_gone(run: Path, tmp_path: Path) -> None:
    (run / LOGS / "mapping_responses.csv").unlink()
    line = one_error_line(nudge("fit", run / LOGS, "--out", tmp_path / "p.json").output)
    assert f"{run} is incomplete: {(LOGS / 'mapping_responses.csv').as_posix()} (missing)" in line


def test_a_recording_naming_an_edited_run_log_is_refused(run: Path) -> None:
    assert read_distortion_session(run / LOGS) is not None
    _truncate(run / STREAM)
    with pytest.raises(RunFolderError, match="changed since it was written"):
        read_distortion_session(run / LOGS)


def test_a_run_of_an_older_nudge_reads_its_logs_as_before(run: Path, tmp_path: Path) -> None:
    manifest = json.loads((run / "manifest.json").read_text())
    del manifest["calibration_checksums"]  # as an older nudge wrote it: absent key, not checked
    (run / "manifest.json").write_text(json.dumps(manifest))
    _truncate(run / STREAM)
    assert nudge("fit", run / LOGS, "--out", tmp_path / "p.json").exit_code == 0


def test_a_resume_simulates_again_a_participant_whose_log_changed(tmp_path: Path) -> None:
    out = tmp_path / "run"
    assert nudge("simulate", "smoke", "--participants", "1", "--seed", "5", "--out", out).exit_code == 0
    written = (out / STREAM).read_bytes()
    _truncate(out / STREAM)
    result = nudge("simulate", "smoke", "--participants", "1", "--seed", "5", "--out", out, "--resume")
    assert result.exit_code == 0
    assert f"{STREAM.as_posix()} (changed since written)" in result.output
    assert (out / STREAM).read_bytes() == written


@pytest.mark.parametrize("command", [("simulate", "smoke", "--participants", "1"),
                                     ("run", "smoke", "--participants", "2"),
                                     ("replicate", "smoke", "-R", "1", "--participants", "2")])
@pytest.mark.parametrize("target_exists", [True, False])
def test_an_out_that_is_a_link_is_refused(tmp_path: Path, command: tuple[str, ...],
                                          target_exists: bool) -> None:
    real = tmp_path / "elsewhere" / "real"
    if target_exists:
        real.mkdir(parents=True)
    link = tmp_path / "out"
    link.symlink_to(real, target_is_directory=True)
    line = one_error_line(nudge(*command, "--out", link).output)
    assert f"{link} is a symbolic link (to {real})" in line
    assert f"give the real folder, {real.resolve()}" in line
    assert link.is_symlink()
    assert (list(real.iterdir()) == []) if target_exists else not real.exists()  # nothing written through it


@pytest.mark.parametrize("table", ["summary.csv", "replications.csv"])
def test_a_batch_refuses_a_link_at_a_table_name(tmp_path: Path, table: str) -> None:
    mine = tmp_path / "elsewhere" / table
    mine.parent.mkdir()
    mine.write_text("mine\n")
    out = tmp_path / "batch"
    out.mkdir()
    (out / table).symlink_to(mine)
    line = one_error_line(nudge("replicate", "smoke", "-R", "1", "--participants", "2", "--out", out,
                                "--force").output)
    assert f"{out / table} is a symbolic link (to {mine})" in line
    assert mine.read_text() == "mine\n" and (out / table).is_symlink()
    assert not (out / "batch.json").exists()


def test_a_run_given_by_a_link_is_analysed_and_drawn_where_it_points(analysed_smoke_run: Path,
                                                                    tmp_path: Path) -> None:
    # only --out is refused as a link; a run named by a link is the person's folder (was: analyze
    # and plot refused it once the --out rule was put into refuse_links, which they share)
    real = tmp_path / "real"
    shutil.copytree(analysed_smoke_run, real)
    linked = tmp_path / "linked"
    linked.symlink_to(real, target_is_directory=True)
    assert nudge("analyze", linked, "--bootstrap", "100").exit_code == 0
    assert nudge("plot", linked, "--formats", "png").exit_code == 0
    assert (real / "figures" / "fig3.png").is_file()
