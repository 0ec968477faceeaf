"""Undefined values over replications: a pooled value or sensitivity input never stands on fewer
or other seeds than it says (docs/batches.md)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from nudgecli.report.replication import point_outputs, summarise


def _rows(differences: list[list[float]]) -> pd.DataFrame:
    """Rows of one metric and pair: ``differences[point][replication]``."""
    records = []
    for point, values in enumerate(differences):
        for replication, value in enumerate(values):
            records.append({"point": point, "replication": replication, "seed": replication,
                            "participants": 4, "metric": "completion_time", "a": "x", "b": "y",
                            "trial_significant": False, "trial_direction": 0,
                            "participant_significant": False, "participant_direction": 0,
                            "kruskal_p": 0.5, "conover_p": value * 0 + 0.5, "participant_p": 0.5,
                            "effect_size_name": "rank_biserial", "effect_size": value, "difference": value})
    return pd.DataFrame(records)


def test_the_sensitivity_input_uses_only_replications_defined_at_every_point() -> None:
    # replication 0 is undefined at point 1: every point's Y is replication 1's and 2's mean
    rows = _rows([[10.0, 2.0, 4.0], [math.nan, 6.0, 8.0], [1.0, 3.0, 5.0]])
    outputs = point_outputs(rows)
    assert outputs["y"].tolist() == [3.0, 7.0, 4.0]
    assert outputs["replications"].tolist() == [2, 2, 2]


def test_the_sensitivity_input_is_undefined_where_no_replication_is_defined_everywhere() -> None:
    outputs = point_outputs(_rows([[math.nan, 2.0], [1.0, math.nan]]))
    assert outputs["y"].isna().all() and outputs["replications"].tolist() == [0, 0]


def test_a_pooled_value_is_undefined_where_some_replication_is() -> None:
    summary = summarise(_rows([[10.0, 2.0, 4.0], [math.nan, 6.0, 8.0]])).set_index("point")
    assert summary.loc[0, "difference"] == 16 / 3 and summary.loc[0, "replications"] == 3
    assert summary.loc[1, "replications"] == 3
    for column in ("difference", "difference_low", "difference_high", "effect_size", "median_conover_p"):
        assert np.isnan(summary.loc[1, column]), column
    assert summary.loc[1, "median_kruskal_p"] == 0.5


def _design(method: str) -> tuple[dict, np.ndarray]:
    from nudgecli.runs.sweep import Design, Range, SweepFile, design_values

    design = Design(method=method, samples=4, levels=4, seed=0)  # type: ignore[arg-type]
    spec = SweepFile(experiment="unused", design=design,
                     parameters={"p.x": Range(low=0.0, high=1.0), "p.z": Range(low=0.0, high=1.0)})
    _, problem, samples = design_values(spec)
    assert problem is not None and samples is not None
    return problem, samples


def test_a_metric_undefined_at_some_point_keeps_its_sensitivity_rows_with_nan_indices() -> None:
    from nudgecli.report.figures.replication import sensitivity_figure
    from nudgecli.report.replication import sensitivity

    for method, names in (("sobol", {"S1", "ST"}), ("morris", {"mu_star", "sigma", "mu"})):
        problem, samples = _design(method)
        y = samples[:, 0].copy()
        broken = y.copy()
        broken[1] = math.nan
        outputs = pd.concat([
            pd.DataFrame({"point": range(len(y)), "metric": "human_effort", "a": "x", "b": "y", "y": y,
                          "replications": 3}),
            pd.DataFrame({"point": range(len(y)), "metric": "completion_time", "a": "x", "b": "y",
                          "y": broken, "replications": 3})])
        indices = sensitivity(method, problem, samples, outputs, levels=4)
        missing = indices[indices["metric"] == "completion_time"]
        assert set(zip(missing["parameter"], missing["index"], strict=True)) == \
            {(p, i) for p in ("p.x", "p.z") for i in names}
        assert missing["value"].isna().all() and missing["conf"].isna().all()
        assert indices[indices["metric"] == "human_effort"]["value"].notna().all()
        sensitivity_figure(indices)  # draws the defined metric beside the undefined one


def test_sobol_indices_of_an_output_constant_over_the_design_are_undefined() -> None:
    from nudgecli.report.replication import sensitivity

    problem, samples = _design("sobol")
    outputs = pd.DataFrame({"point": range(len(samples)), "metric": "success", "a": "x", "b": "y", "y": 0.25,
                            "replications": 3})
    indices = sensitivity("sobol", problem, samples, outputs)
    assert len(indices) == 4 and indices["value"].isna().all() and indices["conf"].isna().all()
    # Morris: the elementary effects of a constant are 0, defined
    problem, samples = _design("morris")
    outputs = outputs.iloc[:0].reindex(range(len(samples))).assign(
        point=range(len(samples)), metric="success", a="x", b="y", y=0.25, replications=3)
    morris = sensitivity("morris", problem, samples, outputs, levels=4).set_index("index")
    assert (morris.loc[["mu_star", "sigma", "mu"], "value"] == 0).all()


def test_a_pair_holding_a_condition_left_out_of_a_metric_carries_no_kruskal_p() -> None:
    from nudgecli.report.plans import AnalysisPlan
    from nudgecli.report.replication import analyse_replication, replication_rows

    rng = np.random.default_rng(4)
    trials = pd.DataFrame([{"participant": p, "condition": c, "trial": t,
                            "human_turns": float(rng.integers(0, 5)) + (2.0 if c == "x" else 0.0)}
                           for p in range(8) for c in ("x", "y", "teleoperation") for t in range(4)])
    plan = AnalysisPlan(conditions=("x", "y", "teleoperation"), bootstrap={"resamples": 100})
    document = analyse_replication(trials, plan, ["human_turns"],
                                   not_applicable={"human_turns": ["teleoperation"]})
    entries = pd.DataFrame([{"point": 0, "replication": 0, "seed": 0, "participants": 8, "analysis": "s"}])
    rows = replication_rows(entries, {"s": document}, plan).set_index(["a", "b"])
    assert rows.loc[("x", "y"), "kruskal_p"] < 0.05
    for pair in (("x", "teleoperation"), ("y", "teleoperation")):
        assert np.isnan(rows.loc[pair, "conover_p"]) and np.isnan(rows.loc[pair, "kruskal_p"]), pair
    summary = summarise(rows.reset_index()).set_index(["a", "b"])
    assert np.isnan(summary.loc[("x", "teleoperation"), "median_kruskal_p"])


def test_a_replication_is_significant_as_analyzes_stars_say(monkeypatch) -> None:
    """Kruskal-Wallis gates at the plan's kruskal_alpha, then a pair's p must pass the first star
    threshold (nudgecli.report.stats.pair_stars): with kruskal_alpha = 0.1 a Conover p of 0.055
    under a gate p of 0.0587 has no star in `nudge analyze`, so the replication is not significant
    (it was, compared with kruskal_alpha alone)."""
    from nudgecli.report import replication
    from nudgecli.report.plans import AnalysisPlan

    pairs = [(0.0587, 0.055, 0.07), (0.0587, 0.04, 0.03), (0.2, 0.01, 0.01)]
    table = pd.DataFrame([{"metric": "completion_time", "a": "x", "b": "y", "median_a": 2.0, "median_b": 1.0,
                           "mean_a": 2.0, "mean_b": 1.0, "mean_rank_a": 2.0, "mean_rank_b": 1.0,
                           "difference": 1.0, "ci_low": 0.5, "ci_high": 1.5, "kruskal_p": k, "conover_p": c,
                           "participant_p": w, "effect_size_name": "rank_biserial", "effect_size": 0.5}
                          for k, c, w in pairs])
    monkeypatch.setattr(replication, "stats_table", lambda document: table.iloc[[document]])
    entries = pd.DataFrame([{"point": 0, "replication": i, "seed": i, "participants": 4, "analysis": f"r{i}"}
                            for i in range(3)])
    plan = AnalysisPlan.model_validate({"name": "gate10", "stats": {"kruskal_alpha": 0.1}})
    rows = replication.replication_rows(entries, {f"r{i}": i for i in range(3)}, plan)
    assert rows["trial_significant"].tolist() == [False, True, False]
    assert rows["participant_significant"].tolist() == [False, True, True]
