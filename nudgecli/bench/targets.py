"""What each ``nudge bench`` figure must meet for its row to read ``ok`` (DESIGN section 8), in
one place: the figures (:mod:`nudgecli.bench.model`, ``study``, ``analyze``, ``scale``) read
them here and print them in their ``target`` column."""

from __future__ import annotations

# --- model figures ------------------------------------------------------------------------------

#: Exact D(s) + s* over one 5 x 5 window (75 states) against per-sample Monte Carlo: speed-up.
WINDOW_SPEEDUP_TARGET = 5000.0
#: ... and its time, s (DESIGN section 8: both must hold for the row to read ``ok``).
WINDOW_TIME_TARGET_S = 0.0001
#: Exact D(s) over the full grid (2400 states x 4 goals) against per-sample Monte Carlo: speed-up.
GRID_SPEEDUP_TARGET = 500.0
#: ... and its time, s (DESIGN section 8: both must hold for the row to read ``ok``).
GRID_TIME_TARGET_S = 0.002
#: Value iteration of one layout's 4 goal MDPs, s (the study setup's target is this per layout).
VI_TARGET_PER_LAYOUT_S = 0.050

# --- study figures ------------------------------------------------------------------------------

#: Simulated seconds per wall second of one participant's trials.
TRIAL_SPEEDUP_TARGET = 1000.0
#: The trial loop per paper trial (participant draw and calibration fit included), s.
TRIAL_TARGET_S = 0.0035
#: ``nudge simulate paper --workers 2``, the whole command on 2 cores, s (DESIGN said 20 s).
STUDY_WALL_TARGET_S = 3.0
STUDY_MEMORY_TARGET_MB = 1024.0
#: ``nudge --help``, interpreter start-up included, s.
CLI_STARTUP_TARGET_S = 0.3
#: A fresh worker process ready: interpreter start-up and the imports of its tasks, s.
WORKER_READY_TARGET_S = 0.5

# --- analyze figure -----------------------------------------------------------------------------

ANALYZE_WALL_TARGET_S = 60.0
ANALYZE_MEMORY_TARGET_MB = 1024.0

# --- scale figures ------------------------------------------------------------------------------

#: Parallel efficiency of each workload on the local worker processes (a 16-core target).
SCALE_EFFICIENCY_TARGET = {"study": 0.80, "sweep": 0.90}
#: Wall time on a local dask cluster over that of the process pool on the same cores.
DASK_RATIO_TARGET = 1.25
#: The largest worker's peak resident memory, MB.
WORKER_MEMORY_TARGET_MB = 300.0
#: Trials per hour of ``nudge replicate paper -R 20 --workers 2`` end to end on 2 cores (issue 23;
#: ``--only pipeline`` times the same command against issue 39's :data:`PIPELINE_THROUGHPUT_TARGET_PER_HOUR`,
#: so each row's target names its issue).
THROUGHPUT_TARGET_PER_HOUR = 1_000_000.0

# --- pipeline figures ---------------------------------------------------------------------------

#: Pipeline efficiency (trials x the loop's time per trial over workers x wall time) of
#: ``nudge replicate paper -R <key> --workers 2`` (issue 39).
PIPELINE_EFFICIENCY_TARGET = {4: 0.80, 20: 0.90}
#: Trials per hour of the larger of those batches end to end on 2 cores (issue 39).
PIPELINE_THROUGHPUT_TARGET_PER_HOUR = 10_000_000.0
#: ``nudge power paper --participants 6,9,12,18,24 -R 50 --workers 2`` end to end on 2 cores, s (issue 39).
POWER_WALL_TARGET_S = 120.0
#: That power analysis's participant counts and replications.
POWER_PARTICIPANTS = (6, 9, 12, 18, 24)
POWER_REPLICATIONS = 50
