"""The local web server of ``nudge study``: the page, a websocket, and the protocol's 10 Hz clock.

aiohttp serves ``static/`` (plain HTML and JavaScript, no build step) and one websocket at
``/ws``. The page sends input events (keys down and up, the gamepad axis) and commands; the server
passes them to the :class:`~nudgecli.live.session.LiveSession` as they arrive, advances the session
once per protocol step on its own clock, and sends every connected page the state after each step.
While no page is connected the session does not advance; a trial whose last page closed is
abandoned (not recorded) and runs again from its start.
The server binds to 127.0.0.1 only: a study session is local.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import time
from collections.abc import AsyncIterator
from importlib import resources
from pathlib import Path
from typing import Any, Protocol

from aiohttp import WSMsgType, web

from nudgecli.live.session import LiveSession

HOST = "127.0.0.1"
SESSION_KEY = web.AppKey("session", LiveSession)
CLOCK_KEY: web.AppKey[Clock] = web.AppKey("clock")


class Sockets:
    """The pages connected to the session."""

    def __init__(self) -> None:
        self.open: set[web.WebSocketResponse] = set()


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
    text = json.dumps(message)
    for ws in list(app[SOCKETS_KEY].open):
        if not ws.closed:
            with contextlib.suppress(ConnectionError, RuntimeError):
                await ws.send_str(text)


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


async def _websocket(request: web.Request) -> web.WebSocketResponse:
    app = request.app
    session, clock = app[SESSION_KEY], app[CLOCK_KEY]
    ws = web.WebSocketResponse(heartbeat=10.0)
    await ws.prepare(request)
    app[SOCKETS_KEY].open.add(ws)
    await ws.send_str(json.dumps(session.view()))
    try:
        async for msg in ws:
            if msg.type != WSMsgType.TEXT:
                continue
            try:
                data = json.loads(msg.data)
            except json.JSONDecodeError:
                await ws.send_str(json.dumps({"type": "error", "message": "not JSON"}))
                continue
            if not isinstance(data, dict):
                continue
            reply = session.handle(data, clock.now())
            if reply is not None:
                await ws.send_str(json.dumps(reply))
            if data.get("type") in ("start", "skip", "questionnaire") or (
                data.get("type") == "key" and data.get("key") == " "
            ):
                await _broadcast(app, session.view())
    finally:
        app[SOCKETS_KEY].open.discard(ws)
        # a closed tab holds no key; with no page left, the running trial is abandoned
        session.handle({"type": "disconnect" if not app[SOCKETS_KEY].open else "blur"}, clock.now())
    return ws


def create_app(session: LiveSession, clock: Clock | None = None) -> web.Application:
    """The aiohttp application of one live session (``clock``: real time at the protocol rate)."""
    app = web.Application()
    app[SESSION_KEY] = session
    app[CLOCK_KEY] = clock or PacedClock(session.settings.dt)
    app[SOCKETS_KEY] = Sockets()
    app.router.add_get("/", _index)
    app.router.add_get("/ws", _websocket)
    app.router.add_static("/static/", static_dir())
    app.cleanup_ctx.append(_ticker_context)
    return app


def serve(session: LiveSession, port: int, announce: Any = print) -> None:
    """Serve the session on ``127.0.0.1:port`` until interrupted."""
    app = create_app(session)
    address = f"http://{HOST}:{port}/"
    web.run_app(app, host=HOST, port=port, print=lambda _: announce(address), handle_signals=True)
