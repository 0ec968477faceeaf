"""Whether a connected dask cluster can run nudge, checked once right after ``--scheduler``
connects (:func:`nudgecli.runs.study.connect_scheduler`), before anything is written.

A scheduler with no workers, or workers that cannot import this nudgecli, used to surface deep in
the work: a traceback of ``client.scatter``, a batch waiting at 0/N for ever, a run folder left
behind. Here they are one ``Error:`` line naming the address and the fix, for simulations and
batches alike. A healthy cluster costs one round trip (:func:`check_cluster`); a scheduler without
workers is asked by a task (:func:`first_worker_answer`), for which an adaptive cluster that
scales from zero starts its first worker. Workers that join later are checked by each task they
run (:func:`submit_checked`).

The scheduler's address is named as the front end that called spells it (:func:`scheduler_named`):
``--scheduler ADDR`` on the command line, ``scheduler='ADDR'`` in the Python API.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Mapping
from contextvars import ContextVar
from typing import Any

from nudgecli.errors import ClusterError, ConfigError, outermost_name

#: Seconds a scheduler without workers is given for one to join before the command is refused (a
#: Note says it waits): workers started with the scheduler join within seconds, a batch system's
#: queued jobs (dask-jobqueue) within minutes.
WORKERS_WAIT_S = 300.0

#: The command line's name of the scheduler's address, which the refusals use by default.
SCHEDULER_OPTION = "--scheduler"
#: The name the refusals use, as the front end that called spells it (``None``: :data:`SCHEDULER_OPTION`).
_NAMED: ContextVar[str | None] = ContextVar("scheduler_named", default=None)


def scheduler_named(name: str) -> contextlib.AbstractContextManager[None]:
    """Within the block, refusals of the scheduler's address name it ``name`` (the Python API's
    ``scheduler=``), unless a caller outside named it first: the command line, which calls the API,
    names :data:`SCHEDULER_OPTION` around it, and the person at the outermost front end is told
    (:func:`~nudgecli.errors.outermost_name`)."""
    return outermost_name(_NAMED, name)


def scheduler_option_name() -> str:
    """The name of the scheduler's address as the front end that called spells it: ``--scheduler``
    on the command line, ``scheduler=`` in the Python API."""
    return _NAMED.get() or SCHEDULER_OPTION


def install_advice(version: str | None = None) -> str:
    """What to do about workers that cannot run this nudge (``version``: its nudgecli version, this
    one's when None): the one wording of the connection check and of a worker met later
    (:func:`run_checked`, :mod:`nudgecli.runs.dask_results`)."""
    import nudgecli

    version = nudgecli.__version__ if version is None else version
    return f"install nudgecli {version}, this one, in the workers' environment and restart them"


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


def submit_checked(client: Any, task: Callable[..., Any], *args: Any, **options: Any) -> Any:
    """``client.submit(task, *args, pure=False, **options)``, run on a worker of this nudgecli version
    only (:func:`run_checked`): how every task nudge sends a cluster is submitted. Without a ``key``
    in ``options``, its key is named after ``task`` (the dashboard shows what runs), as dask's is."""
    import uuid

    import nudgecli

    options.setdefault("key", f"{getattr(task, '__name__', 'task')}-{uuid.uuid4().hex}")
    return client.submit(run_checked, nudgecli.__version__, task, *args, pure=False, **options)


def run_checked(version: str, task: Callable[..., Any], *args: Any) -> Any:
    """``task(*args)``, run on a dask worker once its nudgecli is ``version``, the client's
    (:func:`submit_checked`).

    The connection check (:func:`check_cluster`) asks the workers there then; a worker that joins
    later (an adaptive cluster starts them as the tasks come) is checked here, by the task itself:
    no result of another version's code comes back, and no round trip is added. A worker without
    nudgecli cannot load this function and fails the task's deserialization
    (:func:`nudgecli.runs.dask_results.as_nudge_error`).

    Raises
    ------
    ClusterError
        This worker imports another nudgecli version: the message names the scheduler, the worker,
        both versions and the install that fixes it (in the client's words: ``version``).
    """
    mine = worker_probe()()
    if mine != version:
        from distributed import get_worker

        worker = get_worker()
        raise ClusterError(f"the workers of the dask scheduler at {worker.scheduler.address} cannot run "
                           f"nudge (e.g. {worker.address}: it imports nudgecli {mine}, not {version}); "
                           f"{install_advice(version)}")
    return task(*args)


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

    One round trip where it can (each worker's nudgecli version, :func:`worker_probe`). A scheduler
    without workers is asked by a task (:func:`first_worker_answer`), which the first worker to
    join runs: an adaptive cluster starts workers only for submitted tasks.

    Raises
    ------
    ConfigError
        No worker joined within :data:`WORKERS_WAIT_S` seconds, or a worker cannot import nudgecli
        or imports another version of it.
    """
    versions = client.run(worker_probe(), on_error="return")
    if not versions:
        versions = first_worker_answer(client, address, log)
    problem = workers_problem(versions)
    if problem is not None:
        raise ConfigError(f"the workers of the dask scheduler at {address} cannot run nudge ({problem}); "
                          f"{install_advice()}")


def answer_with_address(probe: Callable[[], str]) -> Callable[[], tuple[str, object]]:
    """A task that runs ``probe`` (:func:`worker_probe`) on the worker that takes it and returns the
    worker's address and the probe's answer, or the exception it raised (a worker without nudgecli).

    Defined inside this function, so that it travels by value, as :func:`worker_probe` does."""
    def answered() -> tuple[str, object]:
        from distributed import get_worker

        try:
            answer: object = probe()
        except Exception as exc:  # the worker's problem, sent back to be named in the refusal
            answer = exc
        return str(get_worker().address), answer

    return answered


#: The name of the attribute of a client that holds the answer of :func:`first_worker_answer`'s task.
FIRST_ANSWER_KEPT = "_nudge_first_worker_answer"


def first_worker_answer(client: Any, address: str,
                        log: Callable[[str], None] | None = None) -> dict[str, object]:
    """The nudgecli version of the first worker the cluster of ``client`` starts (its address: the
    version, or the exception its import raised), asked by a task of :func:`answer_with_address`.

    An adaptive cluster (``cluster.adapt(minimum=0)``) starts workers only for tasks submitted, so
    waiting for a worker before submitting anything waited for ever; a batch system's queued
    workers join within minutes: the task is given :data:`WORKERS_WAIT_S` seconds, a ``Note:``
    to ``log`` saying so at once and another the time it waited once a worker answered. The
    task's result stays on the client (:data:`FIRST_ANSWER_KEPT`) for as long as it lives: an
    adaptive cluster does not retire the one worker holding data no other can take, so the worker
    that answered is still there when the work is submitted (dask's scatter to a cluster without
    workers fails within 2 s).

    Raises
    ------
    ConfigError
        No worker ran the task within :data:`WORKERS_WAIT_S` seconds, or the task was lost.
    """
    import time

    if log is not None:
        log(f"Note: the dask scheduler at {address} has no workers yet; waiting up to {WORKERS_WAIT_S:g} s "
            f"for one to join (an adaptive cluster starts one for the work submitted; else start some "
            f"with `dask worker {address}`; Ctrl-C stops)")
    started = time.monotonic()
    future = client.submit(answer_with_address(worker_probe()), pure=False)
    try:
        worker, answer = future.result(timeout=WORKERS_WAIT_S)
    except TimeoutError:
        future.cancel()
        raise ConfigError(f"the dask scheduler at {address} has no workers "
                          f"(none joined within {WORKERS_WAIT_S:g} s); start some with "
                          f"`dask worker {address}`, in an environment with nudgecli installed") from None
    except Exception as exc:  # the task lost (its worker died, the scheduler went away)
        raise ConfigError(f"the dask scheduler at {address} lost the task that asks its first worker "
                          f"for its nudgecli version ({one_line(exc)}); start workers with `dask worker "
                          f"{address}`, in an environment with nudgecli installed") from None
    setattr(client, FIRST_ANSWER_KEPT, future)
    if log is not None:
        log(f"Note: a worker joined the dask scheduler at {address} after {time.monotonic() - started:.0f} s")
    return {worker: answer}


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
