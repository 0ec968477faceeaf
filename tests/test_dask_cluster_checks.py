"""A dask cluster that cannot run nudge is refused right after ``--scheduler`` connects, before
anything is written: a scheduler without workers, workers that cannot import this nudgecli (or
import another version), and an empty address (``--scheduler ""``, ``scheduler=''``), refused as
``--out ""`` is. The API's refusals name ``scheduler=``, the command line's ``--scheduler``."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from cli_helpers import nudge, one_error_line
from dask_helpers import local_cluster

import nudgecli
from nudgecli import api
from nudgecli.errors import ConfigError
from nudgecli.runs import dask_cluster

distributed = pytest.importorskip("dask.distributed")


@pytest.fixture
def empty_scheduler(monkeypatch: pytest.MonkeyPatch) -> Iterator[str]:
    """The address of a scheduler without workers; the wait for one shortened from the shipped 300 s."""
    monkeypatch.setattr(dask_cluster, "WORKERS_WAIT_S", 0.2)
    with local_cluster(0) as cluster:
        yield cluster.scheduler_address


@pytest.fixture
def one_worker() -> Iterator[str]:
    """The address of a scheduler with one (in-process) worker."""
    with local_cluster(1) as cluster:
        yield cluster.scheduler_address


#: The smallest simulation and batch on a scheduler.
COMMANDS = [["simulate", "smoke", "--participants", "1"], ["replicate", "smoke", "-R", "1"]]


def _probe_of(answer: Callable[[], str]) -> Callable[[], Callable[[], str]]:
    """A replacement of :func:`dask_cluster.worker_probe` whose workers answer ``answer()``."""
    return lambda: answer


def _no_nudgecli() -> str:
    raise ModuleNotFoundError("No module named 'nudgecli'")


@pytest.mark.parametrize("command", COMMANDS)
def test_a_scheduler_without_workers_is_one_line_and_no_folder(tmp_path: Path, empty_scheduler: str,
                                                               command: list[str]) -> None:
    out = tmp_path / "run"
    result = nudge(*command, "--scheduler", empty_scheduler, "--out", out)
    note, error = result.output.splitlines()  # the Note of the wait, then one Error line
    line = one_error_line(error)
    assert result.exit_code == 1
    assert f"the dask scheduler at {empty_scheduler} has no workers" in line
    assert f"`dask worker {empty_scheduler}`" in line
    # the wait is told at once, not silent (a batch system's workers may take minutes to join)
    assert note.startswith(f"Note: the dask scheduler at {empty_scheduler} has no workers yet; waiting up "
                           "to 0.2 s for one to join")
    assert not out.exists()


@pytest.mark.parametrize("command", COMMANDS)
def test_workers_without_nudgecli_are_one_line_naming_the_fix(tmp_path: Path, one_worker: str,
                                                              command: list[str],
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(dask_cluster, "worker_probe", _probe_of(_no_nudgecli))
    out = tmp_path / "run"
    result = nudge(*command, "--scheduler", one_worker, "--out", out)
    line = one_error_line(result.output)
    assert result.exit_code == 1
    assert "No module named 'nudgecli'" in line and f"dask scheduler at {one_worker} cannot run nudge" in line
    assert f"install nudgecli {nudgecli.__version__}" in line and "workers' environment" in line
    assert not out.exists()


def test_workers_of_another_nudgecli_version_are_refused(tmp_path: Path, one_worker: str,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(dask_cluster, "worker_probe", _probe_of(lambda: "0.0.0-other"))
    with pytest.raises(ConfigError, match=r"imports nudgecli 0\.0\.0-other, not "):
        api.simulate("smoke", participants=1, scheduler=one_worker, out=tmp_path / "run")
    assert not (tmp_path / "run").exists()


def test_a_healthy_cluster_is_checked_in_one_round_trip(one_worker: str) -> None:
    with distributed.Client(one_worker) as client:
        runs: list[object] = []
        run = client.run

        def counted(*args: Any, **kwargs: Any) -> Any:
            runs.append(args)
            return run(*args, **kwargs)

        client.run = counted  # type: ignore[method-assign]
        dask_cluster.check_cluster(client, one_worker)
    assert len(runs) == 1


@pytest.mark.parametrize("address", ["", "  "])
@pytest.mark.parametrize("command", COMMANDS)
def test_an_empty_scheduler_address_is_refused_as_an_empty_out(tmp_path: Path, command: list[str],
                                                              address: str) -> None:
    out = tmp_path / "run"
    result = nudge(*command, "--scheduler", address, "--out", out)
    line = one_error_line(result.output)
    assert result.exit_code == 1
    assert line.startswith(f'Error: --scheduler "{address}": an empty address;')
    assert "leave --scheduler out" in line
    assert not out.exists()


@pytest.mark.parametrize("call", [lambda out: api.simulate("smoke", participants=1, scheduler="", out=out),
                                  lambda out: api.replicate("smoke", 1, scheduler="", out=out)])
def test_the_api_refuses_an_empty_scheduler_naming_its_parameter(tmp_path: Path, call: Any) -> None:
    refusal = r"^scheduler='': an empty address; .* leave scheduler= out \(None\)"
    with pytest.raises(ConfigError, match=refusal):
        call(tmp_path / "run")
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("call", [
    lambda out, at: api.simulate("smoke", participants=1, scheduler=at, out=out),
    lambda out, at: api.replicate("smoke", 1, scheduler=at, out=out)])
def test_the_api_names_scheduler_not_the_option(tmp_path: Path, call: Any,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("nudgecli.runs.study.SCHEDULER_TIMEOUT_S", 0.5)
    with pytest.raises(ConfigError) as refused:
        call(tmp_path / "run", "tcp://127.0.0.1:9")
    assert str(refused.value).startswith("scheduler='tcp://127.0.0.1:9': cannot connect")
    assert "--scheduler" not in str(refused.value)
    assert not (tmp_path / "run").exists()
