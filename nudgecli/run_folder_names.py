"""The names of the files and folders in a run folder and in an analysis folder (DESIGN.md section 4).

The one place each name is spelled: :mod:`nudgecli.store` writes and reads the run's own files,
``nudge analyze`` (:mod:`nudgecli.report.analysis`) writes the analysis files into its output
folder (the run folder by default), ``nudge plot`` reads them and writes the figures' folder.
"""

from __future__ import annotations

MANIFEST = "manifest.json"
#: A batch folder's manifest (:mod:`nudgecli.runs.batch_folder`): a run and a batch are never mixed.
BATCH_MANIFEST = "batch.json"
CONFIG = "config.toml"
PARTICIPANTS = "participants.parquet"
LAYOUTS = "layouts.parquet"
#: The folder that keeps an exact copy (its bytes, under its own name) of the ``--people`` file a
#: run or a batch simulated, so that its resume command names a file that is there.
PEOPLE_DIR = "people"
#: The run-folder lock (:func:`nudgecli.locks.run_lock`); not part of the run.
LOCK = ".nudge.lock"
#: The tables written in one part per participant: ``<kind>/part-NNNN.parquet``.
PART_KINDS = ("trials", "steps", "participants")

#: What ``nudge analyze`` writes: the metrics, the statistics (JSON, CSV), the summary, and the
#: questionnaire scores. Outputs have names of their own: no analysis file is named like a record
#: a study keeps (the scores were once written as ``questionnaires.csv``, over the answers).
METRICS_CSV = "metrics.csv"
STATS_JSON = "stats.json"
STATS_CSV = "stats.csv"
SUMMARY_MD = "summary.md"
QUESTIONNAIRE_SCORES_CSV = "questionnaire_scores.csv"
#: The participants' questionnaire answers ``nudge study`` records (a record, read by ``nudge
#: analyze --questionnaires``; never written by an analysis).
QUESTIONNAIRES_CSV = "questionnaires.csv"
#: The folder ``nudge plot`` (and a batch) writes its figures into.
FIGURES_DIR = "figures"
#: The formats figures are written in (``--formats``; a run's ``figures/`` holds them).
FIGURE_FORMATS = ("png", "pdf", "svg")
#: What ``nudge plot`` records in the folder it wrote its figures into: the names of the files it
#: wrote (:mod:`nudgecli.report.figure_records`), so that the next plot there removes those it
#: does not write again, and never a file of the person's own.
FIGURES_RECORD = ".nudge-figures.json"
