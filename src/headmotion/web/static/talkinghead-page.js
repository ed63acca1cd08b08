// headmotion TalkingHead page (/v1/talkinghead): a TalkingHead avatar (vendor/talkinghead.js, bundled
// with three.js) whose neck and head follow WS /v1/stream through driveTalkingHead of
// @headmotion/client.  The avatar is the project's (talkinghead.glb beside this script).  Query:
// input=mic (the microphone is the other party: heard, so the head listens while the user talks),
// autostart=1 (with input=mic: ask for the microphone at once), model, lookahead_ms (0..1080: the
// stream reads that far ahead; streamed audio is held by its whole frames), listening (0..3),
// fps (TalkingHead's frame rate: 30, or 15 where WebGL is drawn by the CPU), glb (another Ready Player
// Me–style avatar on this server), record=1 (keep the audio sent, for tests).
//
// window.headmotionTalkingHead (tests, integrators, the console):
//   headRotation()  [pitch, yaw, roll] degrees: the head bone against its bind pose relative to the
//                   chest, in the project's axes (intrinsic YXZ), read back from the bones
//   latencyMs(), latencyStats()   the driver's: bone time minus the time the frame's audio played
//   shown, frames, ready, error   the driver's (client/talkinghead.js)
//   status, head (the TalkingHead), driver
//   start(mic)      (re)start the driver, with the microphone heard when `mic`
//   stop()          stop driving: TalkingHead moves the head again
//   speak(bytes)    an audio file (ArrayBuffer or Blob) decoded and given to head.speakAudio, with
//                   visemes from its level (the page's stand-in for a TTS's timing); resolves when
//                   it has been played
//   streamFile(bytes, {sampleRate, chunkMs, speed})  the file as a TTS stream: streamStart({sampleRate})
//                   and streamAudio chunks of chunkMs (default 100) at `speed` times the pace of
//                   real time (default 1), then streamNotifyEnd; resolves when it has been played
//   sentAudio(), audioDelayS()    the driver's
import { TalkingHead } from "./vendor/talkinghead.js";
import { driveTalkingHead } from "../client/talkinghead.js";

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);
let head = null, driver = null, mic = null;

const st = window.headmotionTalkingHead = {
  status: "loading", error: null, head: null, driver: null,
  get shown() { return driver ? driver.shown : []; },
  get frames() { return driver ? driver.frames : 0; },
  get ready() { return driver ? driver.ready : null; },
  headRotation: () => (driver ? driver.headRotation() : null),
  latencyMs: () => (driver ? driver.latencyMs() : null),
  latencyStats: () => (driver ? driver.latencyStats() : { median: null, p95: null, n: 0 }),
  sentAudio: () => (driver ? driver.sentAudio() : null),
  audioDelayS: () => (driver ? driver.audioDelayS() : 0),
  start: (withMic) => start(withMic),
  stop: () => stop(),
  speak: (bytes) => speak(bytes),
  streamFile: (bytes, o) => streamFile(bytes, o),
};

function setStatus(s) { st.status = s; $("status").textContent = s; }
function fail(msg) { st.error = msg; $("error").textContent = msg; }

/** WebGL drawn by the CPU (SwiftShader, llvmpipe: a browser without a GPU)? */
function softwareGL() {
  try {
    const gl = document.createElement("canvas").getContext("webgl2");
    if (!gl) return true;
    const ext = gl.getExtension("WEBGL_debug_renderer_info");
    const name = String(gl.getParameter(ext ? ext.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
    const lose = gl.getExtension("WEBGL_lose_context");
    if (lose) lose.loseContext();
    return /swiftshader|llvmpipe|software/i.test(name);
  } catch (e) {
    return true;
  }
}

async function start(withMic) {
  await stop();
  if (withMic) {
    mic = await navigator.mediaDevices.getUserMedia({ audio: { echoCancellation: false, noiseSuppression: false,
      autoGainControl: false } });
  }
  const options = { apiKey: $("key").value || undefined, record: params.get("record") === "1", hear: mic || undefined,
    onError: (e) => fail(e.kind ? `${e.kind}: ${e.detail}` : String(e)),
    onReady: (m) => setStatus(`driving${mic ? ", listening to the microphone" : ""}: ${m.model} (${m.system}), lookahead ${m.latency_ms.toFixed(0)} ms`) };
  if (params.get("model")) options.model = params.get("model");
  if (params.get("lookahead_ms")) options.lookaheadMs = Number(params.get("lookahead_ms"));
  if (params.get("listening")) options.listening = Number(params.get("listening"));
  st.error = null; $("error").textContent = "";
  driver = st.driver = await driveTalkingHead(head, options);
  $("stop").disabled = false;
}

async function stop() {
  if (driver) driver.stop();
  driver = st.driver = null;
  if (mic) mic.getTracks().forEach((t) => t.stop());
  mic = null;
  $("stop").disabled = true;
}

async function bytesOf(x) { return x instanceof ArrayBuffer ? x.slice(0) : x.arrayBuffer(); }

/** 'aa' visemes where the voice is loud (80 ms steps): times and durations in ms. */
function visemes(x, rate) {
  const step = Math.round(rate * 0.08), out = { visemes: [], vtimes: [], vdurations: [] };
  for (let i = 0; i + step <= x.length; i += step) {
    let e = 0;
    for (let k = i; k < i + step; k++) e += x[k] * x[k];
    if (Math.sqrt(e / step) > 0.02) { out.visemes.push("aa"); out.vtimes.push(1000 * i / rate); out.vdurations.push(80); }
  }
  return out;
}

function until(test) {
  return new Promise((resolve) => { const poll = () => (test() ? resolve() : setTimeout(poll, 50)); poll(); });
}

async function speak(bytes) {
  const buffer = await head.audioCtx.decodeAudioData(await bytesOf(bytes));
  const v = visemes(buffer.getChannelData(0), buffer.sampleRate);
  head.speakAudio({ audio: buffer, words: [], ...v });
  await until(() => head.isSpeaking);
  await until(() => !head.isSpeaking);
}

async function streamFile(bytes, o = {}) {
  const rate = o.sampleRate || head.audioCtx.sampleRate, chunkMs = o.chunkMs || 100, pace = chunkMs / (o.speed || 1);
  const x = (await new OfflineAudioContext(1, 1, rate).decodeAudioData(await bytesOf(bytes))).getChannelData(0);
  let ended = false;
  await head.streamStart({ sampleRate: rate, lipsyncType: "visemes", waitForAudioChunks: true }, null, () => { ended = true; });
  const n = Math.round(rate * chunkMs / 1000), t0 = performance.now();
  for (let i = 0, k = 0; i < x.length; i += n, k += 1) {
    const chunk = x.subarray(i, Math.min(x.length, i + n)), pcm = new Int16Array(chunk.length);
    for (let j = 0; j < chunk.length; j++) pcm[j] = Math.max(-32768, Math.min(32767, Math.round(chunk[j] * 32767)));
    const v = visemes(chunk, rate);
    head.streamAudio({ audio: pcm.buffer, ...v, vtimes: v.vtimes.map((t) => t + 1000 * i / rate) });
    const wait = t0 + (k + 1) * pace - performance.now();
    if (wait > 0) await new Promise((r) => setTimeout(r, wait));
  }
  head.streamNotifyEnd();
  await until(() => ended || !head.isStreaming);
}

try {
  const software = softwareGL();  // then a quarter of the pixels, 15 frames a second: drawing on the CPU
  head = st.head = new TalkingHead($("avatar"), {  // at 30 held the page's thread from the audio and the stream
    ttsEndpoint: "", lipsyncModules: ["en"], lipsyncLang: "en", cameraView: "upper",
    modelPixelRatio: software ? 0.5 : 1, modelFPS: Number(params.get("fps")) || (software ? 15 : 30), avatarMood: "neutral",
  });
  await head.showAvatar({ url: params.get("glb") || new URL("./talkinghead.glb", import.meta.url).href, body: "M",
    lipsyncLang: "en", avatarMood: "neutral" });
  const withMic = params.get("input") === "mic" && params.get("autostart") === "1";
  await start(withMic);
  if (!withMic) setStatus("ready: speak or stream a file, or listen to the microphone");
  document.body.dataset.ready = "1";
} catch (e) {
  fail(String(e && e.stack || e));
  document.body.dataset.ready = "error";
}
const guard = (p, what) => p.catch((e) => fail(`${what}: ${e}`));
$("speak").addEventListener("change", (ev) => { const f = ev.target.files[0]; if (f) guard(speak(f), "speak"); });
$("streamfile").addEventListener("change", (ev) => { const f = ev.target.files[0]; if (f) guard(streamFile(f), "stream"); });
$("mic").addEventListener("click", () => guard(start(true), "microphone"));
$("stop").addEventListener("click", () => { stop(); setStatus("stopped: TalkingHead moves the head"); });
setInterval(() => {
  const l = st.latencyStats();
  $("stats").textContent = l.n ? `${st.frames} frames · latency median ${l.median.toFixed(0)} ms, p95 ${l.p95.toFixed(0)} ms` : "";
}, 500);
