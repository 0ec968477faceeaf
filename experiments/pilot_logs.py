"""Pilot logs from a simulated CIAA run: each participant's trials as the CSV log ``nudge habits`` and
``nudge fit-people`` read (the example of docs/people.md, "From a pilot to a power analysis").

A real pilot study exports such a log per participant; this writes one per simulated participant of
a ``ciaa-teleop`` run folder, so that the example's pipeline runs on files of the real format:
``t`` (seconds from the trial's start), ``trial``, ``label`` (the measured label; empty: no input),
``x``, ``y``, ``theta`` (the robot's pose at the row's time), ``mode_switch`` (the mode the
person's switch went to, else 0; ``1`` for a switch in a trial's last step, whose mode no next step
tells), ``participant`` and ``layout`` (the CIAA trial index). A row is
written where the label, the pose or the mode changes (and at each trial's start, and ``1 / rate``
after its last step with the final pose): each row holds the state from its time on, as an
event-driven log's do. ``nudge habits`` measures such a log as it measures the run folder.

Usage (from the repository root)::

    nudge simulate ciaa-teleop --participants 3 --seed 2020 --out pilot-run
    PYTHONPATH=. python experiments/pilot_logs.py pilot-run --out experiments/pilots
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from nudgecli.errors import NudgeError, RunFolderError
from nudgecli.model.world import MODE_NAMES
from nudgecli.store import RunFolder

#: A ``mode_switch`` cell of a switch whose mode is not known (the reader counts it as a switch).
UNKNOWN_SWITCH = "1"
#: Decimals of the pose in the log (the world snaps within 0.1 units).
POSE_DECIMALS = 4


def participant_log(steps: pd.DataFrame, trials: pd.DataFrame, name: str, dt: float) -> pd.DataFrame:
    """One participant's log rows from their steps ``(N,)`` and trials (a run folder's tables).

    A row per step at the step's time with the pose the robot has then, and one row ``dt`` after a
    trial's last step with its final pose (the log's last row closes its last cell); rows that
    change nothing are left out.
    """
    steps = steps.sort_values(["trial", "step"], kind="stable").reset_index(drop=True)
    final = trials.set_index("trial")[["final_x", "final_y", "final_theta", "layout"]]
    trial = steps["trial"].to_numpy()
    last = np.append(trial[1:] != trial[:-1], True)
    first = np.insert(trial[1:] != trial[:-1], 0, True)
    # a switch in a trial's last step is written too, as one of unknown direction: no next step
    # tells where it went (the run folder's cells leave its mode unknown alike)
    switched = steps["event"].astype(str).str.contains("mode_switch_human").to_numpy()
    mode_after = np.where(last, UNKNOWN_SWITCH, np.roll(steps["mode"].to_numpy(dtype=object), -1))
    rows = pd.DataFrame({"t": steps["t"].to_numpy(dtype=float), "trial": trial,
                         "label": steps["phi_m"].fillna("").astype(str).to_numpy(),
                         "x": steps["x"].to_numpy(dtype=float), "y": steps["y"].to_numpy(dtype=float),
                         "theta": steps["theta"].to_numpy(dtype=float),
                         "mode_switch": np.where(switched, mode_after, "0"), "keep": first | switched})
    ends = final.loc[trial[last]]
    closing = pd.DataFrame({"t": rows["t"].to_numpy()[last] + dt, "trial": trial[last], "label": "",
                            "x": ends["final_x"].to_numpy(dtype=float),
                            "y": ends["final_y"].to_numpy(dtype=float),
                            "theta": ends["final_theta"].to_numpy(dtype=float), "mode_switch": "0",
                            "keep": True})
    frame = pd.concat([rows, closing], ignore_index=True).sort_values(["trial", "t"], kind="stable")
    frame[["x", "y", "theta"]] = frame[["x", "y", "theta"]].round(POSE_DECIMALS)
    frame["t"] = frame["t"].round(3)
    state = frame[["trial", "label", "x", "y", "theta"]]
    frame = frame[(state != state.shift()).any(axis=1) | frame["keep"]].drop(columns="keep")
    assert set(frame["mode_switch"]) <= {"0", UNKNOWN_SWITCH, *MODE_NAMES}
    return frame.assign(participant=name, layout=final.loc[frame["trial"], "layout"].to_numpy())


def write_pilot_logs(run: Path, out: Path) -> list[Path]:
    """``out/pilot-<k>.csv`` for each participant ``k - 1`` of the run folder ``run``.

    Raises
    ------
    RunFolderError
        ``run`` is not a complete run folder, or a run of another world than the CIAA task's (its
        layout indices are no CIAA trials, which ``nudge habits`` would read the waypoints of);
        nothing is written.
    """
    folder = RunFolder(run)
    folder.check_complete()  # not a run folder, or one still running: its own message
    config = folder.read_config()
    if config.world.kind != "ciaa":
        raise RunFolderError(f"{run}: a run of the {config.world.kind} world (experiment "
                             f"{config.experiment.name!r}); a pilot log's layout column is a CIAA trial, so "
                             "give a ciaa-teleop run folder (`nudge simulate ciaa-teleop --out FOLDER`)")
    steps, trials = folder.read_steps(), folder.read_trials()
    dt = 1.0 / float(config.study.rate_hz)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for participant in sorted(steps["participant"].unique()):
        name = f"pilot-{int(participant) + 1}"
        log = participant_log(steps[steps["participant"] == participant],
                              trials[trials["participant"] == participant], name, dt)
        path = out / f"{name}.csv"
        log.to_csv(path, index=False)
        written.append(path)
    return written


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="A ciaa-teleop run folder (nudge simulate ciaa-teleop).")
    parser.add_argument("--out", type=Path, required=True, help="Folder for pilot-<k>.csv.")
    args = parser.parse_args(argv)
    try:
        written = write_pilot_logs(args.run, args.out)
    except NudgeError as exc:
        print(f"Error: {exc}", file=sys.stderr)
        return 1
    for path in written:
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
