"""Issue 37's parameter recovery for twins of real people, as a script (not a timed test).

Simulates ``ciaa-teleop`` with 20 people of known parameters (``--participants``), measures their
habits as ``nudge habits`` does, fits a twin of each (``nudge fit-people``'s functions), simulates
the twins with the same seed (the physiology the habits do not determine is then the same draw),
and prints:

- per parameter: the share of people whose fitted value lies within its stated tolerance of the
  truth (:data:`nudgecli.sim.twin_recovery.TOLERANCES`; target 90 %);
- per habit the twins are fitted from: the share of people whose twin's median lies within 0.1 s
  or 20 % of their own (target: 80 % of all (person, habit) pairs).

Exits 1 when a target is missed. Nothing here is tuned: it reports.

Usage (from the repository root): ``PYTHONPATH=. nice python experiments/twins_recovery.py
[--participants 20] [--seed 37] [--twin-seed SEED]`` (``--twin-seed``: simulate the twins with
another seed, so that their physiology is drawn anew).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import pandas as pd

from nudgecli.config import load_experiment
from nudgecli.report.twin_sources import measured_source, twins_of_sources
from nudgecli.runs.study import run_study
from nudgecli.sim.participants import participants_from_frame
from nudgecli.sim.people_file import People
from nudgecli.sim.twin_recovery import (
    HABIT_TARGET,
    habit_agreement,
    parameter_recovery,
)


def recover(participants: int, seed: int, twin_seed: int, folder: Path) -> int:
    """Run the recovery in ``folder``; print the tables; 0 when both targets are met, else 1."""
    config = load_experiment("ciaa-teleop")
    people_run, twin_run = folder / "people", folder / "twins"
    run_study(config, people_run, seed=seed, participants=participants)
    truth = participants_from_frame(pd.read_parquet(people_run / "participants.parquet"))
    twins = twins_of_sources([people_run])
    run_study(config, twin_run, seed=twin_seed, participants=participants,
              people=People(name="recovery", sha256="", twins=tuple(twins)))
    sources, twin_habits = measured_source(people_run), measured_source(twin_run)
    print(f"ciaa-teleop, {participants} people of seed {seed}, twins simulated with seed {twin_seed}")
    print(f"{'parameter':<24} {'tolerance':>9} {'fitted':>7} {'within':>7} {'worst error':>12}  target 90 %")
    ok = True
    for row in parameter_recovery(truth, twins):
        ok &= row.met
        print(f"{row.parameter:<24} {row.tolerance:>9.2f} {row.fitted:>7} {row.share:>7.0%} "
              f"{row.worst:>12.3f}  "
              f"{'met' if row.met else 'MISSED'}")
    counts = habit_agreement(list(sources.values()), list(twin_habits.values()))
    print(f"\n{'habit (twin vs source)':<28} {'near':>6} {'pairs':>6}")
    for habit, (near, pairs) in counts.items():
        print(f"{habit:<28} {near / pairs if pairs else 0:>6.0%} {pairs:>6}")
    near = sum(n for n, _ in counts.values())
    pairs = sum(p for _, p in counts.values())
    share = near / pairs if pairs else 0.0
    habits_met = share >= HABIT_TARGET
    print(f"{'all pairs':<28} {share:>6.0%} {pairs:>6}  target {HABIT_TARGET:.0%}: "
          f"{'met' if habits_met else 'MISSED'}")
    return 0 if ok and habits_met else 1


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--participants", type=int, default=20, help="People with known parameters.")
    parser.add_argument("--seed", type=int, default=37, help="Seed of the people's study.")
    parser.add_argument("--twin-seed", type=int, default=None, help="Seed of the twins' study [the same].")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="twins-recovery-") as tmp:
        return recover(args.participants, args.seed,
                       args.seed if args.twin_seed is None else args.twin_seed, Path(tmp))


if __name__ == "__main__":
    sys.exit(main())
