// headmotion serve example: microphone → stream() of the browser client (@headmotion/client, served at
// /v1/example/static/client/) → frames → the bundled three.js head.  Latency of a frame at audio time t:
// arrival time minus the wall time at which sample t·sr was sent.  window.headmotionExample exposes the
// state (tests, console).
import { mountViewer } from "/v1/example/viewer/viewer.js";
import { stream } from "/v1/example/static/client/index.js";

const $ = (id) => document.getElementById(id);
const st = window.headmotionExample = { status: "idle", frames: 0, last: null, latencies: [], error: null,
  ready: null, closed: null, received: [] };
let media = null, abort = null;
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

async function start() {
  await stop();
  Object.assign(st, { frames: 0, last: null, latencies: [], error: null, ready: null, closed: null, received: [] });
  $("error").textContent = "";
  media = await navigator.mediaDevices.getUserMedia({ audio: { echoCancellation: false, noiseSuppression: false, autoGainControl: false } });
  abort = new AbortController();
  const onReady = (m) => { st.ready = m; setStatus(`streaming: ${m.model} (${m.system}), lookahead ${m.latency_ms.toFixed(0)} ms`); };
  const apiKey = $("key").value || undefined;  // sent in the start message: a browser cannot set the header
  $("stop").disabled = false;
  (async () => {
    try {
      for await (const b of stream(media, { apiKey, signal: abort.signal, onReady })) {
        b.frames.forEach((f, i) => {
          st.latencies.push(b.latencyMs[i]); if (st.latencies.length > 2000) st.latencies.splice(0, 1000);
          st.last = f.rotvec; st.frames += 1;
          if (st.received.length < 5000) st.received.push([f.frame, f.rotvec]);
        });
        dirty = true;
      }
      st.closed = { code: 1000, reason: "" };
    } catch (e) {
      st.closed = { code: e.code ?? null, reason: e.detail ?? "" };
      fail(e.kind ? `${e.kind}: ${e.detail}` : String(e));
    }
  })();
}

async function stop() {
  if (abort) abort.abort();  // the client sends the end message; the last frames still arrive
  abort = null;
  if (media) media.getTracks().forEach((t) => t.stop());
  media = null;
  $("stop").disabled = true;
}

$("mic").addEventListener("click", () => start().catch((e) => fail(`microphone: ${e}`)));
$("stop").addEventListener("click", () => { stop(); setStatus("stopped"); });
