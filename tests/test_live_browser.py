"""`nudge study` in a real browser: headless Chromium driven by Playwright runs the calibration and two
short trials with scripted key presses; the run folder then passes `nudge analyze` and `nudge plot`.

Skipped where no browser can be had: it needs the `playwright` package (the test extra) and a
Chromium (Debian's `chromium` package, `playwright install chromium`, or NUDGE_CHROMIUM=/path).
With NUDGE_SCREENSHOT=path the page's screenshot is also saved there (the README's picture).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

pytest.importorskip("aiohttp", reason="the live server needs aiohttp: pip install '.[study]'")
sync_api = pytest.importorskip("playwright.sync_api", reason="needs playwright: pip install '.[test]'")

from live_helpers import ANSWERS, TWO_TRIALS  # noqa: E402

from nudgecli.cli import main  # noqa: E402
from nudgecli.sim.calibration_profile import fit_calibration_dir  # noqa: E402

#: The key that answers each action prompt with the true mapping (move_p Soft Puff 3, move_n Soft Sip
#: 4, to_mode_r Hard Puff 1, to_mode_l Hard Sip 2; DESIGN.md 2.2).
PROMPT_KEYS = (
    ("COUNTERCLOCKWISE", "4"),
    ("CLOCKWISE", "3"),
    ("RIGHT", "3"),
    ("UP", "3"),
    ("LEFT", "4"),
    ("DOWN", "4"),
    ("forward", "1"),
    ("backward", "2"),
)
LABEL_KEYS = {"Hard Puff": "1", "Hard Sip": "2", "Soft Puff": "3", "Soft Sip": "4"}


def _chromium() -> str | None:
    candidates = [os.environ.get("NUDGE_CHROMIUM")]
    candidates += [shutil.which(name) for name in ("chromium", "chromium-browser", "google-chrome")]
    return next((c for c in candidates if c and Path(c).exists()), None)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _wait(page, expression: str, timeout: float = 30.0) -> None:
    page.wait_for_function(expression, timeout=timeout * 1000)


def _state(page) -> dict:
    return page.evaluate("state")


def _calibrate(page) -> None:
    """Part 1: answer each action prompt with its key after a person's reaction time. Part 2: hold
    the prompted input's key until the prompt clears."""
    answered = 0
    while True:
        state = _state(page)
        if state["phase"] != "mapping":
            break
        prompt = state["calibration"]["prompt"]
        done = state["calibration"]["done"]
        if prompt:
            key = next(k for word, k in PROMPT_KEYS if word in prompt)
            page.wait_for_timeout(150)
            page.keyboard.press(key)
            answered += 1
            _wait(page, f"state.phase !== 'mapping' || state.calibration.done > {done}", 10)
        else:
            page.wait_for_timeout(50)
    assert answered >= 12
    held = None
    while True:
        state = _state(page)  # one reading: the phase may end between two
        if state["phase"] != "distortion":
            break
        prompt = state["calibration"]["prompt"]
        key = LABEL_KEYS.get(prompt) if prompt else None
        if key != held:
            if held:
                page.keyboard.up(held)
            if key:
                page.wait_for_timeout(150)
                page.keyboard.down(key)
            held = key
        page.wait_for_timeout(50)
    if held:
        page.keyboard.up(held)


def _answer_questionnaire(page) -> None:
    _wait(page, "state.phase === 'questionnaire' && document.querySelector('#q-submit') !== null")
    for name, value in ANSWERS.items():
        if name.startswith("tlx_"):
            page.eval_on_selector(f"#{name}", "(el, v) => { el.value = v; }", value)
        else:
            page.check(f"input[name='{name}'][value='{value}']")
    page.click("#q-submit")
    _wait(page, "state.phase !== 'questionnaire'")


def test_browser_session_records_a_folder_that_analyze_and_plot_read(tmp_path):
    chromium = _chromium()
    if chromium is None:
        pytest.skip(
            "no Chromium found: apt-get install chromium, `playwright install chromium`, or set "
            "NUDGE_CHROMIUM to a Chromium executable"
        )
    out, port = tmp_path / "run", _free_port()
    overrides = (*TWO_TRIALS, "study.time_limit_s=3", "calibration.prompt_s=0.8")
    sets = [arg for item in overrides for arg in ("--set", item)]
    server = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "nudgecli.cli",
            "study",
            "paper",
            "--participant",
            "P01",
            "--port",
            str(port),
            "--out",
            str(out),
            *sets,
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        address = server.stdout.readline().strip()  # the server prints its address once it listens
        assert address == f"http://127.0.0.1:{port}/", (
            server.stderr.read() if server.poll() is not None else address
        )
        with sync_api.sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, headless=True)
            page = browser.new_page(viewport={"width": 900, "height": 820})
            page.goto(address)
            _wait(page, "state !== null && state.phase === 'welcome'")
            page.keyboard.press(" ")
            _wait(page, "state.phase === 'mapping'")
            _calibrate(page)
            _wait(page, "state.phase === 'ready' && state.ready_for === 'teleoperation'")
            page.click("#skip")
            _wait(page, "state.ready_for === 'evaluation'")
            # trial 1: hold a soft puff (keeps moving), let go, then a hard puff (one mode switch)
            page.keyboard.press(" ")
            _wait(page, "state.phase === 'trial'")
            page.keyboard.down("3")
            page.wait_for_timeout(1200)
            page.keyboard.up("3")
            page.keyboard.press("1")
            page.wait_for_timeout(300)
            screenshot = page.screenshot(path=str(tmp_path / "study-page.png"))
            _answer_questionnaire(page)
            # trial 2: a soft sip held, then nothing: the turn passes to the assistant
            page.keyboard.press(" ")
            _wait(page, "state.phase === 'trial'")
            page.keyboard.down("4")
            page.wait_for_timeout(800)
            page.keyboard.up("4")
            _answer_questionnaire(page)
            _wait(page, "state.phase === 'done'")
            browser.close()
    finally:
        server.send_signal(signal.SIGINT)
        try:
            server.wait(timeout=10)
        except subprocess.TimeoutExpired:
            server.kill()
    if os.environ.get("NUDGE_SCREENSHOT"):
        Path(os.environ["NUDGE_SCREENSHOT"]).write_bytes(screenshot)

    steps = pd.read_parquet(out / "steps" / "part-0001.parquet")
    trials = pd.read_parquet(out / "trials" / "part-0001.parquet")
    assert list(trials["trial"]) == [0, 1]
    first = steps[steps["trial"] == 0]
    assert (first["phi_m"] == "Soft Puff").sum() >= 5  # the held key moved the robot for many samples
    assert first["event"].str.contains("mode_switch_human").sum() == 1  # one blow, one switch
    # the agent used the tables `nudge fit` fits from the session's calibration logs
    profile = fit_calibration_dir(out / "calibration" / "participant-0001").profile
    record = pd.read_parquet(out / "participants.parquet").iloc[0]
    fitted = profile["p_phm_given_phi"]
    labels = list(fitted)
    assert np.allclose(
        json.loads(record["agent_p_phm_given_phi"]), [[fitted[i][m] for m in labels] for i in labels]
    )
    # keys are clean: every prompted label was measured as itself, (1 + 0.01) / (1 + 4 * 0.01) on the diagonal
    assert np.allclose(np.diag(json.loads(record["agent_p_phm_given_phi"])), 1.01 / 1.04)
    assert json.loads((out / "manifest.json").read_text())["status"] == "complete"
    runner = CliRunner()
    analyzed = runner.invoke(main, ["analyze", str(out), "--questionnaires", str(out / "questionnaires.csv")])
    assert analyzed.exit_code == 0, analyzed.output
    plotted = runner.invoke(main, ["plot", str(out), "--formats", "png"])
    assert plotted.exit_code == 0, plotted.output
    assert (out / "figures" / "fig3.png").is_file()
