"""Live-study mends: a resume matches the answers file's rows as every reader of it does, the
last-resort advice for answers no file took gives the header when the file does not exist yet, every
bad message gets an error reply and the page keeps its answers until the server has them, and the
message size limit counts bytes."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from nudgecli.errors import RunFolderError
from nudgecli.live import records
from nudgecli.live.questionnaire import ROW_COLUMNS, read_answers
from nudgecli.live.record_checks import check_answered_blocks

ANSWER_CELLS = [str(50 if column.startswith("tlx") else 4) for column in ROW_COLUMNS[3:]]


def _answers_file(folder: Path, rows: list[tuple[str, str]]) -> Path:
    """``questionnaires.csv`` in ``folder`` with one row per ``(participant, block)`` as written."""
    lines = [",".join(ROW_COLUMNS)]
    lines += [",".join([participant, "control", block, *ANSWER_CELLS]) for participant, block in rows]
    path = folder / "questionnaires.csv"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


# --- a resume finds the answers of a block read back as a float ------------------------------------


@pytest.mark.parametrize("rows", [
    [("8", "0"), ("9", "")],  # a blank block in another row: the block column reads back as floats
    [("8", "0"), ("", "1")],  # a blank participant: the participant column does
])
def test_a_resume_finds_answers_whose_labels_read_back_as_floats(tmp_path: Path, rows) -> None:
    _answers_file(tmp_path, rows)
    check_answered_blocks(tmp_path, 8, {"participant_id": "P08", "questionnaire_blocks": [0]})


def test_answers_missing_from_the_file_are_refused_in_the_answers_words(tmp_path: Path) -> None:
    _answers_file(tmp_path, [("8", "0"), ("9", "")])
    with pytest.raises(RunFolderError) as refused:
        check_answered_blocks(tmp_path, 8, {"participant_id": "P08", "questionnaire_blocks": [0, 1]})
    message = str(refused.value)
    assert "holds no answers of participant P08 to block(s) 1," in message
    assert message.endswith("restore it from a backup (a person's answers cannot be asked again)")


# --- answers no file took: the advice to write them by hand works as given --------------------------


def _advice_followed(folder: Path, monkeypatch) -> Path:
    """The answers of participant 1's block 0 no file takes (the disk full), written into
    ``questionnaires.csv`` exactly as the error's last-resort advice says."""
    def disk_full(path: Path, text: str) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(records, "write_text_atomic", disk_full)
    row = {"participant": 1, "condition": "control", "block": 0,
           **{column: float(cell) if column.startswith("tlx") else int(cell)
              for column, cell in zip(ROW_COLUMNS[3:], ANSWER_CELLS, strict=True)}}
    message = str(records.LiveFolder(folder)._answers_kept(1, row, OSError(28, "No space left on device")))
    path = folder / "questionnaires.csv"
    if "create " in message:
        header, line = message.split("the header ")[1].split(" and then the answers ")
        path.write_text(f"{header}\n{line}\n", encoding="utf-8")
    else:
        with path.open("a", encoding="utf-8") as handle:
            handle.write(message.split("by hand: ")[1] + "\n")
    return path


def test_answers_given_by_hand_create_the_answers_file_that_does_not_exist_yet(tmp_path, monkeypatch):
    path = _advice_followed(tmp_path, monkeypatch)
    table = read_answers(path)
    assert table[["participant", "block", "tlx_mental", "likert_q10"]].values.tolist() == [[1, 0, 50.0, 4]]


def test_answers_given_by_hand_are_one_more_line_of_an_existing_answers_file(tmp_path, monkeypatch):
    _answers_file(tmp_path, [("2", "0")])
    table = read_answers(_advice_followed(tmp_path, monkeypatch))
    assert table[["participant", "block"]].values.tolist() == [[2, 0], [1, 0]]


# --- the message size limit counts bytes -----------------------------------------------------------


def test_the_message_size_limit_counts_utf8_bytes_not_characters() -> None:
    pytest.importorskip("aiohttp", reason="the live server needs aiohttp: pip install '.[study]'")
    from nudgecli.live.messages import MAX_MESSAGE_BYTES
    from nudgecli.live.server import _parse

    euros = '{"type": "ping", "pad": "' + "\u20ac" * 6000 + '"}'  # 6,027 characters, 18,027 bytes
    assert len(euros) < MAX_MESSAGE_BYTES
    assert _parse(euros) == (None, f"message of 18027 bytes; at most {MAX_MESSAGE_BYTES}", True)
    fits = '{"type": "ping", "pad": "' + "\u20ac" * 5000 + '"}'  # 15,027 bytes
    assert _parse(fits) == ({"type": "ping", "pad": "\u20ac" * 5000}, None, False)


# --- every bad message is answered; the page keeps its answers until the server has them -----------


async def _page_messages(session, frames: list[str | bytes]) -> list[dict]:
    """Every message the server sends the participant's page after each of ``frames`` (text or
    binary), in order, but the pongs that mark the end of each answer (the role and first state the
    page gets as it connects are left out)."""
    from aiohttp.test_utils import TestClient, TestServer

    from nudgecli.live.server import SteppedClock, create_app

    seen = []
    app = create_app(session, SteppedClock(session.settings.dt), token="t")
    async with TestClient(TestServer(app)) as client:
        ws = await client.ws_connect("/ws?token=t", headers={"Origin": f"http://127.0.0.1:{client.server.port}"})
        while (await ws.receive_json(timeout=10))["type"] != "state":  # the role, then the state
            pass
        for frame in frames:
            await (ws.send_bytes(frame) if isinstance(frame, bytes) else ws.send_str(frame))
            await ws.send_json({"type": "ping"})
            while (message := await ws.receive_json(timeout=10))["type"] != "pong":
                seen.append(message)
        await ws.close()
    return seen


def test_a_questionnaire_out_of_phase_and_a_binary_frame_get_an_error_reply(tmp_path: Path) -> None:
    pytest.importorskip("aiohttp", reason="the live server needs aiohttp: pip install '.[study]'")
    import asyncio
    import json

    from live_helpers import ANSWERS, DEFAULT_TABLES, TWO_TRIALS, play_session

    from nudgecli.live.app import build_session

    session = build_session("paper", "P01", tmp_path / "live", overrides=TWO_TRIALS + DEFAULT_TABLES)
    play_session(session, lambda s: s.phase == "questionnaire")
    answers = json.dumps({"type": "questionnaire", "answers": ANSWERS})
    messages = asyncio.run(_page_messages(session, [b'{"type": "start"}', answers, answers]))
    replies = [message for message in messages if message["type"] not in ("state", "role")]
    assert replies == [
        {"type": "error", "message": "a message is text JSON, not a binary frame"},
        {"type": "answers_recorded", "block": 0},  # the page forgets the answers it kept only now
        {"type": "error", "message": "no questionnaire is due"},  # the same answers again, recorded once
    ]
    assert session.phase == "ready" and session.entry["questionnaire_blocks"] == [0]
    assert session.handle(json.loads(answers), 0.0) == {"type": "error", "message": "no questionnaire is due"}
    session.folder.release()


# --- the reply that answers were recorded comes after the state of the next phase ------------


def test_the_answers_recorded_reply_comes_after_the_state_of_the_next_phase(tmp_path: Path) -> None:
    pytest.importorskip("aiohttp", reason="the live server needs aiohttp: pip install '.[study]'")
    import asyncio
    import json

    from live_helpers import ANSWERS, DEFAULT_TABLES, TWO_TRIALS, play_session

    from nudgecli.live.app import build_session

    session = build_session("paper", "P01", tmp_path / "live", overrides=TWO_TRIALS + DEFAULT_TABLES)
    play_session(session, lambda s: s.phase == "questionnaire")
    answers = json.dumps({"type": "questionnaire", "answers": ANSWERS})
    messages = asyncio.run(_page_messages(session, [answers]))
    seen = [(message["type"], message.get("phase")) for message in messages]
    # was: answers_recorded first, and a second Submit before the state was refused as not due
    assert seen == [("state", "ready"), ("answers_recorded", None)]
    session.folder.release()


# --- the page keeps answers until recorded, and forgets those recorded whose reply was lost --------

#: A websocket the page opens in place of the server's: it keeps what the page sends, and the test
#: hands the page the server's messages (``window.deliver``).
FAKE_SOCKET = """
window.sentMessages = [];
window.WebSocket = class { static OPEN = 1;
  constructor() {
    this.readyState = 1; window.socket = this; setTimeout(() => this.onopen && this.onopen(), 0);
  }
  send(text) { window.sentMessages.push(JSON.parse(text)); }
  close() {} };
window.deliver = (message) => window.socket.onmessage({ data: JSON.stringify(message) });
"""
#: The participant's answers, entered in the form as a person does (each slider moved, each statement chosen).
FILL_FORM = """() => {
  for (const slider of document.querySelectorAll("#q-form input[type=range]")) {
    slider.value = 40; slider.dispatchEvent(new Event("input", { bubbles: true }));
  }
  for (const radio of document.querySelectorAll("#q-form input[type=radio][value='5']")) radio.click();
}"""


@pytest.fixture(scope="module")
def browser():
    """A headless Chromium for the page's tests (launched once: it takes most of a second)."""
    sync_api = pytest.importorskip("playwright.sync_api", reason="needs playwright: pip install '.[test]'")
    from test_live_browser import CHROMIUM_ARGS, _chromium

    chromium = _chromium()
    if chromium is None and os.environ.get("NUDGE_REQUIRE_BROWSER"):
        pytest.fail("NUDGE_REQUIRE_BROWSER is set (as in .ci/run) but no Chromium was found")
    if chromium is None:
        pytest.skip("no Chromium found (see tests/test_live_browser.py)")
    with sync_api.sync_playwright() as p:
        launched = p.chromium.launch(executable_path=chromium, headless=True, args=CHROMIUM_ARGS)
        yield launched
        launched.close()


def _study_page(browser):
    """The study page on :data:`FAKE_SOCKET`, controlling the session, before any state."""
    from nudgecli.live.server import static_dir

    page = browser.new_page()
    page.add_init_script(FAKE_SOCKET)
    page.route("http://study.test/**", lambda route: route.fulfill(
        path=str(static_dir() / (route.request.url.split("/")[-1].split("?")[0] or "index.html"))))
    page.goto("http://study.test/?token=tok")
    page.wait_for_function("window.socket !== undefined && window.socket.onmessage !== undefined")
    page.evaluate("deliver({ type: 'role', role: 'controller' })")
    return page


def test_the_page_keeps_the_answers_it_sent_until_the_server_has_recorded_them(browser) -> None:
    from nudgecli.live.input import key_meanings
    from nudgecli.live.questionnaire import questionnaire_form

    state = {"type": "state", "tick": 1, "phase": "questionnaire", "participant": "P01", "trials_done": 1,
             "trials_total": 2, "ready_for": None, "last_outcome": None, "keys": key_meanings(),
             "questionnaire": {"block": 0, "block_number": 1, "blocks": 2, "condition": "control",
                               **questionnaire_form()}}
    kept = "sessionStorage.getItem('nudge-answers:tok:0')"
    page = _study_page(browser)
    page.evaluate("(state) => deliver(state)", state)
    page.evaluate(FILL_FORM)
    # two clicks: the second, while the first answers are on their way, sends nothing
    page.evaluate("() => { for (const n of [1, 2]) document.getElementById('q-submit').click(); }")
    sent = page.evaluate("sentMessages.filter((m) => m.type === 'questionnaire')")
    held = page.evaluate(kept)  # sent, not yet recorded: still kept in the tab
    page.evaluate("deliver({ type: 'answers_recorded', block: 0 })")
    after = page.evaluate(kept)
    page.close()
    assert held is not None and '"tlx_mental":40' in held
    assert len(sent) == 1 and sent[0]["answers"]["tlx_mental"] == 40 and sent[0]["answers"]["likert_q3"] == 5
    assert after is None



def test_answers_kept_of_a_block_no_longer_due_are_forgotten_when_a_state_comes(browser) -> None:
    from nudgecli.live.input import key_meanings
    from nudgecli.live.questionnaire import questionnaire_form

    def state(phase: str, block: int | None = None) -> dict:
        due = {} if block is None else {"questionnaire": {"block": block, "block_number": block + 1,
                                                          "blocks": 2, "condition": "control",
                                                          **questionnaire_form()}}
        return {"type": "state", "tick": 1, "phase": phase, "participant": "P01", "trials_done": 1,
                "trials_total": 2, "ready_for": "evaluation", "last_outcome": None, "keys": key_meanings(),
                **due}

    kept = "() => Object.keys(sessionStorage).sort()"
    page = _study_page(browser)
    page.evaluate("(state) => deliver(state)", state("questionnaire", 0))
    page.evaluate(FILL_FORM)
    page.evaluate("() => document.getElementById('q-submit').click()")
    page.evaluate("(state) => deliver(state)", state("welcome"))  # a resumed session: still due
    before = page.evaluate(kept)
    page.evaluate("(state) => deliver(state)", state("ready"))  # recorded; its reply lost
    after = page.evaluate(kept)
    page.evaluate("() => sessionStorage.setItem('nudge-answers:tok:0', '{\"likert_q3\": 5}')")
    page.evaluate("(state) => deliver(state)", state("questionnaire", 1))
    page.evaluate(FILL_FORM)
    later = page.evaluate(kept)
    page.close()
    assert before == ["nudge-answers:tok:0"]
    assert after == []  # was: kept for the tab's life
    assert later == ["nudge-answers:tok:1"]
