"""The process pool's overflow: a ``here`` job marked ``overflow`` waits for this process's thread,
unless the thread is so far behind that an idle worker does it sooner (its imports counted), and
where it runs never changes a batch's tables."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from nudgecli.config import load_experiment
from nudgecli.report.plans import load_plan
from nudgecli.runs import batch as batch_module
from nudgecli.runs.batch import Batch, run_batch, single_point
from nudgecli.runs.executors import Job, ProcessExecutor

ROOT = Path(__file__).resolve().parents[1]


def _napping_pid(seconds: float) -> int:
    """A job's work: sleep, then say which process ran it."""
    time.sleep(seconds)
    return os.getpid()


def _results(executor: ProcessExecutor, count: int) -> dict[str, int]:
    results = {}
    for _ in range(count):
        job, pid = executor.next_result()
        results[job.key] = pid
    return results


def test_an_overflow_job_goes_to_an_idle_worker_only_when_the_wait_outlasts_the_imports() -> None:
    executor = ProcessExecutor(1)
    try:
        slot = executor._slots[0]
        analysis = Job("a", _napping_pid, (0.0,), here=True, overflow=True)
        prepare = Job("p", _napping_pid, (0.0,), here=True)  # here only: never counted, never moved
        assert not executor._overflow_pays(slot)  # nothing waits
        executor._here_waiting.extend([prepare, analysis, analysis])
        assert not executor._overflow_pays(slot)  # neither the imports nor an analysis measured yet
        executor._warm_s, executor._overflow_s = 0.5, [0.2, 0.4]  # mean 0.3 s
        assert executor._overflow_pays(slot)  # 2 x 0.3 s waiting > 0.5 s of imports
        executor._here_waiting.pop()
        assert not executor._overflow_pays(slot)  # 1 x 0.3 s < 0.5 s: the thread does it sooner
        slot.overflowed = True
        assert executor._overflow_pays(slot)  # a worker that has run one pays no imports again
        assert executor._take_overflow(slot) is analysis
        assert list(executor._here_waiting) == [prepare]
        assert not executor._overflow_pays(slot)  # a here-only job stays
    finally:
        executor.close()


def test_a_backlog_of_overflow_jobs_spreads_over_idle_workers_from_its_tail() -> None:
    executor = ProcessExecutor(2)
    try:
        executor.warm(Job("warm", _napping_pid, (0.05,), here=True))
        for i in range(8):
            executor.submit(Job(f"job{i}", _napping_pid, (0.3,), here=True, overflow=True))
        results = _results(executor, 9)
    finally:
        executor.close()
    here = {key for key, pid in results.items() if pid == os.getpid()}
    assert {"warm", "job0", "job1"} <= here  # the thread's first analysis is measured before any moves
    moved = set(results) - here
    assert moved and moved <= {f"job{i}" for i in range(2, 8)} and "job7" in moved  # the tail moves first
    assert set(results.values()) - {os.getpid()} <= set(executor.pids)


def test_here_only_jobs_never_leave_this_process() -> None:
    executor = ProcessExecutor(2)
    try:
        executor.warm(Job("warm", _napping_pid, (0.0,), here=True))
        for i in range(4):
            executor.submit(Job(f"job{i}", _napping_pid, (0.2,), here=True))
        results = _results(executor, 5)
    finally:
        executor.close()
    assert set(results.values()) == {os.getpid()}


ANALYSE = batch_module.run_analysis_task


def _recording_analysis(log: str, slow_in: int, *args: object) -> object:
    with open(log, "a") as handle:
        handle.write(f"{os.getpid()}\n")
    if os.getpid() == slow_in:
        # this process's thread lags behind the workers: the analyses that arrive meanwhile wait for
        # it, so the workers that run out of studies find some waiting, however fast the machine is
        time.sleep(0.4)
    return ANALYSE(*args)  # type: ignore[arg-type]


def test_analyses_moved_to_workers_give_the_tables_of_one_worker(monkeypatch: pytest.MonkeyPatch,
                                                                 tmp_path: Path) -> None:
    config = load_experiment("smoke")
    batch = Batch("replicate", single_point(config, (config.study.participants,)), 6, 5, load_plan("paper"))
    serial = run_batch(batch, tmp_path / "serial", workers=1)
    log = tmp_path / "analyses.txt"
    # every waiting analysis moves to an idle worker, whatever the timings
    monkeypatch.setattr(ProcessExecutor, "_overflow_pays",
                        lambda self, slot: any(job.overflow for job in self._here_waiting))
    monkeypatch.setattr(batch_module, "run_analysis_task", _LoggingAnalysis(str(log)))
    pooled = run_batch(batch, tmp_path / "pool", workers=2)
    pids = log.read_text().split()
    assert len(pids) == 6 and set(pids) - {str(os.getpid())}  # some analyses ran in a worker
    assert pooled.stats == serial.stats  # the same documents, key for key


class _LoggingAnalysis:
    """``run_analysis_task`` that first appends its process id to ``log`` (picklable to a worker),
    slow in the process that made it."""

    def __init__(self, log: str) -> None:
        self.log = log
        self.slow_in = os.getpid()

    def __call__(self, *args: object) -> object:
        return _recording_analysis(self.log, self.slow_in, *args)


def test_the_warm_up_imports_what_an_analysis_uses_and_no_figures(tmp_path: Path) -> None:
    """A process's first analysis (the pool's thread after :func:`import_analysis_modules`, or a
    worker that takes an overflow job) imports nothing more of the libraries or the report, and
    no process imports matplotlib to analyse (0.5-1.5 s and tens of MB a worker)."""
    config = load_experiment("smoke")
    batch = Batch("replicate", single_point(config, (config.study.participants,)), 1, 3, load_plan("paper"))
    run_batch(batch, tmp_path / "batch", workers=1)
    script = (
        "import sys\n"
        "from pathlib import Path\n"
        "from nudgecli.config import load_experiment\n"
        "from nudgecli.report.plans import load_plan\n"
        "from nudgecli.runs.batch_folder import read_study_metrics\n"
        "from nudgecli.runs.batch_tasks import analysis_design, import_analysis_modules, run_analysis_task\n"
        "folder = Path(sys.argv[1])\n"
        "data = read_study_metrics(folder, next((folder / 'tasks').iterdir()).name, 2, None)\n"
        "import_analysis_modules()\n"
        "before = set(sys.modules)\n"
        "plan = load_plan('paper')\n"
        "design = analysis_design(load_experiment('smoke'), plan)\n"
        "run_analysis_task(data, plan, list(plan.metrics.include), *design)\n"
        "heavy = ('nudgecli', 'scipy', 'pandas', 'pyarrow', 'matplotlib', 'scikit_posthocs')\n"
        "print('NEW', sorted(m for m in set(sys.modules) - before if m.split('.')[0] in heavy))\n"
        "print('MATPLOTLIB', 'matplotlib' in sys.modules)\n")
    result = subprocess.run([sys.executable, "-c", script, str(tmp_path / "batch")], cwd=ROOT,
                            capture_output=True, text=True, timeout=300,
                            env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert result.returncode == 0, result.stderr
    assert "NEW []" in result.stdout and "MATPLOTLIB False" in result.stdout, result.stdout


def _blocked_signals() -> set[int]:
    return set(signal.pthread_sigmask(signal.SIG_BLOCK, []))


def _thread_facts() -> tuple[set[int], bool, str]:
    thread = threading.current_thread()
    return _blocked_signals(), thread.daemon, thread.name


@pytest.mark.skipif(not hasattr(signal, "pthread_sigmask"), reason="POSIX signal masks")
def test_the_pools_own_thread_leaves_ctrl_c_to_the_main_thread_and_never_holds_the_exit() -> None:
    executor = ProcessExecutor(1)
    try:
        executor.submit(Job("mask", _thread_facts, (), here=True))
        _, (blocked, daemon, name) = executor.next_result()
    finally:
        executor.close()
    assert {signal.SIGINT, signal.SIGTERM} <= blocked
    assert daemon and name == "nudge-here"  # an interrupted command does not wait for its job
    assert signal.SIGINT not in _blocked_signals()  # the main thread's own mask is untouched


def test_a_resumed_batch_with_only_analyses_left_warms_up_too(monkeypatch: pytest.MonkeyPatch,
                                                             tmp_path: Path) -> None:
    config = load_experiment("smoke")
    batch = Batch("replicate", single_point(config, (config.study.participants,)), 3, 6, load_plan("paper"))
    whole = run_batch(batch, tmp_path / "batch", workers=1)
    for document in (tmp_path / "batch" / "analyses").iterdir():
        document.unlink()  # every part is there; the analyses are to do again
    warmed: list[str] = []
    warm_up = batch_module.import_analysis_modules
    monkeypatch.setattr(batch_module, "import_analysis_modules", lambda: warmed.append("warm") or warm_up())
    resumed = run_batch(batch, tmp_path / "batch", workers=2, resume=True)
    assert warmed == ["warm"]  # once, so an analysis may overflow to an idle worker
    assert resumed.computed == 3 and resumed.stats == whole.stats
