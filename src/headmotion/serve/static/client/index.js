// @headmotion/client — head motion from speech in the browser, from a `headmotion serve` server.
//
//   import { motion, stream } from "/v1/example/static/client/index.js";   // or from the npm package
//   const doc = await motion(file, { model: "default", seed: 3 });         // POST /v1/motion → JSON
//   for await (const batch of stream(mediaStreamOrChunks, { sampleRate })) // WS /v1/stream
//     head.setRotation(batch.frames.at(-1).rotvec);
//
// No dependency and nothing fetched at run time but the server's own routes.  The protocol is in
// docs/serve.md and /asyncapi.json.

const DEFAULT_URL = () => (typeof location !== "undefined" ? location.origin : "http://127.0.0.1:8000");
const HEADER = 24; // <4s I I f d>: b"HMF1", first frame, count, fps, audio seconds received

/** A refusal of the server: `kind` (e.g. "bad_parameter", "unauthorized"), `detail`, the HTTP
 * `status` (offline calls) or WebSocket close `code` (streams), and `retryAfter` seconds when the
 * server said when to try again. */
export class HeadmotionError extends Error {
  constructor(kind, detail, { status = null, code = null, retryAfter = null } = {}) {
    super(`${kind}: ${detail}`);
    this.name = "HeadmotionError";
    Object.assign(this, { kind, detail, status, code, retryAfter });
  }
}

const OFFLINE_CONTROLS = ["model", "seed", "samples", "gain", "gain_pitch", "gain_yaw", "gain_roll", "offset",
  "offset_pitch", "offset_yaw", "offset_roll", "still", "fps", "format"];

function query(options, names) {
  const q = new URLSearchParams();
  for (const k of names) {
    const v = options[k];
    if (v === undefined || v === null) continue;
    q.set(k, Array.isArray(v) ? v.join(",") : String(v));
  }
  return q;
}

function authHeaders(apiKey) { return apiKey ? { authorization: `Bearer ${apiKey}` } : {}; }

/**
 * Head motion for a speech file: `POST /v1/motion`.
 *
 * @param {Blob|File|ArrayBuffer|Float32Array|Int16Array} file  a wav/flac/ogg/mp3 file, or raw mono
 *   samples (then `options.sampleRate` is required; Float32Array is sent as f32le, Int16Array as s16le)
 * @param {object} options  `url` (default: this page's origin), `apiKey`, and the controls `model`,
 *   `seed`, `samples`, `gain`, `gain_pitch`…, `offset` (degrees), `offset_pitch`…, `still`, `fps`,
 *   `format` ("json" default, "bvh", "npz", "csv", "gltf", "glb"), `signal` (AbortSignal)
 * @returns {Promise<object|Blob>} the JSON document for "json", else the file as a Blob
 */
export async function motion(file, options = {}) {
  const url = (options.url || DEFAULT_URL()).replace(/\/$/, "");
  const q = query(options, OFFLINE_CONTROLS);
  let body = file, type = file && file.type ? file.type : "application/octet-stream";
  if (file instanceof Float32Array || file instanceof Int16Array) {
    if (!options.sampleRate) throw new HeadmotionError("bad_parameter", "raw samples need options.sampleRate");
    q.set("encoding", file instanceof Float32Array ? "f32le" : "s16le");
    q.set("sample_rate", String(options.sampleRate));
    body = new Blob([littleEndian(file)]);
    type = "application/octet-stream";
  }
  const r = await fetch(`${url}/v1/motion?${q}`, {
    method: "POST", body, signal: options.signal,
    headers: { "content-type": type, ...authHeaders(options.apiKey) },
  });
  if (!r.ok) {
    let d = {};
    try { d = await r.json(); } catch (e) { d = { error: "http", detail: `${r.status}` }; }
    const retry = r.headers.get("retry-after");
    throw new HeadmotionError(d.error || "http", d.detail || String(r.status),
      { status: r.status, retryAfter: retry === null ? null : Number(retry) });
  }
  return (options.format || "json") === "json" ? r.json() : r.blob();
}

function littleEndian(x) {
  // typed arrays are in the platform's byte order: little-endian on every browser platform; checked
  const probe = new Uint8Array(new Uint16Array([1]).buffer)[0] === 1;
  if (!probe) throw new HeadmotionError("bad_parameter", "big-endian platform: send PCM bytes instead");
  return x.buffer.slice(x.byteOffset, x.byteOffset + x.byteLength);
}

/** An async queue: `push(v)`, `end()`, `fail(e)`, and `for await` over what was pushed. */
function channel() {
  const items = []; let waiting = null, done = false, error = null;
  const wake = () => { if (waiting) { const w = waiting; waiting = null; w(); } };
  return {
    push(v) { items.push(v); wake(); },
    end() { done = true; wake(); },
    fail(e) { error = e; wake(); },
    get size() { return items.length; },
    async *[Symbol.asyncIterator]() {
      for (;;) {
        if (error) throw error;
        if (items.length) { yield items.shift(); continue; }
        if (done) return;
        await new Promise((r) => { waiting = r; });
      }
    },
  };
}

/** Chunks of a MediaStream (the microphone): Float32Array blocks of `chunkMs` of its first channel,
 * through an AudioWorklet (the module's own file); stops when `signal` aborts or the tracks end. */
async function capture(media, signal, chunkMs = 20) {
  const ctx = new AudioContext();
  if (ctx.state === "suspended" && typeof document !== "undefined") {  // no user gesture yet (autoplay policy)
    const resume = () => ctx.resume().catch(() => {});
    for (const ev of ["pointerdown", "keydown"]) document.addEventListener(ev, resume, { once: true });
  }
  await ctx.audioWorklet.addModule(new URL("./capture-worklet.js", import.meta.url));
  const src = ctx.createMediaStreamSource(media), tap = new AudioWorkletNode(ctx, "headmotion-capture",
    { processorOptions: { samples: Math.round(ctx.sampleRate * chunkMs / 1000) } });
  const sink = ctx.createGain(); sink.gain.value = 0;
  src.connect(tap); tap.connect(sink); sink.connect(ctx.destination);
  const ch = channel();
  tap.port.onmessage = (e) => ch.push(e.data);
  let stopped = false;
  const stop = () => { if (stopped) return; stopped = true; ch.end(); ctx.close().catch(() => {}); };
  if (signal) signal.addEventListener("abort", stop, { once: true });
  for (const t of media.getAudioTracks()) t.addEventListener("ended", stop, { once: true });
  return { chunks: ch, sampleRate: ctx.sampleRate, stop };
}

function base64(buffer) {
  const b = new Uint8Array(buffer);
  let s = "";
  for (let i = 0; i < b.length; i += 0x8000) s += String.fromCharCode.apply(null, b.subarray(i, i + 0x8000));
  return btoa(s);
}

function toPcm(chunk, encoding) {
  if (chunk instanceof ArrayBuffer) return chunk;
  if (ArrayBuffer.isView(chunk) && !(chunk instanceof Float32Array) && !(chunk instanceof Int16Array)) {
    return chunk.buffer.slice(chunk.byteOffset, chunk.byteOffset + chunk.byteLength);  // PCM bytes as they are
  }
  let x = chunk;
  if (encoding === "s16le" && x instanceof Float32Array) {
    const out = new Int16Array(x.length);
    for (let i = 0; i < x.length; i++) out[i] = Math.max(-32768, Math.min(32767, Math.round(x[i] * 32767)));
    x = out;
  } else if (encoding === "f32le" && x instanceof Int16Array) {
    const out = new Float32Array(x.length);
    for (let i = 0; i < x.length; i++) out[i] = x[i] / 32768;
    x = out;
  }
  return littleEndian(x);
}

/**
 * Head motion as the speech comes: `WS /v1/stream`.  Yields batches of frames as the server makes
 * them final: `{first, fps, audioTime, frames: [{frame, time, rotvec: [3] radians,
 * pitchYawRollDeg: [3]}], latencyMs: [per frame: arrival minus the wall time its audio was sent,
 * meaningful for a live source]}`; returns after the last frames of the source.
 *
 * @param {MediaStream|AsyncIterable|Iterable} source  a MediaStream (the microphone: captured at
 *   the audio device's rate, until `options.signal` aborts or its tracks end), or chunks of mono
 *   samples: Float32Array, Int16Array or PCM ArrayBuffer (`options.sampleRate` required)
 * @param {object} options  `url` (default: this page's origin), `apiKey` (sent in the start message:
 *   a browser's WebSocket cannot set headers), `sampleRate`, `encoding` ("s16le" default, "f32le"),
 *   `model`, `seed`, `gain`, `offset` (degrees), `still`, `resample` ("exact" default; "fast" for a
 *   live source), `frames` ("binary" default, "json"), `chunkMs` (a MediaStream's audio per message,
 *   default 20), `role` ("speak" default; "listen": the source is the other party's audio, sent as
 *   hear messages with as much silence as the avatar's own speech), `listening` (0 to 3, with
 *   "listen"), `settle` (seconds the head takes to ease to rest after the end, 0 to 5; default 0),
 *   `lookaheadMs` (how far ahead a live model reads the speech, 0 to 1080 ms, for speech made before
 *   it plays: the frames come that much later, the ready message's `latency_ms`; default 0),
 *   `interrupt` (an AbortSignal: when it aborts, the speech is cut off — the server drops the frames
 *   not yet final and settles the head from the last one sent, `settle` seconds), `shown()` (with
 *   `interrupt`: the number of frames the page showed, sent with the interrupt so that the head
 *   settles from the last one shown), `hear` ({sampleRate, encoding}: the source also yields
 *   `{hear: chunk}` — the other party's audio, sent as hear messages in order with the speech;
 *   the avatar page's `role: "listen"` does it for you), `signal`, `onReady(ready)`, `onAudio(pcm,
 *   sentAtMs)` (each PCM ArrayBuffer as sent, in the stream's encoding, and the performance.now()
 *   of its send: to keep what was sent, or to time frames against the audio)
 */
export async function* stream(source, options = {}) {
  const url = (options.url || DEFAULT_URL()).replace(/\/$/, "").replace(/^http/, "ws");
  const live = typeof MediaStream !== "undefined" && source instanceof MediaStream;
  let chunks = source, sampleRate = options.sampleRate, stopCapture = null;
  if (live) ({ chunks, sampleRate, stop: stopCapture } = await capture(source, options.signal, options.chunkMs));
  if (!sampleRate) throw new HeadmotionError("bad_parameter", "chunks of samples need options.sampleRate");
  const encoding = options.encoding || "s16le", fmt = options.frames || "binary";
  const start = { type: "start", sample_rate: sampleRate, encoding, frames: fmt };
  for (const k of ["model", "seed", "gain", "offset", "still", "settle"]) if (options[k] !== undefined) start[k] = options[k];
  if (options.lookaheadMs !== undefined) start.lookahead_ms = options.lookaheadMs;
  start.resample = options.resample || (live ? "fast" : "exact");
  const listen = options.role === "listen";
  if (listen) {  // the source is the other party: heard, while the avatar's own channel is silence
    start.hear = { sample_rate: sampleRate, encoding };
  } else if (options.hear) {  // the source interleaves the other party's audio with the speech
    start.hear = { sample_rate: options.hear.sampleRate || sampleRate, encoding: options.hear.encoding || encoding };
  }
  if (start.hear && options.listening !== undefined) start.listening = options.listening;
  if (options.apiKey) start.api_key = options.apiKey;

  const ws = new WebSocket(`${url}/v1/stream`);
  ws.binaryType = "arraybuffer";
  const inbox = channel();
  let t0 = null;  // wall time (ms) of audio time 0: the first chunk's send minus its duration
  ws.onmessage = (e) => inbox.push({ data: e.data, at: performance.now() });
  ws.onclose = (e) => { inbox.push({ close: e }); inbox.end(); };
  ws.onerror = () => {};  // the close that follows says how it ended
  await new Promise((resolve, reject) => {
    ws.onopen = resolve;
    ws.addEventListener("close", (e) => reject(new HeadmotionError("closed", `could not connect (${e.code})`,
      { code: e.code })), { once: true });
  });
  ws.send(JSON.stringify(start));

  let feeding = null, stopped = false;
  const cut = () => {  // options.interrupt aborted: no more audio, the server settles the head and ends
    if (stopped) return;
    stopped = true;
    const shown = options.shown ? options.shown() : null;
    if (ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(Number.isInteger(shown) ? { type: "interrupt", shown } : { type: "interrupt" }));
  };
  if (options.interrupt) {
    if (options.interrupt.aborted) cut();
    else options.interrupt.addEventListener("abort", cut, { once: true });
  }
  const feed = async () => {
    const width = encoding === "s16le" ? 2 : 4;
    for await (const c of chunks) {
      if (stopped || ws.readyState !== WebSocket.OPEN) return;
      if (c && c.hear !== undefined && start.hear) {  // the other party's audio (options.hear)
        ws.send(JSON.stringify({ type: "hear", audio: base64(toPcm(c.hear, start.hear.encoding)) }));
        continue;
      }
      const pcm = toPcm(c, encoding);
      if (t0 === null) t0 = performance.now() - (pcm.byteLength / width / sampleRate) * 1000;
      while (ws.bufferedAmount > (1 << 20) && ws.readyState === WebSocket.OPEN) {
        await new Promise((r) => setTimeout(r, 5));  // the socket is full: wait for it to drain
      }
      if (listen) {  // each chunk heard, then as much silence spoken (docs/serve.md: hear first, then speech)
        ws.send(JSON.stringify({ type: "hear", audio: base64(pcm) }));
        ws.send(new ArrayBuffer(pcm.byteLength));
      } else {
        ws.send(pcm);
      }
      if (options.onAudio) options.onAudio(pcm, performance.now());
    }
    if (!stopped && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify({ type: "end" }));
  };

  try {
    for await (const m of inbox) {
      if (m.close) {
        throw new HeadmotionError("closed", `the stream closed before its end (${m.close.code} ${m.close.reason})`,
          { code: m.close.code });
      }
      if (typeof m.data !== "string") {
        const v = new DataView(m.data), first = v.getUint32(4, true), n = v.getUint32(8, true);
        const fps = v.getFloat32(12, true), audioTime = v.getFloat64(16, true);
        const a = new Float32Array(m.data, HEADER, n * 6), frames = [];
        for (let i = 0; i < n; i++) {
          frames.push({ frame: first + i, time: (first + i) / fps, rotvec: Array.from(a.subarray(6 * i, 6 * i + 3)),
            pitchYawRollDeg: Array.from(a.subarray(6 * i + 3, 6 * i + 6)) });
        }
        yield batch(first, fps, audioTime, frames, m.at);
        continue;
      }
      const d = JSON.parse(m.data);
      if (d.type === "ready") {
        if (options.onReady) options.onReady(d);
        feeding = feed().catch((e) => { stopped = true; inbox.fail(e); ws.close(); });
      } else if (d.type === "frames") {
        yield batch(d.first, d.fps, d.audio_time, d.frames.map((f) => ({ frame: f.frame, time: f.time,
          rotvec: f.rotvec, pitchYawRollDeg: f.pitch_yaw_roll_deg })), m.at);
      } else if (d.type === "error") {
        let code = null;
        const closed = new Promise((r) => ws.addEventListener("close", (e) => r(e.code), { once: true }));
        code = await Promise.race([closed, new Promise((r) => setTimeout(() => r(null), 1000))]);
        throw new HeadmotionError(d.error, d.detail, { code, retryAfter: d.retry_after ?? null });
      } else if (d.type === "end") {
        return;
      }
    }
  } finally {
    stopped = true;  // the feed stops at its next chunk
    if (stopCapture) stopCapture();
    if (ws.readyState === WebSocket.OPEN || ws.readyState === WebSocket.CONNECTING) ws.close(1000);
  }

  function batch(first, fps, audioTime, frames, at) {
    const latencyMs = frames.map((f) => (t0 === null ? null : at - (t0 + f.time * 1000)));
    return { first, fps, audioTime, frames, latencyMs };
  }
}
