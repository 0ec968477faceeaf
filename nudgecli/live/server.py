"""The local web server of ``nudge study``: the page, a websocket, and the protocol's 10 Hz clock.

aiohttp serves ``static/`` (plain HTML and JavaScript, no build step) and one websocket at
``/ws``. The page sends input events (keys down and up, the gamepad axis) and commands; the server
passes them to the :class:`~nudgecli.live.session.LiveSession` as they arrive, advances the session
once per protocol step on its own clock, and sends every connected page the state after each step.
While no page is connected the session does not advance; a trial whose last page closed is
abandoned (not recorded) and runs again from its start.

Guards (a study page drives a real person's session; other pages on the machine must not):

- the server binds to 127.0.0.1 only, and answers only requests whose ``Host`` is its own
  address (``127.0.0.1:PORT`` or ``localhost:PORT``), so a foreign name resolving to 127.0.0.1
  (DNS rebinding) gets nothing;
- the page and the websocket need the session's token (``?token=...``, random per server start,
  in the address printed at start); the websocket also needs the page's own ``Origin``;
- every message is checked against the schema of :mod:`nudgecli.live.messages`; a bad one gets
  an error reply and changes nothing;
- one page controls the session at a time: the first to connect; later pages are told they only
  watch (their input is refused). When the controlling page closes, its keys are released and
  the oldest watching page takes over; a watching page closing changes nothing.
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import json
import secrets
import socket
import time
from collections.abc import AsyncIterator
from importlib import resources
from pathlib import Path
from typing import Any, Protocol

from aiohttp import WSCloseCode, WSMsgType, web

from nudgecli.live.messages import INPUT_TYPES, MAX_MESSAGE_BYTES, check_message
from nudgecli.live.session import LiveSession

HOST = "127.0.0.1"
#: Host names the server answers to (with its port): its address and the machine's own name for it.
HOST_NAMES = (HOST, "localhost")
SESSION_KEY = web.AppKey("session", LiveSession)
CLOCK_KEY: web.AppKey[Clock] = web.AppKey("clock")
TOKEN_KEY = web.AppKey("token", str)
#: Paths that need the token: the page and the websocket (``/static/`` holds only the page's code).
GUARDED_PATHS = ("/", "/ws")
WATCHING = "another page controls this session; this page only watches"


class Sockets:
    """The pages connected to the session, in the order they connected; the first controls it."""

    def __init__(self) -> None:
        self.pages: dict[web.WebSocketResponse, None] = {}  # insertion-ordered set

    @property
    def open(self) -> list[web.WebSocketResponse]:
        return list(self.pages)

    @property
    def controller(self) -> web.WebSocketResponse | None:
        return next(iter(self.pages), None)


SOCKETS_KEY = web.AppKey("sockets", Sockets)


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


async def _broadcast(app: web.Application, message: dict[str, Any]) -> None:
    for ws in app[SOCKETS_KEY].open:
        await _send(ws, message)


async def _ticker(app: web.Application) -> None:
    session, clock = app[SESSION_KEY], app[CLOCK_KEY]
    while True:
        await clock.wait()
        if not app[SOCKETS_KEY].open:
            continue  # no page: the session waits (a trial left mid-way was abandoned)
        session.tick(clock.now())
        await _broadcast(app, session.view())


async def _ticker_context(app: web.Application) -> AsyncIterator[None]:
    task = asyncio.create_task(_ticker(app))
    yield
    task.cancel()
    with contextlib.suppress(asyncio.CancelledError):
        await task


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


async def _websocket(request: web.Request) -> web.WebSocketResponse:
    app = request.app
    session, clock, sockets = app[SESSION_KEY], app[CLOCK_KEY], app[SOCKETS_KEY]
    # aiohttp's own limit well above ours, so an oversized message is answered, not a dropped socket
    ws = web.WebSocketResponse(heartbeat=10.0, max_msg_size=64 * MAX_MESSAGE_BYTES)
    await ws.prepare(request)
    sockets.pages[ws] = None
    await _send(ws, {"type": "role", "role": "controller" if sockets.controller is ws else "watcher"})
    await _send(ws, session.view())
    try:
        async for msg in ws:
            if msg.type != WSMsgType.TEXT:
                continue
            if len(msg.data) > MAX_MESSAGE_BYTES:
                await _reply_error(ws, f"message of {len(msg.data)} characters; at most {MAX_MESSAGE_BYTES}")
                continue
            try:
                data = json.loads(msg.data)
            except ValueError:  # not JSON, or a number too long to read
                await _reply_error(ws, "not JSON")
                continue
            problem = check_message(data)
            if problem is not None:
                await _reply_error(ws, problem)
                continue
            if data["type"] in INPUT_TYPES and sockets.controller is not ws:
                await _reply_error(ws, WATCHING)
                continue
            reply = session.handle(data, clock.now())
            if reply is not None:
                await _send(ws, reply)
            if data["type"] in ("start", "skip", "questionnaire") or (
                data["type"] == "key" and data["key"] == " "
            ):
                await _broadcast(app, session.view())
    finally:
        was_controller = sockets.controller is ws
        sockets.pages.pop(ws, None)
        if was_controller:
            # the controlling page's keys are up; with no page left, the running trial is abandoned
            session.handle({"type": "disconnect" if not sockets.pages else "blur"}, clock.now())
            successor = sockets.controller
            if successor is not None:
                await _send(successor, {"type": "role", "role": "controller"})
    return ws


async def _close_pages(app: web.Application) -> None:
    """On Ctrl-C: close the pages' websockets, so the server stops at once instead of waiting for
    them (the pages then show that the server is gone)."""
    for ws in app[SOCKETS_KEY].open:
        await ws.close(code=WSCloseCode.GOING_AWAY, message=b"the study server stopped")


def create_app(session: LiveSession, clock: Clock | None = None, token: str | None = None) -> web.Application:
    """The aiohttp application of one live session (``clock``: real time at the protocol rate;
    ``token``: the session's token, random when ``None``)."""
    app = web.Application(middlewares=[_guard])
    app[SESSION_KEY] = session
    app[TOKEN_KEY] = token or secrets.token_urlsafe(16)
    app[CLOCK_KEY] = clock or PacedClock(session.settings.dt)
    app[SOCKETS_KEY] = Sockets()
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


def serve(session: LiveSession, sock: socket.socket, announce: Any = print) -> None:
    """Serve the session on the listening socket ``sock`` (:func:`bind`) until interrupted;
    ``announce`` gets the page's address (with the token) once the server answers."""
    app = create_app(session)
    address = page_address(sock.getsockname()[1], app[TOKEN_KEY])
    web.run_app(app, sock=sock, print=lambda _: announce(address), handle_signals=True)
