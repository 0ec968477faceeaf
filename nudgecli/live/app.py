"""``nudge study``: set up one participant's live session and serve it."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from nudgecli import command_defaults as defaults
from nudgecli.config import ExperimentConfig, load_experiment
from nudgecli.errors import ConfigError, NudgeError
from nudgecli.live.records import LiveFolder
from nudgecli.live.session import LiveSession, participant_index
from nudgecli.rng import check_seed
from nudgecli.sim.counterbalance import check_design_order
from nudgecli.store import study_resume_command


def chosen_order(config: ExperimentConfig, experiment: str, condition_order: str | None) -> list[str] | None:
    """The conditions of ``--condition-order A,B,...``, checked to be one of the orders the
    experiment's counterbalancing assigns (any participant's), or ``None``."""
    if condition_order is None:
        return None
    names = [name.strip() for name in condition_order.split(",") if name.strip()]
    known = [str(c) for c in config.study.conditions]
    if sorted(names) != sorted(known):
        raise ConfigError(
            f"--condition-order {condition_order!r}: name each condition of the experiment once, "
            f"e.g. {','.join(known)}"
        )
    try:
        return check_design_order(known, config.study.counterbalancing, names)
    except ConfigError as exc:
        raise ConfigError(
            f"--condition-order {condition_order!r}: {exc} in [study] of {experiment}; give one of them"
        ) from None


def build_session(
    experiment: str,
    participant_id: str,
    out: str | Path | None = None,
    condition_order: str | None = None,
    seed: int | None = None,
    resume: bool = False,
    overrides: Sequence[str] = (),
) -> LiveSession:
    """The participant's session, its run folder opened (created, joined or resumed)."""
    config = load_experiment(experiment, tuple(overrides))
    seed = config.experiment.seed if seed is None else seed
    check_seed(seed)
    target = Path(out) if out else Path("results") / f"{config.experiment.name}-live"
    return LiveSession(
        config,
        seed,
        participant_id,
        LiveFolder(target),
        condition_order=chosen_order(config, experiment, condition_order),
        resume=resume,
    )


def run_live_study(
    experiment: str,
    participant_id: str,
    port: int = defaults.STUDY_PORT,
    out: str | None = None,
    condition_order: str | None = None,
    seed: int | None = None,
    resume: bool = False,
    overrides: Sequence[str] = (),
    announce: Callable[[str], None] = print,
    log: Callable[[str], None] = print,
) -> LiveSession:
    """Build the session and serve it on 127.0.0.1 until Ctrl-C; returns the session (its ``phase``
    is ``"done"`` when the participant finished).

    The port is taken before anything is recorded: a port in use leaves the folder as it was.
    """
    try:
        from nudgecli.live.server import bind, serve
    except ImportError as exc:
        raise ConfigError(
            f"nudge study needs the web server extra ({exc.name} is missing): pip install 'nudgecli[study]'"
        ) from None
    participant_index(participant_id)  # a bad ID is refused before the port is taken
    try:
        sock = bind(port)
    except OSError as exc:
        raise ConfigError(
            f"--port {port}: cannot listen on 127.0.0.1:{port} ({exc.strerror}); choose another --port"
        ) from None
    try:
        session = build_session(experiment, participant_id, out, condition_order, seed, resume, overrides)
    except BaseException:
        sock.close()
        raise
    try:
        log(
            f"participant {participant_id} (index {session.index}), {len(session.schedule)} trials, "
            f"condition order {', '.join(session.entry['condition_order'])}; run folder {session.folder.path}"
        )
        log("open the address below in a browser; Ctrl-C ends the server (resume later with --resume)")
        # on --resume the stored token: the participant's tab, still open, reconnects by itself
        token = session.folder.page_token(session.index, resume)
        # the port the page is served on: a command that continues the session names it, as the open
        # tab reconnects only there (after a crash, too: `nudge analyze`'s advice names it)
        session.entry["port"] = port
        session.folder.save(session.index)
        serve(session, sock, announce=announce, token=token, log=log)
    except NudgeError as exc:  # recording failed: the server stopped at once
        failure: NudgeError | None = exc
    else:
        failure = None
    finally:
        session.folder.release()
    if session.phase != "done" or failure is not None:
        command = study_resume_command(experiment, participant_id, session.folder.path,
                                       session.folder.run.resume_port(session.entry), condition_order, seed,
                                       overrides)
        if failure is not None:
            raise type(failure)(f"{failure}; the server stopped (a trial under way is run again): "
                                f"once that is fixed, continue with: {command}") from None
        log(f"stopped before the end of the session; continue at the next trial with: {command}")
    log(f"run folder: {session.folder.path}")
    return session
