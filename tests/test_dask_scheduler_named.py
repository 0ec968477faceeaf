"""The Python API names the scheduler's address ``scheduler=`` in its refusals from one block per
call (``nudgecli/api/run.py``, ``nudgecli/api/batches.py``: it was entered twice, once for the
empty address and once for the work), and which of two bad arguments is refused first is as before:
the address before the others."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from nudgecli import api
from nudgecli.errors import ConfigError
from nudgecli.runs import batch_kinds, dask_cluster, study


class ReachedWorkError(Exception):
    """Raised by the replaced work: the call got there."""


def _stop(*args: Any, **kwargs: Any) -> Any:
    raise ReachedWorkError


@pytest.fixture
def entries(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The names each entry of ``scheduler_named`` gave; the work of simulate and replicate stops."""
    entered: list[str] = []
    named = dask_cluster.scheduler_named

    @contextlib.contextmanager
    def counted(name: str) -> Iterator[None]:
        entered.append(name)
        with named(name):
            yield

    monkeypatch.setattr(dask_cluster, "scheduler_named", counted)
    monkeypatch.setattr(study, "run_study", _stop)
    monkeypatch.setattr(batch_kinds, "replicate", _stop)
    return entered


CALLS: list[Callable[[Path], Any]] = [
    lambda out: api.simulate("smoke", participants=1, out=out),
    lambda out: api.replicate("smoke", 1, participants=2, out=out)]


@pytest.mark.parametrize("call", CALLS)
def test_a_call_names_the_scheduler_in_one_block(tmp_path: Path, entries: list[str], call: Any) -> None:
    with pytest.raises(ReachedWorkError):
        call(tmp_path / "out")
    assert entries == ["scheduler="]


@pytest.mark.parametrize("call", [
    lambda out: api.simulate("smoke", participants=-1, scheduler="", out=out),
    lambda out: api.replicate("smoke", 1, participants=2, scheduler="", resume="yes", out=out)])
def test_an_empty_scheduler_is_refused_before_another_bad_argument(tmp_path: Path, call: Any) -> None:
    with pytest.raises(ConfigError, match=r"^scheduler='': an empty address"):
        call(tmp_path / "out")
