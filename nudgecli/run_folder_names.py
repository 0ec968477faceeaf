"""The names of the files and folders in a run folder and in an analysis folder (DESIGN.md section 4).

The one place each name is spelled: :mod:`nudgecli.store` writes and reads the run's own files,
``nudge analyze`` (:mod:`nudgecli.report.analysis`) writes the analysis files into its output
folder (the run folder by default), ``nudge plot`` reads them and writes the figures' folder.
"""

from __future__ import annotations

import re
from pathlib import Path

MANIFEST = "manifest.json"
#: A batch folder's manifest (:mod:`nudgecli.runs.batch_folder`): a run and a batch are never mixed.
BATCH_MANIFEST = "batch.json"
CONFIG = "config.toml"
PARTICIPANTS = "participants.parquet"
LAYOUTS = "layouts.parquet"
#: The folder that keeps an exact copy (its bytes, under its own name) of the ``--people`` file a
#: run or a batch simulated, so that its resume command names a file that is there.
PEOPLE_DIR = "people"
#: A run's exact copy of the plan file it was run with
#: (:meth:`nudgecli.run_folder_config.ConfigRecord.keep_plan`).
PLAN_COPY = "plan.toml"
#: The run-folder lock (:func:`nudgecli.locks.run_lock`); not part of the run.
LOCK = ".nudge.lock"
#: The tables written in one part per participant: ``<kind>/part-NNNN.parquet``.
PART_KINDS = ("trials", "steps", "participants")
#: A part's file name, the participant in its digits: the one rule that reads a participant from a
#: name. Another ``part-*.parquet`` (a file manager's ``part-0001 (copy).parquet``) is no part.
PART_FILE = re.compile(r"part-(\d{4,})\.parquet")
#: The folder of a run's simulated calibration logs, a ``participant-NNNN`` folder each
#: (:mod:`nudgecli.run_folder_calibration`, which records and verifies them).
CALIBRATION_DIR = "calibration"


def part_name(participant: int) -> str:
    """The file name of a participant's parts."""
    return f"part-{participant:04d}.parquet"


def numbered_parts(folder: Path) -> dict[int, Path]:
    """The parts in ``folder`` by participant: its files named :data:`PART_FILE` (none when the
    folder is missing); other ``part-*.parquet`` files are left out (:func:`stray_part_files`)."""
    found = (PART_FILE.fullmatch(p.name) for p in sorted(folder.glob("part-*.parquet")))
    return {int(match[1]): folder / match[0] for match in found if match is not None}


def stray_part_files(folder: Path) -> list[Path]:
    """The files in ``folder`` named like a part (``part-*.parquet``) that are none (:data:`PART_FILE`)."""
    return [p for p in sorted(folder.glob("part-*.parquet")) if PART_FILE.fullmatch(p.name) is None]

#: What ``nudge analyze`` writes: the metrics, the statistics (JSON, CSV), the summary, and the
#: questionnaire scores. Outputs have names of their own: no analysis file is named like a record
#: a study keeps (the scores were once written as ``questionnaires.csv``, over the answers).
METRICS_CSV = "metrics.csv"
STATS_JSON = "stats.json"
STATS_CSV = "stats.csv"
SUMMARY_MD = "summary.md"
QUESTIONNAIRE_SCORES_CSV = "questionnaire_scores.csv"
#: An analysis's exact copy of the plan file its ``stats.json`` records
#: (:func:`nudgecli.report.recorded_plans.record_plan`): not :data:`PLAN_COPY`, the run's, which an
#: analysis in the run's folder under another plan leaves as it is.
ANALYSIS_PLAN_COPY = "analysis_plan.toml"
#: The participants' questionnaire answers ``nudge study`` records (a record, read by ``nudge
#: analyze --questionnaires``; never written by an analysis).
QUESTIONNAIRES_CSV = "questionnaires.csv"
#: The files an analysis writes into its folder, in this order: ``stats.json``, which every reader
#: starts from, last (:func:`nudgecli.report.analysis.analyze`); what a run's ``--force`` removes
#: with its old analysis (:func:`nudgecli.run_folder_config.remove_run_analysis`).
ANALYSIS_FILES = (METRICS_CSV, STATS_CSV, SUMMARY_MD, QUESTIONNAIRE_SCORES_CSV, ANALYSIS_PLAN_COPY,
                  STATS_JSON)
#: The folder ``nudge plot`` (and a batch) writes its figures into.
FIGURES_DIR = "figures"
#: The formats figures are written in (``--formats``; a run's ``figures/`` holds them).
FIGURE_FORMATS = ("png", "pdf", "svg")
#: What ``nudge plot`` records in the folder it wrote its figures into: the names of the files it
#: wrote (:mod:`nudgecli.report.figure_records`), so that the next plot there removes those it
#: does not write again, and never a file of the person's own.
FIGURES_RECORD = ".nudge-figures.json"
