"""`nudge plot` again into a folder it drew into: the earlier plot's figures it does not draw again are
removed once all of its own are written; a person's files stay; a failed plot changes no figure
(:mod:`nudgecli.report.figure_records`)."""

from __future__ import annotations

import hashlib
import json
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path

import pytest
from click.testing import CliRunner, Result
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli import api
from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.errors import WriteError
from nudgecli.report import figures
from nudgecli.report.analysis import analyze
from nudgecli.report.figure_records import RECORD_KEY, SUMS_KEY, recorded_figures, replace_earlier_figures
from nudgecli.run_folder_names import FIGURES_RECORD
from nudgecli.run_folder_record import remove_run_figures
from nudgecli.runs.study import run_study

#: What `nudge plot` draws of the analysed smoke run (no questionnaires analysed).
RUN_STEMS = ("fig3", "fig4", "metrics", "fig5", "trajectory")
TABLE_STEMS = ("fig3", "fig4", "metrics")


@pytest.fixture(scope="module")
def analysed_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The smoke study analysed with the paper plan, never plotted. Do not modify: copy it."""
    run = run_study(load_experiment("smoke"), tmp_path_factory.mktemp("smoke") / "run").path
    analyze(run, plan="paper")
    return run


@pytest.fixture()
def run(analysed_run: Path, tmp_path: Path) -> Path:
    return Path(shutil.copytree(analysed_run, tmp_path / "run"))


def _plot(*args: str | Path) -> Result:
    return CliRunner().invoke(main, ["plot", *(str(a) for a in args)])


def _files(folder: Path) -> set[str]:
    """The names in ``folder`` but the plot's record."""
    return {p.name for p in folder.iterdir()} - {FIGURES_RECORD}


def _record(folder: Path, names: list[str], written: tuple[str, ...] | None = None) -> None:
    """A record of ``names``, with the SHA-256 of those of ``written`` (all by default) on disk: the
    files an earlier plot wrote."""
    sums = {name: hashlib.sha256((folder / name).read_bytes()).hexdigest() for name in names
            if (written is None or name in written) and (folder / name).is_file()}
    (folder / FIGURES_RECORD).write_text(json.dumps({RECORD_KEY: names, SUMS_KEY: sums}))


def _names(stems: tuple[str, ...], formats: tuple[str, ...]) -> set[str]:
    return {f"{stem}.{fmt}" for stem in stems for fmt in formats}


def test_plot_in_another_format_removes_the_earlier_figures_and_keeps_a_persons(run: Path) -> None:
    folder = run / "figures"
    folder.mkdir()
    own = {"my-sketch.png": b"a person's figure", "notes.txt": b"notes"}  # a figure's suffix, too
    for name, data in own.items():
        (folder / name).write_bytes(data)
    first = _plot(run, "--formats", "png,pdf")
    assert first.exit_code == 0, (first.output, first.exception)
    assert first.stderr == ""  # nothing earlier to remove
    assert _files(folder) == _names(RUN_STEMS, ("png", "pdf")) | set(own)

    second = _plot(run, "--formats", "svg")
    assert second.exit_code == 0, (second.output, second.exception)
    assert _files(folder) == _names(RUN_STEMS, ("svg",)) | set(own)
    assert {name: (folder / name).read_bytes() for name in own} == own
    removed = sorted(_names(RUN_STEMS, ("png", "pdf")))
    assert second.stderr.splitlines() == [
        f"removed {len(removed)} figure file(s) an earlier `nudge plot` wrote into {folder} and this one "
        f"did not draw: {', '.join(removed)}"]
    assert recorded_figures(folder) == (sorted(_names(RUN_STEMS, ("svg",))), None)


def test_plot_of_a_table_into_the_runs_figures_removes_the_trial_figures(run: Path, tmp_path: Path) -> None:
    # a table has no steps: box plots only, no Fig. 5 or trajectory
    table = Path(shutil.copy(run / "metrics.csv", tmp_path / "table.csv"))
    analyze(table, plan="paper")
    out = tmp_path / "figures"
    assert _plot(run, "--formats", "png", "--out", out).exit_code == 0
    result = _plot(table, "--formats", "png", "--out", out, "--force")
    assert result.exit_code == 0, (result.output, result.exception)
    assert _files(out) == _names(TABLE_STEMS, ("png",))
    assert result.stderr.rstrip().endswith("did not draw: fig5.png, trajectory.png")


def test_a_failed_plot_changes_no_figure_and_the_next_removes_what_it_left(
        run: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    folder = run / "figures"
    assert _plot(run, "--formats", "png").exit_code == 0
    before = {name: (folder / name).read_bytes() for name in _files(folder)}
    writing = figures.save_figures

    def full_after_one_file(drawn, out_dir, formats, **kwargs):  # type: ignore[no-untyped-def]
        # killed between the renames: fig3.svg renamed into place (and recorded before), no other file
        writing({"fig3": drawn["fig3"]}, out_dir, formats, **kwargs)
        raise WriteError(f"cannot write {Path(out_dir) / 'fig4.svg'}: no space left on device")

    monkeypatch.setattr(figures, "save_figures", full_after_one_file)
    failed = _plot(run, "--formats", "svg")
    assert failed.exit_code == 1 and failed.stderr.startswith("Error: cannot write ")
    assert "removed" not in failed.stderr
    assert {name: (folder / name).read_bytes() for name in _files(folder) - {"fig3.svg"}} == before
    monkeypatch.undo()
    # the file the failed plot wrote is an earlier plot's figure too: a later plot removes it
    again = _plot(run, "--formats", "pdf")
    assert again.exit_code == 0, (again.output, again.exception)
    assert _files(folder) == _names(RUN_STEMS, ("pdf",))


def test_analyze_and_plot_logs_the_figures_it_removed(run: Path) -> None:
    # `nudge run`'s second half: the line goes to its log (the command's stderr)
    assert _plot(run, "--formats", "svg").exit_code == 0
    lines: list[str] = []
    _, written = api.analyze_and_plot(run, log=lines.append)
    assert {p.name for p in written} == _files(run / "figures") == _names(RUN_STEMS, ("png", "pdf"))
    assert lines[-1].startswith("removed 5 figure file(s)") and "fig5.svg" in lines[-1]


# --- the record ------------------------------------------------------------------------------------


def _writer(folder: Path, names: list[str]):  # type: ignore[no-untyped-def]
    def write(**how: object) -> list[Path]:  # (no before_rename: nothing recorded before the files)
        for name in names:
            (folder / name).write_bytes(b"new")
        return [folder / name for name in names]
    return write


def test_only_recorded_figure_files_in_the_folder_are_removed(tmp_path: Path) -> None:
    folder = tmp_path / "figures"
    (folder / "sub.png").mkdir(parents=True)
    for name in ("old.png", "notes.txt", "mine.pdf"):
        (folder / name).write_bytes(b"old")
    (tmp_path / "outside.png").write_bytes(b"not the folder's")
    _record(folder, ["old.png", "notes.txt", "sub.png", "gone.png", "../outside.png", "", "."])
    lines: list[str] = []
    written = replace_earlier_figures(folder, ["fig3"], ["png"], _writer(folder, ["fig3.png"]), lines.append)
    assert written == [folder / "fig3.png"]
    assert _files(folder) == {"fig3.png", "notes.txt", "mine.pdf", "sub.png"}
    assert (tmp_path / "outside.png").exists()
    assert lines == [f"removed 1 figure file(s) an earlier `nudge plot` wrote into {folder} and this one "
                     "did not draw: old.png"]
    assert recorded_figures(folder) == (["fig3.png"], None)


def test_an_unreadable_record_removes_nothing_says_so_and_is_written_again(tmp_path: Path) -> None:
    for text, why in (("{", "cannot be read"), ('{"written": "fig3.png"}', "holds no list of file names")):
        folder = tmp_path / str(len(why))
        folder.mkdir()
        (folder / "fig4.png").write_bytes(b"old")
        (folder / FIGURES_RECORD).write_text(text)
        lines: list[str] = []
        replace_earlier_figures(folder, ["fig3"], ["png"], _writer(folder, ["fig3.png"]), lines.append)
        assert _files(folder) == {"fig3.png", "fig4.png"}
        assert len(lines) == 1 and lines[0].startswith(f"{folder / FIGURES_RECORD} {why}")
        assert recorded_figures(folder) == (["fig3.png"], None)


def test_a_folder_made_for_the_plot_is_left_empty_by_a_failed_plot(tmp_path: Path) -> None:
    # (the command removes a folder it made for a plot that failed: the record must not keep it)
    folder = tmp_path / "new"
    folder.mkdir()

    def fail(**how: object) -> list[Path]:
        raise WriteError("disk full")

    with pytest.raises(WriteError):
        replace_earlier_figures(folder, ["fig3"], ["png"], fail)
    assert list(folder.iterdir()) == []


NAMES = st.sets(st.sampled_from(["a.png", "a.pdf", "b.svg", "c.png", "d.pdf", "notes.txt"]))


@settings(max_examples=60, deadline=None)
@given(recorded=NAMES, present=NAMES, written=NAMES)
def test_what_stays_is_what_was_there_less_recorded_figures_not_written(
        recorded: set[str], present: set[str], written: set[str]) -> None:
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        for file in present:
            (folder / file).write_bytes(b"old")
        _record(folder, sorted(recorded))
        replace_earlier_figures(folder, [], [], _writer(folder, sorted(written)))
        figure_suffix = {n for n in recorded if n.rsplit(".", 1)[1] in ("png", "pdf", "svg")}
        assert _files(folder) == (present - (figure_suffix - written)) | written
        assert recorded_figures(folder) == (sorted(written), None)


def test_force_removes_the_record_with_the_runs_figures(tmp_path: Path) -> None:
    folder = tmp_path / "figures"
    folder.mkdir()
    (folder / "fig3.png").write_bytes(b"old")
    (folder / FIGURES_RECORD).write_text(json.dumps({RECORD_KEY: ["fig3.png"]}))
    remove_run_figures(tmp_path)
    assert not folder.exists()  # a record left alone would keep the emptied figures/ there


def test_a_recorded_file_whose_bytes_the_plot_did_not_write_is_never_removed(tmp_path: Path) -> None:
    # a forged (or older nudge's) record naming the person's own figure: no SHA-256 of it, one of
    # other bytes, or the plot's own figure written over since
    folder = tmp_path / "figures"
    folder.mkdir()
    for name in ("mine.png", "forged.png", "redrawn.png", "old.png"):
        (folder / name).write_bytes(b"the plot's")
    _record(folder, ["mine.png", "forged.png", "redrawn.png", "old.png"], written=("redrawn.png", "old.png"))
    record = json.loads((folder / FIGURES_RECORD).read_text())
    record[SUMS_KEY]["forged.png"] = hashlib.sha256(b"other bytes").hexdigest()
    (folder / FIGURES_RECORD).write_text(json.dumps(record))
    (folder / "redrawn.png").write_bytes(b"the person's drawing over it")
    lines: list[str] = []
    replace_earlier_figures(folder, ["fig3"], ["png"], _writer(folder, ["fig3.png"]), lines.append)
    assert _files(folder) == {"fig3.png", "mine.png", "forged.png", "redrawn.png"}
    assert lines == [f"removed 1 figure file(s) an earlier `nudge plot` wrote into {folder} and this one "
                     "did not draw: old.png"]


def test_what_a_failed_plot_wrote_is_removed_by_the_next(tmp_path: Path) -> None:
    folder = tmp_path / "figures"
    folder.mkdir()
    (folder / "notes.txt").write_text("mine")

    def half(before_rename: Callable[[dict[str, str]], None]) -> list[Path]:
        # every file written, recorded, then a failure after the first rename (or a kill)
        before_rename({"fig3.png": hashlib.sha256(b"half a plot").hexdigest(), "fig4.png": "0" * 64})
        (folder / "fig3.png").write_bytes(b"half a plot")
        raise WriteError("disk full")

    with pytest.raises(WriteError):
        replace_earlier_figures(folder, ["fig3", "fig4"], ["png"], half)
    replace_earlier_figures(folder, ["fig4"], ["png"], _writer(folder, ["fig4.png"]))
    assert _files(folder) == {"fig4.png", "notes.txt"}
