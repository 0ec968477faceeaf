"""`nudge study` without a browser: the websocket server replays a recorded input stream exactly,
and a session killed mid-trial resumes at that trial with the earlier trials intact."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("aiohttp", reason="the live server needs aiohttp: pip install '.[study]'")

from aiohttp.test_utils import TestClient, TestServer
from live_helpers import (
    ANSWERS,
    DEFAULT_TABLES,
    TWO_TRIALS,
    as_samples,
    free_port,
    recorded_stream,
    transition,
)

from nudgecli.live.app import build_session
from nudgecli.live.records import LiveFolder
from nudgecli.live.server import SteppedClock, create_app
from nudgecli.live.session import LiveSession, live_handover_idle_s
from nudgecli.model.disambiguation import DisambiguationModel
from nudgecli.model.interface import default_distortion_table, default_mapping_table
from nudgecli.report.analysis import analyze
from nudgecli.rng import generator
from nudgecli.run_folder_record import file_sha256
from nudgecli.sim.protocol import ProtocolSettings, TrialSession
from nudgecli.sim.study import StudyPlan, participant_schedule
from nudgecli.sim.trials import handover_steps
from nudgecli.steplog import HUMAN_TURN


class PageClient:
    """A scripted page on the websocket: sends events, follows the state."""

    def __init__(self, ws, clock: SteppedClock) -> None:
        self.ws, self.clock = ws, clock
        self.state: dict = {}
        self.ticks = 0

    async def receive_until(self, done) -> dict:
        while True:
            message = await self.ws.receive_json(timeout=20)
            if message["type"] == "state":
                self.state = message
            if done(message):
                return message

    async def send(self, *messages: dict) -> None:
        """Send and wait until the server has handled them (messages are handled in order)."""
        for message in messages:
            await self.ws.send_json(message)
        await self.ws.send_json({"type": "ping"})
        await self.receive_until(lambda m: m["type"] == "pong")

    async def tick(self) -> dict:
        self.clock.release()
        self.ticks += 1
        return await self.receive_until(lambda m: m["type"] == "state" and m["tick"] == self.ticks)


TOKEN = "test-token"


async def page_socket(client: TestClient, token: str = TOKEN, origin: str | None = None):
    """A websocket as the study page opens it: the session's token and the page's own Origin."""
    own = f"http://127.0.0.1:{client.server.port}"
    return await client.ws_connect(f"/ws?token={token}", headers={"Origin": origin or own})


async def _play_trials(
    session: LiveSession, streams: list[list], stop_in_trial: int | None = None, noise: list | None = None
) -> None:
    """Drive ``session`` through the server with a stepped clock: skip the practice, then play each
    evaluation trial with its recorded stream and answer each questionnaire. ``noise``: raw texts
    sent before each human step of the trials (each must get an error reply and change nothing)."""
    clock = SteppedClock(session.settings.dt)
    async with TestClient(TestServer(create_app(session, clock, token=TOKEN))) as client:
        page = PageClient(await page_socket(client), clock)
        page.ticks = (await page.receive_until(lambda m: m["type"] == "state"))["tick"]
        if page.state["phase"] == "welcome":
            await page.send({"type": "start"})
        if page.state["phase"] == "ready" and page.state["ready_for"] != "evaluation":
            await page.send({"type": "skip"})
        for number, stream in enumerate(streams):
            if page.state["phase"] == "questionnaire":
                await page.send({"type": "questionnaire", "answers": ANSWERS})
            assert page.state["phase"] == "ready" and page.state["ready_for"] == "evaluation"
            await page.send(
                {"type": "key", "key": " ", "down": True}, {"type": "key", "key": " ", "down": False}
            )
            current, k = ("none", 0), 0
            while page.state["phase"] == "trial":
                if number == stop_in_trial and k == 25:
                    return
                if page.state["trial"]["turn"] == HUMAN_TURN:
                    if noise:
                        await page.ws.send_str(noise[k % len(noise)])
                        reply = await page.receive_until(lambda m: m["type"] != "state")
                        assert reply["type"] == "error", reply
                    await page.send(*transition(current, stream[k]))
                    current, k = stream[k], k + 1
                await page.tick()
            await page.send(*transition(current, ("none", 0)))
        if page.state["phase"] == "questionnaire":
            await page.send({"type": "questionnaire", "answers": ANSWERS})


def _direct_steps(session: LiveSession, streams: list[list]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The same streams fed to the protocol directly, the trials built from the experiment alone."""
    config, seed, index = session.config, session.seed, session.index
    settings = ProtocolSettings.from_config(config)
    plan = StudyPlan.build(config, seed)
    handover = handover_steps(live_handover_idle_s(config), settings.dt)
    noise = config.model.default_table_noise
    steps, trials = [], []
    for spec, stream in zip(participant_schedule(config, seed, index, plan.layouts), streams, strict=True):
        model = DisambiguationModel(
            spec.layout.goal_cells,
            plan.solved[spec.layout_index].p_a_given_sg,
            default_mapping_table(noise),
            default_distortion_table(noise),
        )
        agent_rng = generator(seed, "participant", index, "trial", spec.trial).spawn(2)[1]
        trial = TrialSession(spec, settings, model, handover, agent_rng)
        samples = iter(as_samples(stream, config.interface))
        while not trial.finished:
            if trial.turn == HUMAN_TURN:
                trial.human_step(*next(samples))
            else:
                trial.autonomy_step()
        steps.append(pd.DataFrame(trial.columns))
        trials.append(trial.summary())
    return pd.concat(steps, ignore_index=True), pd.DataFrame(trials)


def _streams(seed: int, n_trials: int, length: int) -> list[list]:
    rng = np.random.default_rng(seed)
    return [recorded_stream(rng, length) for _ in range(n_trials)]


def test_server_replays_a_recorded_stream_exactly(tmp_path):
    session = build_session("paper", "P03", tmp_path / "run", overrides=TWO_TRIALS + DEFAULT_TABLES)
    assert len(session.schedule) == 2
    streams = _streams(7, 2, 60)
    asyncio.run(_play_trials(session, streams))
    steps = pd.read_parquet(tmp_path / "run" / "steps" / "part-0003.parquet")
    trials = pd.read_parquet(tmp_path / "run" / "trials" / "part-0003.parquet")
    expected_steps, expected_trials = _direct_steps(session, streams)
    # the stream exercised the protocol: keys, the axis, mode switches and the autonomy's turns
    assert (steps["turn"] == "autonomy").any() and steps["event"].str.contains("mode_switch_human").any()
    assert (steps["phi_i"] == "").any() and (steps["pressure"].abs() > 0).sum() > 20
    pd.testing.assert_frame_equal(steps, expected_steps)
    pd.testing.assert_frame_equal(trials, expected_trials)
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    assert (
        manifest["executor"] == "live" and manifest["completed"] == [3] and manifest["status"] == "complete"
    )
    assert manifest["live"]["3"]["completed_trials"] == [0, 1]
    assert manifest["live"]["3"]["questionnaire_blocks"] == [0, 1]
    questionnaires = pd.read_csv(tmp_path / "run" / "questionnaires.csv")
    assert list(questionnaires["block"]) == [0, 1]
    assert list(questionnaires["condition"]) == list(trials["condition"])  # one block per condition here
    assert (tmp_path / "run" / "participants" / "part-0003.parquet").is_file()
    result = analyze(tmp_path / "run", questionnaires=str(tmp_path / "run" / "questionnaires.csv"))
    assert len(pd.read_csv(result.out / "metrics.csv")) == 2
    assert {"completion_time", "tlx_raw", "likert_q3"} <= set(result.table["metric"])


class _CrashError(Exception):
    """The process dies here."""


def test_a_crash_between_writes_loses_only_the_running_trial(tmp_path, monkeypatch):
    out = tmp_path / "run"
    session = build_session("paper", "P01", out, overrides=TWO_TRIALS + DEFAULT_TABLES)
    streams = _streams(3, 2, 60)
    asyncio.run(_play_trials(session, streams, stop_in_trial=1))
    steps_part = out / "steps" / "part-0001.parquet"
    before = pd.read_parquet(steps_part)
    # a crash after trial 1's parts were renamed into place, before the manifest listed trial 1
    save = LiveFolder.save

    def crash(folder, participant, status_of_participant=None, add_seconds=0.0):
        if add_seconds:  # the checkpoint's last manifest update
            raise _CrashError
        save(folder, participant, status_of_participant, add_seconds)

    monkeypatch.setattr(LiveFolder, "save", crash)
    session.handle({"type": "start"}, 0.0)
    with pytest.raises(_CrashError):
        while True:
            session.tick(0.0)
    monkeypatch.undo()
    assert set(pd.read_parquet(steps_part)["trial"]) == {0, 1}
    resumed = build_session("paper", "P01", out, overrides=TWO_TRIALS + DEFAULT_TABLES, resume=True)
    assert resumed.next_trial is not None and resumed.next_trial.trial == 1
    pd.testing.assert_frame_equal(resumed.steps, before)
    # the parts are written again without trial 1's rows, and the manifest records them
    pd.testing.assert_frame_equal(pd.read_parquet(steps_part), before)
    sums = json.loads((out / "manifest.json").read_text())["checksums"]["1"]
    assert sums["steps"] == file_sha256(steps_part)
    assert sums["trials"] == file_sha256(out / "trials" / "part-0001.parquet")
    with pytest.raises(Exception, match="already recorded"):
        build_session("paper", "P01", out, overrides=TWO_TRIALS + DEFAULT_TABLES)
    with pytest.raises(Exception, match="another experiment"):
        build_session("paper", "P02", out, overrides=(*TWO_TRIALS, *DEFAULT_TABLES, "study.time_limit_s=5"))



async def _play_until_killed(port: int, process: subprocess.Popen) -> None:
    """Over the real server: finish trial 0 in real time, start trial 1, then SIGKILL the server."""
    import aiohttp

    address = process.stdout.readline().strip()  # printed once the server answers
    token = address.split("token=")[1]
    async with aiohttp.ClientSession() as http:
        for _ in range(100):
            try:
                ws = await http.ws_connect(
                    f"http://127.0.0.1:{port}/ws?token={token}", headers={"Origin": f"http://127.0.0.1:{port}"}
                )
                break
            except aiohttp.ClientError:
                await asyncio.sleep(0.1)
        else:
            raise AssertionError("the server did not come up")

        async def until(done):
            while True:
                message = await ws.receive_json(timeout=20)
                if message["type"] == "state" and done(message):
                    return message

        await until(lambda m: True)
        await ws.send_json({"type": "start"})
        await until(lambda m: m["phase"] == "ready")
        await ws.send_json({"type": "skip"})
        await until(lambda m: m["ready_for"] == "evaluation")
        await ws.send_json({"type": "start"})
        await ws.send_json({"type": "key", "key": "3", "down": True})  # hold a soft puff: keeps moving
        await until(lambda m: m["phase"] == "questionnaire")
        await ws.send_json({"type": "key", "key": "3", "down": False})
        await ws.send_json({"type": "questionnaire", "answers": ANSWERS})
        await until(lambda m: m["phase"] == "ready")
        await ws.send_json({"type": "start"})
        await until(lambda m: m["phase"] == "trial" and m["trial"]["step"] >= 5)
        process.send_signal(signal.SIGKILL)
        process.wait(timeout=10)


def test_a_killed_session_resumes_at_the_trial_it_was_in(tmp_path):
    out, port = tmp_path / "run", free_port()
    sets = [arg for item in (*TWO_TRIALS, *DEFAULT_TABLES, "study.time_limit_s=2") for arg in ("--set", item)]
    command = [
        sys.executable,
        "-m",
        "nudgecli.cli",
        "study",
        "paper",
        "--participant",
        "P02",
        "--port",
        str(port),
        "--out",
        str(out),
        *sets,
    ]
    process = subprocess.Popen(
        command,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        asyncio.run(_play_until_killed(port, process))
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == -signal.SIGKILL
    trials_before = pd.read_parquet(out / "trials" / "part-0002.parquet")
    steps_before = pd.read_parquet(out / "steps" / "part-0002.parquet")
    assert list(trials_before["trial"]) == [0] and set(steps_before["trial"]) == {0}
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["live"]["2"]["completed_trials"] == [0] and manifest["completed"] == []
    overrides = (*TWO_TRIALS, *DEFAULT_TABLES, "study.time_limit_s=2")
    resumed = build_session("paper", "P02", out, overrides=overrides, resume=True)
    assert resumed.next_trial is not None and resumed.next_trial.trial == 1
    asyncio.run(_play_trials(resumed, _streams(5, 1, 40)))
    trials = pd.read_parquet(out / "trials" / "part-0002.parquet")
    steps = pd.read_parquet(out / "steps" / "part-0002.parquet")
    assert list(trials["trial"]) == [0, 1]
    pd.testing.assert_frame_equal(trials.iloc[:1], trials_before)
    pd.testing.assert_frame_equal(steps[steps["trial"] == 0].reset_index(drop=True), steps_before)
    assert json.loads((out / "manifest.json").read_text())["status"] == "complete"


def test_a_closed_tab_abandons_the_running_trial_which_then_runs_again_from_its_start(tmp_path):
    session = build_session("paper", "P05", tmp_path / "run", overrides=TWO_TRIALS + DEFAULT_TABLES)
    streams = _streams(11, 2, 60)
    asyncio.run(_play_trials(session, streams, stop_in_trial=1))  # the page closes during trial 1
    assert session.phase == "ready" and session.next_trial is not None and session.next_trial.trial == 1
    asyncio.run(_play_trials(session, streams[1:]))  # a new page: trial 1 again, with its own stream
    steps = pd.read_parquet(tmp_path / "run" / "steps" / "part-0005.parquet")
    expected_steps, _ = _direct_steps(session, streams)
    pd.testing.assert_frame_equal(steps, expected_steps)
