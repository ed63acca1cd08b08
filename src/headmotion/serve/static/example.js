// headmotion serve example: microphone → WebSocket /v1/stream (s16le, ~10 ms messages) → frames → the
// bundled three.js head.  Latency of a frame at audio time t: arrival time minus the wall time at which
// sample t·sr was captured.  window.headmotionExample exposes the state (tests, console).
import { mountViewer } from "/v1/example/viewer/viewer.js";

const $ = (id) => document.getElementById(id);
const st = window.headmotionExample = { status: "idle", frames: 0, last: null, latencies: [], error: null,
  ready: null, closed: null, received: [] };
let ctx = null, ws = null, media = null, pending = [], pendingN = 0, sent = 0, sr = 48000, t0 = 0;
let viewer = null, dirty = false;

function setStatus(s) { st.status = s; $("status").textContent = s; }
function fail(msg) { st.error = msg; $("error").textContent = msg; }
function quantile(a, q) { const s = [...a].sort((x, y) => x - y); return s[Math.min(s.length - 1, Math.floor(q * (s.length - 1) + 0.5))]; }

try {
  viewer = await mountViewer($("viewer"), { motion: { fps: 100, rotvec: [[0, 0, 0]] }, controls: false });
  document.body.dataset.ready = "1";
} catch (e) { fail(String(e && e.stack || e)); document.body.dataset.ready = "error"; }

function draw() {
  if (dirty && viewer && st.last) {
    const r = viewer.motions[0].rotvec; r[0] = st.last[0]; r[1] = st.last[1]; r[2] = st.last[2];
    viewer.renderNow(); dirty = false;
    const l = st.latencies.slice(-200);
    $("stats").textContent = l.length ? `${st.frames} frames · latency median ${quantile(l, 0.5).toFixed(0)} ms, p95 ${quantile(l, 0.95).toFixed(0)} ms` : "";
  }
  requestAnimationFrame(draw);
}
requestAnimationFrame(draw);

function sendPending() {  // ~10 ms messages of 16-bit PCM
  const want = Math.round(sr / 100);
  while (pendingN >= want) {
    const out = new Int16Array(want); let k = 0;
    while (k < want) {
      const h = pending[0], take = Math.min(h.length, want - k);
      for (let i = 0; i < take; i++) out[k + i] = Math.max(-32768, Math.min(32767, Math.round(h[i] * 32767)));
      k += take;
      if (take === h.length) pending.shift(); else pending[0] = h.subarray(take);
    }
    pendingN -= want;
    if (ws && ws.readyState === 1 && st.ready) {
      if (sent === 0) t0 = performance.now() - want / sr * 1000;  // wall time of the first sample sent
      ws.send(out.buffer); sent += want;
    }
  }
}

async function start() {
  await stop();
  Object.assign(st, { frames: 0, last: null, latencies: [], error: null, ready: null, closed: null, received: [] });
  $("error").textContent = ""; pending = []; pendingN = 0; sent = 0;
  ctx = new AudioContext(); sr = ctx.sampleRate;
  await ctx.audioWorklet.addModule("/v1/example/static/example-worklet.js");
  media = await navigator.mediaDevices.getUserMedia({ audio: { echoCancellation: false, noiseSuppression: false, autoGainControl: false } });
  const src = ctx.createMediaStreamSource(media), tap = new AudioWorkletNode(ctx, "hm-tap"), sink = ctx.createGain();
  sink.gain.value = 0; src.connect(tap); tap.connect(sink); sink.connect(ctx.destination);
  tap.port.onmessage = (e) => { pending.push(e.data); pendingN += e.data.length; sendPending(); };
  ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/v1/stream`);
  ws.binaryType = "arraybuffer";
  ws.onopen = () => {
    // a live microphone: the low-delay resampling (frames need not equal an offline answer)
    const first = { type: "start", sample_rate: sr, encoding: "s16le", frames: "json", resample: "fast" };
    if ($("key").value) first.api_key = $("key").value;  // a browser cannot set the Authorization header here
    ws.send(JSON.stringify(first));
  };
  ws.onmessage = (e) => {
    const m = JSON.parse(e.data), now = performance.now();
    if (m.type === "ready") { st.ready = m; sent = 0; setStatus(`streaming: ${m.model} (${m.system}), lookahead ${m.latency_ms.toFixed(0)} ms`); return; }
    if (m.type === "error") { fail(`${m.error}: ${m.detail}`); return; }
    if (m.type !== "frames") return;
    for (const f of m.frames) {
      st.latencies.push(now - (t0 + f.time * 1000)); if (st.latencies.length > 2000) st.latencies.splice(0, 1000);
      st.last = f.rotvec; st.frames += 1;
      if (st.received.length < 5000) st.received.push([f.frame, f.rotvec]);
    }
    dirty = true;
  };
  ws.onclose = (e) => { st.closed = { code: e.code, reason: e.reason }; if (st.status.startsWith("streaming")) setStatus(`closed (${e.code} ${e.reason})`); };
  $("stop").disabled = false;
}

async function stop() {
  if (ws && ws.readyState === 1) ws.send(JSON.stringify({ type: "end" }));
  ws = null;
  if (media) media.getTracks().forEach((t) => t.stop());
  media = null;
  if (ctx) { try { await ctx.close(); } catch (e) { /* closed */ } ctx = null; }
  $("stop").disabled = true;
}

$("mic").addEventListener("click", () => start().catch((e) => fail(`microphone: ${e}`)));
$("stop").addEventListener("click", () => { stop(); setStatus("stopped"); });
