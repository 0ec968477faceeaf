"""Which run's trials an analysis was computed from, so that a run's figures never mix two runs.

``stats.json`` ties itself to its metrics table (:mod:`nudgecli.report.checksum`), but ``nudge plot
RUN`` draws Fig. 5 and the trajectory from the run's own trials and step logs beside the box plots
of ``stats.json``: an analysis of another run written into the folder (``nudge analyze OTHER --out
RUN --force``, or its ``metrics.csv`` and ``stats.json`` copied in) would be drawn beside this
run's trials without a word. ``nudge analyze`` of a run folder therefore records the digest of the
trials it analysed (:data:`TRIALS_DIGEST_KEY`: :func:`trials_digest`), and every reader that draws
an analysis beside a run's trials refuses one of other trials (:func:`check_analysed_trials`).

The digest is of the trials' values (:func:`~nudgecli.report.checksum.metrics_digest` of
:data:`~nudgecli.report.metrics.TRIAL_COLUMNS`, in participant and trial order), not of the Parquet
parts' bytes: a reproduction with another pyarrow writes other bytes for the same trials, and its
``stats.json`` must stay the reference's. A ``stats.json`` without it (an older nudge's, such as the
shipped ``results/``' until they are written again) is drawn as before.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from nudgecli.errors import RunFolderError, shell_words
from nudgecli.report.checksum import metrics_digest
from nudgecli.report.metrics import TRIAL_COLUMNS

#: The ``stats.json`` key of the digest of the run's trials an analysis was computed from.
TRIALS_DIGEST_KEY = "trials_digest"


def trials_digest(trials: pd.DataFrame) -> str:
    """The hex digest of a run's trials table: its conditions and the values of its other
    :data:`~nudgecli.report.metrics.TRIAL_COLUMNS` (those it has), in participant and trial order
    (the order its parts were read in does not count)."""
    columns = [c for c in TRIAL_COLUMNS if c in trials.columns and c != "condition"]
    ordered = trials.sort_values(["participant", "trial"], kind="stable", ignore_index=True)
    return metrics_digest(ordered, columns)


def check_analysed_trials(stats: Mapping[str, Any], trials: pd.DataFrame | None, run: Path,
                          stats_path: Path) -> None:
    """Refuse to draw the analysis ``stats`` (read from ``stats_path``) beside the trials of the run
    folder ``run`` when it was computed from other trials.

    Parameters
    ----------
    stats
        The ``stats.json`` document; one without :data:`TRIALS_DIGEST_KEY` (an older nudge's, or a
        metrics table's analysis) is not checked.
    trials
        The run's trials table about to be drawn; ``None`` (no run's trials: a table's analysis, a
        run kept without its parts) is not checked.
    run, stats_path
        The run folder and the ``stats.json``, for the message and the command that fixes it.

    Raises
    ------
    RunFolderError
        One line naming the ``stats.json``, the run and the ``nudge analyze`` command that analyses
        the run's own trials.
    """
    recorded = stats.get(TRIALS_DIGEST_KEY)
    if recorded is None or trials is None or recorded == trials_digest(trials):
        return
    words = ["nudge", "analyze", str(run)]
    if stats_path.parent.resolve() != run.resolve():  # an analysis written away from the run
        words += ["--out", str(stats_path.parent)]
    raise RunFolderError(f"{stats_path} is the analysis of other trials than {run}'s (its "
                         f"{TRIALS_DIGEST_KEY!r} differs: another run's analysis written or copied there, or "
                         "the run simulated again since), and its figures would mix the two; analyse the "
                         f"run's own trials with `{shell_words(words)}` (with the --plan it was analysed "
                         "with, if any), then plot")


__all__ = ["TRIALS_DIGEST_KEY", "check_analysed_trials", "trials_digest"]
