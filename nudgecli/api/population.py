"""``nudgecli.plot_population``: simulated participants' calibrations and habits beside real
people's, as ``nudge plot-population`` draws them.

The work is :mod:`nudgecli.sim.real_population`'s (calibrations, habits, the coverage table) and
:mod:`nudgecli.report.population_figure`'s (the figure); ``nudge plot-population`` calls it
through this module and prints what it returns.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from nudgecli import command_defaults as defaults

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure

    from nudgecli.api.run import Overrides

#: The data files ``plot-population`` writes beside its figure (``coverage.txt``: the coverage table
#: as the command prints it, :meth:`Population.coverage_text`).
POPULATION_FILES = ("population.csv", "population_habits.csv", "coverage.txt")


@dataclass(frozen=True)
class Population:
    """The simulated population's calibrations and habits, and the files written.

    Attributes
    ----------
    diagonals
        One row per simulated participant, stream and phi_m: the fitted p(phi_m | phi_i)
        diagonal (``population.csv``).
    habits
        One row per simulated participant: their drawn timing habits (``population_habits.csv``).
    coverage
        The coverage table ``nudge plot-population`` prints: the real people's range against the
        simulated one, per stream and mode.
    title
        The figure's title.
    files
        The files written (with ``out``), data first (``population.csv``, ``population_habits.csv``,
        ``coverage.txt``), then the figure's formats.
    """

    diagonals: pd.DataFrame
    habits: pd.DataFrame
    coverage: pd.DataFrame
    title: str
    files: list[Path] = field(default_factory=list)

    def coverage_text(self) -> str:
        """The coverage table as ``nudge plot-population`` prints it (``--format table``), the bytes
        of ``coverage.txt``."""
        return self.coverage.to_string(index=False, float_format=lambda v: f"{v:.3f}") + "\n"

    def figure(self) -> Figure:
        """The figure ``nudge plot-population`` saves, as a matplotlib Figure (nothing written)."""
        from nudgecli.report.population_figure import build_population_figure

        return build_population_figure(self.diagonals, self.title, self.habits)


def is_population_file(name: str) -> bool:
    """``plot-population``'s own outputs (an earlier call's, which it replaces) and the lock."""
    from nudgecli.report.figures import SUPPORTED_FORMATS
    from nudgecli.run_folder_names import LOCK

    stem, _, suffix = name.partition(".")
    return name in (LOCK, *POPULATION_FILES) or (stem == "population" and suffix in SUPPORTED_FORMATS)


def plot_population(experiment: str | Path, *,
                    participants: int = defaults.POPULATION_PARTICIPANTS, seed: int | None = None,
                    out: str | Path | None = None, force: bool = False,
                    formats: str | Sequence[str] = ("png", "pdf"), yes: bool = False,
                    overrides: Overrides | None = None) -> Population:
    """Calibrate ``experiment``'s simulated participants, as ``nudge plot-population`` does.

    Parameters
    ----------
    experiment
        A preset's name or an experiment TOML file.
    participants
        Simulated participants to calibrate.
    seed
        Master seed (default the experiment's).
    out, force, formats
        Folder for ``population.csv``, ``population_habits.csv``, ``coverage.txt`` and
        ``population.<format>``;
        ``None`` writes nothing. A folder holding other files needs ``force``.
    yes
        Calibrate more participants than the size limit allows.
    overrides
        Experiment fields to override, as :func:`~nudgecli.api.run.simulate` takes them (``--set``).

    Raises
    ------
    NudgeError
        ``nudge plot-population``'s errors (size limit, formats, experiment, ``out``), before the
        calibrations and before anything is written.
    """
    from nudgecli.api import arguments
    from nudgecli.api.run import experiment_config
    from nudgecli.runs.size import MAX_CALIBRATIONS_WITHOUT_YES, check_size, override_named
    from nudgecli.sim.real_population import coverage_table, simulated_diagonals, simulated_habits

    participants = arguments.whole_number("participants", participants, minimum=1)
    seed = arguments.seed(seed, optional=True)
    out = arguments.out_folder(out)
    force, yes = arguments.switch("force", force), arguments.switch("yes", yes)
    with override_named("yes=True"):  # the refusal names this API's parameter (--yes on the command line)
        check_size(participants, yes, limit=MAX_CALIBRATIONS_WITHOUT_YES,
                   work="calibrate {} simulated participants", fix="fewer --participants")
    chosen = arguments.formats(formats)
    config = experiment_config(experiment, overrides=overrides)
    if out is not None:
        from nudgecli.outputs import check_output_folder
        from nudgecli.store import check_writable

        # new, empty, or holding this command's own outputs of an earlier call, else force; then
        # writable; before the calibrations, which take a while
        check_output_folder(out, force=force, own_file=is_population_file)
        check_writable(out)
    master = config.experiment.seed if seed is None else seed
    diagonals = simulated_diagonals(config, participants, master)
    habits = simulated_habits(config, participants, master)
    title = f"{config.experiment.name}: {participants} simulated participants (seed {master})"
    made = Population(diagonals, habits, coverage_table(diagonals), title)
    if out is not None:
        from nudgecli.report.population_figure import plot_population as save_population_figure
        from nudgecli.store import write_text_atomic

        folder = Path(out)
        write_text_atomic(folder / "population.csv", diagonals.to_csv(index=False))
        write_text_atomic(folder / "population_habits.csv", habits.to_csv(index=False))
        write_text_atomic(folder / "coverage.txt", made.coverage_text())
        made.files.extend([folder / name for name in POPULATION_FILES])
        made.files.extend(save_population_figure(diagonals, folder, chosen, title, habits))
    return made
