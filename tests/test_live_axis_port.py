"""A live session's gamepad axis ends with the page's keys (blur, a closed page, a trial's start), and
the commands that continue a session name the port its open tab reconnects on."""

from __future__ import annotations

import json

import pytest
from live_helpers import DEFAULT_TABLES, TWO_TRIALS, free_port

from nudgecli.command_defaults import STUDY_PORT
from nudgecli.config import load_experiment
from nudgecli.errors import NudgeError
from nudgecli.live.app import build_session, run_live_study
from nudgecli.live.input import LiveInput
from nudgecli.model.interface import NO_INPUT
from nudgecli.run_folder_record import RunRecord

OVERRIDES = TWO_TRIALS + DEFAULT_TABLES


def test_releasing_the_keys_also_ends_a_gamepad_blow():
    source = LiveInput.from_interface(load_experiment("paper").interface)
    source.axis(-0.3)
    assert source.sample() == (NO_INPUT, -0.3)
    source.release_all()  # blur, a closed page, a trial's start: the page may never say the blow ended
    assert source.axis_value is None and source.sample() == (NO_INPUT, 0.0)


def test_a_blurred_page_and_a_new_trial_record_no_puff_left_from_the_axis(tmp_path):
    session = build_session("paper", "P01", tmp_path / "run", overrides=OVERRIDES)
    try:
        for message in ({"type": "start"}, {"type": "skip"}):
            session.handle(message, 0.0)
        session.handle({"type": "axis", "value": -0.3}, 0.0)  # held on the ready screen...
        session.handle({"type": "start"}, 0.0)  # ...the trial starts without it
        assert session.phase == "trial" and session.input.sample() == (NO_INPUT, 0.0)
        session.handle({"type": "axis", "value": -0.3}, 0.0)
        session.handle({"type": "blur"}, 0.0)
        assert session.input.sample() == (NO_INPUT, 0.0)
        session.handle({"type": "axis", "value": -0.3}, 0.0)
        session.handle({"type": "disconnect"}, 0.0)
        assert session.input.sample() == (NO_INPUT, 0.0)
    finally:
        session.folder.release()



def test_the_continue_commands_name_the_port_the_open_tab_reconnects_on(tmp_path, monkeypatch):
    import nudgecli.live.server as server

    out, port, seen = tmp_path / "run", free_port(), {}

    def killed(session, sock, **_):  # the server is killed (-9) while serving: the folder as it is then
        sock.close()
        seen["manifest"] = json.loads((out / "manifest.json").read_text())

    monkeypatch.setattr(server, "serve", killed)
    lines: list[str] = []
    run_live_study("paper", "P01", port=port, out=str(out), overrides=OVERRIDES,
                   announce=lines.append, log=lines.append)
    manifest = seen["manifest"]
    assert manifest["live"]["1"]["port"] == port
    assert f"--port {port} " in lines[-2] and "--resume" in lines[-2], lines  # Ctrl-C's line
    hint = RunRecord(out).continue_session_hint(manifest)
    assert f"--participant P01 --out {out} --port {port} " in hint, hint
    # another --set on restart: the refusal's command keeps the port
    with pytest.raises(NudgeError, match=f"--port {port} "):
        build_session("paper", "P01", out, resume=True, overrides=(*OVERRIDES, "study.time_limit_s=5"))
    # the default port is left out; several participants' hint names no one port
    manifest["live"]["1"]["port"] = STUDY_PORT
    assert "--port" not in RunRecord(out).continue_session_hint(manifest)
    manifest["live"]["2"] = {**manifest["live"]["1"], "participant_id": "P02", "port": port}
    assert "--port" not in RunRecord(out).continue_session_hint(manifest)
