"""The defaults that a command's options show and the functions behind them use, written once.

The click layer must import in about a tenth of a second (``nudge --help``), so these values live
in this dependency-free module instead of the heavy ones that use them (the bench, the
validation, the comparison, power curves, the study page); both sides read them from here. An
experiment's own defaults are :mod:`nudgecli.config`'s.
"""

from __future__ import annotations

# nudge bench (nudgecli.bench.common.BenchOptions)
BENCH_REPEATS = 7
BENCH_BASELINE_REPEATS = 3
BENCH_STUDY_REPEATS = 3
BENCH_SCALE_PARTICIPANTS = 16
BENCH_SCALE_STUDIES = 24

# nudge validate (nudgecli.sim.validation.settings.ValidationSettings)
VALIDATION_SIMULATIONS = 100
VALIDATION_MIN_GOALS = 3
VALIDATION_MAX_GOALS = 30
VALIDATION_STATES = 200
VALIDATION_SEED = 0
VALIDATION_BELIEF_CONCENTRATION = 1.0
VALIDATION_MC_QUERIES = 100
VALIDATION_READING = "dirichlet"

# nudge compare (nudgecli.report.compare.CompareOptions)
COMPARE_RESAMPLES = 2000
COMPARE_LEVEL = 0.95
COMPARE_SEED = 0

# nudge plot-population (nudgecli.api.population.plot_population)
POPULATION_PARTICIPANTS = 100

# nudge power (nudgecli.runs.batch_kinds.power)
POWER_TARGET = 0.8

# nudge fit --variant (nudgecli.sim.calibration_io: the log variants it reads, and auto to detect them)
PILOT_VARIANT = "pilot"
CIAA_VARIANT = "ciaa"
AUTO_VARIANT = "auto"

# nudge study (nudgecli.live.app.run_live_study)
STUDY_PORT = 8765
