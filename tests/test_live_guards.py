"""`nudge study`'s guards: the folder's locks and manifest, the port taken first, the page's token,
Host and Origin, the message schema, one controlling page, and the resume hint."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import socket
import subprocess
import sys

import pytest

pytest.importorskip("aiohttp", reason="the live server needs aiohttp: pip install '.[study]'")

from aiohttp import WSServerHandshakeError
from aiohttp.test_utils import TestClient, TestServer
from click.testing import CliRunner
from live_helpers import ANSWERS, DEFAULT_TABLES, TWO_TRIALS, free_port

from nudgecli.cli import main
from nudgecli.errors import LockError, RunFolderError
from nudgecli.live.app import build_session
from nudgecli.live.messages import check_message
from nudgecli.live.server import WATCHING, SteppedClock, create_app
from nudgecli.live.session import LiveSession
from nudgecli.model.interface import SOFT_PUFF, SOFT_SIP
from nudgecli.store import study_resume_command as resume_command

TOKEN = "guard-token"
OVERRIDES = TWO_TRIALS + DEFAULT_TABLES



def _to_trial(session: LiveSession) -> None:
    """Welcome -> skip the practice -> the next evaluation trial running."""
    for message in ({"type": "start"}, {"type": "skip"}, {"type": "start"}):
        session.handle(message, 0.0)
    if session.phase == "questionnaire":
        session.handle({"type": "questionnaire", "answers": ANSWERS}, 0.0)
        session.handle({"type": "start"}, 0.0)
    assert session.phase == "trial"


def _finish_trial(session: LiveSession) -> None:
    while session.phase == "trial":
        session.tick(0.0)  # no input: the trial runs to its time limit


def _manifest(folder) -> dict:
    return json.loads((folder / "manifest.json").read_text())


# --- 8a: the folder ------------------------------------------------------------------------------


def test_participants_finishing_trials_interleaved_keep_both_in_the_manifest(tmp_path):
    out = tmp_path / "run"
    p7 = build_session("paper", "P07", out, overrides=OVERRIDES)
    p8 = build_session("paper", "P08", out, overrides=OVERRIDES)
    _to_trial(p7)
    _to_trial(p8)
    _finish_trial(p7)
    _finish_trial(p8)  # P08's checkpoint must not drop P07's finished trial
    live = _manifest(out)["live"]
    assert live["7"]["completed_trials"] == [0] and live["8"]["completed_trials"] == [0]
    p7.handle({"type": "questionnaire", "answers": ANSWERS}, 0.0)
    p8.handle({"type": "questionnaire", "answers": ANSWERS}, 0.0)
    manifest = _manifest(out)
    assert [manifest["live"][k]["questionnaire_blocks"] for k in ("7", "8")] == [[0], [0]]
    assert set(manifest["timings_s"]) == {"7", "8"} and manifest["participants"] == 2
    # both finish, one after the other: the study is complete with both
    for session in (p7, p8):
        session.handle({"type": "start"}, 0.0)
        _finish_trial(session)
        session.handle({"type": "questionnaire", "answers": ANSWERS}, 0.0)
    manifest = _manifest(out)
    assert manifest["completed"] == [7, 8] and manifest["status"] == "complete"
    assert {k: e["completed_trials"] for k, e in manifest["live"].items()} == {"7": [0, 1], "8": [0, 1]}
    # P07 has nothing left to run: a resume is refused (no trial re-run, no data discarded, the
    # study stays complete)
    with pytest.raises(RunFolderError, match="P07's session is complete"):
        build_session("paper", "P07", out, overrides=OVERRIDES, resume=True)
    assert _manifest(out)["status"] == "complete"


def _start_server(out, participant: str, port: int) -> subprocess.Popen:
    sets = [arg for item in OVERRIDES for arg in ("--set", item)]
    return subprocess.Popen(
        [sys.executable, "-m", "nudgecli.cli", "study", "paper", "--participant", participant,
         "--port", str(port), "--out", str(out), *sets],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )


def test_a_second_server_for_a_served_participant_is_refused_and_ctrl_c_says_how_to_resume(tmp_path):
    out, port = tmp_path / "run", free_port()
    server = _start_server(out, "P07", port)
    try:
        address = server.stdout.readline().strip()
        assert address.startswith(f"http://127.0.0.1:{port}/?token="), server.stderr.read()
        # the same participant again, on another port (as `--resume` would be): one line, nothing changed
        before = (out / "manifest.json").read_text()
        second = subprocess.run(  # a subprocess with a timeout: a server that starts would serve forever
            [sys.executable, "-m", "nudgecli.cli", "study", "paper", "--participant", "P07", "--resume",
             "--port", str(free_port()), "--out", str(out), *[a for i in OVERRIDES for a in ("--set", i)]],
            capture_output=True, text=True, timeout=60,
        )
        assert second.returncode == 1 and second.stdout == "", (second.stdout, second.stderr)
        assert second.stderr.count("\n") == 1 and second.stderr.startswith("Error: "), second.stderr
        assert "P07 is already being served by" in second.stderr
        assert (out / "manifest.json").read_text() == before
        with pytest.raises(LockError, match="already being served"):
            build_session("paper", "P07", out, overrides=OVERRIDES, resume=True)
        # another participant joins the folder while P07 is served
        p8 = build_session("paper", "P08", out, overrides=OVERRIDES)
        assert p8.index == 8 and set(_manifest(out)["live"]) == {"7", "8"}
    finally:
        server.send_signal(signal.SIGINT)
        try:
            _, stderr = server.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            server.kill()
            raise
    # Ctrl-C: the hint is a command that works, with every --set value
    hint = next(line for line in stderr.splitlines() if "continue at the next trial" in line)
    for item in OVERRIDES:
        assert f"--set '{item}'" in hint or f"--set {item}" in hint
    assert "--resume" in hint and f"--out {out}" in hint
    # and it is accepted: the folder takes the same --set values back (the lock was released)
    resumed = build_session("paper", "P07", out, overrides=OVERRIDES, resume=True)
    assert resumed.index == 7


def test_the_resume_command_repeats_every_choice():
    command = resume_command("paper", "P03", "runs/x y", 9000, "control,disambiguation", 5,
                             ("study.time_limit_s=4", 'study.corners=["tr"]'))
    assert command == ("nudge study paper --participant P03 --out 'runs/x y' --port 9000 --condition-order "
                       "control,disambiguation --seed 5 --set study.time_limit_s=4 "
                       "--set 'study.corners=[\"tr\"]' --resume")


# --- 18: the port --------------------------------------------------------------------------------


def test_a_port_in_use_records_no_participant(tmp_path):
    out = tmp_path / "run"
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen(1)
        port = busy.getsockname()[1]
        result = CliRunner().invoke(main, ["study", "paper", "--participant", "P01", "--port", str(port),
                                           "--out", str(out), *[a for i in OVERRIDES for a in ("--set", i)]])
    assert result.exit_code == 1 and "cannot listen on 127.0.0.1" in result.output, result.output
    assert not out.exists()  # nothing recorded: the retry needs no --resume
    # and into a folder that already holds someone, the folder is unchanged
    build_session("paper", "P02", out, overrides=OVERRIDES)
    before = (out / "manifest.json").read_text()
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen(1)
        result = CliRunner().invoke(main, ["study", "paper", "--participant", "P01", "--port",
                                           str(busy.getsockname()[1]), "--out", str(out),
                                           *[a for i in OVERRIDES for a in ("--set", i)]])
    assert result.exit_code == 1 and (out / "manifest.json").read_text() == before


# --- 15: token, Host, Origin ---------------------------------------------------------------------


async def _guarded(session: LiveSession) -> dict:
    seen: dict = {}
    async with TestClient(TestServer(create_app(session, SteppedClock(0.1), token=TOKEN))) as client:
        own = f"127.0.0.1:{client.server.port}"
        for name, path, headers in (
            ("no token", "/", {}),
            ("bad token", "/?token=nope", {}),
            ("token", f"/?token={TOKEN}", {}),
            ("localhost", f"/?token={TOKEN}", {"Host": f"localhost:{client.server.port}"}),
            ("rebound host", f"/?token={TOKEN}", {"Host": f"attacker.example:{client.server.port}"}),
            ("other port", f"/?token={TOKEN}", {"Host": "127.0.0.1:1"}),
            ("static", "/static/app.js", {}),
            ("static rebound", "/static/app.js", {"Host": "attacker.example"}),
        ):
            async with client.get(path, headers=headers) as response:
                seen[name] = response.status
        for name, path, headers in (
            ("ws no token", "/ws", {"Origin": f"http://{own}"}),
            ("ws foreign origin", f"/ws?token={TOKEN}", {"Origin": "http://evil.example"}),
            ("ws no origin", f"/ws?token={TOKEN}", {}),
            ("ws rebound host", f"/ws?token={TOKEN}", {"Origin": "http://attacker.example:1",
                                                      "Host": "attacker.example:1"}),
        ):
            try:
                ws = await client.ws_connect(path, headers=headers)
            except WSServerHandshakeError as exc:
                seen[name] = exc.status
            else:
                seen[name] = 101
                await ws.close()
        ws = await client.ws_connect(f"/ws?token={TOKEN}", headers={"Origin": f"http://{own}"})
        seen["ws page"] = [(await ws.receive_json(timeout=5))["type"] for _ in range(2)]
        await ws.close()
    return seen


def test_only_the_page_with_the_token_on_its_own_host_and_origin_is_served(tmp_path):
    session = build_session("paper", "P01", tmp_path / "run", overrides=OVERRIDES)
    seen = asyncio.run(_guarded(session))
    assert seen == {
        "no token": 403, "bad token": 403, "token": 200, "localhost": 200, "rebound host": 403,
        "other port": 403, "static": 200, "static rebound": 403,
        "ws no token": 403, "ws foreign origin": 403, "ws no origin": 403, "ws rebound host": 403,
        "ws page": ["role", "state"],
    }
    assert session.phase == "welcome"  # no refused request reached the session


def test_each_server_start_has_its_own_token(tmp_path):
    from nudgecli.live.server import TOKEN_KEY

    session = build_session("paper", "P01", tmp_path / "run", overrides=OVERRIDES)
    tokens = {create_app(session)[TOKEN_KEY] for _ in range(3)}
    assert len(tokens) == 3 and all(len(t) >= 20 for t in tokens)


# --- 16: the schema ------------------------------------------------------------------------------

BAD_MESSAGES = (
    '{"type": "axis", "value": "abc"}',
    '{"type": "axis", "value": [[0.5]]}',
    '{"type": "axis", "value": 2}',
    '{"type": "axis", "value": NaN}',
    '{"type": "axis", "value": true}',
    '{"type": "axis", "value": 1' + "0" * 5000 + "}",
    '{"type": "key", "key": "3", "down": "false"}',
    '{"type": "key", "key": "3", "down": 0}',
    '{"type": "key", "key": ["3"], "down": true}',
    '{"type": "key", "key": "5", "down": true}',
    '{"type": "key", "key": "3"}',
    '{"type": "key", "key": "3", "down": true, "extra": 1}',
    '{"type": "disconnect"}',
    '{"type": "blur", "now": 1}',
    '{"type": ["key"]}',
    '{"type": "questionnaire", "answers": [1, 2]}',
    '{"type": "questionnaire", "answers": {"tlx_mental": [50]}}',
    '{"type": "questionnaire", "answers": {"likert_q3": true}}',
    "[1, 2]",
    '"key"',
    "not json",
    '{"type": "ping", "pad": "' + "x" * 20000 + '"}',
)


def test_the_schema_refuses_each_bad_message_and_takes_the_good_ones():
    from nudgecli.live.messages import MAX_MESSAGE_BYTES

    for text in BAD_MESSAGES:
        if len(text) > MAX_MESSAGE_BYTES or text == "not json":
            continue  # the server refuses these before the schema (tested over the socket)
        try:
            data = json.loads(text)
        except ValueError:
            continue
        assert check_message(data) is not None, text
    for good in (
        {"type": "key", "key": "3", "down": True},
        {"type": "key", "key": " ", "down": False},
        {"type": "axis", "value": -1},
        {"type": "axis", "value": 0.25},
        {"type": "axis", "value": None},
        {"type": "start"}, {"type": "skip"}, {"type": "blur"}, {"type": "ping"},
        {"type": "questionnaire", "answers": {**ANSWERS, "likert_q3": None}},
    ):
        assert check_message(good) is None, good


def test_bad_messages_mid_trial_get_an_error_and_change_nothing(tmp_path):
    """The replay of a recorded stream with a bad message before every human step is still exact."""
    import pandas as pd
    from test_live_server import _direct_steps, _play_trials, _streams

    session = build_session("paper", "P03", tmp_path / "run", overrides=OVERRIDES)
    streams = _streams(7, 2, 60)
    asyncio.run(_play_trials(session, streams, noise=list(BAD_MESSAGES)))
    steps = pd.read_parquet(tmp_path / "run" / "steps" / "part-0003.parquet")
    expected, _ = _direct_steps(session, streams)
    pd.testing.assert_frame_equal(steps, expected)
    assert _manifest(tmp_path / "run")["status"] == "complete"


# --- 17: one controlling page --------------------------------------------------------------------


async def _two_pages(session: LiveSession) -> dict:
    seen: dict = {}
    clock = SteppedClock(session.settings.dt)
    async with TestClient(TestServer(create_app(session, clock, token=TOKEN))) as client:
        own = {"Origin": f"http://127.0.0.1:{client.server.port}"}

        async def connect():
            ws = await client.ws_connect(f"/ws?token={TOKEN}", headers=own)
            role = await ws.receive_json(timeout=5)
            await ws.receive_json(timeout=5)  # the state
            return ws, role["role"]

        async def handled(ws) -> list[dict]:
            """Everything the server sent ``ws`` until its reply to a ping."""
            await ws.send_json({"type": "ping"})
            out = []
            while True:
                message = await ws.receive_json(timeout=5)
                if message["type"] == "pong":
                    return out
                out.append(message)

        controller, seen["first"] = await connect()
        watcher, seen["second"] = await connect()
        for message in ({"type": "start"}, {"type": "skip"}, {"type": "start"}):
            await controller.send_json(message)
        await handled(controller)
        seen["phase"] = session.phase
        await watcher.send_json({"type": "key", "key": "4", "down": True})
        await watcher.send_json({"type": "blur"})
        seen["watcher replies"] = [m.get("message") for m in await handled(watcher) if m["type"] == "error"]
        await controller.send_json({"type": "key", "key": "3", "down": True})
        await handled(controller)
        seen["held"] = list(session.input.held)
        await watcher.close()
        await handled(controller)
        seen["held after the watcher closed"] = list(session.input.held)
        third, seen["third"] = await connect()
        await controller.close()
        promoted = await third.receive_json(timeout=5)
        while promoted["type"] != "role":
            promoted = await third.receive_json(timeout=5)
        seen["promoted"] = promoted["role"]
        seen["held after the controller closed"] = list(session.input.held)
        seen["phase after the controller closed"] = session.phase
        await third.send_json({"type": "key", "key": "4", "down": True})
        await handled(third)
        seen["held by the new controller"] = list(session.input.held)
        await third.close()
    return seen


def test_one_page_controls_the_session_and_a_second_only_watches(tmp_path):
    session = build_session("paper", "P01", tmp_path / "run", overrides=OVERRIDES)
    seen = asyncio.run(_two_pages(session))
    assert seen["first"] == "controller" and seen["second"] == "watcher" and seen["third"] == "watcher"
    assert seen["phase"] == "trial"
    assert seen["watcher replies"] == [WATCHING, WATCHING]  # its key and its blur changed nothing
    assert seen["held"] == [SOFT_PUFF] == seen["held after the watcher closed"]
    assert seen["promoted"] == "controller" and seen["held after the controller closed"] == []
    assert seen["phase after the controller closed"] == "trial"  # a page is still there: the trial goes on
    assert seen["held by the new controller"] == [SOFT_SIP]  # key 4
