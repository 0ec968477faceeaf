"""Everything that schedules work: the study runner, the one executor family (serial, processes,
dask), the batch graph of replications, power curves and sweeps, and the size guards.

:mod:`nudgecli.sim` holds the domain (worlds, people, population, calibration, protocol, one
participant's study); this package decides where and in what order that work runs, writes the
run and batch folders through :mod:`nudgecli.store`, and analyses batches through
:mod:`nudgecli.report`.
"""
