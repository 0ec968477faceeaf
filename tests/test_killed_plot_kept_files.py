"""``nudge plot --plan`` keeps the analysis it replaces as hard links named as temporaries
(``.stats.json.kept-<pid>.tmp``). Killed by SIGKILL, it cannot put them back: the next command that
writes the folder's analysis does, unless the folder holds that analysis still, and removes them."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from cli_helpers import file_digests, nudge

from nudgecli.report.analysis_folders import recover_kept_analysis

RECORDS = ("manifest.json", "metrics.csv", "stats.csv", "summary.md", "stats.json")


@pytest.fixture(scope="module")
def dead_pid() -> int:
    """The pid of a process that has ended."""
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def _keep(run: Path, pid: int, names: tuple[str, ...] = ("stats.json", *RECORDS[:-1])) -> None:
    """Keep ``names`` as the killed plot ``pid`` kept them: hard links named as their temporaries."""
    for name in names:
        os.link(run / name, run / f".{name}.kept-{pid}.tmp")


def _replace(path: Path, text: str) -> None:
    """Replace ``path`` as an analysis's atomic write does: a new file under the old name."""
    path.with_name(f"{path.name}.new").write_text(text, encoding="utf-8")
    os.replace(path.with_name(f"{path.name}.new"), path)


def _kept(run: Path) -> list[str]:
    return sorted(path.name for path in run.iterdir() if ".kept-" in path.name)


def _killed_midway(run: Path, pid: int) -> None:
    """The folder as a plot killed in its analysis again leaves it: all kept, the manifest given a
    plan, ``stats.json`` removed, ``stats.csv`` rewritten."""
    manifest = json.loads((run / "manifest.json").read_text(encoding="utf-8"))
    _replace(run / "manifest.json", json.dumps({k: v for k, v in manifest.items() if k != "plan"}))
    _keep(run, pid)
    _replace(run / "manifest.json", json.dumps({**manifest, "plan": "study-code"}))
    (run / "stats.json").unlink()
    _replace(run / "stats.csv", "metric\nhalf written\n")


def test_the_next_analysis_puts_back_what_a_killed_plot_kept(analysed_smoke_run, tmp_path, dead_pid):
    run = shutil.copytree(analysed_smoke_run, tmp_path / "run")
    _killed_midway(run, dead_pid)
    kept = file_digests(run, [f".{name}.kept-{dead_pid}.tmp" for name in RECORDS])
    recover_kept_analysis(run)
    assert _kept(run) == []
    after = file_digests(run, RECORDS)
    for name in RECORDS[1:]:
        assert after[name] == kept[f".{name}.kept-{dead_pid}.tmp"]
    assert "plan" not in json.loads((run / "manifest.json").read_text(encoding="utf-8"))


def test_nudge_analyze_after_a_killed_plot_leaves_no_kept_files(analysed_smoke_run, tmp_path, dead_pid):
    run = shutil.copytree(analysed_smoke_run, tmp_path / "run")
    _killed_midway(run, dead_pid)
    result = nudge("analyze", run, "--bootstrap", "100")
    assert result.exit_code == 0, result.output
    assert _kept(run) == []
    assert (run / "stats.json").is_file()


def test_files_kept_of_the_analysis_the_folder_holds_are_only_removed(analysed_smoke_run, tmp_path, dead_pid):
    run = shutil.copytree(analysed_smoke_run, tmp_path / "run")
    before = file_digests(run, RECORDS)
    _keep(run, dead_pid, ("stats.json", "manifest.json"))  # killed while it kept the files
    recover_kept_analysis(run)
    assert _kept(run) == [] and file_digests(run, RECORDS) == before


def test_a_manifest_changed_since_by_another_command_stays(analysed_smoke_run, tmp_path, dead_pid):
    run = shutil.copytree(analysed_smoke_run, tmp_path / "run")
    _keep(run, dead_pid)
    (run / "stats.json").unlink()
    manifest = json.loads((run / "manifest.json").read_text(encoding="utf-8"))
    _replace(run / "manifest.json", json.dumps({**manifest, "status": "changed since"}))
    recover_kept_analysis(run)
    assert _kept(run) == [] and (run / "stats.json").is_file()
    assert json.loads((run / "manifest.json").read_text(encoding="utf-8"))["status"] == "changed since"


def test_files_kept_by_a_running_process_are_left_alone(analysed_smoke_run, tmp_path):
    run = shutil.copytree(analysed_smoke_run, tmp_path / "run")
    _keep(run, os.getppid())
    recover_kept_analysis(run)
    assert len(_kept(run)) == len(RECORDS)


def test_a_stats_json_written_where_the_kept_analysis_had_none_is_removed(analysed_smoke_run, tmp_path,
                                                                          dead_pid):
    run = shutil.copytree(analysed_smoke_run, tmp_path / "run")
    stats = (run / "stats.json").read_text(encoding="utf-8")
    (run / "stats.json").unlink()  # the folder held no stats.json when the plot kept its analysis
    before = file_digests(run, RECORDS[:-1])
    _keep(run, dead_pid, RECORDS[:-1])  # all kept but the stats.json there was none of
    _replace(run / "stats.json", stats)  # the killed plot's, beside the analysis the folder held
    recover_kept_analysis(run)
    assert _kept(run) == [] and file_digests(run, RECORDS[:-1]) == before
    assert not (run / "stats.json").exists()  # the folder's analysis had none: put back as it was


def test_a_plot_killed_as_it_removes_what_it_kept_leaves_its_analysis(analysed_smoke_run, tmp_path, dead_pid,
                                                                      monkeypatch):
    # was: the kept stats.json went first, and the next analysis read the rest as a folder that had
    # none, put the old analysis back and left the plot's figures beside it
    import nudgecli.report.analysis_folders as folders

    run = shutil.copytree(analysed_smoke_run, tmp_path / "run")

    def killed(paths):  # the process dies as it starts removing what it kept
        raise KeyboardInterrupt

    with monkeypatch.context() as patch:
        patch.setattr(folders, "_remove", killed)
        with pytest.raises(KeyboardInterrupt), folders.analysis_restored_on_failure(run, run=True):
            _replace(run / "stats.csv", "metric\nthe new analysis\n")
            _replace(run / "stats.json", '{"metrics": []}')
    for left in run.glob(f"*-{os.getpid()}.tmp"):  # as the killed process left them
        left.rename(left.with_name(left.name.replace(str(os.getpid()), str(dead_pid))))
    now = file_digests(run, RECORDS)
    recover_kept_analysis(run)
    assert _kept(run) == [] and not list(run.glob("*.tmp")) and file_digests(run, RECORDS) == now
