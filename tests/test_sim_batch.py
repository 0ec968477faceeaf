"""Many studies at once: replicate/power/sweep, executors, resume after SIGKILL, orphan workers."""

from __future__ import annotations

import errno
import io
import json
import math
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.stats
from click.testing import CliRunner
from dask_helpers import local_cluster
from import_guard import run_refusing

from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.config_files import list_presets
from nudgecli.errors import ConfigError
from nudgecli.report.plans import AnalysisPlan, load_plan
from nudgecli.report.replication import (
    analyse_replication,
    clopper_pearson,
    paper_direction,
    point_outputs,
    power_table,
    replication_rows,
    sensitivity,
    smallest_n,
    summarise,
)
from nudgecli.runs import batch as batch_module
from nudgecli.runs import batch_tasks
from nudgecli.runs import size as size_module
from nudgecli.runs.batch import replication_seed
from nudgecli.runs.batch_kinds import replicate
from nudgecli.runs.batch_tasks import layout_key
from nudgecli.runs.progress import Progress
from nudgecli.runs.study import build_plan_on
from nudgecli.runs.sweep import Design, Range, SweepFile, design_values, load_sweep
from nudgecli.sim.study import StudyPlan, simulate_participant

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}
TABLES = ("replications", "conditions", "summary")


def assert_same_tables(a, b) -> None:
    for name in TABLES:
        pd.testing.assert_frame_equal(a.tables[name], b.tables[name], check_exact=True)


def test_replicate_is_identical_with_1_and_2_workers_and_dask(tmp_path):
    serial = replicate("smoke", 3, tmp_path / "serial", seed=5)
    two = replicate("smoke", 3, tmp_path / "two", seed=5, workers=2)
    with local_cluster(1) as cluster:
        on_dask = replicate("smoke", 3, tmp_path / "dask", seed=5, scheduler=cluster.scheduler_address)
    assert_same_tables(serial, two)
    assert_same_tables(serial, on_dask)
    rows = serial.tables["replications"]
    # three independent studies: their seeds and their results differ
    assert rows["seed"].nunique() == 3
    assert rows.groupby("replication")["median_a"].apply(tuple).nunique() == 3
    assert (tmp_path / "serial" / "figures" / "forest.png").is_file()


def test_a_large_job_and_a_large_result_do_not_block_each_other() -> None:
    # a 2 MB result coming back while a 2 MB job goes out: through the pipe both ends would wait
    # for ever (run in a child Python, so a regression fails here instead of hanging the suite)
    script = (
        "from nudgecli.runs.executors import Job, ProcessExecutor\n"
        "if __name__ == '__main__':\n"
        "    ex = ProcessExecutor(1)\n"
        "    ex.submit(Job('a', bytes, (2_000_000,)))\n"
        "    ex.submit(Job('b', len, (b'y' * 2_000_000,)))\n"
        "    results = {job.key: value for job, value in (ex.next_result(), ex.next_result())}\n"
        "    ex.close()\n"
        "    print(len(results['a']), results['b'])\n"
    )
    done = subprocess.run([sys.executable, "-c", script], env=ENV, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["2000000", "2000000"]


def test_a_broadcast_never_reuses_the_file_of_one_still_being_read() -> None:
    import pickle

    from nudgecli.runs.executors import Job, ProcessExecutor

    executor = ProcessExecutor(1)
    try:
        executor.broadcast(Job("a", int, ("1",)))
        executor.broadcast(Job("b", int, ("2",)))
        # "a" has come back from its one worker (next_result's bookkeeping); "b" has not
        executor._read_by_one("a")
        assert "a" not in executor._spooled and "a" not in executor._broadcast
        executor.broadcast(Job("c", int, ("3",)))
        files = {key: entry[0][0] for key, entry in executor._spooled.items()}
        assert files["b"] != files["c"]
        for key, path in files.items():
            with open(path, "rb") as handle:
                assert pickle.load(handle).key == key
        # the files a broadcast job reads go with it, once its one reader is done
        scratch = executor.scratch_path("chunk.pickle")
        Path(scratch).write_bytes(b"solved layouts")
        executor.broadcast(Job("d", int, ("4",)), files=[scratch])
        assert scratch in executor._spooled["d"][0] and scratch != executor.scratch_path("chunk.pickle")
        executor._read_by_one("d")
        assert not Path(scratch).exists()
    finally:
        executor.close()


def test_the_pool_gives_every_worker_a_job_before_any_gets_a_second() -> None:
    # a study's two layout chunks went to one worker (filled to POOL_DEPTH first) and ran in turn
    from nudgecli.runs.executors import POOL_DEPTH, Job, ProcessExecutor

    executor = ProcessExecutor(2)
    try:
        for key in ("chunk0", "chunk1", "chunk2", "chunk3"):
            executor.submit(Job(key, int, ("1",)))
        executor._fill()
        assert [len(slot.inflight) for slot in executor._slots] == [min(2, POOL_DEPTH)] * 2
        assert [next(iter(slot.inflight)) for slot in executor._slots] == ["chunk0", "chunk1"]
        keys = sorted(executor.next_result()[0].key for _ in range(4))
        assert keys == ["chunk0", "chunk1", "chunk2", "chunk3"]
    finally:
        executor.close()


def test_the_pool_refills_a_worker_before_its_result_is_handled() -> None:
    # the caller's handling of a result (a first part's write imports pandas and pyarrow) can take
    # longer than the worker's queued job: the worker already has its next one by then
    from nudgecli.runs.executors import POOL_DEPTH, Job, ProcessExecutor

    executor = ProcessExecutor(1)
    try:
        for k in range(POOL_DEPTH + 2):
            executor.submit(Job(f"job{k}", int, (str(k),)))
        job, result = executor.next_result()
        assert (job.key, result) == ("job0", 0)
        assert len(executor._slots[0].inflight) == POOL_DEPTH
    finally:
        executor.close()


def test_layout_chunks_cover_the_layouts_in_order() -> None:
    assert batch_module.contiguous_chunks(48, 16) == [(3 * k, 3 * k + 3) for k in range(16)]
    assert batch_module.contiguous_chunks(10, 4) == [(0, 2), (2, 5), (5, 8), (8, 10)]
    assert batch_module.contiguous_chunks(3, 8) == [(0, 1), (1, 2), (2, 3)]
    assert batch_module.contiguous_chunks(5, 1) == [(0, 5)]


def test_a_plan_assembled_from_layout_tasks_equals_the_built_one(tmp_path) -> None:
    from nudgecli.runs.study import solve_layout_chunk, solve_layout_chunk_into

    config = load_experiment("paper")
    ranges = batch_module.contiguous_chunks(48, 5)
    chunks = [solve_layout_chunk(config, 11, a, b) for a, b in ranges]
    built = StudyPlan.build(config, 11)
    # a batch's workers assemble it from the layout tasks' files (in chunk order) into their cache
    files = [solve_layout_chunk_into(str(tmp_path / f"{a}.pickle"), config, 11, a, b)
             for a, b in ranges[::-1]]
    batch_tasks._PLANS.clear()
    batch_tasks.install_plan_of_files(config, 11, files[::-1])
    installed = batch_tasks._PLANS[layout_key(config, 11)]
    # assembled here from chunks, and by `nudge simulate --workers 3` in three processes
    for assembled in (StudyPlan.assemble(config, 11, chunks), build_plan_on(config, 11, 3), installed):
        assert len(assembled.solved) == len(built.solved) == 48
        for mine, theirs in zip(assembled.solved, built.solved, strict=True):
            for name in ("policy", "values", "p_a_given_sg"):
                np.testing.assert_array_equal(getattr(mine, name), getattr(theirs, name))
        pd.testing.assert_frame_equal(simulate_participant(assembled, 0).trials,
                                      simulate_participant(built, 0).trials, check_exact=True)


def test_off_the_pool_a_lone_study_is_spread_and_every_worker_builds_its_plan(tmp_path, monkeypatch):
    """A lone study with as many participants as workers, on executors whose workers may not share
    this machine's files (dask): no layout tasks and no plan sent (each worker builds the plan,
    faster than sending it to many), its tasks spread over the workers; the tables equal a serial
    run's, on a fake two-worker executor and on dask."""
    from nudgecli.runs.executors import SerialExecutor

    events: list[tuple[str, str]] = []

    class TwoWorkers(SerialExecutor):
        workers = 2

        def submit(self, job):
            events.append(("submit", job.func.__name__))
            super().submit(job)

        def broadcast(self, job):
            events.append(("broadcast", job.func.__name__))
            super().broadcast(job)

        def spread(self, affinity):
            events.append(("spread", affinity))

    serial = replicate("smoke", 1, tmp_path / "serial", seed=5)
    monkeypatch.setattr(batch_module, "make_executor", lambda workers, client: TwoWorkers())
    shared = replicate("smoke", 1, tmp_path / "shared", seed=5)
    assert_same_tables(serial, shared)
    study = next(iter(shared.run.graph.studies.values()))
    assert [e for e in events if e[0] != "submit"] == [("spread", study.layouts)]
    submitted = {name for kind, name in events if kind == "submit"}
    assert submitted == {"run_participant_task", "run_analysis_task"}
    # two studies for two workers: each keeps its own worker, nothing is spread or sent
    events.clear()
    replicate("smoke", 2, tmp_path / "two-studies", seed=5)
    assert [e for e in events if e[0] != "submit"] == []
    monkeypatch.undo()
    with local_cluster(2) as cluster:
        on_dask = replicate("smoke", 1, tmp_path / "dask", seed=5, scheduler=cluster.scheduler_address)
    assert_same_tables(serial, on_dask)


@pytest.mark.parametrize("workers", [1, 3])
def test_every_analysis_of_a_batch_is_that_of_its_parts_as_read_back(tmp_path, monkeypatch, workers):
    # power: analyses of a study's first n participants; on 3 workers each analysis's metrics are
    # split over 3 tasks (merged in order) and its input comes from the parts this run just wrote
    from nudgecli.runs.batch_folder import analysis_part, read_study_metrics
    from nudgecli.runs.batch_kinds import power

    submit_ready = batch_module._GraphRun.submit_ready

    def keeping_only_what_waits(self) -> None:
        submit_ready(self)
        # the parts kept in memory are those of studies with an analysis still to submit
        assert set(self.written) <= {analysis.study for analysis in self.waiting}

    monkeypatch.setattr(batch_module._GraphRun, "submit_ready", keeping_only_what_waits)
    result = power("smoke", [2, 3], 2, tmp_path / "power", seed=4, workers=workers)
    run, plan = result.run, load_plan("paper")
    names = list(plan.metrics.include)
    assert len(names) >= 3
    conditions = tuple(load_experiment("smoke").study.conditions)
    for analysis in run.graph.analyses.values():
        data = read_study_metrics(run.path, analysis.study, analysis.participants)
        expected = batch_tasks.run_analysis_task(data, plan, names, conditions)
        written = json.loads(analysis_part(run.path, analysis.key).read_text())
        assert written == json.loads(json.dumps(expected))
        assert [m["metric"] for m in written["metrics"]] == names


def test_merged_analysis_chunks_are_the_document_of_all_the_metrics() -> None:
    plan = AnalysisPlan(conditions=("a", "b"), bootstrap={"resamples": 100})
    data = synthetic_study(np.random.default_rng(3), 6, 0.7)
    data["other"] = data["value"] * 2.0 + 1.0
    data["third"] = -data["value"]
    names = ["value", "other", "third"]
    whole = batch_tasks.run_analysis_task(data, plan, names)
    for chunks in ([names], [names[:1], names[1:]], [names[:2], names[2:]], [[n] for n in names]):
        parts = [batch_tasks.run_analysis_task(data, plan, chunk) for chunk in chunks]
        assert batch_tasks.merge_analysis_chunks(parts) == whole
    other = dict(whole, conditions=list(reversed(whole["conditions"])))
    with pytest.raises(ValueError, match="different conditions"):
        batch_tasks.merge_analysis_chunks([whole, other])
    with pytest.raises(ValueError, match="no stats documents"):
        batch_tasks.merge_analysis_chunks([])


@pytest.mark.skipif(os.name != "posix", reason="the pool's workers inherit the test's patches by fork")
def test_on_the_pool_a_lone_studys_plan_reaches_the_workers_in_its_chunks_files(tmp_path, monkeypatch):
    from nudgecli.runs.executors import ProcessExecutor

    serial = replicate("smoke", 1, tmp_path / "serial", seed=5)
    batch_tasks._PLANS.clear()

    def no_build(*args, **kwargs):
        raise AssertionError("a worker built a plan that was to be sent to it")

    sent: list[tuple[str, list[str]]] = []
    broadcast = ProcessExecutor.broadcast

    def recording(self, job, files=()):
        sent.append((job.func.__name__, list(files)))
        broadcast(self, job, files)

    monkeypatch.setattr(StudyPlan, "build", no_build)  # the forked workers inherit it
    monkeypatch.setattr(batch_tasks, "build_plan", no_build)  # (its layouts solved through the cache)
    monkeypatch.setattr(ProcessExecutor, "broadcast", recording)
    pooled = replicate("smoke", 1, tmp_path / "pool", seed=5, workers=2)
    assert_same_tables(serial, pooled)
    # one broadcast, of the two layout chunks' files (the plan itself is never sent)
    assert [(name, len(files)) for name, files in sent] == [("install_plan_of_files", 2)]
    assert not any(Path(path).exists() for _, files in sent for path in files)


def test_on_dask_a_spread_or_broadcast_affinity_is_hinted_to_no_worker_and_others_to_one(monkeypatch) -> None:
    # every worker holds a lone study's plan (each builds it, or it was sent to all); hinting its
    # tasks to one of them left the others idle until dask's work stealing moved tasks (a second)
    distributed = pytest.importorskip("dask.distributed")
    from nudgecli.runs.executors import DaskExecutor, Job

    done = type("Done", (), {"add": lambda self, future: None})
    monkeypatch.setattr(distributed, "as_completed", done)

    class Client:
        def __init__(self, workers: tuple[str, ...] = ("tcp://b", "tcp://a")) -> None:
            self.workers = workers
            self.submitted: dict[str, dict] = {}
            self.ran: list = []

        def scheduler_info(self) -> dict:
            return {"workers": {name: {} for name in self.workers}}

        def submit(self, func, *args, key, pure, **kwargs):
            self.submitted[key] = kwargs
            return type("Future", (), {"key": key})()

        def run(self, func, *args) -> None:
            self.ran.append((func, args))

    client = Client()
    executor = DaskExecutor(client)
    executor.submit(Job("s1-p0", int, ("1",), affinity="s1"))
    executor.submit(Job("s2-p0", int, ("1",), affinity="s2"))
    executor.broadcast(Job("s3-plan", int, ("1",), affinity="s3"))
    executor.submit(Job("s3-p0", int, ("1",), affinity="s3"))
    executor.spread("s4")
    executor.submit(Job("s4-p0", int, ("1",), affinity="s4"))
    executor.submit(Job("s1-p1", int, ("1",), affinity="s1"))
    executor.submit(Job("n1", int, ("1",)))
    assert client.ran == [(int, ("1",))]
    hinted = {key: kwargs.get("workers") for key, kwargs in client.submitted.items()}
    assert hinted == {"nudge-s1-p0": ["tcp://a"], "nudge-s2-p0": ["tcp://b"], "nudge-s3-p0": None,
                      "nudge-s4-p0": None, "nudge-s1-p1": ["tcp://a"], "nudge-n1": None}
    assert all(kwargs == {"workers": hinted[key], "allow_other_workers": True}
               for key, kwargs in client.submitted.items() if hinted[key] is not None)
    # a cluster whose workers are not known yet: anywhere (dask refuses allow_other_workers alone)
    empty = Client(workers=())
    DaskExecutor(empty).submit(Job("s1-p0", int, ("1",), affinity="s1"))
    assert empty.submitted == {"nudge-s1-p0": {}}


def _full_disk(path: str) -> None:
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), path)


def test_an_oserror_in_a_task_reaches_the_command_as_itself_on_the_pool_and_on_dask() -> None:
    # the command turns an OSError into one error line with its path and cause (a WorkerError
    # would be a traceback)
    from nudgecli.runs.executors import DaskExecutor, Job, ProcessExecutor

    def check(executor) -> None:
        executor.submit(Job("x", _full_disk, ("/spool/chunk.pickle",)))
        with pytest.raises(OSError) as raised:
            executor.next_result()
        assert raised.value.errno == errno.ENOSPC and raised.value.filename == "/spool/chunk.pickle"

    pool = ProcessExecutor(1)
    try:
        check(pool)
    finally:
        pool.abort()
    distributed = pytest.importorskip("dask.distributed")
    with local_cluster(1) as cluster, distributed.Client(cluster) as client:
        check(DaskExecutor(client))


def test_points_differing_only_in_participants_share_one_study_of_the_largest(monkeypatch) -> None:
    from nudgecli.runs.batch import Batch, Point, build_graph, estimate, estimate_batch

    monkeypatch.setattr("nudgecli.runs.size.available_cores", lambda: 8)  # 3 workers run at once

    config = load_experiment("smoke")

    def sized(n: int):
        return config.model_copy(update={"study": config.study.model_copy(update={"participants": n})})

    # the smaller point first: the study must still grow to the larger one's participants
    points = (Point(0, {"study.participants": 2}, sized(2), (2,)),
              Point(1, {"study.participants": 5}, sized(5), (5,)))
    batch = Batch("sweep", points, 3, 7, AnalysisPlan(), {})
    graph = build_graph(batch)
    assert len(graph.studies) == 3  # one per replication
    assert [s.participants for s in graph.studies.values()] == [5, 5, 5]
    assert graph.entries.groupby("replication")["study"].nunique().tolist() == [1, 1, 1]
    assert sorted(graph.entries["participants"]) == [2, 2, 2, 5, 5, 5]
    # the size guard's estimate without the graph equals the graph's, whatever the workers
    for workers in (1, 3):
        assert estimate_batch(batch, workers) == estimate(graph, workers)
    from nudgecli.runs.size import SECONDS_PER_ANALYSIS, SECONDS_PER_TRIAL  # (the workers share these only)

    one, three = estimate(graph, 1), estimate(graph, 3)
    shared = one.trials * SECONDS_PER_TRIAL + one.analyses * SECONDS_PER_ANALYSIS
    assert one.seconds - three.seconds == pytest.approx(shared - shared / min(3, three.cores))


def test_a_participant_does_not_depend_on_how_many_others_there_are():
    # power analyses the first n participants of each replication's largest study: this must hold
    config = load_experiment("smoke")
    bigger = config.model_copy(update={"study": config.study.model_copy(update={"participants": 7})})
    a = simulate_participant(StudyPlan.build(config, 3), 1)
    b = simulate_participant(StudyPlan.build(bigger, 3), 1)
    pd.testing.assert_frame_equal(a.trials, b.trials, check_exact=True)


def test_layout_key_ignores_settings_that_do_not_touch_layouts():
    config = load_experiment("smoke")
    kappa = load_experiment("smoke", ["inference.kappa=0.8"])
    epsilon = load_experiment("smoke", ["model.epsilon=0.2"])
    goals = load_experiment("smoke", ["study.goal_counts=[5]"])
    assert layout_key(config, 1) == layout_key(kappa, 1)
    keys = {layout_key(config, 1), layout_key(epsilon, 1), layout_key(goals, 1), layout_key(config, 2)}
    assert len(keys) == 4
    assert replication_seed(9, 0) != replication_seed(9, 1)
    assert replication_seed(9, 0) == replication_seed(9, 0)


# --- power ------------------------------------------------------------------------------------

def signed_rank_distribution(n: int, q: float) -> np.ndarray:
    """P(T+ = t), t = 0..n(n+1)/2, when rank k (1..n) is positive with probability q, independently.

    The exact distribution of Wilcoxon's signed-rank statistic for differences whose signs are
    independent of their magnitudes (by convolution, rank by rank); q = 1/2 is the null.
    """
    dist = np.zeros(n * (n + 1) // 2 + 1)
    dist[0] = 1.0
    for k in range(1, n + 1):
        shifted = np.zeros_like(dist)
        shifted[k:] = dist[:-k]
        dist = (1 - q) * dist + q * shifted
    return dist


def analytic_power(n: int, q: float, alpha: float = 0.05) -> float:
    """Power of the exact two-sided signed-rank test at alpha, counting only rejections with T+ > T-."""
    null = signed_rank_distribution(n, 0.5)
    upper = np.cumsum(null[::-1])[::-1]  # P0(T+ >= t)
    lower = np.cumsum(null)  # P0(T+ <= t)
    t = np.arange(null.size)
    p = np.minimum(1.0, 2 * np.minimum(upper, lower))
    reject = (p < alpha) & (t > n * (n + 1) / 4)
    return float(signed_rank_distribution(n, q)[reject].sum())


def synthetic_study(rng: np.random.Generator, n: int, q: float) -> pd.DataFrame:
    """n participants, one trial per condition; a - b = sign * magnitude, sign + with probability q."""
    sign = np.where(rng.random(n) < q, 1.0, -1.0)
    magnitude = rng.uniform(0.5, 1.5, n)
    base = rng.normal(10.0, 1.0, n)
    return pd.DataFrame({
        "participant": np.repeat(np.arange(n), 2),
        "condition": np.tile(["a", "b"], n),
        "value": np.column_stack([base + sign * magnitude, base]).ravel(),
    })


def test_power_rises_with_n_and_matches_the_analytic_power_of_the_test():
    q, replications, counts = 0.85, 60, (6, 9, 14)
    plan = AnalysisPlan(conditions=("a", "b"), bootstrap={"resamples": 100})
    rng = np.random.default_rng(20240611)
    entries, stats = [], {}
    for n in counts:
        for r in range(replications):
            key = f"n{n}-r{r}"
            stats[key] = analyse_replication(synthetic_study(rng, n, q), plan, ["value"])
            entries.append({"point": 0, "replication": r, "seed": r, "participants": n, "analysis": key})
    rows = replication_rows(pd.DataFrame(entries), stats, plan)
    curve = power_table(rows, {"value": +1})
    level = curve[curve["level"] == "participant"].set_index("participants")
    expected = {n: analytic_power(n, q) for n in counts}
    assert expected[6] == pytest.approx(q ** 6)  # n = 6: only all six positive reach p = 2/64 < .05
    for n in counts:
        low, high = level.loc[n, "low"], level.loc[n, "high"]
        assert low <= expected[n] <= high, (n, expected[n], low, high)
    assert level.loc[6, "power"] < level.loc[9, "power"] < level.loc[14, "power"]
    first = smallest_n(curve, target=0.6).set_index("level").loc["participant", "participants"]
    assert first == min(n for n in counts if level.loc[n, "power"] >= 0.6)
    assert smallest_n(curve, target=0.99).set_index("level").loc["participant", "participants"] is None


# --- sensitivity --------------------------------------------------------------------------------

def test_sobol_indices_of_the_ishigami_function_through_the_sweep_machinery():
    # Ishigami & Homma (1990); the analytic indices for a = 7, b = 0.1 as tabulated in Saltelli et
    # al., "Global Sensitivity Analysis: The Primer" (2008), and in SALib's documentation:
    # S1 = 0.3139, S2 = 0.4424, S3 = 0; ST1 = 0.5576, ST2 = 0.4424, ST3 = 0.2437. Recomputed below
    # from the variance decomposition V1 = (1 + b pi^4 / 5)^2 / 2, V2 = a^2 / 8, V13 = 8 b^2 pi^8 / 225.
    a, b = 7.0, 0.1
    v1, v2, v13 = (1 + b * math.pi ** 4 / 5) ** 2 / 2, a ** 2 / 8, 8 * b ** 2 * math.pi ** 8 / 225
    total = v1 + v2 + v13
    analytic = {("x1", "S1"): v1 / total, ("x2", "S1"): v2 / total, ("x3", "S1"): 0.0,
                ("x1", "ST"): (v1 + v13) / total, ("x2", "ST"): v2 / total, ("x3", "ST"): v13 / total}
    tabulated = {("x1", "S1"): 0.3139, ("x2", "S1"): 0.4424, ("x3", "S1"): 0.0,
                 ("x1", "ST"): 0.5576, ("x2", "ST"): 0.4424, ("x3", "ST"): 0.2437}
    for key, value in tabulated.items():
        assert analytic[key] == pytest.approx(value, abs=1e-4)

    spec = SweepFile(experiment="unused", design=Design(method="sobol", samples=4096, seed=3),
                     parameters={f"ishigami.x{k}": Range(low=-math.pi, high=math.pi) for k in (1, 2, 3)})
    points, problem, samples = design_values(spec)
    assert problem is not None and samples is not None and len(points) == 4096 * 5
    x = np.array([[p[f"ishigami.x{k}"] for k in (1, 2, 3)] for p in points])
    y = np.sin(x[:, 0]) + a * np.sin(x[:, 1]) ** 2 + b * x[:, 2] ** 4 * np.sin(x[:, 0])
    outputs = pd.DataFrame({"point": np.arange(len(y)), "metric": "ishigami", "a": "a", "b": "b", "y": y})
    indices = sensitivity("sobol", problem, samples, outputs, seed=1).set_index(["parameter", "index"])
    for (name, index), value in analytic.items():
        got, conf = indices.loc[(f"ishigami.{name}", index), ["value", "conf"]]
        assert abs(got - value) <= max(2 * conf, 0.02), (name, index, got, conf, value)


def test_point_outputs_average_the_replications_of_each_point():
    rows = pd.DataFrame({"point": [0, 0, 1, 1], "replication": [0, 1, 0, 1], "metric": "m", "a": "a",
                         "b": "b", "difference": [1.0, 3.0, -2.0, 0.0]})
    assert point_outputs(rows)["y"].tolist() == [2.0, -1.0]


# --- counting replications: intervals, smallest n, pooled effects --------------------------------

@pytest.mark.parametrize(("k", "n", "level"), [(0, 10, 0.95), (3, 10, 0.95), (10, 10, 0.95), (7, 20, 0.9),
                                               (1, 4, 0.5), (13, 60, 0.99)])
def test_clopper_pearson_is_the_pair_of_beta_quantiles(k: int, n: int, level: float) -> None:
    # Clopper & Pearson (1934): low = Beta(k, n - k + 1) quantile alpha/2 (0 at k = 0), high =
    # Beta(k + 1, n - k) quantile 1 - alpha/2 (1 at k = n)
    tail = (1 - level) / 2
    low = 0.0 if k == 0 else scipy.stats.beta.ppf(tail, k, n - k + 1)
    high = 1.0 if k == n else scipy.stats.beta.ppf(1 - tail, k + 1, n - k)
    assert clopper_pearson(k, n, level) == pytest.approx((low, high), abs=1e-9)
    assert all(math.isnan(v) for v in clopper_pearson(0, 0))


def power_rows(significant: dict[int, list[bool]], a: str = "disambiguation", b: str = "control",
               metric: str = "mode_switches", direction: int = -1) -> pd.DataFrame:
    """Replication rows of one metric and pair: per participant count, which replications were
    significant (at both levels, in ``direction``)."""
    return pd.DataFrame([
        {"participants": n, "metric": metric, "a": a, "b": b, "trial_significant": s,
         "trial_direction": direction, "participant_significant": s, "participant_direction": direction}
        for n, flags in significant.items() for s in flags])


def test_smallest_n_is_the_first_count_whose_power_reaches_the_target() -> None:
    # powers 0.5, 0.8 (exactly the target), 1.0: the smallest n is 9, reached with equality
    curve = power_table(power_rows({6: [True, False] * 5, 9: [True] * 8 + [False] * 2, 12: [True] * 10}))
    level = curve[curve["level"] == "participant"].set_index("participants")["power"]
    assert level.to_dict() == {6: 0.5, 9: 0.8, 12: 1.0}
    assert smallest_n(curve, target=0.8).set_index("level")["participants"].to_dict() == {
        "trial": 9, "participant": 9}
    assert smallest_n(curve, target=0.5).set_index("level").loc["trial", "participants"] == 6


def test_smallest_n_is_per_pair_of_conditions_and_an_integer() -> None:
    # three conditions: the paper's pair never reaches the target, another pair does at 2; each
    # pair gets its own row with its a, b (never the best of the pairs under the metric's name)
    rows = pd.concat([power_rows({2: [True] * 3, 3: [True] * 3}, a="disambiguation", b="teleoperation"),
                      power_rows({2: [False] * 3, 3: [False] * 3})])
    smallest = smallest_n(power_table(rows), target=0.6)
    assert list(smallest.columns) == ["metric", "a", "b", "level", "participants", "status"]
    by_pair = smallest.set_index(["a", "b", "level"])["participants"]
    assert by_pair[("disambiguation", "teleoperation", "trial")] == 2
    assert by_pair[("disambiguation", "control", "trial")] is None
    assert "mode_switches,disambiguation,teleoperation,trial,2,reached\n" in smallest.to_csv(index=False)
    assert "mode_switches,disambiguation,control,trial,,not reached\n" in smallest.to_csv(index=False)


def test_point_outputs_and_sensitivity_keep_the_pairs_apart() -> None:
    # two pairs whose differences move oppositely with x: pooled, Y would be flat in x
    rows = pd.DataFrame({"point": [0, 0, 1, 1], "replication": 0, "metric": "m", "a": ["p", "q"] * 2,
                         "b": "c", "difference": [1.0, -1.0, 3.0, -3.0]})
    outputs = point_outputs(rows)
    assert outputs.set_index(["point", "a"])["y"].to_dict() == {(0, "p"): 1.0, (0, "q"): -1.0,
                                                               (1, "p"): 3.0, (1, "q"): -3.0}
    spec = SweepFile(experiment="unused", design=Design(method="morris", samples=2, levels=4, seed=2),
                     parameters={"p.x": Range(low=0.0, high=1.0)})
    points, problem, samples = design_values(spec)
    assert problem is not None and samples is not None
    xs = samples[:, 0]
    rows = pd.DataFrame({"point": np.repeat(np.arange(len(points)), 2), "replication": 0, "metric": "m",
                         "a": ["p", "q"] * len(points), "b": "c",
                         "difference": np.column_stack([xs, -2 * xs]).ravel()})
    indices = sensitivity("morris", problem, samples, point_outputs(rows), levels=4)
    mu = indices[indices["index"] == "mu"].set_index("a")["value"]
    assert mu.to_dict() == pytest.approx({"p": 1.0, "q": -2.0})
    assert set(indices["b"]) == {"c"}
    from nudgecli.report.figures.replication import sensitivity_figure

    titles = [ax.get_title() for ax in sensitivity_figure(indices).get_axes()]
    assert titles == ["m (p - c)", "m (q - c)"]


def test_power_counts_only_the_papers_direction_of_either_order_of_the_pair() -> None:
    # the paper: fewer mode switches under Disambiguation; a - b < 0 when a is Disambiguation,
    # a - b > 0 when the pair is written the other way round
    assert paper_direction("mode_switches", "disambiguation", "control") == -1
    assert paper_direction("mode_switches", "control", "disambiguation") == +1
    assert paper_direction("assistance_engagement", "disambiguation", "control") is None
    flags = {6: [True] * 4}
    cases = [("disambiguation", "control", -1, 1.0), ("disambiguation", "control", +1, 0.0),
             ("control", "disambiguation", +1, 1.0), ("control", "disambiguation", -1, 0.0)]
    for a, b, direction, power in cases:
        curve = power_table(power_rows(flags, a, b, direction=direction))
        assert curve["power"].tolist() == [power, power], (a, b, direction)
        assert curve["direction"].iloc[0] == ("a < b" if a == "disambiguation" else "a > b")
    either = power_table(power_rows(flags, metric="assistance_engagement", direction=+1))
    assert either["power"].tolist() == [1.0, 1.0] and either["direction"].iloc[0] == "either"


def test_summarise_counts_directions_and_pools_effects_over_replications() -> None:
    effects = np.arange(1.0, 41.0) / 40  # 40 replications: r = 0.025 ... 1.0
    rows = pd.DataFrame({
        "point": 0, "participants": 8, "metric": "m", "a": "x", "b": "y",
        "trial_significant": [True] * 30 + [False] * 10,
        "trial_direction": [1] * 10 + [-1] * 10 + [0] * 10 + [1] * 10,
        "participant_significant": [True] * 20 + [False] * 20,
        "participant_direction": [-1] * 5 + [1] * 35,
        "kruskal_p": np.linspace(0.0, 0.39, 40), "conover_p": np.linspace(0.0, 0.78, 40),
        "participant_p": np.linspace(1.0, 0.61, 40),
        "effect_size_name": "rank_biserial", "effect_size": effects, "difference": -2 * effects,
    })
    (summary,) = summarise(rows).to_dict("records")
    assert summary["replications"] == 40
    # a direction of 0 (tied medians and means) is neither higher nor lower
    assert (summary["trial_a_higher"], summary["trial_a_lower"]) == (0.25, 0.25)
    assert (summary["participant_a_higher"], summary["participant_a_lower"]) == (15 / 40, 5 / 40)
    assert summary["median_kruskal_p"] == pytest.approx(np.median(rows["kruskal_p"]))
    assert summary["median_conover_p"] == pytest.approx(np.median(rows["conover_p"]))
    assert summary["median_participant_p"] == pytest.approx(0.805)
    # numpy's linear percentiles: 2.5 % of 39 gaps is 0.975 of the way from the 1st to the 2nd value
    low, high = 0.025 + 0.975 * 0.025, 0.025 * 39 + 0.025 * 0.025
    assert (summary["effect_size"], summary["effect_size_low"], summary["effect_size_high"]) == pytest.approx(
        (effects.mean(), low, high))
    assert (summary["difference"], summary["difference_low"], summary["difference_high"]) == pytest.approx(
        (-2 * effects.mean(), -2 * high, -2 * low))


def test_point_outputs_average_the_column_asked_for() -> None:
    rows = pd.DataFrame({"point": [0, 0, 1, 1], "replication": [0, 1, 0, 1], "metric": "m", "a": "a",
                         "b": "b", "difference": [1.0, 3.0, -2.0, 0.0],
                         "effect_size": [0.5, 0.1, -0.2, -0.4]})
    assert point_outputs(rows, "effect_size")["y"].tolist() == pytest.approx([0.3, -0.3])


def test_a_replication_is_significant_at_the_trial_level_only_when_both_tests_are() -> None:
    plan = AnalysisPlan(conditions=("a", "b"), bootstrap={"resamples": 100})
    document = analyse_replication(synthetic_study(np.random.default_rng(5), 8, 0.9), plan, ["value"])
    entry = document["metrics"][0]
    entries = pd.DataFrame([{"point": 0, "replication": 0, "seed": 0, "participants": 8, "analysis": "s"}])
    verdicts = {}
    for kruskal_p, conover_p in [(0.01, 0.01), (0.01, 0.2), (0.2, 0.01), (0.2, 0.2)]:
        entry["kruskal"]["p"], entry["conover"][0]["p"] = kruskal_p, conover_p
        (row,) = replication_rows(entries, {"s": document}, plan).to_dict("records")
        verdicts[kruskal_p, conover_p] = row["trial_significant"]
    assert verdicts == {(0.01, 0.01): True, (0.01, 0.2): False, (0.2, 0.01): False, (0.2, 0.2): False}
    # a document written before the mean ranks were recorded: the medians, then (tied) the means
    del entry["mean_rank"]
    entry["median"]["b"] = entry["median"]["a"]
    for mean_b, direction in [(entry["mean"]["a"] - 1.0, +1), (entry["mean"]["a"] + 1.0, -1),
                              (entry["mean"]["a"], 0)]:
        entry["mean"]["b"] = mean_b
        (row,) = replication_rows(entries, {"s": document}, plan).to_dict("records")
        assert row["trial_direction"] == direction, mean_b


def test_the_trial_direction_is_the_mean_ranks_where_medians_tie_and_means_disagree() -> None:
    # medians tie at 1; b's mean is higher (one 10) but its mean rank lower (two 0s). Ranked
    # together by hand: the two 0s share ranks 1-2 (1.5), the seventeen 1s ranks 3-19 (11), the 10
    # rank 20; so a's mean rank is 11 and b's (2 x 1.5 + 7 x 11 + 20) / 10 = 10: a is higher
    values = {"a": [1.0] * 10, "b": [0.0, 0.0, *[1.0] * 7, 10.0]}
    table = pd.DataFrame([{"participant": k % 5, "condition": c, "value": v}
                          for c, vs in values.items() for k, v in enumerate(vs)])
    plan = AnalysisPlan(conditions=("a", "b"), bootstrap={"resamples": 100})
    document = analyse_replication(table, plan, ["value"])
    entry = document["metrics"][0]
    assert entry["mean_rank"] == {"a": 11.0, "b": 10.0}
    assert entry["median"] == {"a": 1.0, "b": 1.0} and entry["mean"]["b"] > entry["mean"]["a"]
    entries = pd.DataFrame([{"point": 0, "replication": 0, "seed": 0, "participants": 5, "analysis": "s"}])
    (row,) = replication_rows(entries, {"s": document}, plan).to_dict("records")
    assert row["trial_direction"] == +1
    entry["mean_rank"] = {"a": 10.0, "b": 10.0}
    (row,) = replication_rows(entries, {"s": document}, plan).to_dict("records")
    assert row["trial_direction"] == 0


def test_morris_mu_star_of_a_linear_model_is_its_slope_times_the_range() -> None:
    # y = sum c_i x_i: every elementary effect on the unit scale is c_i (high_i - low_i), whatever
    # the trajectory, so mu* = |c_i| (high_i - low_i), mu = c_i (high_i - low_i) and sigma = 0;
    # six levels, so analysing the design as a four-level one would scale every effect by 0.9
    slopes, lows, highs = np.array([2.0, -0.5, 0.0]), np.array([0.0, 1.0, -3.0]), np.array([1.0, 5.0, 3.0])
    spec = SweepFile(experiment="unused", design=Design(method="morris", samples=10, levels=6, seed=2),
                     parameters={f"p.x{k}": Range(low=lo, high=hi)
                                 for k, lo, hi in zip((1, 2, 3), lows, highs, strict=True)})
    points, problem, samples = design_values(spec)
    assert problem is not None and samples is not None and len(points) == 10 * 4
    outputs = pd.DataFrame({"point": np.arange(len(points)), "metric": "linear", "a": "a", "b": "b",
                            "y": samples @ slopes})
    indices = sensitivity("morris", problem, samples, outputs, levels=6).set_index(["parameter", "index"])
    for k, (slope, lo, hi) in enumerate(zip(slopes, lows, highs, strict=True), start=1):
        assert indices.loc[(f"p.x{k}", "mu_star"), "value"] == pytest.approx(abs(slope) * (hi - lo))
        assert indices.loc[(f"p.x{k}", "mu"), "value"] == pytest.approx(slope * (hi - lo))
        assert indices.loc[(f"p.x{k}", "sigma"), "value"] == pytest.approx(0.0, abs=1e-9)


# --- sweep files ------------------------------------------------------------------------------

SWEEP = """
experiment = "smoke"
replications = 2
seed = 3

[design]
method = "grid"

[parameters]
"inference.kappa" = [0.6, 0.7]
"""


def test_a_grid_sweep_file_gives_every_combination(tmp_path):
    path = tmp_path / "grid.toml"
    path.write_text(SWEEP + '"disambiguation.window" = [3, 5]\n')
    sweep = load_sweep(str(path))
    values = [(p.parameters["inference.kappa"], p.parameters["disambiguation.window"]) for p in sweep.points]
    assert values == [(0.6, 3), (0.6, 5), (0.7, 3), (0.7, 5)]
    assert sweep.points[3].config.disambiguation.window == 5 and sweep.points[3].config.inference.kappa == 0.7


def test_a_design_coordinate_picks_a_value_by_its_whole_part() -> None:
    from nudgecli.runs.sweep import Values, map_sample, salib_problem

    choices = Values(values=["a", "b", "c"])
    # the coordinate of k values runs over [0, k]: value i owns [i, i + 1), the top end the last
    assert [map_sample(choices, x) for x in (0.0, 0.99, 1.0, 1.6, 2.5, 3.0)] == ["a", "a", "b", "b", "c", "c"]
    whole = Range(low=1.0, high=5.0, integer=True)
    # the integers 1..5 are five values: the coordinate runs over [1, 6], integer i owns [i, i + 1)
    assert [map_sample(whole, x) for x in (1.0, 3.7, 4.999, 5.0, 5.999, 6.0)] == [1, 3, 4, 5, 5, 5]
    assert salib_problem(SweepFile(experiment="unused", design=Design(method="sobol"),
                                   parameters={"a.n": whole}))["bounds"] == [[1.0, 6.0]]
    assert isinstance(map_sample(whole, 3.7), int) and map_sample(Range(low=1.0, high=5.0), 3.7) == 3.7
    spec = SweepFile(experiment="unused", design=Design(method="sobol", samples=64, seed=1),
                     parameters={"a.k": choices, "b.x": Range(low=-1.0, high=2.0)})
    assert salib_problem(spec)["bounds"] == [[0.0, 3.0], [-1.0, 2.0]]
    points, _, _ = design_values(spec)
    assert {p["a.k"] for p in points} == {"a", "b", "c"}  # every value is drawn


def test_a_sampled_design_follows_its_seed() -> None:
    def design(seed: int) -> np.ndarray:
        spec = SweepFile(experiment="unused", design=Design(method="sobol", samples=8, seed=seed),
                         parameters={"a.x": Range(low=0.0, high=1.0), "a.y": Range(low=0.0, high=1.0)})
        return design_values(spec)[2]

    np.testing.assert_array_equal(design(4), design(4))
    assert not np.array_equal(design(4), design(5))


@pytest.mark.parametrize(("parameters", "message"), [
    ({"a.x": {"low": 1.0, "high": 1.0}}, "low must be below high"),
    ({"x": [1, 2]}, "write it as section.key"),  # a deeper key, as --set takes, is a parameter
])
def test_an_empty_range_or_a_key_without_a_section_is_refused(parameters: dict, message: str) -> None:
    from pydantic import ValidationError

    with pytest.raises(ValidationError, match=message):
        SweepFile.model_validate({"experiment": "unused", "design": {"method": "sobol"},
                                  "parameters": parameters})


@pytest.mark.parametrize(("extra", "message"), [
    ('"inference.kapa" = [0.6]\n', "inference.kapa"),
    ('"disambiguation.window" = [4]\n', "design point"),
    ('"model.epsilon" = { low = 0.1, high = 0.2 }\n', "a grid needs values"),
])
def test_bad_sweep_files_fail_with_one_error_line(tmp_path, extra, message):
    path = tmp_path / "bad.toml"
    path.write_text(SWEEP + extra)
    result = CliRunner().invoke(main, ["sweep", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 1 and message in result.output and "Traceback" not in result.output
    assert not (tmp_path / "out").exists()


def test_the_shipped_sweep_loads_and_is_not_listed_as_an_experiment():
    assert "example" not in list_presets("experiments")
    sweep = load_sweep("example")
    assert sweep.spec.design.method == "sobol" and len(sweep.points) == 4 * (5 + 2)
    assert {tuple(p.config.study.goal_counts) for p in sweep.points} <= {(3, 4), (5, 6)}


def test_a_sweep_killed_with_sigkill_and_resumed_equals_an_uninterrupted_one(tmp_path):
    path = tmp_path / "grid.toml"
    path.write_text(SWEEP)
    killed = tmp_path / "killed"
    proc = subprocess.Popen([sys.executable, "-m", "nudgecli.cli", "sweep", str(path), "--out", str(killed)],
                            env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not list((killed / "tasks").glob("*/part-*.parquet")):
        time.sleep(0.005)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    finished = len(list((killed / "tasks").glob("*/part-*.parquet")))
    assert 1 <= finished < 8, "the sweep must be interrupted part-way for this test to mean anything"
    resumed = CliRunner().invoke(main, ["sweep", str(path), "--out", str(killed), "--resume"])
    assert resumed.exit_code == 0, resumed.output
    clean = CliRunner().invoke(main, ["sweep", str(path), "--out", str(tmp_path / "clean")])
    assert clean.exit_code == 0, clean.output
    for name in ("sweep.csv", "replications.csv", "points.csv"):
        left, right = (pd.read_csv(folder / name) for folder in (killed, tmp_path / "clean"))
        pd.testing.assert_frame_equal(left, right, check_exact=True)
    tidy = pd.read_csv(killed / "sweep.csv")
    assert list(tidy.columns[:4]) == ["point", "replication", "seed", "inference.kappa"]
    assert list(tidy.columns[-3:]) == ["condition", "metric", "value"]
    # common random numbers: every point uses the same seeds
    assert tidy.groupby("point")["seed"].apply(lambda s: tuple(sorted(set(s)))).nunique() == 1


# --- the run: size, progress, refusals --------------------------------------------------------

def test_a_batch_above_the_size_limit_is_refused_without_yes(tmp_path, monkeypatch):
    monkeypatch.setattr(size_module, "MAX_TRIALS_WITHOUT_YES", 10)
    out = tmp_path / "big"
    refused = CliRunner().invoke(main, ["replicate", "smoke", "-R", "1", "--out", str(out)])
    assert refused.exit_code == 1 and "16 trials" in refused.output and "--yes" in refused.output
    assert not out.exists()
    accepted = CliRunner().invoke(main, ["replicate", "smoke", "-R", "1", "--out", str(out), "--yes",
                                         "--format", "csv"])
    assert accepted.exit_code == 0, accepted.output
    assert "participant_a_higher" in accepted.stdout


def test_progress_prints_rate_and_eta_every_few_seconds_when_not_a_terminal():
    now = [0.0]
    stream = io.StringIO()
    progress = Progress("sweep", stream=stream, interval=5.0, clock=lambda: now[0])
    for done in range(0, 11):
        progress(done, 10)
        now[0] += 1.0
    lines = stream.getvalue().splitlines()
    assert lines[0] == "sweep: 0/10 tasks (0%), 0.00 tasks/s, ETA unknown"
    assert lines[1] == "sweep: 5/10 tasks (50%), 1.00 tasks/s, ETA 5 s"
    assert lines[-1] == "sweep: 10/10 tasks (100%), 1.00 tasks/s, ETA 0 s"
    assert len(lines) == 3


def test_a_bad_scheduler_address_is_refused_before_the_folder_is_created(tmp_path, monkeypatch):
    pytest.importorskip("dask.distributed")
    monkeypatch.setattr("nudgecli.runs.study.SCHEDULER_TIMEOUT_S", 0.5)
    for args in (["simulate", "smoke", "--scheduler", "nonsense"],
                 ["simulate", "smoke", "--scheduler", "tcp://127.0.0.1:9"],
                 ["replicate", "smoke", "-R", "1", "--scheduler", "tcp://127.0.0.1:9"]):
        out = tmp_path / "run"
        result = CliRunner().invoke(main, [*args, "--out", str(out)])
        assert result.exit_code == 1 and "cannot connect" in result.output, result.output
        assert not out.exists()


def test_resume_refuses_a_different_batch(tmp_path):
    out = str(tmp_path / "b")
    assert CliRunner().invoke(main, ["replicate", "smoke", "-R", "1", "--out", out]).exit_code == 0
    again = CliRunner().invoke(main, ["replicate", "smoke", "-R", "2", "--out", out, "--resume"])
    assert again.exit_code == 1 and "different batch" in again.output
    same = CliRunner().invoke(main, ["replicate", "smoke", "-R", "1", "--out", out, "--resume"])
    assert same.exit_code == 0 and "0 tasks computed now" in same.output


def test_resume_removes_the_temporaries_of_killed_writers_and_nothing_else(tmp_path):
    out = tmp_path / "b"
    assert CliRunner().invoke(main, ["replicate", "smoke", "-R", "1", "--out", str(out)]).exit_code == 0
    task_folder = next((out / "tasks").iterdir())
    torn = [out / ".batch.json.k2j4h1x9.tmp", task_folder / ".part-0000.parquet.a8d0c3b1.tmp",
            out / "analyses" / ".x.json.0000abcd.tmp"]
    for path in torn:
        path.write_bytes(b"half a file")
    theirs = out / "notes.tmp"  # not a temporary of the toolkit's (no leading dot): the person's own
    theirs.write_text("mine")
    same = CliRunner().invoke(main, ["replicate", "smoke", "-R", "1", "--out", str(out), "--resume"])
    assert same.exit_code == 0 and "0 tasks computed now" in same.output
    assert not [path for path in torn if path.exists()] and theirs.read_text() == "mine"


# --- orphans ----------------------------------------------------------------------------------

def _children(pid: int) -> list[int]:
    path = Path(f"/proc/{pid}/task/{pid}/children")
    return [int(p) for p in path.read_text().split()] if path.exists() else []


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state != "Z"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads the process tree from /proc")
@pytest.mark.parametrize("command", [
    ["simulate", "smoke", "--participants", "60"],
    ["replicate", "smoke", "-R", "30"],
])
def test_workers_exit_when_their_parent_is_killed(tmp_path, command):
    out = tmp_path / "run"
    args = [sys.executable, "-m", "nudgecli.cli", *command, "--workers", "2", "--out", str(out)]
    proc = subprocess.Popen(args, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    workers: list[int] = []
    while time.monotonic() < deadline and len(workers) < 2:
        time.sleep(0.05)
        workers = [c for c in _children(proc.pid)
                   if "resource_tracker" not in Path(f"/proc/{c}/cmdline").read_text(errors="replace")]
    assert len(workers) >= 2, "the workers must have started for this test to mean anything"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline and any(_alive(w) for w in workers):
        time.sleep(0.05)
    leftover = [w for w in workers if _alive(w)]
    for pid in leftover:  # clean up before failing
        os.kill(pid, signal.SIGKILL)
    assert not leftover, f"workers {leftover} outlived their parent"
    # nobody holds the caller's pipes any more: reading them ends (TimeoutExpired otherwise)
    proc.communicate(timeout=10)


@pytest.mark.parametrize("target", ["0", "1", "1.5", "-0.2"])
def test_a_power_target_outside_the_open_interval_is_refused_in_words(tmp_path, target: str) -> None:
    # a power of 1 is never reached with certainty and 0 always: --target says "strictly"
    result = CliRunner().invoke(main, ["power", "smoke", "--participants", "2,3", "-R", "2", "--out",
                                       str(tmp_path / "p"), "--target", target])
    assert result.exit_code != 0 and "Traceback" not in result.output
    assert f"Error: Invalid value for '--target': {float(target)} is not in the range 0<x<1." in result.output
    assert not (tmp_path / "p").exists()
    shown = CliRunner().invoke(main, ["power", "--help"]).output
    assert "strictly between 0 and 1" in " ".join(shown.split())


def test_replicate_and_power_commands_print_their_tables(tmp_path, monkeypatch):
    from nudgecli.report import replication

    targets = []
    original = replication.smallest_n
    monkeypatch.setattr(replication, "smallest_n", lambda power, target=0.8: targets.append(target) or
                        original(power, target))
    result = CliRunner().invoke(main, ["power", "smoke", "--participants", "2,3", "-R", "2", "--out",
                                       str(tmp_path / "p"), "--format", "json", "--target", "0.55"])
    assert result.exit_code == 0, result.output
    assert targets == [0.55]  # --target reaches the smallest n
    assert (tmp_path / "p" / "power.csv").is_file() and (tmp_path / "p" / "figures" / "power.png").is_file()
    power = pd.read_csv(tmp_path / "p" / "power.csv")
    assert sorted(power["participants"].unique()) == [2, 3]
    assert set(power["level"]) == {"trial", "participant"}
    # 2 replications x largest study (3 participants), analysed at 2 and 3: 6 participant tasks + 4 analyses
    manifest = (tmp_path / "p" / "batch.json").read_text()
    assert '"participant_tasks": 6' in manifest and '"analyses": 4' in manifest


def test_size_estimate_counts_tasks_and_trials():
    config = load_experiment("smoke")
    batch = batch_module.Batch("power", batch_module.single_point(config, (2, 4)), 3, 1,
                               AnalysisPlan())
    graph = batch_module.build_graph(batch)
    size = batch_module.estimate_batch(batch, workers=2)
    assert (size.studies, size.participant_tasks, size.analyses, size.trials) == (3, 12, 6, 12 * 8)
    assert (size.studies, size.participant_tasks, size.analyses, size.trials) == \
        (len(graph.studies), graph.participant_tasks, len(graph.analyses), graph.trials)
    # the trials and analyses are shared by the workers; the start-up, the plans, the participants'
    # own work (their parts are written by the command) and the tail (tables, power figure) are not
    from nudgecli.runs import size as sizes
    work = 96 * sizes.SECONDS_PER_TRIAL + 6 * sizes.SECONDS_PER_ANALYSIS
    serial = 3 * (sizes.SECONDS_PER_STUDY + 8 * sizes.SECONDS_PER_LAYOUT) + 12 * sizes.SECONDS_PER_TASK
    tail = (sizes.TAIL_SECONDS + 6 * sizes.TAIL_SECONDS_PER_ANALYSIS + sizes.POWER_TAIL_SECONDS
            + 2 * sizes.POWER_TAIL_SECONDS_PER_LEVEL)  # participant counts 2 and 4
    assert size.tail_seconds == pytest.approx(tail) and size.power_levels == 2
    fixed = sizes.SECONDS_FIXED + serial + tail
    assert size.seconds == pytest.approx(fixed + work / min(2, size.cores))
    assert batch_module.estimate_batch(batch, workers=1).seconds == pytest.approx(fixed + work)
    with pytest.raises(ConfigError, match="--workers"):
        batch_module.run_batch(batch, "unused", workers=0)


@pytest.mark.parametrize("method", ["bonferroni", "sidak", "holm-sidak", "holm", "simes-hochberg", "hommel",
                                    "fdr_bh", "fdr_by"])
def test_conover_of_two_conditions_is_adjusted_as_statsmodels_adjusts_one_test(method):
    # the shortcut for two conditions (no call to multipletests) must give what multipletests gives
    from statsmodels.stats.multitest import multipletests

    from nudgecli.report.stats import conover

    rng = np.random.default_rng(4)
    values = rng.normal(size=24) + np.repeat([0, 1], 12)
    data = pd.DataFrame({"condition": np.repeat(["a", "b"], 12), "value": values})
    row = conover(data, "value", ["a", "b"], p_adjust=method).iloc[0]
    assert row["p"] == pytest.approx(multipletests([row["p_unadjusted"]], method=method)[1][0], rel=1e-12)


def test_bench_scale_figures_cover_every_core_count_and_dask():
    from nudgecli.bench import select_figures
    from nudgecli.bench.common import BenchOptions
    from nudgecli.bench.scale import scale_figure

    names = [f.__name__ for f in select_figures("scale")]
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    for workload in ("study", "sweep"):
        assert [n for n in names if n.startswith(f"figure_scale_{workload}_")] == [
            *(f"figure_scale_{workload}_{w}" for w in range(1, cores + 1)), f"figure_scale_{workload}_dask"]
    row = scale_figure("sweep", 1)(BenchOptions(scale_studies=2))
    assert row["ratio"] == 1.0 and row["time_s"] > 0 and "2 smoke studies" in row["what"]


@pytest.mark.parametrize(("name", "plan"), [("study-code", "study-code"), ("a-new-study", "paper")])
def test_replicate_takes_the_plan_run_and_analyze_take(tmp_path: Path, name: str, plan: str) -> None:
    # one rule for the default plan (config_files.default_plan_name): the plan named like the
    # experiment, else paper; the smoke study renamed, so that only the name decides
    experiment = tmp_path / "experiment.toml"
    experiment.write_text(list_presets("experiments")["smoke"].read_text().replace(
        'name = "smoke"', f'name = "{name}"'))
    out = tmp_path / "batch"
    result = CliRunner().invoke(main, ["replicate", str(experiment), "-R", "1", "--out", str(out),
                                       "--format", "json"])
    assert result.exit_code == 0, result.output
    assert json.loads((out / "batch.json").read_text())["batch"]["plan"]["name"] == plan


@pytest.mark.parametrize(("experiment", "plan_line", "expected"), [
    ("ciaa-teleop", "", "ciaa-teleop"),  # the plan named like the experiment
    ("smoke", "", "paper"),  # no plan of that name: paper's
    ("ciaa-teleop", 'plan = "paper"\n', "paper"),  # the plan given wins
])
def test_a_sweep_takes_its_plan_by_the_rule_of_replicate_and_power(tmp_path, experiment, plan_line, expected):
    path = tmp_path / "sweep.toml"
    path.write_text(f'experiment = "{experiment}"\nreplications = 1\n{plan_line}\n'
                    '[design]\nmethod = "grid"\n\n[parameters]\n"study.participants" = [2]\n')
    assert load_sweep(str(path)).spec.plan == expected


def test_participant_metrics_are_those_of_the_whole_step_log() -> None:
    # a batch's participant task formats only the step log's columns the metrics read
    from nudgecli.report.metrics import trial_metrics
    from nudgecli.sim.study import StudyPlan, simulate_participant

    config = load_experiment("smoke")
    plan = StudyPlan.build(config, 7)
    for analysis in (AnalysisPlan(), load_plan("study-code"), load_plan("paper")):
        definitions = batch_tasks.metric_definitions(analysis)
        for index in (0, 1):
            whole = simulate_participant(plan, index)
            expected = trial_metrics(whole.trials, whole.steps, **definitions)
            pd.testing.assert_frame_equal(batch_tasks.participant_metrics(plan, index, definitions).frame(),
                                          expected, check_exact=True)
        assert expected["first_input_latency"].notna().any()  # the input columns were there
    kept = simulate_participant(plan, 0, step_log_columns=("event", "trial", "belief")).steps
    assert list(kept.columns) == ["trial", "belief", "event"]
    pd.testing.assert_frame_equal(kept, simulate_participant(plan, 0).steps[["trial", "belief", "event"]])


def test_a_batch_worker_runs_participant_tasks_without_pandas_or_scipy() -> None:
    # a worker that only simulates participants imports neither pandas nor scipy (the statistics,
    # the special functions); the process writing the parts makes the frames
    script = textwrap.dedent("""
        import sys

        from nudgecli.config import load_experiment
        from nudgecli.runs.batch_tasks import run_participant_task

        definitions = {"engagement": "per_turn", "strength": "per_step", "mode_switches": "human_turn",
                       "success": "reached_goal", "completion_time": "all_trials"}
        result = run_participant_task(load_experiment("smoke"), 3, 1, definitions)
        assert len(result.trials) == len(result.values["mode_switches"]) > 0
        assert not any(name.split(".")[0] == "pandas" for name in sys.modules)
        print("ok")
        """)
    done = run_refusing(script, ("pandas", "pyarrow", "scikit_posthocs", "scipy"))
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == "ok"


@pytest.mark.parametrize("target", [0.0, 1.0, 1.5])
def test_the_apis_power_target_outside_the_open_interval_is_refused_in_words(tmp_path: Path,
                                                                            target: float) -> None:
    import nudgecli

    with pytest.raises(nudgecli.NudgeError, match=r"strictly between 0 and 1 \(a power\), got"):
        nudgecli.power("smoke", [2, 3], 1, target=target, out=tmp_path / "p")
    assert not (tmp_path / "p").exists()
