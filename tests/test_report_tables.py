"""Real metrics tables at face value no more: duplicates, infinities, near-identical labels,
delimiters, exclusions on stderr, output folders; the blockwise cluster bootstrap against its
definition; `--bootstrap`; the plan recorded in a run's manifest."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.errors import DataError
from nudgecli.report import cluster_bootstrap as bootstrap_module
from nudgecli.report.analysis import analyze
from nudgecli.report.cluster_bootstrap import _weighted_medians, bootstrap_median_differences
from nudgecli.report.tables import sniff_delimiter
from nudgecli.runs.study import run_study

# the table as the paper plan analyses it (no time for a failed trial): analysed as it is
TABLE = Path(__file__).parent / "data" / "metrics_two_conditions_paper.csv"


def write(path: Path, frame: pd.DataFrame, sep: str = ",") -> Path:
    frame.to_csv(path, index=False, sep=sep)
    return path


@pytest.fixture
def table() -> pd.DataFrame:
    return pd.read_csv(TABLE)


# --- validation of real tables -----------------------------------------------------------------


def test_duplicate_trials_are_an_error_or_dropped_with_a_count(tmp_path, table):
    doubled = pd.concat([table, table.iloc[[3, 10]]], ignore_index=True)
    source = write(tmp_path / "study.csv", doubled)
    with pytest.raises(DataError, match=r"2 duplicate trial row\(s\).*rows 50, 51.*--drop-duplicates"):
        analyze(source)
    assert not (tmp_path / "study-analysis").exists()  # a refused table leaves no empty folder
    result = CliRunner().invoke(main, ["analyze", str(source), "--drop-duplicates", "--format", "json"])
    assert result.exit_code == 0, result.output
    assert "dropped 2 duplicate trial row(s)" in result.stderr
    clean = analyze(TABLE, out=tmp_path / "clean")
    dropped = json.loads((tmp_path / "study-analysis" / "stats.json").read_text())
    assert dropped["metrics"] == clean.stats["metrics"]  # the same statistics as without the repeats
    assert dropped["metrics_table"] == "metrics.csv"  # the analysed table differs from the input: written
    assert len(pd.read_csv(tmp_path / "study-analysis" / "metrics.csv")) == len(table)


def test_infinite_values_are_an_error_naming_rows_and_columns(tmp_path, table):
    table = table.astype({"completion_time": float, "mode_switches": float})
    table.loc[[4, 7], "completion_time"] = [np.inf, -np.inf]
    table.loc[9, "mode_switches"] = np.inf
    source = write(tmp_path / "inf.csv", table)
    with pytest.raises(DataError) as caught:
        analyze(source)
    message = str(caught.value)
    assert "infinite values in 3 row(s)" in message
    assert "'completion_time' (rows 6, 9)" in message and "'mode_switches' (rows 11)" in message


@pytest.mark.parametrize("variant", ["control ", "Control", " CONTROL"])
def test_condition_labels_differing_by_case_or_spaces_are_an_error(tmp_path, table, variant):
    table.loc[table.index[-3:], "condition"] = variant
    source = write(tmp_path / "labels.csv", table)
    result = CliRunner().invoke(main, ["analyze", str(source)])
    assert result.exit_code == 1
    assert f"{variant!r}" in result.output and "did you mean 'control'?" in result.output


@pytest.mark.parametrize("sep", [";", "\t", "|"])
def test_the_delimiter_is_sniffed(tmp_path, table, sep):
    source = write(tmp_path / "semi.csv", table, sep=sep)
    assert sniff_delimiter(source) == sep
    assert analyze(source).stats["metrics"] == analyze(TABLE, out=tmp_path / "comma").stats["metrics"]


def test_an_excluded_participant_is_reported_on_stderr(tmp_path, table):
    only_one = table[~((table["participant"] == 2) & (table["condition"] == "control"))]
    source = write(tmp_path / "partial.csv", only_one)
    result = CliRunner().invoke(main, ["analyze", str(source), "--format", "json"])
    assert result.exit_code == 0, result.output
    json.loads(result.stdout)  # stdout stays pure JSON
    assert "1 participant(s) without a value in every condition dropped: 2" in result.stderr
    assert "participant-level test of mode_switches, completion_time" in result.stderr


def test_two_tables_in_one_folder_get_their_own_analysis_folders_and_are_not_copied(tmp_path, table):
    first = write(tmp_path / "study.csv", table)
    second = write(tmp_path / "pilot.csv", table.assign(completion_time=table["completion_time"] + 1))
    a, b = analyze(first), analyze(second)
    assert a.out == tmp_path / "study-analysis" and b.out == tmp_path / "pilot-analysis"
    assert a.stats["metrics"] != b.stats["metrics"]
    for result, source in ((a, first), (b, second)):
        assert not (result.out / "metrics.csv").exists()  # the table is the metrics table: no copy
        recorded = json.loads((result.out / "stats.json").read_text())["metrics_table"]
        assert (result.out / recorded).resolve() == source.resolve()


def test_bootstrap_option_sets_the_resamples(tmp_path):
    result = CliRunner().invoke(main, ["analyze", str(TABLE), "--out", str(tmp_path), "--bootstrap", "300",
                                       "--format", "json"])
    assert result.exit_code == 0, result.output
    ci = json.loads(result.stdout)["metrics"][0]["ci"]
    assert ci["resamples"] == 300 and ci["pairs"][0]["valid_resamples"] == 300
    assert "(300 resamples" in (tmp_path / "summary.md").read_text()
    bad = CliRunner().invoke(main, ["analyze", str(TABLE), "--bootstrap", "0"])
    assert bad.exit_code == 1 and "at least 100" in bad.output  # the plan's bound, one Error line


# --- the cluster bootstrap against its definition -------------------------------------------------


def bootstrap_by_definition(data: pd.DataFrame, conditions: list[str], resamples: int, seed: int,
                            level: float = 0.95) -> list[tuple[float, float]]:
    """The documented draw, then np.median of each resample's replicated trials (brute force)."""
    codes, uniques = pd.factorize(data["participant"])
    draws = np.random.default_rng(seed).integers(0, len(uniques), size=(resamples, len(uniques)))
    out = []
    for i, a in enumerate(conditions):
        for b in conditions[i + 1:]:
            differences = []
            for row in draws:
                medians = []
                for c in (a, b):
                    values = [v for p in row for v, q, cc in zip(data["value"], codes, data["condition"],
                                                                 strict=True) if q == p and cc == c]
                    medians.append(np.median(values) if values else math.nan)
                if all(np.isfinite(medians)):
                    differences.append(medians[0] - medians[1])
            tail = (1 - level) / 2
            out.append(tuple(float(q) for q in np.quantile(differences, [tail, 1 - tail])))
    return out


def test_the_bootstrap_equals_its_definition_with_small_blocks(monkeypatch):
    rng = np.random.default_rng(4)
    n = 90
    data = pd.DataFrame({"participant": rng.choice(["p1", "p2", "p3", "p4", "p5", "p6"], n),
                         "condition": rng.choice(["a", "b", "c"], n),
                         "value": rng.integers(0, 12, n).astype(float)})
    monkeypatch.setattr(bootstrap_module, "_block_size", lambda n, p: 4)  # many blocks
    monkeypatch.setattr(bootstrap_module, "_BOOTSTRAP_CHUNK_CELLS", 37)  # many chunks
    fast = bootstrap_median_differences(data, "value", ["a", "b", "c"], resamples=60, seed=9)
    expected = bootstrap_by_definition(data, ["a", "b", "c"], resamples=60, seed=9)
    assert list(zip(fast["low"], fast["high"], strict=True)) == expected


@settings(max_examples=80, deadline=None)
@given(st.integers(1, 8), st.integers(0, 40), st.integers(1, 12), st.integers(1, 9), st.integers(1, 50),
       st.integers(0, 2**32 - 1), st.booleans())
def test_weighted_medians_equal_replicated_medians_for_any_blocks(participants, n, resamples, block, chunk,
                                                                   seed, ties):
    rng = np.random.default_rng(seed)
    # few distinct values (one block per value) or all distinct (blocks of `block` values)
    values = np.sort(rng.integers(0, 6, n).astype(float) if ties else rng.normal(size=n))
    owners = rng.integers(0, participants, n)
    weights = rng.integers(0, 3, size=(resamples, participants))
    original = bootstrap_module._block_size, bootstrap_module._BOOTSTRAP_CHUNK_CELLS
    bootstrap_module._block_size, bootstrap_module._BOOTSTRAP_CHUNK_CELLS = (lambda n, p: block), chunk
    try:
        fast = _weighted_medians(values, owners, weights)
    finally:
        bootstrap_module._block_size, bootstrap_module._BOOTSTRAP_CHUNK_CELLS = original
    for r in range(resamples):
        replicated = np.repeat(values, weights[r, owners])
        expected = np.median(replicated) if replicated.size else math.nan
        assert fast[r] == pytest.approx(expected, nan_ok=True)


# --- the plan recorded in the manifest ---------------------------------------------------------------


def test_analyze_uses_the_plan_recorded_in_the_manifest(tmp_path):
    run = tmp_path / "run"
    run_study(load_experiment("smoke"), run, participants=2, plan="study-code")
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["plan"] == "study-code"
    result = analyze(run)
    assert "- plan: study-code;" in result.summary
    assert "- plan: paper;" in analyze(run, plan="paper").summary
    del manifest["plan"]  # a run made before plans were recorded
    (run / "manifest.json").write_text(json.dumps(manifest))
    before = (run / "manifest.json").read_bytes()
    elsewhere = analyze(run, out=tmp_path / "elsewhere")  # writes only into its output folder
    assert "- plan: paper;" in elsewhere.summary and (run / "manifest.json").read_bytes() == before
    assert "- plan: paper;" in analyze(run).summary  # smoke has no plan of its own
    assert json.loads((run / "manifest.json").read_text())["plan"] == "paper"


def test_plot_finds_the_table_an_analysis_folder_did_not_copy(tmp_path):
    from nudgecli.bench.analyze import synthetic_metrics_table

    frame = synthetic_metrics_table(400, 6)
    source = write(tmp_path / "full.csv", frame)
    result = analyze(source, bootstrap=100)
    assert not (result.out / "metrics.csv").exists()
    plotted = CliRunner().invoke(main, ["plot", str(result.out), "--formats", "png"])
    assert plotted.exit_code == 0, plotted.output
    assert (result.out / "figures" / "fig3.png").is_file()
