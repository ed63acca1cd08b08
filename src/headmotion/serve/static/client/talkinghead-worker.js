// @headmotion/client: the worker of talkinghead.js — its streams, off the page's thread (which a
// browser drawing WebGL without a GPU holds for tens of milliseconds a frame).  Loaded as a module
// worker it serves its own messages; `serveStreams(port)` serves a MessagePort's instead (the page's
// thread, where a worker cannot be made: a module imported from another origin).  Per stream: the
// clock of the avatar's AudioContext (clock-worklet.js, on a MessagePort of its own) carries the
// speech channel in silence up to each block it has played, after that block of the microphone on
// the hear channel; the voice the page places ({at: its first sample frame on the context}) comes
// in between; frames go back to the page.
//
// page → worker: {type: "open", id, rate, t0, chunk, options, hear, record, clock: MessagePort},
//   {type: "hold", id, at} (voice will start at `at`: no silence past it until it comes),
//   {type: "speech", id, at, pcm: Int16Array}, {type: "cut", id} (interrupt: the server settles the
//   head from the frame the page showed, `options.shown` in the open message being replaced by the
//   `shown` of this one), {type: "close", id}, {type: "sent", id} (the audio sent, when recorded)
// worker → page: {type: "ready", id, ready}, {type: "frames", id, frames}, {type: "error", id, error},
//   {type: "done", id}, {type: "sent", id, speech, hear}
import { stream } from "./index.js";

function queue() {
  const items = []; let wake = null, done = false;
  const poke = () => { if (wake) { wake(); wake = null; } };
  return {
    push(v) { items.push(v); poke(); },
    end() { done = true; poke(); },
    async *[Symbol.asyncIterator]() {
      for (;;) {
        if (items.length) { yield items.shift(); continue; }
        if (done) return;
        await new Promise((r) => { wake = r; });
      }
    },
  };
}

function s16(x) {
  const out = new Int16Array(x.length);
  for (let i = 0; i < x.length; i++) { const v = Math.max(-1, Math.min(1, x[i])); out[i] = v < 0 ? v * 0x8000 : v * 0x7fff; }
  return out;
}

function base64(parts) {
  const n = parts.reduce((k, p) => k + p.byteLength, 0), all = new Uint8Array(n);
  let k = 0, s = "";
  for (const p of parts) { all.set(new Uint8Array(p.buffer, p.byteOffset, p.byteLength), k); k += p.byteLength; }
  for (let i = 0; i < all.length; i += 0x8000) s += String.fromCharCode.apply(null, all.subarray(i, i + 0x8000));
  return btoa(s);
}

function push(s, pcm) {
  for (let i = 0; i < pcm.length; i += s.chunk) s.q.push(pcm.slice(i, Math.min(pcm.length, i + s.chunk)).buffer);
  s.sent += pcm.length;
  if (s.record) s.speech.push(pcm);
}

function padTo(s, at) {
  if (at > s.sent) push(s, new Int16Array(at - s.sent));
}

function hear(s, x) {
  s.q.push({ hear: x });
  s.heard += x.length;
  if (s.record) s.hear.push(x);
}

/** A block of the clock: its microphone heard, then the speech channel carried to its end. */
function tick(s, { start, samples }) {
  if (s.closed) return;
  const from = start - s.t0, end = from + s.chunk;
  if (s.hearing) {
    let x = samples ? s16(samples) : new Int16Array(s.chunk);
    if (from > s.heard) hear(s, new Int16Array(from - s.heard));
    if (from < s.heard) x = x.subarray(Math.min(x.length, s.heard - from));
    if (x.length) hear(s, x);
  }
  padTo(s, Math.min(end, s.hold - s.t0));
}

async function run(s, options, port, streams) {
  const o = { ...options, sampleRate: s.rate, encoding: "s16le", resample: "exact", interrupt: s.abort.signal,
    shown: () => s.shown, onReady: (ready) => port.postMessage({ type: "ready", id: s.id, ready }) };
  if (s.hearing) o.hear = { sampleRate: s.rate };
  try {
    for await (const b of stream(s.q, o)) {
      port.postMessage({ type: "frames", id: s.id, frames: b.frames.map((f) => ({ frame: f.frame, time: f.time, rotvec: f.rotvec })) });
    }
  } catch (e) {
    port.postMessage({ type: "error", id: s.id, error: e.kind ? `${e.kind}: ${e.detail}` : String(e) });
  } finally {
    s.closed = true;
    port.postMessage({ type: "done", id: s.id });
    if (!s.record) streams.delete(s.id);
  }
}

/** Serve the page's messages on `port` (module comment). */
export function serveStreams(port) {
  const streams = new Map();
  port.onmessage = (e) => {
    const m = e.data, s = streams.get(m.id);
    if (m.type === "open") {
      const t = { id: m.id, rate: m.rate, t0: m.t0, chunk: m.chunk, hearing: m.hear, record: m.record, sent: 0, heard: 0,
        hold: Infinity, shown: null, q: queue(), abort: new AbortController(), speech: [], hear: [], closed: false };
      streams.set(m.id, t);
      m.clock.onmessage = (c) => tick(t, c.data);
      run(t, m.options, port, streams);
    } else if (!s) {
      if (m.type === "sent") port.postMessage({ type: "sent", id: m.id, speech: "", hear: null });
    } else if (m.type === "hold") {
      s.hold = Math.min(s.hold, m.at);
    } else if (m.type === "speech") {
      s.hold = Infinity;
      padTo(s, m.at - s.t0);
      push(s, m.pcm);
    } else if (m.type === "cut") {
      s.shown = m.shown; s.closed = true;
      s.abort.abort(); s.q.end();
    } else if (m.type === "close") {
      s.closed = true; s.q.end();
    } else if (m.type === "sent") {
      port.postMessage({ type: "sent", id: s.id, speech: base64(s.speech), hear: s.hearing ? base64(s.hear) : null });
    }
  };
}

if (typeof WorkerGlobalScope !== "undefined" && self instanceof WorkerGlobalScope) serveStreams(self);
