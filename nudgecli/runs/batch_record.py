"""A batch's ``batch.json`` as :func:`nudgecli.runs.batch.run_batch` writes it: what the batch is
(its description, its counts, its policy copies and inputs) and how it was computed (its executor,
the nudge that ran it, when, in what wall time and worker memory).

How it was computed is the record of the run that computed its tasks (:data:`RUN_KEYS`), never of a
``--resume`` that found nothing left to compute: such a resume only marks the batch ``complete``
again (it wrote its tables), and keeps the executor, wall time and worker peak of the run that
computed them. A resume that computes tasks records its own values in their place and keeps those
of every earlier run, oldest first, in :data:`EARLIER_RUNS`: each run that computed some of the
batch's tasks is on record, with the number of tasks it computed (``tasks_computed``).
"""

from __future__ import annotations

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

    def interrupted(self) -> None:
        """Mark the batch ``interrupted`` (now), neither running nor complete."""
        self.manifest.update({"status": "interrupted", "interrupted": utc_now()})
        self.write()

    def complete(self, computed: int, wall_s: float, peak_mb: float | None) -> None:
        """Mark the batch ``complete``: with this run's ``wall_s``, worker peak and ``computed`` tasks
        where it computed some (or is the batch's first run); else the recorded run's stay."""
        if self.computes:
            self.manifest.update({"finished": utc_now(), "wall_s": wall_s, "tasks_computed": computed,
                                  "worker_peak_rss_mb": None if peak_mb is None else round(peak_mb, 1)})
        else:  # a resume with nothing left: the batch is complete now if it was not before
            self.manifest.setdefault("finished", utc_now())
        self.manifest["status"] = "complete"
        self.write()


__all__ = ["EARLIER_RUNS", "RUN_KEYS", "BatchRecord"]
