"""The process pool's jobs marked ``here`` (a batch's analyses): run in the pool's own process, in
a thread beside the workers, their results and failures given back by ``next_result`` among the
workers' results."""

from __future__ import annotations

import os
import sys
import threading
import time

import pytest

from nudgecli.runs.executors import Job, ProcessExecutor, SerialExecutor


def where(tag: str) -> tuple[str, int, str]:
    """The job's tag, the process and the thread it ran in."""
    return tag, os.getpid(), threading.current_thread().name


def slow_where(tag: str) -> tuple[str, int, str]:
    time.sleep(0.2)
    return where(tag)


def fails(tag: str) -> None:
    raise ValueError(f"job {tag} failed")


def imports_a_module(name: str) -> bool:
    __import__(name)
    return name in sys.modules


def test_here_jobs_run_in_this_process_and_the_others_in_workers() -> None:
    executor = ProcessExecutor(2)
    try:
        for i in range(4):
            executor.submit(Job(f"w{i}", slow_where, (f"w{i}",), affinity="study"))
        for i in range(3):
            executor.submit(Job(f"h{i}", where, (f"h{i}",), here=True))
        results = dict(executor.next_result() for _ in range(7))
    finally:
        executor.close()
    by_tag = {job.key: value for job, value in results.items()}
    assert sorted(by_tag) == ["h0", "h1", "h2", "w0", "w1", "w2", "w3"]
    for key, (tag, pid, thread) in by_tag.items():
        assert tag == key
        if key.startswith("h"):
            assert pid == os.getpid() and thread.startswith("nudge-here")
        else:
            assert pid in executor.pids and pid != os.getpid()


def test_here_jobs_finish_while_the_workers_are_busy() -> None:
    """A here job does not wait for the workers' jobs: it comes back first."""
    executor = ProcessExecutor(1)
    try:
        executor.submit(Job("slow", slow_where, ("slow",), affinity="study"))
        executor.submit(Job("here", where, ("here",), here=True))
        first, _ = executor.next_result()
        second, _ = executor.next_result()
    finally:
        executor.close()
    assert (first.key, second.key) == ("here", "slow")


def test_a_failed_here_job_raises_its_own_error() -> None:
    executor = ProcessExecutor(1)
    try:
        executor.submit(Job("bad", fails, ("bad",), here=True))
        with pytest.raises(ValueError, match="job bad failed"):
            executor.next_result()
        executor.submit(Job("good", where, ("good",), here=True))  # the thread goes on
        job, (tag, pid, _) = executor.next_result()
    finally:
        executor.abort()
    assert job.key == tag == "good" and pid == os.getpid()


def test_what_a_here_job_imports_stays_out_of_the_workers() -> None:
    module = "tabnanny"  # a module nothing here imports
    if module in sys.modules:
        pytest.skip("imported earlier in this session")
    executor = ProcessExecutor(1)
    try:
        executor.submit(Job("here", imports_a_module, (module,), here=True))
        assert executor.next_result()[1] is True
        executor.submit(Job("worker", where, ("worker",), affinity="study"))
        executor.next_result()
        executor.submit(Job("check", _in_modules, (module,), affinity="study"))
        assert executor.next_result()[1] is False  # forked before the import: the worker has it not
    finally:
        executor.close()


def _in_modules(name: str) -> bool:
    return name in sys.modules


def test_other_executors_run_here_jobs_as_any_job() -> None:
    executor = SerialExecutor()
    executor.submit(Job("here", where, ("here",), here=True))
    job, (tag, pid, thread) = executor.next_result()
    assert job.key == tag == "here" and pid == os.getpid() and thread == threading.current_thread().name
