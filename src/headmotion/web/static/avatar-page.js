// headmotion avatar page (/v1/avatar): microphone or file → stream() of @headmotion/client
// (WS /v1/stream) → frames → the VRM avatar's neck and head bones (avatar.js, bundled three.js and
// @pixiv/three-vrm).  Query: input=mic|file, autostart=1 (mic: start at once), model, resample
// (exact default | fast), role=listen (the head hears the input instead of speaking it; listening=0..3),
// lookahead_ms (0..1080: the model reads the speech that far ahead; a file is then heard that much
// later, so the head, whose frames come that much later, moves with the voice), vrm (a VRM file on
// this server), record=1 (keep the audio sent, for tests).
//
// window.headmotionAvatar (tests, integrators, the console):
//   headRotation()  [pitch, yaw, roll] degrees: the head bone against its rest pose (the avatar's
//                   axes: +x its left, +y up, +z forward; intrinsic YXZ), read back from the bones
//   latencyMs()     the newest frame's latency: the time its bones were set minus the time the page
//                   had the frame's audio (null before the first frame)
//   latencyStats()  {median, p95, n} over the last 200 frames
//   shown           [{frame, time, at, latencyMs, rotation, audioTime}]: each frame put on the bones
//                   (the newest of each batch; `at` performance.now(), `rotation` headRotation() just
//                   after, `audioTime` the audio the server had when it sent the frame)
//   renderMs        the last 200 draws' durations
//   frames, status, error, ready (the server's ready message), ended
//   start("mic" | File), stop(), setRotvec([rx, ry, rz]) (drive the bones from another source)
//   follow(message, given)  an agent's message (audio-start, frames, end) timed by the audio the page
//                   plays: `given` the seconds of the agent's audio the page's player had been given
//                   when it came.  A frame goes on the bones once played() reaches its place in that
//                   audio (its utterance's audio-start plus its time), so a gap in the audio's way or
//                   in playback holds the head as long as the voice; settling frames go on at their
//                   pace once the player is idle; listening frames (and frames with no utterance) once
//                   the audio given with them has played.  Returns {shownAt, rotation}, filled in then
//   played(position, idle)  seconds of the agent's audio the player has played (or dropped); idle:
//                   it has played all it was given
//   sentAudio()     {sampleRate, encoding, base64} of the audio sent (with record=1)
//   audioDelayS()   seconds by which the page delays the file it plays aloud (the whole frames of
//                   lookahead_ms; 0 without a lookahead, or for the microphone)
import { mountAvatar } from "./avatar.js";
import { stream } from "../client/index.js";

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);
const KEEP = 20000;
let avatar = null, abort = null, media = null, player = null, dirty = false;
let t0 = Infinity, sentSamples = 0, sampleRate = null, sent = [];

function quantile(a, q) {
  if (!a.length) return null;
  const s = [...a].sort((x, y) => x - y);
  return s[Math.min(s.length - 1, Math.floor(q * (s.length - 1) + 0.5))];
}
const st = window.headmotionAvatar = {
  status: "loading", error: null, ready: null, frames: 0, ended: false, shown: [], renderMs: [],
  headRotation: () => (avatar ? avatar.headRotation() : null),
  latencyMs: () => (st.shown.length ? st.shown[st.shown.length - 1].latencyMs : null),
  latencyStats() {
    const l = st.shown.slice(-200).map((s) => s.latencyMs).filter((x) => x !== null);
    return { median: quantile(l, 0.5), p95: quantile(l, 0.95), n: l.length };
  },
  setRotvec(r) { if (avatar) { avatar.setRotvec(r); dirty = true; } },
  audioDelayS: () => (player && player.delay ? player.delay.delayTime.value : 0),
  follow: (message, given) => follow(message, given),
  played: (position, idle) => played(position, idle),
  start: (what) => start(what),
  stop: () => stop(),
  sentAudio() {
    const n = sent.reduce((k, b) => k + b.byteLength, 0), all = new Uint8Array(n);
    let k = 0;
    for (const b of sent) { all.set(new Uint8Array(b), k); k += b.byteLength; }
    let bin = "";
    for (let i = 0; i < all.length; i += 0x8000) bin += String.fromCharCode.apply(null, all.subarray(i, i + 0x8000));
    return { sampleRate, encoding: "s16le", base64: btoa(bin) };
  },
};

function setStatus(s) { st.status = s; $("status").textContent = s; }
function fail(msg) { st.error = msg; $("error").textContent = msg; }

function draw() {
  if (waiting.length) release();
  if (dirty && avatar) {
    const t = performance.now();
    avatar.renderNow(); dirty = false;
    st.renderMs.push(performance.now() - t); if (st.renderMs.length > 200) st.renderMs.shift();
    const l = st.latencyStats();
    $("stats").textContent = l.n ? `${st.frames} frames · latency median ${l.median.toFixed(0)} ms, p95 ${l.p95.toFixed(0)} ms` : "";
  }
  requestAnimationFrame(draw);
}

/** The audio the client sent: the wall time of audio time 0 is the earliest bound its sends give
 * (a chunk ending at sample n cannot be sent before the page had sample n). */
function onAudio(pcm, at) {
  sentSamples += pcm.byteLength / 2;
  t0 = Math.min(t0, at - (sentSamples / sampleRate) * 1000);
  if (params.get("record") === "1") sent.push(pcm);
}

function show(batch) {
  const f = batch.frames[batch.frames.length - 1];
  avatar.setRotvec(f.rotvec);
  const at = performance.now();
  const latency = Number.isFinite(t0) ? at - (t0 + f.time * 1000) : null;
  st.shown.push({ frame: f.frame, time: f.time, at, latencyMs: latency, rotation: avatar.headRotation(),
    audioTime: batch.audioTime });
  if (st.shown.length > KEEP) st.shown.splice(0, st.shown.length - KEEP);
  st.frames += batch.frames.length;
  dirty = true;
}

// Frames waiting for their audio to play (follow/played).  An agent's integration marks where each
// utterance's audio begins (an audio-start message in order with the audio), so a frame's place in
// the audio the player was given is that start plus its time, however the audio was delayed on its
// way or in the player.  Settling frames go on at their own pace from the end of the voice: when
// the player has played the utterance's audio (up to the first settling frame's place) or, after an
// interruption, when it has played all it was given.  A listening turn's frames (made from the
// user's audio), and frames from a source that marks no utterance, go on when the player has played
// the audio it had when they came.
const waiting = [];
const starts = new Map();  // utterance → where its audio begins in the audio given to the player (s)
const settles = new Map();  // utterance → {time of its first settling frame, when the voice ended}
let playedTo = -Infinity, idle = false;

function follow(message, given) {
  const entry = { shownAt: null, rotation: null };
  if (message && message.type === "audio-start") {
    starts.set(message.utterance, given);
    for (const m of [starts, settles]) for (const u of m.keys()) if (u < message.utterance - 8) m.delete(u);
    for (const w of waiting) if (w.utterance === message.utterance) w.target = given + w.time;
  } else if (message && message.type === "frames" && message.frames.length) {
    const f = message.frames[message.frames.length - 1], u = message.utterance;
    let target = given, settle = null;
    if (u !== undefined && !message.listening) target = starts.has(u) ? starts.get(u) + f.time : Infinity;
    if (message.settling) {
      if (!settles.has(u)) settles.set(u, { time: message.frames[0].time, ended: null, cut: !!message.interrupted });
      settle = settles.get(u);
    }
    waiting.push({ message, utterance: u, time: f.time, target, settle, entry });
  }
  release();
  return entry;
}

function played(position, isIdle = false) {
  playedTo = Math.max(playedTo, position);
  idle = !!isIdle;
  release();
}

/** Whether a settling frame is due: its time after the first settling frame has passed since the
 * voice ended. */
function settled(w, now) {
  const s = w.settle, start = starts.get(w.utterance);
  if (s.ended === null) {
    const spoken = start !== undefined && playedTo >= start + s.time - 0.01;
    if (spoken || (s.cut && idle) || (start === undefined && idle)) s.ended = now;
  }
  return s.ended !== null && now - s.ended >= 1000 * (w.time - s.time) - 1e-6;
}

/** Put on the bones the newest frame due (those before it go by). */
function release() {
  const now = performance.now();
  let k = -1;
  for (let i = 0; i < waiting.length; i += 1) {  // a settling is not cut short by what comes after it
    const w = waiting[i], due = w.settle ? settled(w, now) : w.target <= playedTo + 1e-9;
    if (due) k = i;
    else if (w.settle) break;
  }
  for (let i = 0; i < k; i += 1) {  // a settling ends on its last frame before the next turn's come
    if (waiting[i].settle && waiting[i].utterance !== waiting[k].utterance && !waiting[i + 1].settle) k = i;
  }
  if (k < 0 || !avatar) return;
  const due = waiting.splice(0, k + 1), m = due[k].message, f = m.frames[m.frames.length - 1];
  avatar.setRotvec(f.rotvec);
  const at = performance.now(), rotation = avatar.headRotation();
  for (const d of due) Object.assign(d.entry, { shownAt: at, rotation });
  st.shown.push({ frame: f.frame, time: f.time, at, latencyMs: null, rotation, audioTime: m.audio_time });
  if (st.shown.length > KEEP) st.shown.splice(0, st.shown.length - KEEP);
  st.frames += due.reduce((n, d) => n + d.message.frames.length, 0);
  dirty = true;
}

async function source(what) {
  if (what === "mic") {
    return navigator.mediaDevices.getUserMedia({ audio: { echoCancellation: false, noiseSuppression: false,
      autoGainControl: false } });
  }
  // a file: played aloud, and its sound captured as the microphone would be; with a lookahead the
  // stream's frames come that much later, so what is heard is delayed by as much
  const ctx = new AudioContext();
  const buffer = await ctx.decodeAudioData(await what.arrayBuffer());
  const src = ctx.createBufferSource(), out = ctx.createMediaStreamDestination();
  src.buffer = buffer; src.connect(out);
  let delay = null;  // its time is set from the ready message: the whole frames the model reads ahead
  if (lookaheadMs() > 0) {
    delay = ctx.createDelay(Math.max(1, 2 * lookaheadMs() / 1000));
    src.connect(delay); delay.connect(ctx.destination);
  } else {
    src.connect(ctx.destination);
  }
  src.onended = () => { if (abort) abort.abort(); };
  player = { ctx, src, delay, start: () => src.start() };
  return out.stream;
}

/** The lookahead asked for (ms; the query's lookahead_ms, 0 without); the server checks its range. */
function lookaheadMs() {
  const v = params.get("lookahead_ms");
  return v === null || v === "" ? 0 : Number(v);
}

async function start(what) {
  await stop();
  Object.assign(st, { error: null, ready: null, frames: 0, ended: false, shown: [] });
  t0 = Infinity; sentSamples = 0; sent = [];
  $("error").textContent = "";
  media = await source(what);
  abort = new AbortController();
  const options = { apiKey: $("key").value || undefined, signal: abort.signal, onAudio,
    resample: params.get("resample") || "exact" };
  if (params.get("model")) options.model = params.get("model");
  if (params.get("lookahead_ms") !== null) options.lookaheadMs = lookaheadMs();
  if (params.get("role") === "listen") {  // the avatar listens to the microphone (or file) rather than speaking it
    options.role = "listen";
    if (params.get("listening")) options.listening = Number(params.get("listening"));
  }
  options.onReady = (m) => {
    st.ready = m; sampleRate = m.sample_rate;  // the capture's rate, as the start message declared it
    setStatus(`${options.role === "listen" ? "listening to" : "streaming"} (${what === "mic" ? "microphone" : "file"}): ${m.model} (${m.system}), lookahead ${m.latency_ms.toFixed(0)} ms`);
    if (player && player.delay) player.delay.delayTime.value = Math.floor(lookaheadMs() * m.fps / 1000 + 1e-9) / m.fps;
    if (player) player.start();
  };
  $("stop").disabled = false;
  sampleRate = null;
  try {
    for await (const b of stream(media, options)) show(b);
    st.ended = true;
    setStatus("ended");
  } catch (e) {
    fail(e.kind ? `${e.kind}: ${e.detail}` : String(e));
  } finally {
    $("stop").disabled = true;
  }
}

async function stop() {
  if (abort) abort.abort();  // the client sends the end message; the last frames still arrive
  abort = null;
  if (media) media.getTracks().forEach((t) => t.stop());
  media = null;
  if (player) { try { player.src.stop(); } catch (e) { /* not started */ } player.ctx.close().catch(() => {}); }
  player = null;
}

try {
  const vrmUrl = params.get("vrm") || undefined;
  avatar = await mountAvatar($("avatar"), { vrmUrl, width: 640, height: 480 });
  setStatus("ready");
  document.body.dataset.ready = "1";
  requestAnimationFrame(draw);
} catch (e) {
  fail(String(e && e.stack || e));
  document.body.dataset.ready = "error";
}
$("mic").addEventListener("click", () => start("mic").catch((e) => fail(`microphone: ${e}`)));
$("file").addEventListener("change", (ev) => { const f = ev.target.files[0]; if (f) start(f).catch((e) => fail(`file: ${e}`)); });
$("stop").addEventListener("click", () => { stop(); setStatus("stopped"); });
if (avatar && params.get("autostart") === "1" && (params.get("input") || "mic") === "mic") {
  start("mic").catch((e) => fail(`microphone: ${e}`));
}
