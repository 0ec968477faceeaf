"""While another process holds a live folder's lock (another participant's server, ``nudge analyze``),
the study server goes on answering: the session's record waits for the lock in the session's own
thread, goes on once the lock is released, and stops the server with the lock's error when the wait
runs out."""

from __future__ import annotations

import asyncio
import functools
import json
import threading
import time
from pathlib import Path

import pytest

pytest.importorskip("aiohttp", reason="the live server needs aiohttp: pip install '.[study]'")

from aiohttp.test_utils import TestClient, TestServer
from live_helpers import DEFAULT_TABLES, TWO_TRIALS
from test_live_server import TOKEN, PageClient, page_socket

from nudgecli.errors import LockError
from nudgecli.live import records
from nudgecli.live.app import build_session
from nudgecli.live.server import FAILURE_KEY, STOPPED, SteppedClock, create_app
from nudgecli.locks import acquire_lock_file
from nudgecli.run_folder_names import LOCK, MANIFEST

#: How long the other process holds the folder's lock after the page's message arrives.
HELD_S = 2.0


def _familiarised(out: Path) -> bool:
    return bool(json.loads((out / MANIFEST).read_text())["live"]["1"]["familiarised"])


class OtherHolder:
    """The folder's lock held as another process holds it (its own open file, locked by the OS),
    released by :meth:`release` from another thread, as that process would release it."""

    def __init__(self, out: Path) -> None:
        self.path = out / LOCK
        self.handle = acquire_lock_file(self.path, "nudge analyze")
        self.released_at: float | None = None

    def release(self) -> None:
        self.path.unlink()
        self.handle.close()
        self.released_at = time.monotonic()


async def _skip_while_locked(out: Path, release_after: float | None) -> dict:
    """Open the participant's page, take the folder's lock as another process, send the page's
    ``skip`` (its record waits for the lock) and request the page and its script meanwhile."""
    session = build_session("paper", "P01", out, overrides=TWO_TRIALS + DEFAULT_TABLES)
    seen: dict = {}
    clock = SteppedClock(session.settings.dt)
    app = create_app(session, clock, token=TOKEN, log=lambda line: None)
    async with TestClient(TestServer(app)) as client:
        page = PageClient(await page_socket(client), clock)
        await page.receive_until(lambda m: m["type"] == "state")
        await page.send({"type": "start"})
        holder = OtherHolder(out)
        if release_after is not None:
            threading.Timer(release_after, holder.release).start()
        await page.ws.send_json({"type": "skip"})  # the end of the practice: recorded in the manifest
        await asyncio.sleep(0.2)  # the server has taken the message in and waits for the lock
        asked = time.monotonic()
        responses = [await client.get(f"/?token={TOKEN}"), await client.get("/static/app.js")]
        seen["answered"] = [response.status for response in responses]
        seen["answered in s"] = time.monotonic() - asked
        seen["answered while held"] = holder.released_at is None
        seen["recorded while held"] = _familiarised(out)
        if release_after is None:  # held throughout: the wait runs out and the page is told
            seen["page told"] = await page.receive_until(lambda m: m["type"] == "error")
            seen["failures"] = list(app[FAILURE_KEY])
            holder.release()
        else:
            await page.send()  # handled after the skip, in order
            seen["after"] = page.state["phase"], page.state["ready_for"]
            seen["recorded after the release"] = _familiarised(out) and holder.released_at is not None
    session.folder.release()
    return seen


def test_the_server_answers_while_another_process_holds_the_folder_lock(tmp_path):
    seen = asyncio.run(_skip_while_locked(tmp_path / "run", release_after=HELD_S))
    assert seen["answered"] == [200, 200]
    assert seen["answered while held"] and seen["answered in s"] < HELD_S
    assert not seen["recorded while held"]  # the skip's record was waiting for the lock
    # the waiting record goes on once the lock is released, and the messages after it in order
    assert seen["recorded after the release"]
    assert seen["after"] == ("ready", "evaluation")


def test_a_wait_that_runs_out_stops_the_server_with_the_lock_error(tmp_path, monkeypatch):
    monkeypatch.setattr(records, "folder_lock", functools.partial(records.folder_lock, wait_s=1.0))
    seen = asyncio.run(_skip_while_locked(tmp_path / "run", release_after=None))
    assert seen["answered"] == [200, 200] and seen["answered while held"]
    assert seen["page told"]["message"] == STOPPED and seen["page told"]["stopped"]
    [failure] = seen["failures"]
    assert isinstance(failure, LockError)
    assert str(failure).startswith(f"{tmp_path / 'run'}: in use by `nudge analyze` (pid ")
    assert not _familiarised(tmp_path / "run")
