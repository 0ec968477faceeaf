"""Issue 37's parameter recovery for twins of real people, as a script (not a timed test).

Simulates ``ciaa-teleop`` with 20 people of known parameters (``--participants``) for each seed
(``--seeds``), measures their habits as ``nudge habits`` does, fits a twin of each (``nudge
fit-people``'s functions), simulates the twins with the same seed (the physiology the habits do not
determine is then the same draw), and prints, over the people of all the seeds:

- per parameter: the share of people whose fitted value lies within its stated tolerance of the
  truth (:data:`nudgecli.sim.twin_recovery.TOLERANCES`; target 90 %), the worst error, and the
  signed mean error (fitted less true), which must lie within a quarter of the tolerance
  (:data:`BIAS_SHARE`): a fit biased one way makes every twin slower or faster than its source even
  where each error is within its tolerance;
- per habit the twins are fitted from: the share of people whose twin's median lies within 0.1 s
  or 20 % of their own (target: 80 % of all (person, habit) pairs);
- per seed: the trials' success of the people and of their twins.

Exits 1 when a target is missed. Nothing here is tuned: it reports.

Usage (from the repository root): ``PYTHONPATH=. nice python experiments/twins_recovery.py
[--participants 20] [--seeds 37,11,23,44,5] [--twin-seed SEED]`` (``--twin-seed``: simulate the
twins with another seed, so that their physiology is drawn anew; ``--seed 37`` is ``--seeds 37``).
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
from nudgecli.sim.participants import Participant, participants_from_frame
from nudgecli.sim.people_file import People
from nudgecli.sim.twin_fit import HabitFigures
from nudgecli.sim.twin_recovery import (
    HABIT_TARGET,
    TOLERANCES,
    habit_agreement,
    parameter_recovery,
)
from nudgecli.sim.twins import TWIN_PARAMETERS, Twin

#: The signed mean error a parameter may have, as a share of its tolerance.
BIAS_SHARE = 0.25


def signed_mean_errors(truth: list[Participant], twins: list[Twin]) -> dict[str, float]:
    """Per parameter, the mean of fitted less true over the people it was fitted for (NaN: none)."""
    means = {}
    for name in TWIN_PARAMETERS:
        errors = [float(twin.parameters[name]) - float(getattr(person, name))
                  for person, twin in zip(truth, twins, strict=True) if name in twin.parameters]
        means[name] = sum(errors) / len(errors) if errors else float("nan")
    return means


#: What one seed gives: the truth, the twins, the people's habits, the twins', and both successes.
Pair = tuple[list[Participant], list[Twin], list[dict[str, HabitFigures]], list[dict[str, HabitFigures]],
             float, float]


def simulate_pair(participants: int, seed: int, twin_seed: int, folder: Path) -> Pair:
    """People of one seed and their twins: the truth, the twins, both habits, both successes."""
    config = load_experiment("ciaa-teleop")
    people_run, twin_run = folder / f"people-{seed}", folder / f"twins-{seed}"
    run_study(config, people_run, seed=seed, participants=participants)
    truth = participants_from_frame(pd.read_parquet(people_run / "participants.parquet"))
    twins = twins_of_sources([people_run])
    run_study(config, twin_run, seed=twin_seed, participants=participants,
              people=People(name="recovery", sha256="", twins=tuple(twins)))
    success = [float(pd.read_parquet(run / "trials")["success"].mean()) for run in (people_run, twin_run)]
    own, theirs = (list(measured_source(run).values()) for run in (people_run, twin_run))
    return truth, twins, own, theirs, success[0], success[1]


def recover(participants: int, seeds: list[int], twin_seed: int | None, folder: Path) -> int:
    """Run the recovery in ``folder``; print the tables; 0 when every target is met, else 1."""
    truth: list[Participant] = []
    twins: list[Twin] = []
    sources: list[dict[str, HabitFigures]] = []
    twin_habits: list[dict[str, HabitFigures]] = []
    for seed in seeds:
        people, fitted, own, theirs, source_success, twin_success = simulate_pair(
            participants, seed, seed if twin_seed is None else twin_seed, folder)
        truth += people
        twins += fitted
        sources += own
        twin_habits += theirs
        print(f"seed {seed}: success {source_success:.3f} (people), {twin_success:.3f} (their twins)")
    print(f"\nciaa-teleop, {participants} people of seed(s) {', '.join(map(str, seeds))}, twins simulated "
          f"with {'the same seed' if twin_seed is None else f'seed {twin_seed}'}")
    print(f"{'parameter':<24} {'tolerance':>9} {'fitted':>7} {'within':>7} {'worst error':>12} "
          f"{'mean error':>11}  target 90 %, mean within {BIAS_SHARE:.0%} of the tolerance")
    ok = True
    means = signed_mean_errors(truth, twins)
    for row in parameter_recovery(truth, twins):
        unbiased = abs(means[row.parameter]) <= BIAS_SHARE * TOLERANCES[row.parameter] + 1e-9
        ok &= row.met and unbiased
        print(f"{row.parameter:<24} {row.tolerance:>9.2f} {row.fitted:>7} {row.share:>7.0%} "
              f"{row.worst:>12.3f} {means[row.parameter]:>+11.3f}  "
              f"{'met' if row.met else 'MISSED'}, {'unbiased' if unbiased else 'BIASED'}")
    counts = habit_agreement(sources, twin_habits)
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
    parser.add_argument("--participants", type=int, default=20, help="People with known parameters per seed.")
    parser.add_argument("--seeds", "--seed", default="37,11,23,44,5",
                        help="Seeds of the people's studies, separated by commas [37,11,23,44,5].")
    parser.add_argument("--twin-seed", type=int, default=None,
                        help="Seed of the twins' studies [each the same].")
    args = parser.parse_args(argv)
    seeds = [int(seed) for seed in args.seeds.split(",") if seed.strip()]
    with tempfile.TemporaryDirectory(prefix="twins-recovery-") as tmp:
        return recover(args.participants, seeds, args.twin_seed, Path(tmp))


if __name__ == "__main__":
    sys.exit(main())
