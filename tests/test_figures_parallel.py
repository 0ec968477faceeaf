"""Figures written at once in forked processes (:func:`nudgecli.report.figures.output.save_figures`):
the same bytes and order as written one after the other, and a child's failure as the command's
one error line."""

from __future__ import annotations

import os
import threading
from pathlib import Path

import pytest
from click.testing import CliRunner
from matplotlib.figure import Figure

from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.cores import available_cores
from nudgecli.errors import WorkerError, WriteError
from nudgecli.report import plotting
from nudgecli.report.analysis import analyze
from nudgecli.report.figures import output
from nudgecli.report.stats import ComparisonOptions
from nudgecli.runs.study import run_study

needs_two_cores = pytest.mark.skipif(available_cores() < 2 or not hasattr(os, "fork"),
                                     reason="the figures are written here without two cores and fork")


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The smoke study (2 participants x 8 trials), simulated and analysed. Do not modify."""
    run = run_study(load_experiment("smoke"), tmp_path_factory.mktemp("smoke") / "run")
    analyze(run.path, plan="paper")
    return run.path


def _drawn(run: Path, out: Path) -> dict[str, Figure]:
    """Every figure of ``nudge plot`` of the run, drawn anew (a figure keeps state once written)."""
    plan = plotting.PlotPlan(out_dir=out, formats=("png", "pdf", "svg"), trial=None,
                             star_rule=ComparisonOptions(), item_labels={}, reference=None)
    return plotting.draw_figures(plotting.read_inputs(run), plan)


def _spy_pids(monkeypatch: pytest.MonkeyPatch, log: Path) -> None:
    """Log the pid of every ``savefig`` (the children inherit the patch with the fork)."""
    savefig = Figure.savefig

    def logged(self: Figure, *args: object, **kwargs: object) -> None:
        with open(log, "a", encoding="utf-8") as handle:
            handle.write(f"{os.getpid()}\n")
        savefig(self, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(Figure, "savefig", logged)


@needs_two_cores
def test_figures_written_at_once_are_those_written_one_after_the_other(
        smoke_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(output, "_other_threads_running", lambda: False)  # threads other tests left
    serial_dir, parallel_dir = tmp_path / "serial", tmp_path / "parallel"
    formats = ("png", "pdf", "svg")
    serial = output.save_figures(_drawn(smoke_run, serial_dir), serial_dir, formats, processes=1)
    log = tmp_path / "pids.log"
    _spy_pids(monkeypatch, log)
    parallel = output.save_figures(_drawn(smoke_run, parallel_dir), parallel_dir, formats)
    pids = {int(line) for line in log.read_text(encoding="utf-8").split()}
    assert os.getpid() not in pids and len(pids) >= 2  # written by forked children, several of them
    assert [p.relative_to(parallel_dir) for p in parallel] == [p.relative_to(serial_dir) for p in serial]
    assert len(serial) == 3 * 5  # fig3, fig4, metrics, fig5, trajectory in three formats
    for a, b in zip(serial, parallel, strict=True):
        assert a.read_bytes() == b.read_bytes(), a.name


def test_one_process_writes_here(smoke_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    log = tmp_path / "pids.log"
    _spy_pids(monkeypatch, log)
    written = output.save_figures(_drawn(smoke_run, tmp_path), tmp_path, ("png",), processes=1)
    assert {int(line) for line in log.read_text(encoding="utf-8").split()} == {os.getpid()}
    assert [p.name for p in written] == ["fig3.png", "fig4.png", "metrics.png", "fig5.png", "trajectory.png"]


@needs_two_cores
def test_a_childs_write_error_is_the_commands_error_line(smoke_run: Path, tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    render = output._render

    def failing(fig: Figure, temporaries: list[Path], targets: list[Path], *args: object) -> None:
        if targets[0].stem in ("fig4", "fig5"):
            raise WriteError(f"{targets[0]}: cannot be written (No space left on device)")
        render(fig, temporaries, targets, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(output, "_render", failing)
    monkeypatch.setattr(output, "_other_threads_running", lambda: False)
    with pytest.raises(WriteError, match=r"fig4\.png: cannot be written \(No space left on device\)$"):
        output.save_figures(_drawn(smoke_run, tmp_path), tmp_path, ("png",), processes=2)
    assert sorted(tmp_path.iterdir()) == []  # the figures written are not renamed into place: no file changed


@needs_two_cores
def test_a_childs_crash_names_the_figure_and_the_traceback(smoke_run: Path, tmp_path: Path,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    def broken(fig: Figure, temporaries: list[Path], targets: list[Path], *args: object) -> None:
        raise ValueError(f"cannot draw {targets[0].stem}")

    monkeypatch.setattr(output, "_render", broken)
    monkeypatch.setattr(output, "_other_threads_running", lambda: False)
    expected = r"(?s)writing figure 'fig3' failed in a worker:.*ValueError: cannot draw fig3"
    with pytest.raises(WorkerError, match=expected):
        output.save_figures(_drawn(smoke_run, tmp_path), tmp_path, ("png",), processes=2)


@needs_two_cores
def test_figures_are_written_here_while_another_thread_runs(smoke_run: Path, tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    """A process with another thread running (a dask client's) is not forked."""
    log = tmp_path / "pids.log"
    _spy_pids(monkeypatch, log)
    release = threading.Event()
    other = threading.Thread(target=release.wait, daemon=True)
    other.start()
    try:
        output.save_figures(_drawn(smoke_run, tmp_path), tmp_path, ("png",))
    finally:
        release.set()
        other.join()
    assert {int(line) for line in log.read_text(encoding="utf-8").split()} == {os.getpid()}


@needs_two_cores
def test_nudge_run_writes_its_figures_in_forked_processes(tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """No thread of the command's (its progress bar's tqdm monitor was one) keeps it from forking;
    threads that other tests left running (a server's, a pool's) are not the command's."""
    before = set(threading.enumerate())
    monkeypatch.setattr(output, "_other_threads_running",
                        lambda: any(t not in before for t in threading.enumerate()))
    log = tmp_path / "pids.log"
    _spy_pids(monkeypatch, log)
    result = CliRunner().invoke(main, ["run", "smoke", "--out", str(tmp_path / "run")])
    assert result.exit_code == 0, result.output
    pids = {int(line) for line in log.read_text(encoding="utf-8").split()}
    assert os.getpid() not in pids and len(pids) >= 2
    assert len(list((tmp_path / "run" / "figures").glob("*.png"))) == 5
