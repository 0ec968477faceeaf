"""Inside a soft blow: the Soft-Hard deadband (``nudge habits``' rows of issue 37).

HABITS.md's section "Inside a soft blow: the Soft-Hard deadband" measures how a person's pressure
strays within a soft blow (a blow with no Hard cell), in the same 10 Hz cells as the other habits
(:mod:`nudgecli.report.habit_cells`):

- **share of soft-blow time in the deadband**: deadband cells / all cells of soft blows (a merged
  gap's neutral cells count as the blow's cells, as they count in its duration); a person's share
  is summed over their trials. Filed as one event per soft-blow cell (1.0 in the deadband, else
  0.0), so the share habits' mean is that ratio for a person, a trial or everyone pooled;
- **a deadband run inside a soft blow** (s): a run of contiguous deadband cells inside one;
- **what follows a deadband run inside a soft blow**: the next cell of the same blow: the soft
  command again, the blow ends (the run's last cell is the blow's), or a neutral gap (one or two
  neutral cells the blow is merged across; it goes on after it). Three share habits, each run one
  event of each (1.0 for the one that happened).
"""

from __future__ import annotations

import numpy as np

from nudgecli.report.habit_cells import DEADBAND, NEUTRAL, SOFT, cell_runs

#: The habits measured here, in HABITS.md's order (keys of the packaged reference ``ciaa-people``).
DEADBAND_HABIT_KEYS = ("deadband_share_soft_blows", "deadband_run_in_soft_blow", "deadband_then_soft",
                       "deadband_then_blow_ends", "deadband_then_gap_soft")


def deadband_events(kind: np.ndarray, new_trial: np.ndarray, soft_starts: np.ndarray, soft_ends: np.ndarray,
                    dt: float) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """The events of HABITS.md's deadband rows.

    Parameters
    ----------
    kind
        ``(N,)`` cell kinds (:data:`~nudgecli.report.habit_cells.NEUTRAL` ...), trials contiguous.
    new_trial
        ``(N,)`` True at each trial's first cell.
    soft_starts, soft_ends
        ``(B,)`` the soft blows' first cells and ends (exclusive), in order: merged blows with no
        Hard cell.
    dt
        Seconds per cell.

    Returns
    -------
    list
        ``(habit key, cells the events are filed at, values)`` per habit of :data:`DEADBAND_HABIT_KEYS`.
    """
    n = len(kind)
    cover = np.zeros(n + 1, dtype=np.int64)
    np.add.at(cover, soft_starts, 1)
    np.add.at(cover, soft_ends, -1)
    in_soft = np.cumsum(cover[:-1]) > 0
    soft_cells = np.flatnonzero(in_soft)
    events = [("deadband_share_soft_blows", soft_cells, (kind[soft_cells] == DEADBAND).astype(float))]

    # a run of deadband cells is all non-neutral, so it lies inside one blow
    run_starts, run_ends = cell_runs((kind == DEADBAND) & in_soft, new_trial)
    events.append(("deadband_run_in_soft_blow", run_starts, (run_ends - run_starts) * dt))
    blow = np.searchsorted(soft_starts, run_starts, side="right") - 1
    blow_ends = run_ends == soft_ends[blow] if len(blow) else np.zeros(0, dtype=bool)
    after = kind[np.minimum(run_ends, n - 1)] if n else np.zeros(0, dtype=kind.dtype)
    events.append(("deadband_then_soft", run_starts, (~blow_ends & (after == SOFT)).astype(float)))
    events.append(("deadband_then_blow_ends", run_starts, blow_ends.astype(float)))
    events.append(("deadband_then_gap_soft", run_starts, (~blow_ends & (after == NEUTRAL)).astype(float)))
    return events
