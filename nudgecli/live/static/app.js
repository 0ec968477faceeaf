// nudge study: the page. It only draws the state the server sends and forwards input events;
// the protocol (10 Hz sampling, labelling, inference, blending, the autonomy) runs on the server.
"use strict";

const params = new URLSearchParams(location.search);
const AXIS = Number(params.get("axis") || 0);      // which gamepad axis is the pressure
const AXIS_SIGN = params.get("invert") ? -1 : 1;   // sip positive, puff negative
const TOKEN = params.get("token") || "";           // the session's token, from the printed address
const MONITOR = params.get("role") === "monitor";  // the experimenter's read-only page, asked for explicitly
const INPUT_KEYS = new Set(["1", "2", "3", "4", " "]);
const INPUT_PHASES = new Set(["mapping", "distortion", "ready", "trial"]);

let ws = null;
let state = null;
let lastAxis = undefined;   // the axis value the server has from this page (undefined: send it anew)
const keysDown = new Set(); // input keys the server holds down from this page, as far as it knows
let unsent = false;       // the questionnaire's form holds answers the server has not recorded yet
let sentBlock = null;     // the block whose answers were sent and await the server's reply
let role = null;          // "controller" (this page drives the session), "watcher" or "monitor"
let everConnected = false;
let lastError = "";       // the server's last error reply (tests read it)
let stoppedBecause = "";  // why the server stopped (it could not record the session), when it says

function send(message) {  // whether the message went to the server
  // a watching page sends no input (the server would refuse it); a ping is fine
  if (role !== "controller" && message.type !== "ping") return false;
  if (!ws || ws.readyState !== WebSocket.OPEN) return false;
  ws.send(JSON.stringify(message));
  return true;
}

// The server releases the page's keys and axis when focus is lost, the connection closes or a trial
// starts; a watching page that comes to control sent none. Then the page forgets what it sent: a key
// still down is sent again on its next repeat, the axis on the next poll.
function forgetSentInput() {
  keysDown.clear();
  lastAxis = undefined;
}

function connect() {
  ws = new WebSocket(`ws://${location.host}/ws?token=${encodeURIComponent(TOKEN)}` +
    (MONITOR ? "&role=monitor" : ""));
  const badge = document.getElementById("connection");
  ws.onopen = () => {
    everConnected = true; stoppedBecause = "";
    badge.textContent = "connected"; badge.className = "online"; forgetSentInput();
    document.getElementById("lost").classList.remove("shown");
  };
  ws.onclose = () => {
    role = null; sentBlock = null;  // answers sent and not confirmed may be sent again
    badge.textContent = "disconnected: reconnecting…"; badge.className = "offline";
    document.getElementById("lost-help").textContent = stoppedBecause ? stoppedBecause : everConnected ?
      "The connection to the study server was lost. Keep this page open: it reconnects by itself " +
      "when the server is back. If nothing happens, tell the experimenter." :
      "Cannot reach the study server. Open the exact address the server printed (it ends in " +
      "?token=…), and check that the server is running.";
    document.getElementById("lost").classList.add("shown");
    setTimeout(connect, 1000);
  };
  ws.onmessage = (event) => {
    const message = JSON.parse(event.data);
    if (message.type === "state") {
      if (!state || state.phase !== message.phase) forgetSentInput();  // a trial's start released them
      forgetAnswersNotDue(message);
      state = message; render();
    } else if (message.type === "role") {
      role = message.role; forgetSentInput();
      document.getElementById("watching").classList.toggle("shown", role === "watcher");
      document.getElementById("monitoring").classList.toggle("shown", role === "monitor");
      if (state) render(); else applyRole();
    } else if (message.type === "answers_recorded") {
      sentBlock = null; forgetAnswers(message.block);  // the server has them: no longer kept in the tab
    } else if (message.type === "error") {
      lastError = message.message; sentBlock = null;
      if (state && state.phase === "questionnaire") keepAnswers();  // refused: the answers are still unsent
      if (message.stopped) stoppedBecause = `${message.message}. Tell the experimenter.`;
      document.getElementById(state && state.phase === "questionnaire" ? "q-error" : "notice").textContent =
        message.message;
    }
  };
}

// --- input: keys held down, and a gamepad axis -------------------------------------------------

document.addEventListener("keydown", (e) => {
  if (state && state.phase === "questionnaire") { questionnaireKey(e); return; }  // the form's keys
  if (!INPUT_KEYS.has(e.key) || isTyping(e)) return;
  e.preventDefault();
  if (e.key === " ") { if (!e.repeat) send({ type: "key", key: e.key, down: true }); return; }  // starts once
  // a repeat says the key is still down: sent again unless the server is known to hold it
  if (e.repeat && keysDown.has(e.key)) return;
  if (send({ type: "key", key: e.key, down: true })) keysDown.add(e.key);
});
document.addEventListener("keyup", (e) => {
  if (state && state.phase === "questionnaire") return;
  if (!INPUT_KEYS.has(e.key) || isTyping(e)) return;
  e.preventDefault();
  keysDown.delete(e.key);
  send({ type: "key", key: e.key, down: false });
});
window.addEventListener("blur", () => { send({ type: "blur" }); keysDown.clear(); });
window.addEventListener("focus", forgetSentInput);
document.addEventListener("visibilitychange", () => { if (document.visibilityState === "visible") forgetSentInput(); });
window.addEventListener("beforeunload", (e) => {  // closing the tab would lose answers not sent yet
  if (!unsent || !state || state.phase !== "questionnaire") return;
  e.preventDefault(); e.returnValue = "";
});

function isTyping(e) {
  return e.target && (e.target.tagName === "INPUT" && e.target.type === "text");
}

function pollGamepad() {
  const pads = navigator.getGamepads ? navigator.getGamepads() : [];
  const pad = Array.from(pads || []).find((p) => p && p.connected);
  const value = pad && pad.axes.length > AXIS ? AXIS_SIGN * pad.axes[AXIS] : null;
  const changed = value === null ? lastAxis !== null : (lastAxis === null || lastAxis === undefined ||
    Math.abs(value - lastAxis) > 0.0005);
  if (changed && send({ type: "axis", value: value })) lastAxis = value;  // a dropped one is sent later
  requestAnimationFrame(pollGamepad);
}

document.getElementById("skip").addEventListener("click", () => send({ type: "skip" }));

// --- drawing -----------------------------------------------------------------------------------

function show(id) {
  for (const screen of document.querySelectorAll(".screen")) screen.classList.toggle("active", screen.id === id);
}

function renderLegend() {  // the keys on every screen that takes input, in the task's words
  const legend = document.getElementById("legend");
  const phase = state.phase;
  legend.classList.toggle("shown", INPUT_PHASES.has(phase));
  // calibration part 1 asks which input the person would use for an action: the legend names the
  // inputs only, so it does not answer for them; Space starts something only on a ready screen
  const explained = phase === "ready" || phase === "trial";
  const wanted = `${phase === "mapping" || phase === "distortion" ? "labels" : "meanings"}` +
    (phase === "ready" ? "+space" : "");
  if (legend.dataset.filled === wanted) return;
  legend.innerHTML = Object.entries(state.keys).map(([key, k]) =>
    `<span><kbd>${key}</kbd> ${k.label}${explained ? ": " + k.does : ""}</span>`).join("") +
    (phase === "ready" ? "<span><kbd>Space</kbd> start</span>" : "");
  legend.dataset.filled = wanted;
}

function renderWelcomeKeys() {  // the welcome screen's table: the server's words for each key
  const table = document.getElementById("welcome-keys");
  if (table.dataset.filled) return;
  table.innerHTML = Object.entries(state.keys).map(([key, k]) =>
    `<tr><th>${key}</th><td>${k.label}</td><td>${k.does}</td></tr>`).join("");
  table.dataset.filled = "1";
}

function render() {
  document.getElementById("participant").textContent = `Participant ${state.participant}`;
  document.getElementById("progress").textContent = `Trials ${state.trials_done} / ${state.trials_total}`;
  document.getElementById("notice").textContent = "";
  renderLegend();
  const phase = state.phase;
  if (phase === "welcome") { renderWelcomeKeys(); show("welcome"); }
  else if (phase === "mapping" || phase === "distortion") renderCalibration();
  else if (phase === "ready") renderReady();
  else if (phase === "trial") renderTrial();
  else if (phase === "questionnaire") renderQuestionnaire();
  else if (phase === "done") show("done");
  if (phase !== "questionnaire") unsent = false;
  applyRole();
}

function applyRole() {  // a watching or monitor page shows the session; its form and Skip do nothing
  const watching = role === "watcher" || role === "monitor";
  for (const line of document.querySelectorAll(".watch-only")) line.classList.toggle("shown", watching);
  document.getElementById("skip").disabled = watching;
  for (const element of document.getElementById("q-form").elements) element.disabled = watching;
}

function renderCalibration() {
  show("calibration");
  const c = state.calibration;
  const title = document.getElementById("cal-title");
  const help = document.getElementById("cal-help");
  const prompt = document.getElementById("cal-prompt");
  if (c.part === 1) {
    title.textContent = "Calibration 1 of 2: which input would you use?";
    help.textContent = "For each action, press the key of the sip or puff you would use for it: " +
      Object.entries(state.keys).map(([key, k]) => `${key} ${k.label}`).join(", ") + ".";
    prompt.textContent = c.break ? "Short break…" : (c.prompt || "");
  } else {
    title.textContent = "Calibration 2 of 2: produce the input";
    help.textContent = "When an input is shown, produce it and hold it until it disappears.";
    prompt.textContent = c.prompt || "";
  }
  document.getElementById("cal-progress").textContent = `${c.done} / ${c.total}`;
}

const PRACTICE_HELP = {
  teleoperation: "Practice 1 of 3: drive the robot yourself to the red goal (position and heading).",
  blending: "Practice 2 of 3: the assistant now adds its own motion to yours while you give a command.",
  "turn-taking": "Practice 3 of 3: stop giving commands for about two seconds to hand the robot to the " +
    "assistant; it moves, then hands it back to you.",
  evaluation: "Drive the robot to the red goal. Hand over to the assistant by pausing for about two seconds.",
};

function renderReady() {
  show("ready");
  const next = state.ready_for;
  document.getElementById("ready-title").textContent =
    next === "evaluation" ? `Trial ${state.trials_done + 1} of ${state.trials_total}` : "Practice";
  document.getElementById("ready-help").textContent = PRACTICE_HELP[next] || "";
  document.getElementById("skip").style.display = next === "evaluation" ? "none" : "inline-block";
  document.getElementById("ready-outcome").textContent = outcomeText(state.last_outcome);
}

const PRACTICE_NAMES = { teleoperation: "Practice 1 of 3 (teleoperation)", blending: "Practice 2 of 3 (blending)",
  "turn-taking": "Practice 3 of 3 (turn-taking)" };

function outcomeText(o) {  // what the last trial or practice gave, named, so it is not taken for the next
  if (!o) return "";
  const what = o.kind === "evaluation" ? `Trial ${o.number}` : (PRACTICE_NAMES[o.kind] || "Practice");
  if (o.abandoned) return `${what}: the page was closed during it; it starts again from the beginning.`;
  if (o.success) return `${what}: goal reached in ${o.duration_s.toFixed(1)} s.`;
  return `${what}: ${o.timed_out ? "time is up" : "that was not the red goal"}.`;
}

function renderTrial() {
  show("trial");
  const t = state.trial;
  // only the page that drives the robot is told it is its turn
  document.getElementById("turn").textContent = t.autonomy ? "Assistant's turn" :
    (role === "controller" ? "Your turn" : "Participant's turn");
  for (const span of document.querySelectorAll(".modes span")) span.classList.toggle("active", span.dataset.mode === t.mode);
  document.getElementById("clock").textContent = `${t.t.toFixed(1)} s / ${t.time_limit_s} s`;
  const canvas = document.getElementById("world");
  canvas.style.borderColor = t.autonomy ? "#999" : borderColour(t.border);
  document.getElementById("border-help").textContent = t.autonomy ?
    "Grey border: the assistant is moving the robot; wait for your turn." :
    `The border turns from blue to red over the first ${t.border_s} s of your commands in a turn; ` +
    "pause for about two seconds to hand the robot to the assistant.";
  draw(canvas, t);
}

function borderColour(fraction) {  // blue -> red as the human turn goes on
  const f = Math.max(0, Math.min(1, fraction || 0));
  return `rgb(${Math.round(34 + f * (204 - 34))}, ${Math.round(68 * (1 - f))}, ${Math.round(204 * (1 - f))})`;
}

function draw(canvas, t) {
  const g = canvas.getContext("2d");
  const [x0, x1] = t.world.x, [y0, y1] = t.world.y;
  const scale = Math.min(canvas.width / (x1 - x0), canvas.height / (y1 - y0));
  const px = (x) => (x - x0) * scale;
  const py = (y) => canvas.height - (y - y0) * scale;
  g.clearRect(0, 0, canvas.width, canvas.height);
  g.strokeStyle = "#eee"; g.lineWidth = 1;
  const [nx, ny] = t.world.cells;
  for (let i = 0; i <= nx; i++) { const x = px(x0 + i * (x1 - x0) / nx); g.beginPath(); g.moveTo(x, 0); g.lineTo(x, canvas.height); g.stroke(); }
  for (let j = 0; j <= ny; j++) { const y = py(y0 + j * (y1 - y0) / ny); g.beginPath(); g.moveTo(0, y); g.lineTo(canvas.width, y); g.stroke(); }
  t.goals.forEach((goal, k) => {
    const colour = k === t.true_goal ? "#d22" : "#999";
    pose(g, px(goal[0]), py(goal[1]), goal[2], t.world.goal_radius * scale * 1.6, colour, false);
  });
  pose(g, px(t.x), py(t.y), t.theta, t.world.robot_radius * scale * 1.6, "#222", true);
}

function pose(g, x, y, theta, radius, colour, filled) {
  g.beginPath(); g.arc(x, y, radius, 0, 2 * Math.PI);
  g.lineWidth = 3; g.strokeStyle = colour; g.fillStyle = colour;
  if (filled) g.fill(); else g.stroke();
  g.beginPath(); g.moveTo(x, y);
  g.lineTo(x + 2.2 * radius * Math.cos(theta), y - 2.2 * radius * Math.sin(theta));
  g.lineWidth = 4; g.stroke();
}

let formBlock = null;

function renderQuestionnaire() {
  show("questionnaire");
  const q = state.questionnaire;
  if (formBlock === q.block) return;  // keep what the person has entered
  formBlock = q.block;
  document.getElementById("q-title").textContent =
    `About the block you just finished: block ${q.block_number} of ${q.blocks}, condition "${q.condition}"`;
  const form = document.getElementById("q-form");
  form.innerHTML = "";
  document.getElementById("q-error").textContent = "";
  for (const item of q.tlx) {  // sliders start unset: an untouched one is no answer, not a 50
    const div = document.createElement("div"); div.className = "item";
    const middle = (q.tlx_range[0] + q.tlx_range[1]) / 2;
    div.innerHTML = `<label for="${item.name}">${item.question} <output id="${item.name}-out">not set</output></label>` +
      `<span class="small">${item.low}</span> <input type="range" class="unset" id="${item.name}" name="${item.name}" ` +
      `min="${q.tlx_range[0]}" max="${q.tlx_range[1]}" step="5" value="${middle}" aria-valuetext="not set">` +
      ` <span class="small">${item.high}</span>`;
    form.appendChild(div);
    const input = div.querySelector("input");
    const touch = () => {  // moved or clicked: now it has a value, drawn as a normal slider
      input.classList.remove("unset"); input.dataset.touched = "1";
      input.removeAttribute("aria-valuetext");
      div.querySelector("output").textContent = input.value;
    };
    input.addEventListener("input", touch);
    input.addEventListener("change", touch);
    input.addEventListener("pointerdown", touch);
  }
  for (const item of q.likert) {
    const div = document.createElement("div"); div.className = "item likert";
    let html = `<p>${item.statement}</p><span class="small">strongly disagree</span> `;
    for (let v = q.likert_range[0]; v <= q.likert_range[1]; v++) {
      html += `<label><input type="radio" name="${item.name}" value="${v}"> ${v}</label>`;
    }
    div.innerHTML = html + ` <span class="small">strongly agree</span>`;
    form.appendChild(div);
  }
  restoreAnswers(form, q.block);
  form.addEventListener("input", keepAnswers);
  form.addEventListener("change", keepAnswers);
  form.addEventListener("pointerup", keepAnswers);
  const submit = document.createElement("button");
  submit.type = "submit"; submit.id = "q-submit"; submit.textContent = "Submit";
  form.appendChild(submit);
  form.onsubmit = (e) => {
    e.preventDefault();
    if (role !== "controller") return;  // the watch-only line says where to answer
    if (sentBlock === q.block) return;  // sent already (a second click): the server's reply is on its way
    const answers = {};
    const unset = [];
    for (const item of q.tlx) {
      const input = form.elements[item.name];
      answers[item.name] = input.dataset.touched ? Number(input.value) : null;
      if (!input.dataset.touched) unset.push(item.subscale);
    }
    if (unset.length) {
      document.getElementById("q-error").textContent = `Set every slider (not yet: ${unset.join(", ")}).`;
      return;
    }
    for (const item of q.likert) {
      const checked = form.querySelector(`input[name="${item.name}"]:checked`);
      answers[item.name] = checked ? Number(checked.value) : null;
    }
    // kept in the tab until the server says it recorded them (answers_recorded), not forgotten as sent
    if (send({ type: "questionnaire", answers: answers })) sentBlock = q.block;
  };
  if (role === "controller") focusItem(0);
}

// --- answers entered and not recorded survive a reload of the tab (kept per session token and block) --

function answersKey(block) { return `nudge-answers:${TOKEN}:${block}`; }

function keepAnswers() {
  const form = document.getElementById("q-form");
  const kept = {};
  for (const input of form.querySelectorAll("input[type=range]")) {
    if (input.dataset.touched) kept[input.name] = Number(input.value);
  }
  for (const input of form.querySelectorAll("input[type=radio]:checked")) kept[input.name] = Number(input.value);
  unsent = Object.keys(kept).length > 0;
  try {
    if (unsent) sessionStorage.setItem(answersKey(formBlock), JSON.stringify(kept));
    else sessionStorage.removeItem(answersKey(formBlock));
  } catch (err) { /* no storage (private mode): the beforeunload prompt still warns */ }
}

function forgetAnswers(block) {
  unsent = false;
  try { sessionStorage.removeItem(answersKey(block)); } catch (err) { /* nothing was kept */ }
}

// The phases a resumed session shows before the questionnaire it has due: answers kept stay kept.
const BEFORE_DUE_ANSWERS = new Set(["welcome", "mapping", "distortion"]);

// Answers kept of a block whose questionnaire is no longer due were recorded (their answers_recorded
// lost to a reload or a reconnect): forgotten, not kept for the tab's life.
function forgetAnswersNotDue(current) {
  if (BEFORE_DUE_ANSWERS.has(current.phase)) return;
  const due = current.phase === "questionnaire" && current.questionnaire ?
    answersKey(current.questionnaire.block) : null;
  try {
    for (const key of Object.keys(sessionStorage)) {
      if (key.startsWith(answersKey("")) && key !== due) sessionStorage.removeItem(key);
    }
  } catch (err) { /* no storage: nothing was kept */ }
}

function restoreAnswers(form, block) {
  let kept = {};
  try { kept = JSON.parse(sessionStorage.getItem(answersKey(block)) || "{}") || {}; } catch (err) { kept = {}; }
  for (const [name, value] of Object.entries(kept)) {
    const input = form.querySelector(`input[name="${CSS.escape(name)}"][type=range]`) ||
      form.querySelector(`input[name="${CSS.escape(name)}"][value="${CSS.escape(String(value))}"]`);
    if (!input) continue;
    if (input.type === "range") { input.value = value; input.dispatchEvent(new Event("input")); }
    else input.checked = true;
  }
  unsent = Object.keys(kept).length > 0;
}

// --- the questionnaire by keyboard: arrows move a slider or choose a statement's answer, digits
// answer a statement (1-7), Enter goes to the next question and on the last one submits ---------

function questionItems() {  // one focus target per question: its slider, or its checked (or first) radio
  return Array.from(document.querySelectorAll("#q-form .item")).map((div) =>
    div.querySelector("input[type=range]") || div.querySelector("input[type=radio]:checked") ||
    div.querySelector("input[type=radio]"));
}

function focusItem(index) {
  const items = questionItems();
  if (index < items.length) items[index].focus();
  else document.getElementById("q-submit").focus();
}

function questionnaireKey(e) {
  const target = e.target;
  const items = questionItems();
  const div = target && target.closest ? target.closest("#q-form .item") : null;
  const index = div ? Array.from(document.querySelectorAll("#q-form .item")).indexOf(div) : -1;
  if (index < 0) {
    if (e.key === "Enter" && target.id !== "q-submit") { e.preventDefault(); focusItem(0); }
    return;  // the submit button takes Enter and Space itself
  }
  if (target.type === "radio" && /^[0-9]$/.test(e.key)) {  // a digit answers the statement
    const radio = div.querySelector(`input[type=radio][value="${e.key}"]`);
    e.preventDefault();
    if (radio) { radio.checked = true; radio.focus(); keepAnswers(); }
  } else if (e.key === "Enter") {
    e.preventDefault();
    if (index + 1 < items.length) focusItem(index + 1);
    else document.getElementById("q-form").requestSubmit();
  }
  // arrows: the browser's own (a slider moves by its step; in a radio group the next answer is chosen)
}

connect();
requestAnimationFrame(pollGamepad);
