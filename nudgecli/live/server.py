"""The local web server of ``nudge study``: the page, a websocket, and the protocol's 10 Hz clock.

aiohttp serves ``static/`` (plain HTML and JavaScript, no build step) and one websocket at
``/ws``. The page sends input events (keys down and up, the gamepad axis) and commands; the server
passes them to the :class:`~nudgecli.live.session.LiveSession` as they arrive, advances the session
once per protocol step on its own clock, and sends every connected page the state after each step.
While no page is connected the session does not advance; a trial whose last page closed is
abandoned (not recorded) and runs again from its start. The session runs in a thread of its own,
one call at a time in the order they come (:func:`_in_session`): a record waiting for the folder's
lock held by another process holds up only the session, not the server's answers.

Guards (a study page drives a real person's session; other pages on the machine must not):

- the server binds to 127.0.0.1 only, and answers only requests whose ``Host`` is its own
  address (``127.0.0.1:PORT`` or ``localhost:PORT``), so a foreign name resolving to 127.0.0.1
  (DNS rebinding) gets nothing;
- the page and the websocket need the session's token (``?token=...``, in the address printed at
  start: random for a new participant, the stored one on ``--resume``, so the participant's open
  tab reconnects by itself after a crash); the websocket also needs the page's own ``Origin``;
- every message is checked against the schema of :mod:`nudgecli.live.messages`; a bad one gets
  an error reply and changes nothing. Its size is checked before it is parsed (a message of up
  to :data:`MAX_FRAME_BYTES` is read and refused; aiohttp closes the socket on a larger one, from
  its frame header), and a message nested too deeply for Python's JSON reader is refused too,
  each with one line on the server's log;
- pages have a role. A participant's page (the printed address) drives the session: the first
  open one controls it, later ones are told they only watch (their input is refused), and when
  the controlling page closes its keys are released and the oldest other participant's page takes
  over. A monitor page (the address with ``&role=monitor``) shows the session and never
  controls it, whatever closes. While no participant's page is open the session waits and its
  clock stops: a running trial is abandoned (it runs again from its start), a calibration prompt
  keeps the time it had left.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import hmac
import json
import secrets
import socket
import sys
import time
from collections.abc import AsyncIterator, Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Protocol, TypeVar

from aiohttp import WSCloseCode, WSMsgType, web

from nudgecli.live.messages import INPUT_TYPES, MAX_MESSAGE_BYTES, check_message
from nudgecli.live.session import LiveSession
from nudgecli.store import write_error

HOST = "127.0.0.1"
#: Host names the server answers to (with its port): its address and the machine's own name for it.
HOST_NAMES = (HOST, "localhost")
SESSION_KEY = web.AppKey("session", LiveSession)
CLOCK_KEY: web.AppKey[Clock] = web.AppKey("clock")
TOKEN_KEY = web.AppKey("token", str)
#: The session's own thread (one: its calls run one at a time, in the order they were made).
WORKER_KEY = web.AppKey("worker", ThreadPoolExecutor)
#: Paths that need the token: the page and the websocket (``/static/`` holds only the page's code).
GUARDED_PATHS = ("/", "/ws")
WATCHING = "another page controls this session; this page only watches"
MONITORING = "this is a monitor page: it shows the session and sends no input"
#: The roles a page may ask for with ``?role=``: none is the participant's page.
PARTICIPANT, MONITOR = "participant", "monitor"
#: The largest websocket message aiohttp reads (checked from the frame header, before reading):
#: one up to this size is read and refused by its length, larger ones close the socket.
MAX_FRAME_BYTES = 16 * 1024 * 1024


def _stderr_line(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


class Sockets:
    """The pages connected to the session, in the order they connected, with their roles; the
    first participant's page controls the session, a monitor page never does."""

    def __init__(self) -> None:
        self.pages: dict[web.WebSocketResponse, str] = {}  # insertion-ordered: page -> role

    @property
    def open(self) -> list[web.WebSocketResponse]:
        return list(self.pages)

    @property
    def controller(self) -> web.WebSocketResponse | None:
        return next((ws for ws, role in self.pages.items() if role == PARTICIPANT), None)

    def role_of(self, ws: web.WebSocketResponse) -> str:
        """What the page is told it is: ``controller``, ``watcher`` or ``monitor``."""
        if self.pages.get(ws) == MONITOR:
            return MONITOR
        return "controller" if self.controller is ws else "watcher"


SOCKETS_KEY = web.AppKey("sockets", Sockets)


@dataclass
class SessionTime:
    """The session's time: the clock's, less the spans when no participant's page was open (a
    calibration prompt's clock pauses while the tab is closed). It starts paused: no page yet."""

    clock: Clock
    paused_s: float = 0.0
    paused_at: float | None = 0.0

    def now(self) -> float:
        current = self.clock.now() if self.paused_at is None else self.paused_at
        return current - self.paused_s

    def pause(self) -> None:
        if self.paused_at is None:
            self.paused_at = self.clock.now()

    def go_on(self) -> None:
        if self.paused_at is not None:
            self.paused_s += self.clock.now() - self.paused_at
            self.paused_at = None


@dataclass
class ServerLog:
    """The server's console lines: refused messages that look like attacks, and the end."""

    write: Callable[[str], None] = _stderr_line
    finished: bool = field(default=False)

    def session_changed(self, session: LiveSession) -> None:
        """Say once when the participant has finished (the experimenter may not watch the page)."""
        if session.phase == "done" and not self.finished:
            self.finished = True
            done = len(session.entry["completed_trials"])
            self.write(
                f"participant {session.participant_id} finished: {done} of {len(session.schedule)} trials "
                f"and the questionnaires recorded in {session.folder.path}; Ctrl-C ends the server"
            )


TIME_KEY = web.AppKey("time", SessionTime)
#: The failure that stopped the server (at most one), and how to stop it.
FAILURE_KEY: web.AppKey[list[Exception]] = web.AppKey("failure")
STOP_KEY: web.AppKey[Callable[[], None]] = web.AppKey("stop")
LOG_KEY = web.AppKey("log", ServerLog)


def static_dir() -> Path:
    """The page's files, shipped inside the package."""
    return Path(str(resources.files("nudgecli.live") / "static"))


class Clock(Protocol):
    """When the protocol steps, and the session's time in seconds."""

    async def wait(self) -> None:
        """Return at the next step."""

    def now(self) -> float:
        """Seconds since the session started."""


class PacedClock:
    """Real time: one step every ``dt`` seconds, on a fixed schedule (no drift); after a stall of
    more than a second the schedule restarts instead of running steps back to back."""

    def __init__(self, dt: float) -> None:
        self.dt = dt
        self.start = time.monotonic()
        self.next = self.start

    async def wait(self) -> None:
        self.next += self.dt
        delay = self.next - time.monotonic()
        if delay < -1.0:
            self.next = time.monotonic()
            delay = 0.0
        await asyncio.sleep(max(delay, 0.0))

    def now(self) -> float:
        return time.monotonic() - self.start


class SteppedClock:
    """Steps on demand (tests, replays): :meth:`release` lets one step happen; the time is
    ``steps x dt``, so the logs are reproducible."""

    def __init__(self, dt: float) -> None:
        self.dt = dt
        self.steps = 0
        self._permits = asyncio.Semaphore(0)

    async def wait(self) -> None:
        await self._permits.acquire()
        self.steps += 1

    def release(self, n: int = 1) -> None:
        for _ in range(n):
            self._permits.release()

    def now(self) -> float:
        return round(self.steps * self.dt, 9)


_T = TypeVar("_T")


async def _in_session(app: web.Application, call: Callable[[], _T]) -> _T:
    """Run ``call`` (the session's handling of a message, its step, its view) in the session's own
    thread. Recording may wait up to :data:`~nudgecli.live.records.FOLDER_LOCK_WAIT_S` for the
    folder's lock while another process holds it (another participant's server, ``nudge analyze``):
    the wait holds up only the session's later calls, queued in order behind it, while the server
    goes on answering pages, monitors and the websockets' heartbeats."""
    try:
        future = asyncio.get_running_loop().run_in_executor(app[WORKER_KEY], call)
    except RuntimeError:  # the server is stopping and the session's thread has ended: none runs there
        return call()
    return await future


def _stepped(app: web.Application, now: float) -> dict[str, Any]:
    """One protocol step of the session (in its thread), and the state it leaves."""
    session = app[SESSION_KEY]
    session.tick(now)
    app[LOG_KEY].session_changed(session)
    return session.view()


async def _broadcast(app: web.Application, message: dict[str, Any]) -> None:
    for ws in app[SOCKETS_KEY].open:
        await _send(ws, message)


STOPPED = "the study server stopped: the session could not be recorded; the experimenter will continue it"


def recording_failure(exc: Exception) -> Exception:
    """What stops the server when recording the session fails: a :class:`NudgeError` as it is, an
    ``OSError`` (a write) as the :class:`~nudgecli.errors.WriteError` naming its file; anything else
    (a bug) as it is."""
    if isinstance(exc, OSError) and not isinstance(exc, ConnectionError):
        return write_error(exc.filename or "the run folder", exc)
    return exc


async def _fail(app: web.Application, exc: Exception) -> None:
    """Recording the session failed: keep the first failure, tell every page, close them, and stop
    the server (``create_app``'s ``stop``); ``serve`` then raises it."""
    if app[FAILURE_KEY]:
        return
    app[FAILURE_KEY].append(recording_failure(exc))
    await _broadcast(app, {"type": "error", "message": STOPPED, "stopped": True})
    await _close_pages(app)
    app[STOP_KEY]()


async def _ticker(app: web.Application) -> None:
    clock, session_time = app[CLOCK_KEY], app[TIME_KEY]
    while True:
        await clock.wait()
        if app[SOCKETS_KEY].controller is None:
            continue  # no participant's page: the session waits (a trial left mid-way was abandoned)
        try:
            view = await _in_session(app, functools.partial(_stepped, app, session_time.now()))
        except Exception as exc:  # a checkpoint not written: the server stops, the page is told
            await _fail(app, exc)
            return
        await _broadcast(app, view)


async def _ticker_context(app: web.Application) -> AsyncIterator[None]:
    task = asyncio.create_task(_ticker(app))
    yield
    task.cancel()
    with contextlib.suppress(asyncio.CancelledError):
        await task
    # a recording under way in the session's thread ends (written, or its error) before serve returns
    await asyncio.to_thread(app[WORKER_KEY].shutdown)


async def _index(request: web.Request) -> web.FileResponse:
    return web.FileResponse(static_dir() / "index.html")


def _own_hosts(request: web.Request) -> set[str]:
    """The ``Host`` values that name this server: its address or localhost, with its port."""
    sockname = request.transport.get_extra_info("sockname") if request.transport else None
    port = sockname[1] if sockname else None
    return {f"{name}:{port}" for name in HOST_NAMES}


@web.middleware
async def _guard(request: web.Request, handler: Any) -> web.StreamResponse:
    """Refuse requests for another host (DNS rebinding), without the session's token, or (the
    websocket) from a page of another origin."""
    host = request.headers.get("Host", "")
    if host not in _own_hosts(request):
        raise web.HTTPForbidden(text=f"refused: Host {host!r} is not this study server\n")
    if request.path in GUARDED_PATHS:
        token = request.query.get("token", "")
        if not hmac.compare_digest(token.encode(), request.app[TOKEN_KEY].encode()):
            raise web.HTTPForbidden(
                text="refused: open the address the server printed at start (it holds the session's token)\n"
            )
        if request.path == "/ws" and request.headers.get("Origin") != f"http://{host}":
            raise web.HTTPForbidden(text="refused: the websocket serves only the study page itself\n")
    return await handler(request)


async def _send(ws: web.WebSocketResponse, message: dict[str, Any]) -> None:
    if not ws.closed:
        with contextlib.suppress(ConnectionError, RuntimeError):
            await ws.send_str(json.dumps(message))


async def _reply_error(ws: web.WebSocketResponse, text: str) -> None:
    await _send(ws, {"type": "error", "message": text})


def _parse(text: str) -> tuple[Any, str | None, bool]:
    """The JSON value of a message, or why it is refused, its size checked before it is parsed;
    and whether the refusal goes to the log (what no page of ours sends: too large, too deep)."""
    size = len(text.encode("utf-8", "surrogatepass"))  # the limit is in bytes: '€' is three of them
    if size > MAX_MESSAGE_BYTES:
        return None, f"message of {size} bytes; at most {MAX_MESSAGE_BYTES}", True
    try:
        return json.loads(text), None, False
    except RecursionError:  # Python's JSON reader recurses per nesting level; no message nests
        return None, "not a message: JSON nested too deeply", True
    except ValueError:  # not JSON, or a number too long to read
        return None, "not JSON", False


async def _websocket(request: web.Request) -> web.WebSocketResponse:
    app = request.app
    session, sockets, session_time, log = app[SESSION_KEY], app[SOCKETS_KEY], app[TIME_KEY], app[LOG_KEY]
    role = request.query.get("role", PARTICIPANT)
    if role not in (PARTICIPANT, MONITOR):
        raise web.HTTPBadRequest(
            text=f"refused: role {role[:20]!r}; a page is the participant's, or role=monitor\n")
    # aiohttp's own limit far above ours, so an oversized message is answered, not a dropped socket
    ws = web.WebSocketResponse(heartbeat=10.0, max_msg_size=MAX_FRAME_BYTES)
    await ws.prepare(request)
    sockets.pages[ws] = role
    if sockets.controller is ws:
        session_time.go_on()  # a participant's page again: the session's clock runs
    await _send(ws, {"type": "role", "role": sockets.role_of(ws)})
    await _send(ws, await _in_session(app, session.view))
    try:
        async for msg in ws:
            if msg.type == WSMsgType.BINARY:  # answered as every bad message is
                await _reply_error(ws, "a message is text JSON, not a binary frame")
                continue
            if msg.type != WSMsgType.TEXT:
                continue
            data, problem, worth_logging = _parse(msg.data)
            if worth_logging:
                log.write(f"refused a message from a {role} page: {problem}")
            problem = problem or check_message(data)
            if problem is not None:
                await _reply_error(ws, problem)
                continue
            if data["type"] in INPUT_TYPES and sockets.controller is not ws:
                await _reply_error(ws, MONITORING if role == MONITOR else WATCHING)
                continue
            changes = data["type"] in ("start", "skip", "questionnaire") or (
                data["type"] == "key" and data["key"] == " "
            )
            try:
                reply, view = await _in_session(app, _handling(app, data, session_time.now(), changes))
            except Exception as exc:  # a record not written: the server stops, the page is told
                await _fail(app, exc)
                break
            # the state first: a page told its answers were recorded already shows the next phase
            # (else a second Submit in between sends them again, refused as "no questionnaire is due")
            if view is not None:
                await _broadcast(app, view)
            if reply is not None:
                await _send(ws, reply)
    finally:
        was_controller = sockets.controller is ws
        sockets.pages.pop(ws, None)
        if was_controller:
            successor, now = sockets.controller, session_time.now()
            if successor is None:
                session_time.pause()
            # a task of its own, run to its end even where the page's connection dropped and this
            # handler is cancelled: the session hears of it all the same
            task = asyncio.ensure_future(_controller_left(app, successor, now))
            _LEAVING.add(task)
            task.add_done_callback(_LEAVING.discard)
            await asyncio.shield(task)
    return ws


#: The tasks telling the session its controlling page left (held here: the loop holds tasks weakly).
_LEAVING: set[asyncio.Future[None]] = set()


async def _controller_left(app: web.Application, successor: web.WebSocketResponse | None, now: float) -> None:
    """The controlling page closed: its keys are up; with no participant's page left (no
    ``successor``), the running trial is abandoned (the session's clock stopped)."""
    left = {"type": "blur" if successor is not None else "disconnect"}
    _, view = await _in_session(app, _handling(app, left, now, True))
    if successor is not None:
        await _send(successor, {"type": "role", "role": "controller"})
    assert view is not None
    await _broadcast(app, view)  # a monitor sees the trial abandoned


def _handling(
    app: web.Application, message: dict[str, Any], now: float, changes: bool
) -> Callable[[], tuple[dict[str, Any] | None, dict[str, Any] | None]]:
    """The session's handling of ``message`` (for its thread): the reply to the sender, and the
    state every page is sent where the message ``changes`` what they show (else ``None``)."""
    session = app[SESSION_KEY]

    def handle() -> tuple[dict[str, Any] | None, dict[str, Any] | None]:
        reply = session.handle(message, now)
        if not changes:
            return reply, None
        app[LOG_KEY].session_changed(session)
        return reply, session.view()

    return handle


async def _close_pages(app: web.Application) -> None:
    """On Ctrl-C: close the pages' websockets, so the server stops at once instead of waiting for
    them (the pages then show that the server is gone)."""
    for ws in app[SOCKETS_KEY].open:
        await ws.close(code=WSCloseCode.GOING_AWAY, message=b"the study server stopped")


def create_app(
    session: LiveSession,
    clock: Clock | None = None,
    token: str | None = None,
    log: Callable[[str], None] = _stderr_line,
    stop: Callable[[], None] = lambda: None,
) -> web.Application:
    """The aiohttp application of one live session (``clock``: real time at the protocol rate;
    ``token``: the session's token, random when ``None``; ``log``: the console's lines; ``stop``:
    stops the server when recording the session failed, the failure in ``app[FAILURE_KEY]``)."""
    app = web.Application(middlewares=[_guard])
    app[SESSION_KEY] = session
    app[TOKEN_KEY] = token or secrets.token_urlsafe(16)
    app[CLOCK_KEY] = clock or PacedClock(session.settings.dt)
    app[TIME_KEY] = SessionTime(app[CLOCK_KEY])
    app[LOG_KEY] = ServerLog(log)
    app[SOCKETS_KEY] = Sockets()
    app[WORKER_KEY] = ThreadPoolExecutor(max_workers=1, thread_name_prefix="nudge-study-session")
    app[FAILURE_KEY] = []
    app[STOP_KEY] = stop
    app.router.add_get("/", _index)
    app.router.add_get("/ws", _websocket)
    app.router.add_static("/static/", static_dir())
    app.cleanup_ctx.append(_ticker_context)
    app.on_shutdown.append(_close_pages)
    return app


def bind(port: int) -> socket.socket:
    """A socket listening on ``127.0.0.1:port``, before anything is recorded (so a port in use
    leaves nothing behind). Connections wait in its backlog until :func:`serve` answers them.

    Raises
    ------
    OSError
        The port is in use or not allowed.
    """
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        # a port left in TIME_WAIT by the previous server is free to take; a listening one is not
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((HOST, port))
        sock.listen(128)
    except OSError:
        sock.close()
        raise
    return sock


def page_address(port: int, token: str) -> str:
    """The address of the study page, with the session's token."""
    return f"http://{HOST}:{port}/?token={token}"


def serve(
    session: LiveSession,
    sock: socket.socket,
    announce: Any = print,
    token: str | None = None,
    log: Callable[[str], None] = _stderr_line,
) -> None:
    """Serve the session on the listening socket ``sock`` (:func:`bind`) until interrupted;
    ``announce`` gets the page's address (with ``token``, random when ``None``) once the server
    answers, ``log`` the console's lines (the monitor page's address first).

    Raises
    ------
    Exception
        Recording the session failed (:func:`recording_failure`): the server stopped at once.
    """
    app = create_app(session, token=token, log=log, stop=_stop_soon)
    address = page_address(sock.getsockname()[1], app[TOKEN_KEY])

    def answering(_: str) -> None:
        announce(address)
        log(f"a read-only monitor page for the experimenter: {address}&role={MONITOR}")

    web.run_app(app, sock=sock, print=answering, handle_signals=True)
    if app[FAILURE_KEY]:
        raise app[FAILURE_KEY][0]


def _stop_soon() -> None:
    """Stop ``web.run_app`` as Ctrl-C does (its loop ends on ``GracefulExit``)."""

    def stop() -> None:
        raise web.GracefulExit

    asyncio.get_running_loop().call_soon(stop)
