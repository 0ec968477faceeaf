"""``nudgecli.plot`` of an analysis written away from its run (``analyze(run, out=OTHER)``) draws
Fig. 5 and the trajectory from the run the Analysis knows; OTHER's path alone, which names no run,
gets one line saying what to give instead."""

from __future__ import annotations

from pathlib import Path

import pytest

import nudgecli
from nudgecli.errors import ConfigError


@pytest.fixture(scope="module")
def analysis_elsewhere(analysed_smoke_run: Path,
                       tmp_path_factory: pytest.TempPathFactory) -> nudgecli.Analysis:
    """The smoke run analysed into a folder of its own, away from the run."""
    return nudgecli.analyze(analysed_smoke_run, out=tmp_path_factory.mktemp("elsewhere") / "other",
                            bootstrap=100)


def _fig5_lines(source, trial: tuple[int, int]) -> list[list[float]]:
    """Fig. 5 of ``trial`` drawn into an axes of one's own: each line's values."""
    from matplotlib.figure import Figure

    ax = Figure().subplots()
    nudgecli.plot(source, "fig5", trial=trial, ax=ax)
    return [list(line.get_ydata()) for line in ax.get_lines()]


def test_fig5_of_an_analysis_written_elsewhere_is_its_runs(analysis_elsewhere, analysed_smoke_run):
    assert analysis_elsewhere.path != analysed_smoke_run
    drawn = _fig5_lines(analysis_elsewhere, (0, 1))
    assert drawn and drawn == _fig5_lines(analysed_smoke_run, (0, 1))


def test_fig5_of_its_folder_alone_says_what_to_give(analysis_elsewhere):
    with pytest.raises(ConfigError, match=r"names no run to read them from; draw it from the Analysis "
                                          r"that analyze returned \(nudgecli\.plot\(analysis, 'fig5'\)\)"):
        nudgecli.plot(analysis_elsewhere.path, "fig5", trial=(0, 1))
    assert nudgecli.plot(analysis_elsewhere.path, "fig4").axes  # its box plots draw as before
