"""Whether a connected dask cluster can run nudge, checked once right after ``--scheduler``
connects (:func:`nudgecli.runs.study.connect_scheduler`), before anything is written.

A scheduler with no workers, or workers that cannot import this nudgecli, used to surface deep in
the work: a traceback of ``client.scatter``, a batch waiting at 0/N for ever, a run folder left
behind. Here they are one ``Error:`` line naming the address and the fix, for simulations and
batches alike. A healthy cluster costs one round trip (:func:`check_cluster`).

The scheduler's address is named as the front end that called spells it (:func:`scheduler_named`):
``--scheduler ADDR`` on the command line, ``scheduler='ADDR'`` in the Python API.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator, Mapping
from contextvars import ContextVar
from typing import Any

from nudgecli.errors import ConfigError

#: Seconds a scheduler without workers is given for one to join before the command is refused (a
#: Note says it waits): workers started with the scheduler join within seconds, a batch system's
#: queued jobs (dask-jobqueue) within minutes.
WORKERS_WAIT_S = 300.0

#: The command line's name of the scheduler's address, which the refusals use by default.
SCHEDULER_OPTION = "--scheduler"
#: The name the refusals use, as the front end that called spells it (``None``: :data:`SCHEDULER_OPTION`).
_NAMED: ContextVar[str | None] = ContextVar("scheduler_named", default=None)


@contextlib.contextmanager
def scheduler_named(name: str) -> Iterator[None]:
    """Within the block, refusals of the scheduler's address name it ``name`` (the Python API's
    ``scheduler=``), unless a caller outside named it first: the command line, which calls the API,
    names :data:`SCHEDULER_OPTION` around it, and the person at the outermost front end is told."""
    token = _NAMED.set(name) if _NAMED.get() is None else None
    try:
        yield
    finally:
        if token is not None:
            _NAMED.reset(token)


def scheduler_option_name() -> str:
    """The name of the scheduler's address as the front end that called spells it: ``--scheduler``
    on the command line, ``scheduler=`` in the Python API."""
    return _NAMED.get() or SCHEDULER_OPTION


def install_advice() -> str:
    """What to do about workers that cannot run this nudge: the one wording of the connection check
    and of a worker met later (:mod:`nudgecli.runs.dask_results`)."""
    import nudgecli

    return f"install nudgecli {nudgecli.__version__}, this one, in the workers' environment and restart them"


def scheduler_label(address: str) -> str:
    """``address`` as the front end that called names it: ``--scheduler tcp://h:8786`` (``--scheduler ""``
    when empty) on the command line, ``scheduler='tcp://h:8786'`` in the Python API."""
    name = scheduler_option_name()
    if name.startswith("--"):
        return f"{name} {address}" if address.strip() else f'{name} "{address}"'
    return f"{name.rstrip('=')}={address!r}"


def check_scheduler_address(address: str | None) -> str | None:
    """``address``, refused when empty or blank (as ``--out ""`` is): it would run on local workers
    without a word, though a scheduler was asked for (an unset variable in a script's command line).

    Raises
    ------
    ConfigError
        An empty or blank address.
    """
    if address is not None and not address.strip():
        name = scheduler_option_name()
        leave_out = f"leave {name} out" if name.startswith("--") else f"leave {name.rstrip('=')}= out (None)"
        raise ConfigError(f"{scheduler_label(address)}: an empty address; give the address of a running "
                          f"dask scheduler, e.g. tcp://host:8786, or {leave_out} to run on local workers")
    return address


def one_line(exc: BaseException) -> str:
    """An exception's message on one line (or its type's name when it has none)."""
    text = " ".join(str(exc).split())
    return text or type(exc).__name__


def worker_probe() -> Callable[[], str]:
    """The function each worker runs to say which nudgecli it imports: its ``__version__``.

    Defined inside this function, so that it travels to the workers by value (cloudpickle) and a
    worker without nudgecli runs it and fails in its import, which it sends back as the error,
    rather than failing to read it at all (a traceback in the worker's log).
    """
    def nudgecli_version() -> str:
        import nudgecli

        return str(nudgecli.__version__)

    return nudgecli_version


def checked_client(client: Any, address: str, log: Callable[[str], None] | None = None) -> Any:
    """``client`` (connected to ``address``), once :func:`check_cluster` found its cluster can run
    nudge; else it is closed and the refusal raised."""
    try:
        check_cluster(client, address, log)
    except BaseException:
        client.close()
        raise
    return client


def check_cluster(client: Any, address: str, log: Callable[[str], None] | None = None) -> None:
    """Refuse the cluster of ``client`` (connected to ``address``) where it cannot run nudge.

    One round trip where it can (each worker's nudgecli version, :func:`worker_probe`); a scheduler
    without workers is given :data:`WORKERS_WAIT_S` seconds for one to join, a ``Note:`` line to
    ``log`` saying so.

    Raises
    ------
    ConfigError
        No worker joined within :data:`WORKERS_WAIT_S` seconds, or a worker cannot import nudgecli
        or imports another version of it.
    """
    versions = client.run(worker_probe(), on_error="return")
    if not versions:
        if log is not None:
            log(f"Note: the dask scheduler at {address} has no workers yet; waiting up to {WORKERS_WAIT_S:g} "
                f"s for one to join (start some with `dask worker {address}`; Ctrl-C stops)")
        try:
            client.wait_for_workers(1, timeout=WORKERS_WAIT_S)
        except TimeoutError:
            raise ConfigError(f"the dask scheduler at {address} has no workers "
                              f"(none joined within {WORKERS_WAIT_S:g} s); start some with "
                              f"`dask worker {address}`, in an environment with nudgecli installed") from None
        versions = client.run(worker_probe(), on_error="return")
    problem = workers_problem(versions)
    if problem is not None:
        raise ConfigError(f"the workers of the dask scheduler at {address} cannot run nudge ({problem}); "
                          f"{install_advice()}")


def workers_problem(versions: Mapping[str, object]) -> str | None:
    """What stops the workers of ``versions`` (a worker's address: the nudgecli version it imports,
    or the exception it raised) from running this nudgecli, in a few words; None when nothing does."""
    import nudgecli

    # a worker that left between the scheduler's list and its answer (OSError: a closed comm) says
    # nothing about the others: only the answers of the workers still there count
    answered = {worker: answer for worker, answer in versions.items() if not isinstance(answer, OSError)}
    wrong = {worker: answer for worker, answer in answered.items() if answer != nudgecli.__version__}
    if not wrong:
        return None if answered else "no worker answered: each left as it was asked"
    worker, answer = sorted(wrong.items())[0]
    said = (one_line(answer) if isinstance(answer, BaseException)
            else f"it imports nudgecli {answer}, not {nudgecli.__version__}")
    return f"{len(wrong)} of {len(answered)} worker(s), e.g. {worker}: {said}"
