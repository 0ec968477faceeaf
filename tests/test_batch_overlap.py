"""A batch's work besides trials off its critical path: on the process pool the analyses and the
command's preparation (its figures' imports) run in the command's own process beside the workers,
nothing heavy is imported before the workers start, and the tables stay those of one worker."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from pathlib import Path

import pandas as pd
import pytest

from nudgecli.config import load_experiment
from nudgecli.report.plans import load_plan
from nudgecli.runs import batch as batch_module
from nudgecli.runs.batch import Batch, run_batch, single_point

ROOT = Path(__file__).resolve().parents[1]


def _smoke_batch(replications: int = 2) -> Batch:
    config = load_experiment("smoke")
    return Batch("replicate", single_point(config, (config.study.participants,)), replications, 3,
                 load_plan("paper"))


def test_prepare_and_the_analyses_run_here_beside_the_pool(monkeypatch: pytest.MonkeyPatch,
                                                           tmp_path: Path) -> None:
    calls: list[tuple[str, int, str]] = []
    analyse = batch_module.run_analysis_task

    def spied_analysis(*args: object) -> object:  # a worker's call would be recorded in the worker only
        calls.append(("analysis", os.getpid(), threading.current_thread().name))
        return analyse(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(batch_module, "run_analysis_task", spied_analysis)
    prepare = lambda: calls.append(("prepare", os.getpid(), threading.current_thread().name))  # noqa: E731
    pooled = run_batch(_smoke_batch(), tmp_path / "pool", workers=2, prepare=prepare)
    assert [c[0] for c in calls] == ["prepare", "analysis", "analysis"]  # one analysis a replication
    assert all(pid == os.getpid() and thread.startswith("nudge-here") for _, pid, thread in calls)
    calls.clear()
    serial = run_batch(_smoke_batch(), tmp_path / "serial", workers=1, prepare=prepare)
    assert [c[0] for c in calls] == ["analysis", "analysis"]  # the serial run does not prepare
    assert pooled.stats == serial.stats  # the same documents, key for key


def test_a_failing_preparation_leaves_the_batch_to_finish(tmp_path: Path) -> None:
    def broken() -> None:
        raise ImportError("no figures here")

    run = run_batch(_smoke_batch(1), tmp_path / "batch", workers=2, prepare=broken)
    assert run.computed == 3 and len(run.stats) == 1  # two participants and the analysis


def test_nothing_heavy_is_imported_before_the_workers_start(tmp_path: Path) -> None:
    """``nudge replicate`` forks its workers before it has imported the statistics', the figures' or
    the tables' libraries (pandas, pyarrow: about 0.3-0.5 s that left a core idle before the workers
    started): they are imported beside the workers, and the workers never hold them."""
    script = (
        "import sys\n"
        "import nudgecli.runs.executors as executors\n"
        "start = executors.ProcessExecutor.__init__\n"
        "def spy(self, workers):\n"
        "    heavy = ('matplotlib', 'scipy.stats', 'scikit_posthocs', 'statsmodels', 'pandas', 'pyarrow')\n"
        "    print('HEAVY', sorted(m for m in heavy if m in sys.modules), flush=True)\n"
        "    start(self, workers)\n"
        "executors.ProcessExecutor.__init__ = spy\n"
        "from nudgecli.cli import main\n"
        "main(['replicate', 'smoke', '-R', '1', '--workers', '2', '--out', sys.argv[1]])\n")
    result = subprocess.run([sys.executable, "-c", script, str(tmp_path / "batch")], cwd=ROOT,
                            capture_output=True, text=True, timeout=300,
                            env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert result.returncode == 0, result.stderr
    assert "HEAVY []" in result.stdout
    assert (tmp_path / "batch" / "figures" / "forest.png").is_file()
    summary = pd.read_csv(tmp_path / "batch" / "summary.csv")
    assert len(summary) == len(load_plan("paper").metrics.include)
