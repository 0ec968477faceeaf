"""A live folder's records damaged or not writable: one error line naming the file, nothing of the
person's lost (a trial or an answer cannot be asked again), and the server stops at once, telling
the page, rather than freezing."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest

pytest.importorskip("aiohttp", reason="the live server needs aiohttp: pip install '.[study]'")

from aiohttp.test_utils import TestClient, TestServer
from live_helpers import ANSWERS, DEFAULT_TABLES, TWO_TRIALS, free_port, play_session

from nudgecli.errors import DataError, NudgeError
from nudgecli.live.app import build_session
from nudgecli.live.records import unsaved_answers_name
from nudgecli.live.server import FAILURE_KEY, STOPPED, SteppedClock, create_app
from nudgecli.live.session import LiveSession
from nudgecli.report.questionnaires import read_questionnaires

TOKEN = "damage-token"
OVERRIDES = TWO_TRIALS + DEFAULT_TABLES


def _manifest(folder: Path) -> dict:
    return json.loads((folder / "manifest.json").read_text())


def _at_second_questionnaire(out: Path) -> LiveSession:
    """P02's session with block 0's answers recorded, waiting for block 1's questionnaire."""
    session = build_session("paper", "P02", out, overrides=OVERRIDES)
    play_session(session, lambda s: s.phase == "questionnaire" and len(s.entry["questionnaire_blocks"]) == 1)
    assert session.phase == "questionnaire"
    return session


def _resume(out: Path) -> LiveSession:
    return build_session("paper", "P02", out, resume=True, overrides=OVERRIDES)


class Page:
    """A participant's page on the websocket: its error messages, and whether it was closed."""

    def __init__(self, ws) -> None:
        self.ws = ws
        self.errors: list[dict] = []

    async def read_until(self, done) -> dict | None:
        while True:
            message = await self.ws.receive(timeout=10)
            if message.type.name != "TEXT":
                return None  # closed by the server
            data = json.loads(message.data)
            if data["type"] == "error":
                self.errors.append(data)
            if done(data):
                return data


async def _serve(session: LiveSession, script) -> tuple[list[Exception], list[str], Page]:
    """Serve ``session`` with a stepped clock, open a participant's page and run ``script(page,
    clock)``; the failures that stopped the server, the times it was told to stop, the page."""
    clock = SteppedClock(session.settings.dt)
    stops: list[str] = []
    app = create_app(session, clock, token=TOKEN, log=lambda line: None, stop=lambda: stops.append("stop"))
    async with TestClient(TestServer(app)) as client:
        ws = await client.ws_connect(f"/ws?token={TOKEN}",
                                     headers={"Origin": f"http://127.0.0.1:{client.server.port}"})
        page = Page(ws)
        await page.read_until(lambda m: m["type"] == "state")
        await script(page, clock)
        failures = list(app[FAILURE_KEY])
    return failures, stops, page


# --- 1: questionnaires.csv ---------------------------------------------------------------------------


@pytest.mark.parametrize("damage, words", [
    (lambda text: text.replace(",", ";"), "not the comma-separated table nudge study writes"),
    (lambda text: "", "is empty"),
    (lambda text: text.splitlines()[0] + "\n2,disambiguation,0,50.0,40", "looks cut off"),
])
def test_a_damaged_answers_file_is_refused_when_the_session_resumes(tmp_path, damage, words):
    out = tmp_path / "live2"
    _at_second_questionnaire(out).folder.release()
    path = out / "questionnaires.csv"
    path.write_text(damage(path.read_text()))
    before, manifest = path.read_bytes(), _manifest(out)
    with pytest.raises(DataError) as refused:
        _resume(out)
    message = str(refused.value)
    assert str(path) in message and words in message and "\n" not in message
    assert path.read_bytes() == before and _manifest(out) == manifest


async def _answer(page: Page, clock: SteppedClock) -> None:
    await page.ws.send_json({"type": "questionnaire", "answers": ANSWERS})
    await page.read_until(lambda m: False)  # until the server closes the page


def test_answers_that_cannot_be_written_are_kept_and_taken_in_by_the_resume(tmp_path):
    out = tmp_path / "live2"
    session = _at_second_questionnaire(out)
    path = out / "questionnaires.csv"
    good = path.read_text()
    path.write_text(good.replace(",", ";"))  # a spreadsheet re-saved it during the session
    failures, stops, page = asyncio.run(_serve(session, _answer))
    assert stops == ["stop"] and [e["message"] for e in page.errors] == [STOPPED]
    side = out / unsaved_answers_name(2)
    assert len(failures) == 1 and isinstance(failures[0], NudgeError)
    assert str(path) in str(failures[0]) and f"kept in {side}" in str(failures[0])
    kept = read_questionnaires(side)
    assert kept[["participant", "block"]].astype(str).values.tolist() == [["2", "1"]]
    assert kept["likert_q3"].tolist() == [ANSWERS["likert_q3"]]
    session.folder.release()

    path.write_text(good)  # restored from a backup
    resumed = _resume(out)
    table = read_questionnaires(path)
    assert table[["participant", "block"]].astype(str).values.tolist() == [["2", "0"], ["2", "1"]]
    assert resumed.entry["questionnaire_blocks"] == [0, 1] and not side.exists()
    assert _manifest(out)["live"]["2"]["questionnaire_blocks"] == [0, 1]
    resumed.folder.release()


# --- 2: a checkpoint that cannot be written ------------------------------------------------------------


async def _trial_until_stopped(page: Page, clock: SteppedClock) -> None:
    for message in ({"type": "start"}, {"type": "skip"}, {"type": "start"}):
        await page.ws.send_json(message)
    for _ in range(1000):  # the trial runs to its time limit, then its checkpoint fails
        clock.release()
        if await page.read_until(lambda m: m["type"] == "state") is None:
            break


def test_a_checkpoint_that_cannot_be_written_stops_the_server_and_tells_the_page(tmp_path, monkeypatch):
    import pandas as pd

    def full_disk(frame, path, **options):
        raise OSError(28, "No space left on device")

    session = build_session("paper", "P02", tmp_path / "live2", overrides=OVERRIDES)
    monkeypatch.setattr(pd.DataFrame, "to_parquet", full_disk)
    failures, stops, page = asyncio.run(_serve(session, _trial_until_stopped))
    assert stops == ["stop"] and [e["message"] for e in page.errors] == [STOPPED]
    assert len(failures) == 1 and isinstance(failures[0], NudgeError)
    assert "steps/part-0002.parquet" in str(failures[0]) and "No space left on device" in str(failures[0])
    session.folder.release()


def test_the_study_command_stops_at_once_with_one_error_line_and_the_resume_command(tmp_path):
    """Over the real server: the manifest overwritten during a trial (its checkpoint cannot be
    written) ends the command with one Error line and the resume command, exit 1."""
    import os
    import signal
    import subprocess
    import sys

    out, port = tmp_path / "live2", free_port()
    sets = [arg for item in (*OVERRIDES, "study.time_limit_s=1") for arg in ("--set", item)]
    process = subprocess.Popen(
        [sys.executable, "-m", "nudgecli.cli", "study", "paper", "--participant", "P02", "--port", str(port),
         "--out", str(out), *sets],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        told = asyncio.run(asyncio.wait_for(_trial_with_a_damaged_manifest(port, process, out), 60))
        _, stderr = process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.send_signal(signal.SIGKILL)
            process.wait()
    assert told == STOPPED
    errors = [line for line in stderr.splitlines() if line.startswith("Error:")]
    assert process.returncode == 1 and len(errors) == 1 and "Traceback" not in stderr
    assert "manifest.json" in errors[0] and "--participant P02" in errors[0]
    assert errors[0].endswith("--resume")


async def _trial_with_a_damaged_manifest(port: int, process, out: Path) -> str:
    import aiohttp

    address = process.stdout.readline().strip()
    token = address.split("token=")[1]
    async with aiohttp.ClientSession() as http:
        ws = await http.ws_connect(f"http://127.0.0.1:{port}/ws?token={token}",
                                   headers={"Origin": f"http://127.0.0.1:{port}"})
        for message in ({"type": "start"}, {"type": "skip"}, {"type": "start"}):
            await ws.send_json(message)
        damaged = False
        while True:
            message = await ws.receive(timeout=20)
            if message.type.name != "TEXT":
                return ""
            data = json.loads(message.data)
            if data["type"] == "state" and data["phase"] == "trial" and not damaged:
                (out / "manifest.json").write_text('{"oops')  # overwritten during the trial
                damaged = True
            if data["type"] == "error":
                return data["message"]


# --- 3: a finished participant ------------------------------------------------------------------------


def _fingerprint(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("resume", [True, False])
def test_a_finished_participant_is_not_opened_again(tmp_path, resume):
    out = tmp_path / "live2"
    session = build_session("paper", "P02", out, overrides=OVERRIDES)
    play_session(session, lambda s: False)
    assert session.phase == "done"
    session.folder.release()
    before = _fingerprint(out)
    with pytest.raises(NudgeError, match="P02's session is complete") as refused:
        build_session("paper", "P02", out, resume=resume, overrides=OVERRIDES)
    assert "\n" not in str(refused.value)
    assert _fingerprint(out) == before and _manifest(out)["status"] == "complete"


# --- 4: the parts' checksums ----------------------------------------------------------------------------


def test_the_manifest_records_each_parts_sha256_as_simulate_does(tmp_path):
    from nudgecli.run_folder_names import PART_KINDS
    from nudgecli.run_folder_record import file_sha256

    out = tmp_path / "live2"
    session = build_session("paper", "P02", out, overrides=OVERRIDES)
    play_session(session, lambda s: False)
    session.folder.release()
    assert _manifest(out)["checksums"] == {
        "2": {kind: file_sha256(out / kind / "part-0002.parquet") for kind in PART_KINDS}
    }


def _edit_manifest(out: Path, edit) -> None:
    manifest = _manifest(out)
    edit(manifest)
    (out / "manifest.json").write_text(json.dumps(manifest, indent=2))


def _flip_success(out: Path) -> None:
    import pandas as pd

    part = out / "trials" / "part-0002.parquet"
    table = pd.read_parquet(part)
    table.loc[0, "success"] = not table.loc[0, "success"]
    table.to_parquet(part, index=False)


def _truncate_without_record(out: Path) -> None:
    _edit_manifest(out, lambda manifest: manifest.pop("checksums"))  # a folder of an older nudge
    part = out / "steps" / "part-0002.parquet"
    part.write_bytes(part.read_bytes()[:200])


@pytest.mark.parametrize("damage, words", [
    (_flip_success, "trials/part-0002.parquet changed since it was written"),
    (lambda out: (out / "steps" / "part-0002.parquet").unlink(),
     "steps/part-0002.parquet is missing, but the manifest records 2 trial(s) of participant P02"),
    (lambda out: _edit_manifest(out, lambda m: m["live"]["2"]["completed_trials"].append(5)),
     "trials/part-0002.parquet holds no rows of trial(s) 5, which the manifest lists as completed"),
    (lambda out: (out / "questionnaires.csv").unlink(),
     "questionnaires.csv is missing, but the manifest records the answers of participant P02 to block(s) 0"),
    (_truncate_without_record, "steps/part-0002.parquet is not a readable part of a live session"),
])
def test_a_resume_refuses_records_that_do_not_match_the_manifest(tmp_path, damage, words):
    out = tmp_path / "live2"
    _at_second_questionnaire(out).folder.release()
    damage(out)
    before = _fingerprint(out)
    with pytest.raises(NudgeError) as refused:
        _resume(out)
    message = str(refused.value)
    assert words in message and "restore it from a backup" in message and "\n" not in message, message
    assert _fingerprint(out) == before


# --- 5: a resume with other settings --------------------------------------------------------------------


def _stopped_after_first_trial(out: Path) -> None:
    session = build_session("paper", "P02", out, overrides=OVERRIDES)
    play_session(session, lambda s: len(s.entry["completed_trials"]) == 1)
    session.folder.release()


@pytest.mark.parametrize("options, named", [
    ({"overrides": (*OVERRIDES, "study.time_limit_s=5")}, "study.time_limit_s: 4.0 in the manifest, 5.0 now"),
    ({"overrides": OVERRIDES, "seed": 12}, "seed: 2022 in the manifest, 12 now"),
])
def test_a_resume_with_other_settings_names_them_and_the_command_that_continues(tmp_path, options, named):
    from nudgecli.store import study_resume_command

    out = tmp_path / "live2"
    _stopped_after_first_trial(out)
    before = _fingerprint(out)
    with pytest.raises(NudgeError) as refused:
        build_session("paper", "P02", out, resume=True, **options)
    message = str(refused.value)
    command = study_resume_command(str(out / "config.toml"), "P02", out)
    assert named in message and f"`{command}`" in message and "\n" not in message, message
    assert _fingerprint(out) == before
    resumed = build_session(str(out / "config.toml"), "P02", out, resume=True)  # the advice works
    assert resumed.entry["completed_trials"] == [0]
    resumed.folder.release()


def test_a_deleted_config_toml_is_written_again_and_an_edited_one_is_named(tmp_path, capsys):
    out = tmp_path / "live2"
    _stopped_after_first_trial(out)
    config = out / "config.toml"
    text = config.read_text()
    config.unlink()
    _resume(out).folder.release()  # the original command still continues the session
    assert config.read_text() == text and "was missing" in capsys.readouterr().err
    config.write_text(text.replace("time_limit_s = 4.0", "time_limit_s = 6.0"))
    with pytest.raises(NudgeError) as refused:
        build_session(str(config), "P02", out, resume=True)
    message = str(refused.value)
    assert "study.time_limit_s: 4.0 in the manifest, 6.0 now" in message, message
    assert f"{config} was edited" in message, message


# --- 6: an experiment of another world ------------------------------------------------------------------


def test_an_experiment_of_another_world_is_refused_before_anything_is_recorded(tmp_path):
    from click.testing import CliRunner

    from nudgecli.cli import main

    out = tmp_path / "live_ciaa"
    result = CliRunner().invoke(main, ["study", "ciaa-teleop", "--participant", "P01", "--out", str(out),
                                       "--port", str(free_port()), "--set", "model.tables=default"])
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert result.exit_code == 1 and len(errors) == 1, result.output
    assert "runs only the grid world's experiments" in errors[0] and "ciaa" in errors[0], errors[0]
    assert not out.exists()


# --- 7: answers of unknown names ----------------------------------------------------------------------


def test_answers_of_unknown_names_are_refused_naming_them(tmp_path):
    session = _at_second_questionnaire(tmp_path / "live2")
    before = (tmp_path / "live2" / "questionnaires.csv").read_bytes()
    for extra, named in (({"likert_q11": 4}, "'likert_q11'"),
                         ({"tlx_mentl": 30}, "'tlx_mentl' (did you mean 'tlx_mental'?)")):
        reply = session.handle({"type": "questionnaire", "answers": {**ANSWERS, **extra}}, 0.0)
        assert reply is not None and reply["type"] == "error", reply
        assert f"unknown answer(s) {named}" in reply["message"], reply
    assert session.phase == "questionnaire" and session.entry["questionnaire_blocks"] == [0]
    assert (tmp_path / "live2" / "questionnaires.csv").read_bytes() == before
    session.folder.release()
