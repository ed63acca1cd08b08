// Participant pages of a headmotion listening test (MOS with reference, MUSHRA, A/B).
// One page app: consent -> demographics -> instructions -> trials -> done.  The participant token
// is kept in localStorage so a closed tab resumes at the next unanswered trial; the server only
// accepts the next trial, so ratings cannot be changed afterwards.
import { createPlayer, destroyAll, stopAll } from "/static/player.js";

const $ = (s, root = document) => root.querySelector(s);
const main = $("#main");
let info = null;
let token = null;
let storageKey = "headmotion-listen";

function h(tag, attrs = {}, ...children) {
  const el = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === "class") el.className = v;
    else if (k.startsWith("on")) el.addEventListener(k.slice(2), v);
    else if (v === true) el.setAttribute(k, "");
    else if (v !== false && v !== null && v !== undefined) el.setAttribute(k, v);
  }
  for (const c of children.flat()) if (c !== null && c !== undefined) el.append(c instanceof Node ? c : document.createTextNode(String(c)));
  return el;
}

class ApiError extends Error {
  constructor(status, detail) { super(`${status}: ${detail}`); this.status = status; this.detail = detail; }
}

async function api(method, path, body, { retries = 3 } = {}) {
  for (let attempt = 0; ; attempt++) {
    let r;
    try {
      r = await fetch(path, {
        method, headers: body ? { "Content-Type": "application/json" } : {},
        body: body ? JSON.stringify(body) : undefined, cache: "no-store",
      });
    } catch (e) {  // network error: retry (an answer is stored at most once server-side)
      if (attempt < retries) { await new Promise((res) => setTimeout(res, 500 * (attempt + 1))); continue; }
      throw new ApiError(0, "cannot reach the server; please check your connection and reload");
    }
    if (r.ok) return r.json();
    let detail = r.statusText;
    try { const d = await r.json(); detail = typeof d.detail === "string" ? d.detail : JSON.stringify(d.detail); } catch (e) { /* not JSON */ }
    throw new ApiError(r.status, detail);
  }
}

function showError(msg) {
  const el = $("#error");
  el.textContent = msg; el.hidden = false;
  clearTimeout(showError.t); showError.t = setTimeout(() => { el.hidden = true; }, 6000);
}

function setProgress(p) {
  const bar = $("#progress");
  if (!p) { bar.hidden = true; return; }
  bar.hidden = false;
  $("#progress-text").textContent = `${Math.min(p.done + 1, p.total)} of ${p.total}`;
  $("#progress-fill").style.width = `${(100 * p.done) / Math.max(1, p.total)}%`;
}

async function refresh() {
  destroyAll();
  let st;
  try { st = await api("GET", `/api/p/${encodeURIComponent(token)}/state`); } catch (e) {
    if (e.status === 404) { localStorage.removeItem(storageKey); token = null; return renderConsent(); }
    showError(e.message); return;
  }
  document.body.dataset.stage = st.stage;
  if (st.stage === "demographics") { setProgress(null); return renderDemographics(); }
  if (st.stage === "instructions") { setProgress(null); return renderInstructions(); }
  if (st.stage === "done") { setProgress(null); return renderDone(); }
  setProgress(st.progress);
  return renderTrial(st.trial, st.progress);
}

function renderConsent() {
  document.body.dataset.stage = "consent";
  main.replaceChildren(
    h("h2", {}, "Consent"),
    h("div", { class: "text" }, info.consent || "By taking part you agree that your anonymous answers are stored and analysed for research."),
    h("p", {}, h("label", {}, h("input", { type: "checkbox", id: "consent-box" }), " I agree to take part.")),
    h("div", { class: "actions" }, h("button", {
      id: "consent", class: "primary", onclick: async () => {
        if (!$("#consent-box").checked) return showError("Please tick the box to agree.");
        try {
          const r = await api("POST", "/api/participants", { consent: true }, { retries: 0 });
          token = r.token; localStorage.setItem(storageKey, token);
          refresh();
        } catch (e) { showError(e.message); }
      },
    }, "Continue")));
}

function renderDemographics() {
  const form = h("form", { class: "demo", id: "demographics" });
  for (const q of info.demographics) {
    let input;
    if (q.type === "choice") {
      input = h("select", { name: q.name, id: `q-${q.name}` }, h("option", { value: "" }, "— please choose —"),
        q.options.map((o) => h("option", { value: o }, o)));
    } else {
      input = h("input", { name: q.name, id: `q-${q.name}`, type: q.type === "number" ? "number" : "text" });
    }
    form.append(h("label", {}, `${q.label}${q.required ? "" : " (optional)"} `, input));
  }
  form.append(h("div", { class: "actions" }, h("button", { type: "submit", id: "demo-submit", class: "primary" }, "Continue")));
  form.addEventListener("submit", async (e) => {
    e.preventDefault();
    const answers = {};
    for (const q of info.demographics) {
      const v = $(`#q-${q.name}`).value;
      answers[q.name] = v === "" ? null : (q.type === "number" ? Number(v) : v);
    }
    try { await api("POST", `/api/p/${encodeURIComponent(token)}/demographics`, { answers }, { retries: 0 }); refresh(); }
    catch (err) { if (err.status === 409) refresh(); else showError(err.detail || err.message); }
  });
  main.replaceChildren(h("h2", {}, "About you"), form);
}

function renderInstructions() {
  main.replaceChildren(
    h("h2", {}, "Instructions"),
    h("div", { class: "text" }, info.instructions || defaultInstructions()),
    h("div", { class: "actions" }, h("button", {
      id: "start", class: "primary", onclick: async () => {
        try { await api("POST", `/api/p/${encodeURIComponent(token)}/start`, null, { retries: 0 }); }
        catch (e) { if (e.status !== 409) return showError(e.message); }
        refresh();
      },
    }, "Start")));
}

function defaultInstructions() {
  const t = {
    mos_ref: "The video on the left is the reference. Rate how similar the video on the right is to it.",
    mushra: "The reference is labelled. Rate every video on the sliders; one of them is the reference itself.",
    ab: "Choose the video in which the head motion looks more natural.",
  }[info.type];
  return `${t}\nThe audio is recorded speech: do not judge it, judge the head motion only.\n` +
    "You can play each video as often as you like. Once you submit a rating you cannot go back to change it.";
}

function renderDone() {
  localStorage.setItem(storageKey, token);
  main.replaceChildren(h("h2", { id: "done" }, "Finished"), h("div", { class: "text" }, info.finish_text));
}

// ---------------------------------------------------------------------------------------------
// trials
// ---------------------------------------------------------------------------------------------
function renderTrial(trial, progress) {
  const t0 = performance.now();
  const players = [];
  const answer = {};
  const submit = h("button", { id: "submit", class: "primary", disabled: true }, "Submit");
  const phaseLabel = trial.phase === "training" ? h("p", { class: "phase", id: "phase" }, "Training") : null;
  const played = new Set();
  let ready = () => true;
  const update = () => { submit.disabled = !(ready() && (!info.require_play || played.size >= players.length)); };
  const stim = (label, s, extraClass = "") => {
    const p = createPlayer(s, { onplay: () => { played.add(p); update(); } });
    players.push(p);
    return h("div", { class: `stim ${extraClass}`, "data-slot": label },
      h("div", { class: "label" }, label), p.element,
      h("button", { class: "play", "data-play": label, onclick: () => p.play() }, "▶ Play"));
  };

  let body;
  if (trial.kind === "mos") {
    let rating = null;
    ready = () => rating !== null;
    const buttons = info.scale_labels.map((lab, i) => h("button", {
      id: `rating-${i + 1}`, "data-rating": i + 1, onclick: (e) => {
        rating = i + 1; answer.rating = rating;
        for (const b of buttons) b.classList.toggle("selected", b === e.currentTarget);
        update();
      },
    }, lab));
    body = [h("div", { class: "stimuli" }, stim("Reference", trial.reference), stim("Video", trial.slots[0].stimulus)),
      h("p", { class: "question" }, info.question), h("div", { class: "scale" }, buttons)];
  } else if (trial.kind === "mushra") {
    const touched = new Set();
    answer.ratings = {};
    ready = () => touched.size === trial.slots.length;
    const cols = trial.slots.map((s) => {
      const val = h("span", { class: "value", id: `value-${s.label}` }, "–");
      const slider = h("input", { type: "range", min: 0, max: 100, step: 1, value: 0, id: `slider-${s.label}`, "aria-label": `rating of ${s.label}` });
      slider.addEventListener("input", () => {
        touched.add(s.label); answer.ratings[s.label] = Number(slider.value); val.textContent = slider.value; update();
      });
      const col = stim(s.label, s.stimulus, "mushra");
      col.append(h("div", { class: "slider-wrap" }, slider,
        h("div", { class: "marks" }, info.mushra_marks.map((m) => h("span", {}, m))), val));
      return col;
    });
    body = [h("div", { class: "stimuli" }, stim("Reference", trial.reference, "mushra")),
      h("p", { class: "question" }, info.question), h("div", { class: "stimuli" }, cols)];
  } else if (trial.kind === "ab") {
    ready = () => answer.choice !== undefined;
    const [l, r] = trial.slots;
    const pick = (side) => (e) => {
      answer.choice = side;
      for (const b of main.querySelectorAll("button.choose")) b.classList.toggle("selected", b === e.currentTarget);
      update();
    };
    body = [h("div", { class: "stimuli" }, stim("Left", l.stimulus), stim("Right", r.stimulus)),
      h("p", { class: "question" }, info.question),
      h("div", { class: "scale" },
        h("button", { id: "choose-left", class: "choose", onclick: pick("left") }, "Left"),
        h("button", { id: "choose-right", class: "choose", onclick: pick("right") }, "Right"))];
  } else {  // attention check
    ready = () => answer.choice !== undefined;
    body = [h("p", { class: "question", id: "attention" }, trial.question),
      h("div", { class: "scale" }, trial.options.map((o, i) => h("button", {
        class: "option", id: `option-${i}`, "data-option": o, onclick: (e) => {
          answer.choice = o;
          for (const b of main.querySelectorAll("button.option")) b.classList.toggle("selected", b === e.currentTarget);
          update();
        },
      }, o)))];
  }
  submit.addEventListener("click", async () => {
    submit.disabled = true;
    stopAll();
    try {
      await api("POST", `/api/p/${encodeURIComponent(token)}/answer`,
        { trial_index: trial.index, ...answer, response_ms: Math.round(performance.now() - t0) });
    } catch (e) {
      if (e.status !== 409) { showError(e.detail || e.message); submit.disabled = false; return; }
    }
    refresh();
  });
  if (trial.kind === "attention") players.length = 0;
  main.replaceChildren(...[phaseLabel, ...body, h("div", { class: "actions" }, submit)].filter(Boolean));
  main.dataset.trial = trial.index;
  update();
}

async function boot() {
  try { info = await api("GET", "/api/test"); } catch (e) { showError(e.message); return; }
  document.title = info.title; $("#title").textContent = info.title;
  storageKey = `headmotion-listen:${info.name}`;
  window.__listen = { info };  // for scripted tests
  token = localStorage.getItem(storageKey);
  if (token) return refresh();
  renderConsent();
}
boot();
