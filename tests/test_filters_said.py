"""A plan's ``[filters]`` are said wherever they remove values a researcher reads: ``nudge compare``
counts them per source in its notes (on stderr), as ``nudge analyze`` does."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.report.compare import compare_sources

METRICS_CSV = Path(__file__).parent / "data" / "metrics_two_conditions.csv"
LINE = ("plan study-code's [filters] left out {} of 48 mode_switches values (above 10); each trial stays in "
        "its other metrics")


def _sources(tmp_path: Path) -> tuple[Path, Path]:
    """A simulated table with 12 mode_switches above study-code's maximum of 10, a real one with 6."""
    simulated, real = pd.read_csv(METRICS_CSV), pd.read_csv(METRICS_CSV)
    simulated.loc[::4, "mode_switches"] = 15
    real.loc[::8, "mode_switches"] = 12
    simulated.to_csv(tmp_path / "sim.csv", index=False)
    real.to_csv(tmp_path / "real.csv", index=False)
    return tmp_path / "sim.csv", tmp_path / "real.csv"


def test_compare_says_the_values_a_plans_filters_remove_from_each_source(tmp_path: Path) -> None:
    sim, real = _sources(tmp_path)
    notes: list[str] = []
    result = compare_sources(sim, real, plan="study-code", metrics=["mode_switches"], notes=notes)
    assert f"{sim}: {LINE.format(12)}" in notes and f"{real}: {LINE.format(6)}" in notes
    assert int(result.table["n_simulated"].sum()) == 36 and int(result.table["n_real"].sum()) == 42
    cli = CliRunner().invoke(main, ["compare", str(sim), str(real), "--plan", "study-code",
                                    "--metric", "mode_switches", "--resamples", "0"])
    assert cli.exit_code == 0, cli.output
    assert f"{sim}: {LINE.format(12)}" in cli.stderr and "[filters]" not in cli.stdout


def test_compare_says_nothing_of_filters_that_remove_no_value(tmp_path: Path) -> None:
    notes: list[str] = []
    compare_sources(METRICS_CSV, METRICS_CSV, plan="study-code", metrics=["mode_switches"], notes=notes)
    assert not any("[filters]" in note for note in notes)
