"""A run's analysis knows the trials it came from: ``nudge plot RUN`` never draws another run's
statistics beside this run's own trial figures (Fig. 5, the trajectory)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

import nudgecli
from nudgecli.errors import RunFolderError
from nudgecli.report.plotting import read_inputs


@pytest.fixture(scope="module")
def other_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Another run of the smoke experiment (seed 8, one participant: other trials), analysed."""
    run = tmp_path_factory.mktemp("other-smoke") / "other"
    assert nudge("simulate", "smoke", "--participants", "1", "--seed", "8", "--out", run).exit_code == 0
    assert nudge("analyze", run, "--bootstrap", "100").exit_code == 0
    return run


def _copy(run: Path, to: Path) -> Path:
    shutil.copytree(run, to, ignore=shutil.ignore_patterns("figures", ".nudge.lock"))
    return to


def _refused(folder: Path) -> str:
    result = nudge("plot", folder)
    assert result.exit_code == 1
    line = one_error_line(result.output)
    assert f"{folder / 'stats.json'} is the analysis of other trials than {folder}'s" in line
    assert f"`nudge analyze {folder}`" in line
    assert not (folder / "figures").exists()  # nothing drawn
    return line


def test_analyze_records_the_trials_it_analysed(analysed_smoke_run, other_run):
    digests = [json.loads((run / "stats.json").read_text())["trials_digest"]
               for run in (analysed_smoke_run, other_run)]
    assert all(isinstance(d, str) and len(d) == 64 for d in digests) and digests[0] != digests[1]


def test_another_runs_analysis_written_into_the_run_is_refused(analysed_smoke_run, other_run, tmp_path):
    x1 = _copy(analysed_smoke_run, tmp_path / "x1")  # cp -a r1 x1; nudge analyze r2 --out x1 --force
    assert nudge("analyze", other_run, "--out", x1, "--force", "--bootstrap", "100").exit_code == 0
    _refused(x1)


def test_another_runs_analysis_copied_in_is_refused(analysed_smoke_run, other_run, tmp_path):
    r1 = _copy(analysed_smoke_run, tmp_path / "r1")  # cp r2/metrics.csv r2/stats.json r1/
    for name in ("metrics.csv", "stats.json"):
        shutil.copy(other_run / name, r1 / name)
    _refused(r1)


def test_the_runs_own_analysis_and_an_older_nudges_without_the_digest_are_read(analysed_smoke_run, tmp_path):
    assert read_inputs(analysed_smoke_run).trials is not None  # what plot draws, without drawing it
    run = _copy(analysed_smoke_run, tmp_path / "run")
    stats = json.loads((run / "stats.json").read_text())
    del stats["trials_digest"]  # as results/paper's and results/baselines' until written again
    (run / "stats.json").write_text(json.dumps(stats, indent=2))
    assert read_inputs(run).steps is not None


def test_the_api_refuses_an_analysis_elsewhere_of_a_run_simulated_again(analysed_smoke_run, other_run,
                                                                         tmp_path):
    run = _copy(analysed_smoke_run, tmp_path / "run")
    analysis = nudgecli.analyze(run, out=tmp_path / "elsewhere", bootstrap=100)
    shutil.rmtree(run)
    _copy(other_run, run)  # the run simulated again since, with other trials
    with pytest.raises(RunFolderError, match=r"is the analysis of other trials .*`nudge analyze .*--out"):
        nudgecli.plot(analysis, "fig5")
