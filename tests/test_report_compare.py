"""`nudge compare`: simulated against real metrics tables (issue 14, part 5)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.stats
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli import api
from nudgecli.cli import main
from nudgecli.errors import ConfigError, DataError
from nudgecli.report.compare import (
    CompareOptions,
    align_conditions,
    compare_tables,
    participant_medians,
    shared_metrics,
    weighted_distances,
)
from nudgecli.report.plans import MIN_RESAMPLES
from nudgecli.rng import generator


def synthetic(n_participants: int = 6, trials: int = 8, shift: float = 0.0, seed: int = 0,
              condition: str = "none", prefix: str = "p") -> pd.DataFrame:
    """A metrics table: completion_time ~ 20 + 3 z (+ shift), success 0/1, mode_switches integers."""
    rng = np.random.default_rng(seed)
    n = n_participants * trials
    return pd.DataFrame({
        "participant": [f"{prefix}{i}" for i in range(n_participants) for _ in range(trials)],
        "condition": condition,
        "trial": np.tile(np.arange(trials), n_participants),
        "completion_time": 20.0 + 3.0 * rng.standard_normal(n) + shift,
        "success": rng.random(n) < 0.8,
        "mode_switches": rng.integers(5, 12, n),
    })


@pytest.mark.filterwarnings("ignore:ks_2samp. Exact calculation unsuccessful")
@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(-5, 5), min_size=1, max_size=25),
       st.lists(st.integers(-5, 5), min_size=1, max_size=25))
def test_unit_weight_distances_equal_scipy(a: list[int], b: list[int]) -> None:
    # integers make ties within and across the samples; scipy is the reference
    va, vb = np.array(a, dtype=float), np.array(b, dtype=float)
    ks, w1 = weighted_distances(va, np.ones((1, va.size)), vb, np.ones((1, vb.size)))
    assert ks[0] == pytest.approx(scipy.stats.ks_2samp(va, vb).statistic, abs=1e-12)
    assert w1[0] == pytest.approx(scipy.stats.wasserstein_distance(va, vb), abs=1e-12)


def test_integer_weights_equal_repeated_samples() -> None:
    # a cluster resample = each trial counted as often as its participant was drawn
    rng = np.random.default_rng(3)
    va, vb = rng.normal(size=13), rng.normal(0.5, 2.0, size=9)
    wa, wb = rng.integers(0, 4, size=(5, 13)).astype(float), rng.integers(1, 3, size=(5, 9)).astype(float)
    ks, w1 = weighted_distances(va, wa, vb, wb)
    for row in range(5):
        ra, rb = np.repeat(va, wa[row].astype(int)), np.repeat(vb, wb[row].astype(int))
        assert ks[row] == pytest.approx(scipy.stats.ks_2samp(ra, rb).statistic, abs=1e-12)
        assert w1[row] == pytest.approx(scipy.stats.wasserstein_distance(ra, rb), abs=1e-12)
    # a row without weight in one sample has no distance
    ks, w1 = weighted_distances(va, np.zeros((1, 13)), vb, np.ones((1, 9)))
    assert np.isnan(ks[0]) and np.isnan(w1[0])


def test_a_constant_shift_is_the_wasserstein_distance_and_ks_matches_scipy() -> None:
    simulated = synthetic(seed=1)
    real = simulated.assign(participant="r" + simulated["participant"],
                            completion_time=simulated["completion_time"] + 2.5)
    table = compare_tables(simulated, real, ["completion_time"], ["none"], CompareOptions(resamples=200))
    row = table.iloc[0]
    # the same sample moved by 2.5: W1 = 2.5 exactly (quantile functions differ by 2.5 everywhere)
    assert row["wasserstein"] == pytest.approx(2.5, abs=1e-12)
    expected = scipy.stats.ks_2samp(simulated["completion_time"], real["completion_time"])
    assert row["ks_statistic"] == pytest.approx(expected.statistic)
    assert row["ks_p"] == pytest.approx(expected.pvalue)
    assert row["median_real"] - row["median_simulated"] == pytest.approx(2.5)
    assert row["q1_real"] - row["q1_simulated"] == pytest.approx(2.5)
    assert row["ks_low"] <= row["ks_high"] and row["wasserstein_low"] <= row["wasserstein_high"]
    assert row["valid_resamples"] == 200


def test_separated_samples_have_ks_one_in_every_resample() -> None:
    simulated, real = synthetic(seed=2), synthetic(seed=3, shift=100.0, prefix="r")
    options = CompareOptions(resamples=300)
    row = compare_tables(simulated, real, ["completion_time"], ["none"], options).iloc[0]
    assert row["ks_statistic"] == row["ks_low"] == row["ks_high"] == 1.0
    assert 90 < row["wasserstein_low"] <= row["wasserstein"] * 1.1 and row["wasserstein_high"] < 110


def test_identical_tables_are_at_distance_zero_and_bootstrap_is_seeded() -> None:
    simulated = synthetic(seed=4)
    real = simulated.assign(participant="r" + simulated["participant"])
    options = CompareOptions(resamples=150, seed=7)
    first = compare_tables(simulated, real, ["completion_time", "success"], ["none"], options)
    assert (first["ks_statistic"] == 0).all() and (first["wasserstein"] == 0).all()
    again = compare_tables(simulated, real, ["completion_time", "success"], ["none"], options)
    pd.testing.assert_frame_equal(first, again)
    other = compare_tables(simulated, real, ["completion_time", "success"], ["none"],
                           CompareOptions(resamples=150, seed=8))
    assert not np.allclose(first["wasserstein_high"], other["wasserstein_high"])


def test_participant_medians_and_the_real_range_by_hand() -> None:
    simulated = pd.DataFrame({"participant": [0, 0, 0, 1, 1, 2], "condition": "none",
                              "completion_time": [10.0, 30.0, 20.0, 40.0, 41.0, 25.0]})
    real = pd.DataFrame({"participant": ["a", "a", "b", "b", "b"], "condition": "none",
                         "completion_time": [18.0, 22.0, 30.0, 31.0, np.nan]})
    medians = participant_medians(simulated, real, ["completion_time"])
    sim = medians[medians["source"] == "simulated"].set_index("participant")["median"]
    assert sim.to_dict() == {"0": 20.0, "1": 40.5, "2": 25.0}
    got = medians[medians["source"] == "real"].set_index("participant")
    assert got["median"].to_dict() == {"a": 20.0, "b": 30.5} and got["n"].to_dict() == {"a": 2, "b": 2}
    row = compare_tables(simulated, real, ["completion_time"], ["none"], CompareOptions(resamples=0)).iloc[0]
    # real people's medians 20 and 30.5: simulated 20 and 25 inside, 40.5 outside -> 2/3
    assert (row["real_participant_min"], row["real_participant_max"]) == (20.0, 30.5)
    assert row["simulated_inside_real_range"] == pytest.approx(2 / 3)
    assert (row["n_simulated"], row["n_real"], row["participants_real"]) == (6, 4, 2)
    assert np.isnan(row["ks_low"]) and row["valid_resamples"] == 0


def test_conditions_are_matched_by_name_or_by_map() -> None:
    simulated = pd.concat([synthetic(condition="none"), synthetic(condition="blend", seed=5)])
    real = synthetic(condition="no assistance", prefix="r")
    with pytest.raises(DataError, match=r"no condition in common.*--match none=no assistance"):
        align_conditions(simulated, real)
    sim, _, shared = align_conditions(simulated, real, {"none": "no assistance"})
    assert shared == ["no assistance"] and len(sim) == 48 and set(sim["condition"]) == {"no assistance"}
    with pytest.raises(DataError, match="has no condition 'nnone' \\(did you mean 'none'\\?\\)"):
        align_conditions(simulated, real, {"nnone": "no assistance"})


def test_shared_metrics_and_their_errors() -> None:
    assert shared_metrics(["a", "b", "c"], ["c", "x", "a"]) == ["c", "a"]
    with pytest.raises(DataError, match="no metric in common"):
        shared_metrics(["a"], ["b"])
    with pytest.raises(DataError, match="the real table has no metric 'b'"):
        shared_metrics(["a", "b"], ["a"], ["b"])


def test_the_cluster_bootstrap_intervals_by_a_plain_loop_over_repeated_samples() -> None:
    """Each resample draws participants with replacement (the seed's ``compare/<source>`` branch);
    its distances are scipy's on the drawn people's trials; the interval is the level's central
    percentiles. Integer values, so the two sources tie often."""
    simulated = synthetic(4, 5, seed=1).assign(mode_switches=lambda t: t["mode_switches"] + 1)
    real = synthetic(5, 3, seed=2, prefix="r")
    options = CompareOptions(resamples=60, level=0.8, seed=11)
    (row,) = compare_tables(simulated, real, ["mode_switches"], ["none"], options).to_dict("records")
    draws = {}
    for source, table in (("simulated", simulated), ("real", real)):
        people = sorted(table["participant"].unique())
        rng = generator(options.seed, "compare", source)
        picks = rng.integers(0, len(people), (options.resamples, len(people)))
        draws[source] = [pd.concat([table[table["participant"] == people[i]] for i in pick])["mode_switches"]
                         for pick in picks]
    pairs = list(zip(draws["simulated"], draws["real"], strict=True))
    ks = [scipy.stats.ks_2samp(a, b).statistic for a, b in pairs]
    w1 = [scipy.stats.wasserstein_distance(a, b) for a, b in pairs]
    assert (row["ks_low"], row["ks_high"]) == pytest.approx(tuple(np.quantile(ks, [0.1, 0.9])))
    assert (row["wasserstein_low"], row["wasserstein_high"]) == pytest.approx(
        tuple(np.quantile(w1, [0.1, 0.9])))
    assert row["valid_resamples"] == 60
    assert (row["q1_real"], row["median_real"], row["q3_real"]) == pytest.approx(
        tuple(np.quantile(real["mode_switches"], [0.25, 0.5, 0.75])))


def test_a_simulated_median_on_the_edge_of_the_real_range_is_inside() -> None:
    real = pd.DataFrame({"participant": ["r1", "r1", "r2"], "condition": "none", "m": [1.0, 3.0, 6.0]})
    simulated = pd.DataFrame({"participant": ["s1", "s2", "s3", "s4"], "condition": "none",
                              "m": [2.0, 6.0, 6.5, 1.9]})
    (row,) = compare_tables(simulated, real, ["m"], ["none"], CompareOptions(resamples=0)).to_dict("records")
    assert (row["real_participant_min"], row["real_participant_max"]) == (2.0, 6.0)
    assert row["simulated_inside_real_range"] == 0.5  # 2.0 and 6.0 are on the edges: inside


def _write(tmp_path: Path) -> tuple[Path, Path]:
    simulated = pd.concat([synthetic(condition="none"), synthetic(condition="blend", seed=5)])
    real = synthetic(condition="none", shift=4.0, seed=9, prefix="r").drop(columns="mode_switches")
    simulated.to_csv(tmp_path / "sim.csv", index=False)
    real.to_csv(tmp_path / "real.csv", index=False)
    return tmp_path / "sim.csv", tmp_path / "real.csv"


def test_cli_compare_formats_and_files(tmp_path: Path) -> None:
    sim, real = _write(tmp_path)
    runner = CliRunner()
    result = runner.invoke(main, ["compare", str(sim), str(real), "--resamples", "100"])
    assert result.exit_code == 0, result.output
    assert "completion_time" in result.stdout and "mode_switches" not in result.stdout
    assert "Per-participant medians" in result.stdout
    result = runner.invoke(main, ["compare", str(sim), str(real), "--resamples", "100", "--format", "json"])
    document = json.loads(result.stdout)
    assert document["metrics"] == ["completion_time", "success"] and document["conditions"] == ["none"]
    assert {r["source"] for r in document["participant_medians"]} == {"simulated", "real"}
    result = runner.invoke(main, ["compare", str(sim), str(real), "--resamples", "100", "--format", "csv",
                                  "--metric", "completion_time", "--out", str(tmp_path / "out"),
                                  "--formats", "png"])
    assert result.exit_code == 0, result.output
    table = pd.read_csv(pd.io.common.StringIO(result.stdout))
    assert list(table["metric"]) == ["completion_time"]
    for name in ("compare.csv", "participant_medians.csv", "compare.json", "compare.png"):
        assert (tmp_path / "out" / name).is_file(), name


def test_cli_compare_errors_are_one_line(tmp_path: Path) -> None:
    sim, real = _write(tmp_path)
    runner = CliRunner()
    cases = [
        ["compare", str(sim), str(real), "--match", "nnone=none"],
        ["compare", str(sim), str(real), "--metric", "mode_switches"],
        ["compare", str(sim), str(tmp_path)],
        ["compare", str(sim), str(real), "--match", "none"],
    ]
    for args in cases:
        result = runner.invoke(main, args)
        assert result.exit_code == 1, (args, result.output)
        assert result.stderr.startswith("Error: ") and result.stderr.count("\n") == 1, result.stderr


@pytest.mark.parametrize("resamples", [1, 20, MIN_RESAMPLES - 1])
def test_compare_refuses_fewer_resamples_than_a_plan_allows(tmp_path: Path, resamples: int) -> None:
    sim, real = _write(tmp_path)
    result = CliRunner().invoke(main, ["compare", str(sim), str(real), "--resamples", str(resamples),
                                       "--out", str(tmp_path / "out")])
    assert result.exit_code == 1, result.output
    assert result.stderr == (f"Error: --resamples {resamples}: at least {MIN_RESAMPLES} bootstrap resamples "
                             "(an interval of fewer is a few resamples' values), as in a plan's [bootstrap] "
                             "resamples; 2000 is the usual number\n")
    assert not (tmp_path / "out").exists()
    with pytest.raises(ConfigError, match=f"^--resamples {resamples}: at least {MIN_RESAMPLES} "):
        api.compare(sim, real, resamples=resamples)


def test_compare_takes_no_resamples_or_as_few_as_a_plan_allows(tmp_path: Path) -> None:
    sim, real = _write(tmp_path)
    assert api.compare(sim, real, resamples=0).table["valid_resamples"].eq(0).all()  # 0: no intervals
    fewest = api.compare(sim, real, resamples=MIN_RESAMPLES, metrics=["completion_time"])
    assert fewest.table["valid_resamples"].eq(MIN_RESAMPLES).all()


def test_importing_the_comparison_does_not_import_scipy_stats() -> None:
    # scipy.stats costs about 0.6 s of CPU: compare_tables imports it where it runs the tests, so
    # every command that imports this module (the CLI's) does not pay for it; a fresh interpreter
    # because this one has scipy.stats already
    code = "import sys, nudgecli.report.compare; print('scipy.stats' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
