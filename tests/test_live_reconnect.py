"""The study page for a real participant, at the websocket: a monitor page that never controls, a
token that survives ``--resume``, messages too large or too deep refused while the trial goes on,
a calibration clock that stops while the tab is closed, the console told when the participant
finishes, and what the page is told to show (keys in the task's words, trial numbers, the block
and condition of a questionnaire)."""

from __future__ import annotations

import asyncio
import stat

import pytest

pytest.importorskip("aiohttp", reason="the live server needs aiohttp: pip install '.[study]'")

from aiohttp import WSServerHandshakeError
from aiohttp.test_utils import TestClient, TestServer
from live_helpers import ANSWERS, DEFAULT_TABLES, TWO_TRIALS, play_session

from nudgecli.live.app import build_session
from nudgecli.live.input import key_meanings
from nudgecli.live.messages import MAX_MESSAGE_BYTES
from nudgecli.live.records import LiveFolder, participant_token_name
from nudgecli.live.server import MAX_FRAME_BYTES, MONITORING, WATCHING, SteppedClock, create_app
from nudgecli.live.session import LiveSession

TOKEN = "reconnect-token"
OVERRIDES = TWO_TRIALS + DEFAULT_TABLES


class Page:
    """A page's websocket: follows the state, and waits for the server to handle what it sent."""

    def __init__(self, ws) -> None:
        self.ws = ws
        self.role: str | None = None
        self.state: dict = {}
        self.errors: list[str] = []

    async def read_until(self, done) -> dict:
        while True:
            message = await self.ws.receive_json(timeout=10)
            if message["type"] == "state":
                self.state = message
            elif message["type"] == "role":
                self.role = message["role"]
            elif message["type"] == "error":
                self.errors.append(message["message"])
            if done(message):
                return message

    async def send(self, *messages: dict | str) -> None:
        for message in messages:
            await (self.ws.send_str(message) if isinstance(message, str) else self.ws.send_json(message))
        await self.ws.send_json({"type": "ping"})
        await self.read_until(lambda m: m["type"] == "pong")


async def _open(client: TestClient, role: str | None = None) -> Page:
    query = f"/ws?token={TOKEN}" + (f"&role={role}" if role else "")
    ws = await client.ws_connect(query, headers={"Origin": f"http://127.0.0.1:{client.server.port}"})
    page = Page(ws)
    await page.read_until(lambda m: m["type"] == "state")
    return page


async def _tick(page: Page, clock: SteppedClock, session: LiveSession, n: int = 1) -> None:
    """``n`` protocol steps with a participant's page open (each sends every page the state)."""
    for _ in range(n):
        wanted = session.tick_count + 1
        clock.release()
        await page.read_until(lambda m, wanted=wanted: m["type"] == "state" and m["tick"] >= wanted)


# --- a monitor page never controls -------------------------------------------------------------


async def _monitor_and_participant(session: LiveSession) -> dict:
    seen: dict = {}
    clock = SteppedClock(session.settings.dt)
    async with TestClient(TestServer(create_app(session, clock, token=TOKEN))) as client:
        # the monitor opens first: it is told it monitors, and its clicks and keys are refused
        monitor = await _open(client, "monitor")
        seen["monitor"] = monitor.role
        await monitor.send({"type": "start"}, {"type": "key", "key": "3", "down": True})
        seen["monitor's input"] = monitor.errors[:]
        clock.release(5)  # steps with only a monitor open: the session does not move
        await monitor.send({"type": "ping"})
        seen["ticks with only a monitor"] = session.tick_count
        participant = await _open(client)
        seen["participant"] = participant.role
        await participant.send({"type": "start"}, {"type": "skip"}, {"type": "start"})
        seen["phase"] = session.phase
        await participant.send({"type": "key", "key": "3", "down": True})
        # the participant's tab closes and opens again; the monitor stays a monitor throughout
        while monitor.state["phase"] != "trial":
            await monitor.read_until(lambda m: m["type"] == "state")
        await participant.ws.close()
        await monitor.send({"type": "key", "key": "4", "down": True})
        seen["monitor after the participant closed"] = (monitor.role, monitor.errors[-1])
        seen["phase with only a monitor"] = session.phase  # the trial was abandoned: no participant
        while monitor.state["phase"] != "ready":  # and the monitor is shown so
            await monitor.read_until(lambda m: m["type"] == "state")
        seen["held with only a monitor"] = list(session.input.held)
        reopened = await _open(client)
        seen["reopened"] = reopened.role
        await reopened.send({"type": "start"}, {"type": "key", "key": "4", "down": True})
        seen["held by the reopened tab"] = list(session.input.held)
        await monitor.send({"type": "blur"})
        seen["held after the monitor's blur"] = list(session.input.held)
        await _tick(reopened, clock, session)
        ticked = session.tick_count
        await monitor.read_until(lambda m: m["type"] == "state" and m["tick"] == ticked)
        seen["monitor's state follows"] = monitor.state["phase"], monitor.state["tick"]
        second = await _open(client)  # the participant's address opened twice: the second watches
        await second.send({"type": "key", "key": "3", "down": True})
        seen["second tab"] = (second.role, second.errors[-1])
        for page in (monitor, reopened, second):
            await page.ws.close()
        try:
            await client.ws_connect(f"/ws?token={TOKEN}&role=controller",
                                    headers={"Origin": f"http://127.0.0.1:{client.server.port}"})
        except WSServerHandshakeError as exc:
            seen["role=controller"] = exc.status
    return seen


def test_a_monitor_page_never_controls_and_the_participants_tab_does_when_it_reopens(tmp_path):
    session = build_session("paper", "P01", tmp_path / "run", overrides=OVERRIDES)
    seen = asyncio.run(_monitor_and_participant(session))
    assert seen["monitor"] == "monitor" and seen["monitor's input"] == [MONITORING, MONITORING]
    assert seen["ticks with only a monitor"] == 0
    assert seen["participant"] == "controller" and seen["phase"] == "trial"
    assert seen["monitor after the participant closed"] == ("monitor", MONITORING)
    assert seen["phase with only a monitor"] == "ready" and seen["held with only a monitor"] == []
    assert seen["reopened"] == "controller" and seen["held by the reopened tab"] == [3]  # key 4, Soft Sip
    assert seen["held after the monitor's blur"] == [3]
    assert seen["monitor's state follows"] == ("trial", session.tick_count)
    assert seen["second tab"] == ("watcher", WATCHING)
    assert seen["role=controller"] == 400


# --- the token survives a restart -------------------------------------------------------------


def test_resume_serves_the_token_of_the_last_start_and_a_new_participant_gets_a_new_one(tmp_path):
    folder = LiveFolder(tmp_path / "run")
    (tmp_path / "run").mkdir()
    first = folder.page_token(1, resume=False)
    path = tmp_path / "run" / participant_token_name(1)
    assert stat.S_IMODE(path.stat().st_mode) == 0o600  # the owner's alone
    assert folder.page_token(1, resume=True) == first == folder.page_token(1, resume=True)
    assert folder.page_token(2, resume=False) != first  # another participant, another token
    again = folder.page_token(1, resume=False)  # a new start of the participant: a new token
    assert again != first and len(again) >= 22 and folder.page_token(1, resume=True) == again
    for damaged in ("", "short", "has spaces in it, twenty-two+", "é" * 30):
        path.write_text(damaged)  # an edited file is not a token: a new random one replaces it
        token = folder.page_token(1, resume=True)
        assert token not in (damaged, again) and len(token) >= 22
        assert folder.page_token(1, resume=True) == token
    folder.forget_page_token(1)
    assert not path.exists()


def test_the_token_file_goes_when_the_participant_is_complete(tmp_path):
    session = build_session("paper", "P01", tmp_path / "run", overrides=OVERRIDES)
    token = session.folder.page_token(session.index, resume=False)
    path = tmp_path / "run" / participant_token_name(1)
    assert path.read_text().strip() == token
    _run_to_the_end(session)
    assert session.phase == "done" and not path.exists()


def _run_to_the_end(session: LiveSession) -> None:
    play_session(session, lambda s: False)


# --- messages too large or too deep ------------------------------------------------------------


async def _hostile_messages(session: LiveSession, log: list[str]) -> dict:
    seen: dict = {}
    clock = SteppedClock(session.settings.dt)
    async with TestClient(TestServer(create_app(session, clock, token=TOKEN, log=log.append))) as client:
        page = await _open(client)
        await page.send({"type": "start"}, {"type": "skip"}, {"type": "start"},
                        {"type": "key", "key": "3", "down": True})
        await _tick(page, clock, session, 3)
        step = session.trial.session.step
        nested = "[" * MAX_MESSAGE_BYTES  # 16 KB of '[': within the size limit, too deep to parse
        await page.send(nested)
        seen["nested"] = page.errors[-1]
        for size in (5 * 1024 * 1024, 10 * 1024 * 1024):  # read (under aiohttp's limit), then refused
            await page.send('{"type": "ping", "pad": "' + "x" * size + '"}')
            seen[size] = page.errors[-1]
        await _tick(page, clock, session, 2)
        seen["steps after"] = session.trial.session.step - step
        seen["phase"], seen["held"] = session.phase, list(session.input.held)
        seen["open"] = not page.ws.closed
        await page.ws.close()
    return seen


def test_a_deeply_nested_or_huge_message_is_refused_and_the_trial_goes_on(tmp_path):
    session = build_session("paper", "P01", tmp_path / "run", overrides=OVERRIDES)
    log: list[str] = []
    seen = asyncio.run(_hostile_messages(session, log))
    assert seen["nested"] == "not a message: JSON nested too deeply"
    five, ten = 5 * 1024 * 1024 + 27, 10 * 1024 * 1024 + 27  # the pad and the message around it
    assert seen[5 * 1024 * 1024] == f"message of {five} bytes; at most {MAX_MESSAGE_BYTES}"
    assert seen[10 * 1024 * 1024].startswith(f"message of {ten} bytes")
    assert ten < MAX_FRAME_BYTES
    assert seen["open"] and seen["phase"] == "trial" and seen["held"] == [2]  # key 3, Soft Puff
    assert seen["steps after"] == 2  # the running trial went on stepping
    assert len(log) == 3 and all(line.startswith("refused a message from a participant page") for line in log)
    assert "nested too deeply" in log[0] and "\n" not in "".join(log)


# --- the calibration clock stops while the tab is closed ---------------------------------------


async def _prompt_across_a_closed_tab(session: LiveSession) -> dict:
    seen: dict = {}
    clock = SteppedClock(session.settings.dt)
    async with TestClient(TestServer(create_app(session, clock, token=TOKEN))) as client:
        page = await _open(client)
        await page.send({"type": "start"})
        recorder = session.mapping_recorder
        assert session.phase == "mapping" and recorder is not None
        while recorder.prompt is None:
            await _tick(page, clock, session)
        seen["prompt"], shown_at = recorder.prompt, recorder.shown_at
        await _tick(page, clock, session, 5)  # half a second of the prompt, then the tab closes
        await page.ws.close()
        await asyncio.sleep(0.05)
        clock.release(round(3 * session.config.calibration.answer_timeout_s / session.settings.dt))
        await asyncio.sleep(0.05)
        page = await _open(client)  # the tab again, three timeouts later
        await _tick(page, clock, session, 2)
        seen["prompt after"] = recorder.prompt
        await page.send({"type": "key", "key": "1", "down": True}, {"type": "key", "key": "1", "down": False})
        seen["answered after"] = recorder.response_times[-1] - shown_at if recorder.response_times else None
        seen["missed"] = recorder.commands.count("") - len(recorder.response_times)
        await page.ws.close()
    return seen


def test_a_calibration_prompt_keeps_its_time_while_the_tab_is_closed(tmp_path):
    session = build_session("paper", "P01", tmp_path / "run", overrides=TWO_TRIALS)
    seen = asyncio.run(_prompt_across_a_closed_tab(session))
    assert seen["prompt after"] == seen["prompt"]  # still shown, not cleared as missed
    # answered 0.5 s + 2 steps after it showed, on the session's clock (the closed span left out)
    assert seen["answered after"] == pytest.approx(0.7)
    assert seen["missed"] <= 0


# --- the console and the page's words ----------------------------------------------------------


async def _last_questionnaire(session: LiveSession, log: list[str]) -> None:
    clock = SteppedClock(session.settings.dt)
    async with TestClient(TestServer(create_app(session, clock, token=TOKEN, log=log.append))) as client:
        page = await _open(client)
        await page.send({"type": "questionnaire", "answers": ANSWERS})
        await page.send({"type": "start"}, {"type": "key", "key": " ", "down": True})  # said once only
        await _tick(page, clock, session, 2)
        await page.ws.close()


def test_the_console_says_once_when_the_participant_has_finished(tmp_path):
    session = build_session("paper", "P07", tmp_path / "run", overrides=OVERRIDES)
    play_session(session, lambda s: s.phase == "questionnaire" and s.next_trial is None)
    log: list[str] = []
    asyncio.run(_last_questionnaire(session, log))
    assert session.phase == "done"
    assert log == [
        f"participant P07 finished: 2 of 2 trials and the questionnaires recorded in {session.folder.path}; "
        "Ctrl-C ends the server"
    ]


def test_the_keys_are_explained_in_the_words_of_the_interfaces_rules():
    """By hand from DESIGN.md 2.2 and the paper: a hard puff cycles the mode x -> y -> theta, a hard
    sip back; a soft puff moves +x, +y or turns clockwise; a soft sip the opposite way."""
    assert key_meanings() == {
        "1": {"label": "Hard Puff", "does": "switch the mode forward (x \u2192 y \u2192 \u03b8 \u2192 x)"},
        "2": {"label": "Hard Sip", "does": "switch the mode backward (x \u2192 \u03b8 \u2192 y \u2192 x)"},
        "3": {"label": "Soft Puff",
              "does": "move right in the x mode, move up in the y mode, turn clockwise in the \u03b8 mode"},
        "4": {"label": "Soft Sip",
              "does": "move left in the x mode, move down in the y mode, "
                      "turn counterclockwise in the \u03b8 mode"},
    }


def test_the_page_is_told_which_trial_was_abandoned_and_which_block_a_questionnaire_is_about(tmp_path):
    session = build_session("paper", "P01", tmp_path / "run", overrides=OVERRIDES)
    assert session.view()["keys"] == key_meanings()
    for message in ({"type": "start"}, {"type": "skip"}, {"type": "start"}):
        session.handle(message, 0.0)
    session.handle({"type": "disconnect"}, 0.0)  # the tab closes during the first trial
    outcome = session.view()["last_outcome"]
    assert outcome == {"kind": "evaluation", "number": 1, "abandoned": True}  # trial 1, not "Trial 0"
    session.handle({"type": "start"}, 0.0)
    while session.phase == "trial":
        session.tick(0.0)
    view = session.view()
    assert view["last_outcome"]["number"] == 1 and view["phase"] == "questionnaire"
    first, second = session.schedule[0], session.schedule[1]
    assert first.block != second.block and first.condition != second.condition
    assert {k: view["questionnaire"][k] for k in ("block", "block_number", "blocks", "condition")} == {
        "block": first.block, "block_number": 1, "blocks": 2, "condition": first.condition,
    }
    session.handle({"type": "questionnaire", "answers": ANSWERS}, 0.0)
    session.handle({"type": "start"}, 0.0)
    session.handle({"type": "disconnect"}, 0.0)
    assert session.view()["last_outcome"] == {"kind": "evaluation", "number": 2, "abandoned": True}
    session.handle({"type": "start"}, 0.0)
    while session.phase == "trial":
        session.tick(0.0)
    assert session.view()["questionnaire"]["block_number"] == 2
    assert session.view()["questionnaire"]["condition"] == second.condition
