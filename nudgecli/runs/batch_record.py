"""A batch's ``batch.json`` as :func:`nudgecli.runs.batch.run_batch` writes it: what the batch is
(its description, its counts, its policy copies and inputs) and how it was computed (its executor,
the nudge that ran it, when, in what wall time and worker memory).

How it was computed is the record of the run that computed its tasks (:data:`RUN_KEYS`), never of a
``--resume`` that found nothing left to compute: such a resume only marks the batch ``complete``
again (it wrote its tables), and keeps the executor, wall time and worker peak of the run that
computed them. A resume that computes tasks records its own values in their place and keeps those
of every earlier run, oldest first, in :data:`EARLIER_RUNS`: each run that computed some of the
batch's tasks is on record, with the number of tasks it computed (``tasks_computed``).

A run records its ``tasks_computed`` and ``wall_s`` as it goes, not only at its end: with the first
task it finishes :data:`RUNNING_RECORD_S` seconds or more after its last record, once all its tasks
are computed (with its ``worker_peak_rss_mb``, known once its workers close: before its tables, so
a run killed while it writes them is on record as fully as one that finished), and when it is
interrupted. A run killed (SIGKILL) mid-way leaves them as of its last record, missing at most the
tasks it finished in its last :data:`RUNNING_RECORD_S` seconds (the peak ``null``); one killed
within its first :data:`RUNNING_RECORD_S` seconds leaves none. Each record is one atomic rewrite of
``batch.json`` (about 8 ms on a local disk, its flush to disk), a few a minute at most: nothing
measurable beside the tasks (never one a task: a smoke replication's analysis takes 50 ms or more).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from nudgecli.run_folder_names import BATCH_MANIFEST
from nudgecli.runs.batch_folder import read_manifest
from nudgecli.store import provenance, utc_now, write_json_atomic

#: ``batch.json``'s keys that describe one run of the batch (not the batch), beside those of
#: :func:`~nudgecli.store.provenance` (the nudge that ran it, when it started): the executor, how
#: it ended (``finished`` or ``interrupted``), its ``wall_s``, ``worker_peak_rss_mb`` and
#: ``tasks_computed``.
RUN_KEYS = ("executor", "finished", "interrupted", "wall_s", "worker_peak_rss_mb", "tasks_computed")
#: ``batch.json``'s list of the earlier runs that computed some of its tasks (their :data:`RUN_KEYS`),
#: oldest first, where a resume computed the rest.
EARLIER_RUNS = "earlier_runs"
#: Seconds a run waits, while it computes, before it records its ``tasks_computed`` and ``wall_s`` so
#: far again (with the next task it finishes): a run killed mid-way leaves a count that misses at
#: most the tasks it finished in these last seconds.
RUNNING_RECORD_S = 10.0


class BatchRecord:
    """The ``batch.json`` of one command's run of a batch in ``folder``, written as it goes.

    Parameters
    ----------
    folder
        The batch folder.
    described
        What the batch is: its ``batch`` description, counts and policy copies' record.
    executor
        This run's executor (:func:`~nudgecli.runs.study.executor_name`).
    resumed_record
        A resume's ``batch.json`` as it found it (None for a new batch): kept as it is where
        ``computes`` is false, the run it records moved to :data:`EARLIER_RUNS` where it is true.
    computes
        Whether this run has tasks left to compute.
    """

    def __init__(self, folder: Path, described: Mapping[str, Any], executor: str,
                 resumed_record: Mapping[str, Any] | None = None, computes: bool = True) -> None:
        self.path = folder / BATCH_MANIFEST
        self.computes = computes or resumed_record is None
        #: this run's tasks computed, its clock (from :meth:`begin`), when it last recorded them, whether
        #: it computed all of them (:meth:`ran`) and its workers' peak (known once they close)
        self.computed, self.started, self.recorded_at, self.ran_all = 0, time.perf_counter(), -math.inf, False
        self.peak_mb: float | None = None
        this_run = {"executor": executor, **provenance()}
        if resumed_record is None:
            self.manifest: dict[str, Any] = {"batch": described["batch"], "status": "running", **this_run,
                                             **{k: v for k, v in described.items() if k != "batch"}}
            return
        run_keys = {*RUN_KEYS, *this_run}  # provenance's keys are its owner's
        runs = {k: v for k, v in resumed_record.items() if k in run_keys}
        self.manifest = {k: v for k, v in resumed_record.items() if k not in ("status", "interrupted")}
        self.manifest.update({**described, "status": "running"})
        if self.computes:  # this run's values take the first place; the last run's join the list
            self.manifest = {k: v for k, v in self.manifest.items() if k not in run_keys}
            earlier = resumed_record.get(EARLIER_RUNS)
            self.manifest.update({**this_run, EARLIER_RUNS: [*(earlier if isinstance(earlier, list) else []),
                                                             runs]})

    @classmethod
    def resumed(cls, folder: Path, described: Mapping[str, Any], executor: str,
                computes: bool) -> BatchRecord:
        """The record of a resume of the batch in ``folder`` (its ``batch.json`` read again: the
        prepare rule has accepted it)."""
        return cls(folder, described, executor, read_manifest(folder / BATCH_MANIFEST)[0] or None, computes)

    def write(self) -> None:
        """Write ``batch.json`` as it stands (atomic)."""
        write_json_atomic(self.path, self.manifest)

    def begin(self) -> None:
        """Write the record this run starts with, and start its clock (its ``wall_s``)."""
        self.write()
        self.started = self.recorded_at = time.perf_counter()

    def task_computed(self) -> None:
        """Count a task this run computed; record the count and wall time so far where the last
        record of them is :data:`RUNNING_RECORD_S` old (a run killed mid-way leaves them)."""
        self.computed += 1
        if time.perf_counter() - self.recorded_at >= RUNNING_RECORD_S:
            self._record_run(write=True)

    def ran(self, peak_mb: float | None) -> None:
        """Record that this run computed all its tasks: their count, its wall time and its workers'
        peak (``peak_mb``, once they closed), before the command writes its tables."""
        self.peak_mb, self.ran_all = peak_mb, True
        self._record_run(write=True)

    def interrupted(self) -> None:
        """Mark the batch ``interrupted`` (now), neither running nor complete, with what this run
        computed so far (as :meth:`ran` recorded it, where it computed all its tasks)."""
        if not self.ran_all:
            self._record_run(write=False)
        self.manifest.update({"status": "interrupted", "interrupted": utc_now()})
        self.write()

    def _record_run(self, write: bool) -> None:
        """This run's ``tasks_computed``, ``wall_s`` and worker peak so far, where it computes (a
        resume with nothing left keeps the recorded run's)."""
        if not self.computes:
            return
        self.recorded_at = time.perf_counter()
        peak = None if self.peak_mb is None else round(self.peak_mb, 1)
        self.manifest.update({"wall_s": round(self.recorded_at - self.started, 3),
                              "tasks_computed": self.computed, "worker_peak_rss_mb": peak})
        if write:
            self.write()

    def complete(self) -> None:
        """Mark the batch ``complete``: ``finished`` now, with the values :meth:`ran` recorded and the
        wall time to now (its tables and figures included) where this run computed tasks (or is the
        batch's first run); else the recorded run's stay."""
        if self.computes:  # its wall time to the end, tables and figures included (as before it ran)
            self._record_run(write=False)
            self.manifest["finished"] = utc_now()
        else:  # a resume with nothing left: the batch is complete now if it was not before
            self.manifest.setdefault("finished", utc_now())
        self.manifest["status"] = "complete"
        self.write()


__all__ = ["EARLIER_RUNS", "RUNNING_RECORD_S", "RUN_KEYS", "BatchRecord"]
