// @headmotion/client — a TalkingHead avatar (@met4citizen/talkinghead) whose neck and head follow
// WS /v1/stream, fed the voice TalkingHead plays and timed by the clock of the AudioContext it plays it on.
//
//   import { driveTalkingHead } from "/v1/talkinghead/client/talkinghead.js";
//   const driver = await driveTalkingHead(head, { hear: micStream, lookaheadMs: 200 });
//
// `head` is a TalkingHead whose avatar is loaded (after `await head.showAvatar(...)`).  From then on,
// one stream runs for as long as the driver does, its speech channel the audio TalkingHead plays on
// its own clock — silence while it is quiet, the voice where its AudioContext plays it — and its
// `hear` channel the other party's microphone (`options.hear`, a MediaStream), captured on the
// same clock, so that the head listens while the user talks and the avatar does not.  The voice is
// taken where TalkingHead hands it to the audio graph:
//   * speakAudio (and speakText): the AudioBuffer of the buffer source TalkingHead starts, at the
//     context time it starts it — the whole utterance at once, so its frames are read ahead of the
//     voice without delaying it;
//   * streamStart/streamAudio: each chunk as it is given, sent at once and handed on to TalkingHead
//     the whole frames of `lookaheadMs` later (the avatar page delays a file by as much), so that the
//     stream reads that far ahead of the voice heard; it plays from the end of what was given before,
//     or when it is handed on if TalkingHead had run out.
// A frame goes on the bones when the context's output reaches its place in the speech channel
// (AudioContext.getOutputTimestamp), inside TalkingHead's animation loop (its `update` option, run
// after its own pose each frame): the rotation vector r split as the BVH writer splits it, the
// neck turning by s·r and the head by (1 − s)·r about the avatar's axes (+x its left, +y up, +z
// forward), against the bind pose of the avatar's skin; s is the file's `extras.neck_share` (0.93
// when it has none).  While the driver runs, TalkingHead's own head movement is off: the random
// head turns of its moods (headRotateX/Y/Z are fixed at 0), and the nods it adds with the voice's
// loudness and the neck and head rotations of its poses and gestures are replaced; the eyes (and
// their eye contact), the face, the lip-sync and the body (the spine's sway included) stay
// TalkingHead's.  When TalkingHead's voice is cut (stopSpeaking, pauseSpeaking, streamInterrupt,
// streamStop) with speech sent that will not play, the stream is interrupted, the head settles from
// the frame it shows over `settle` seconds, and a new stream starts; a new AudioContext (streamStart
// with another sample rate) does the same.  The streams run in a worker (talkinghead-worker.js), to
// which the clock of the context (clock-worklet.js) posts directly: a page whose thread is busy
// drawing (WebGL without a GPU) does not hold the audio on its way to the server.
//
// options: url, apiKey, model, seed, gain, offset (degrees), listening (0–3), lookaheadMs (0–1080),
//   settle (seconds, default 0.5), hear (a MediaStream: the other party), neckShare, chunkMs (default
//   20), record (keep the audio sent: sentAudio()), onReady(ready), onError(error)
// driver: headRotation() [pitch, yaw, roll] degrees of the head bone against its bind pose relative
//   to the chest, in the project's axes (intrinsic YXZ, as pitch_yaw_roll_deg); latencyMs() (the
//   newest frame's: the time its bones were set minus the time the context output its audio);
//   latencyStats() {median, p95, n} over the last 200; shown [{frame, time, at, latencyMs, rotation,
//   stream}]; frames; ready; error; streams (how many were opened); neckShare; audioDelayS() (how
//   long streamed audio is held); sentAudio() (with `record`: a Promise of {sampleRate, stream,
//   speech, hear}, the current stream's channels as base64 16-bit PCM); stop()
import { serveStreams } from "./talkinghead-worker.js";

const DEFAULT_NECK_SHARE = 0.93;
const HEAD_TURNS = ["headRotateX", "headRotateY", "headRotateZ"];
const CUT_METHODS = ["stopSpeaking", "pauseSpeaking", "streamInterrupt", "streamStop"];
const KEEP = 20000;
const DEG = 180 / Math.PI;
const loaded = new WeakSet();  // AudioContexts that have the clock's worklet

function quantile(a, q) {
  if (!a.length) return null;
  const s = [...a].sort((x, y) => x - y);
  return s[Math.min(s.length - 1, Math.floor(q * (s.length - 1) + 0.5))];
}

/** Float32 samples as 16-bit PCM (TalkingHead's own conversion of float chunks). */
function s16(x) {
  const out = new Int16Array(x.length);
  for (let i = 0; i < x.length; i++) { const v = Math.max(-1, Math.min(1, x[i])); out[i] = v < 0 ? v * 0x8000 : v * 0x7fff; }
  return out;
}

/** A streamAudio chunk (ArrayBuffer, Int16Array, Uint8Array of 16-bit PCM, or Float32Array) copied as Int16Array. */
function chunkPcm(a) {
  if (a instanceof Float32Array) return s16(a);
  if (a instanceof ArrayBuffer) return new Int16Array(a.slice(0, a.byteLength - (a.byteLength % 2)));
  if (ArrayBuffer.isView(a)) return new Int16Array(a.buffer.slice(a.byteOffset, a.byteOffset + a.byteLength - (a.byteLength % 2)));
  return null;
}

/** What a buffer source plays: `buffer` at `playbackRate`, mono, at the context's `rate`. */
async function played(buffer, rate, playbackRate) {
  if (buffer.sampleRate === rate && playbackRate === 1) {
    const out = new Float32Array(buffer.length);
    for (let c = 0; c < buffer.numberOfChannels; c++) {
      const x = buffer.getChannelData(c);
      for (let i = 0; i < x.length; i++) out[i] += x[i] / buffer.numberOfChannels;
    }
    return out;
  }
  const oc = new OfflineAudioContext(1, Math.ceil(buffer.duration / playbackRate * rate), rate);
  const src = oc.createBufferSource();
  src.buffer = buffer; src.playbackRate.value = playbackRate; src.connect(oc.destination); src.start();
  return (await oc.startRendering()).getChannelData(0);
}

/** The streams' worker; where none can be made (this module imported from another origin), the
 * same code on the page's thread behind a MessagePort. */
function streamsWorker() {
  try {
    return new Worker(new URL("./talkinghead-worker.js", import.meta.url), { type: "module" });
  } catch (e) {
    const ch = new MessageChannel();
    serveStreams(ch.port2);
    ch.port1.terminate = () => { ch.port1.close(); ch.port2.close(); };
    return ch.port1;
  }
}

/** The neck and head of a loaded avatar: their bind rotations, posing by a rotation vector, reading back. */
function rig(head, neckShare) {
  const neck = head.objectNeck, bone = head.objectHead, chest = neck && neck.parent;
  if (!neck || !bone || !chest || bone.parent !== neck) throw new Error("driveTalkingHead: the avatar needs Head under Neck under the chest");
  const Q = bone.quaternion.constructor, V = bone.position.constructor, M = bone.matrix.constructor, E = bone.rotation.constructor;
  const bind = (b) => {  // the bone's world rotation in the skin's bind pose
    let m = null;
    head.armature.traverse((o) => {
      const k = !m && o.isSkinnedMesh ? o.skeleton.bones.indexOf(b) : -1;
      if (k >= 0) m = new M().copy(o.skeleton.boneInverses[k]).invert();
    });
    if (!m) throw new Error(`driveTalkingHead: no skin binds the bone ${b.name}`);
    const q = new Q(); m.decompose(new V(), q, new V());
    return q;
  };
  const C0 = bind(chest), N0 = bind(neck), H0 = bind(bone), C0i = C0.clone().invert(), N0i = N0.clone().invert();
  const H0i = H0.clone().invert(), axis = new V(), e1 = new Q(), e2 = new Q();
  const exp = (r, k, out) => {
    const a = Math.hypot(r[0], r[1], r[2]);
    return a < 1e-12 ? out.identity() : out.setFromAxisAngle(axis.set(r[0] / a, r[1] / a, r[2] / a), a * k);
  };
  return {
    /** Neck C0⁻¹·exp(s·r)·N0 and head N0⁻¹·exp((1−s)·r)·H0: the head turns by exp(r) against the chest. */
    pose(r) {
      neck.quaternion.copy(C0i).multiply(exp(r, neckShare, e1)).multiply(N0);
      bone.quaternion.copy(N0i).multiply(exp(r, 1 - neckShare, e2)).multiply(H0);
    },
    /** [pitch, yaw, roll] degrees: C0·(neck·head)·H0⁻¹, the head against its bind pose relative to the chest. */
    rotation() {
      const q = C0.clone().multiply(neck.quaternion).multiply(bone.quaternion).multiply(H0i);
      const e = new E().setFromQuaternion(q, "YXZ");
      return [e.x * DEG, e.y * DEG, e.z * DEG];
    },
  };
}

/** Drive `head`'s neck and head from /v1/stream (module comment). */
export async function driveTalkingHead(head, options = {}) {
  if (!head || !head.armature || !head.objectHead) throw new Error("driveTalkingHead: load the avatar first (await head.showAvatar(...))");
  const neckShare = options.neckShare ?? (Number.isFinite(head.userData && head.userData.neck_share) ? head.userData.neck_share : DEFAULT_NECK_SHARE);
  const bones = rig(head, neckShare);
  const chunkMs = options.chunkMs || 20, settle = options.settle ?? 0.5;
  const st = { shown: [], frames: 0, ready: null, error: null, streams: 0 };
  const worker = streamsWorker();
  const streams = new Map(), replies = new Map();
  const settling = [];  // streams cut off, their settling frames still to show
  let sess = null, running = true, last = [0, 0, 0], forwards = [], timer = null;
  const streamOptions = { url: options.url || location.origin, apiKey: options.apiKey, settle };
  for (const k of ["model", "seed", "gain", "offset", "listening", "lookaheadMs"]) if (options[k] !== undefined) streamOptions[k] = options[k];

  worker.onmessage = (e) => {
    const m = e.data, s = streams.get(m.id);
    if (m.type === "sent") { const r = replies.get(m.id); replies.delete(m.id); if (r) r(m); return; }
    if (!s) return;
    if (m.type === "ready") { s.fps = m.ready.fps; st.ready = m.ready; if (options.onReady) options.onReady(m.ready); }
    else if (m.type === "frames") {
      st.frames += m.frames.length;
      for (const f of m.frames) {
        if (!s.cut) s.pending.push(f);
        else if (f.frame >= s.cut.first) s.cut.frames.push(f);  // its settling
      }
    } else if (m.type === "error") {
      st.error = m.error;
      if (options.onError) options.onError(new Error(m.error));
      if (running && sess === s) setTimeout(() => { if (running && sess === s) restart(false); }, 1000);
    } else if (m.type === "done") {
      s.done = true;
      stopClock(s);
      if (!options.record) streams.delete(s.id);
    }
  };

  /** The context time (s) the output is playing now, and the page's time of a context time. */
  function audible(ctx) {
    const ts = ctx.getOutputTimestamp ? ctx.getOutputTimestamp() : null;
    if (ts && ts.contextTime > 0 && ts.performanceTime > 0) {
      return { now: ts.contextTime + (performance.now() - ts.performanceTime) / 1000, perf: (t) => ts.performanceTime + (t - ts.contextTime) * 1000 };
    }
    const lag = ctx.outputLatency || ctx.baseLatency || 0, at = performance.now(), ct = ctx.currentTime - lag;
    return { now: ct, perf: (t) => at + (t - ct) * 1000 };
  }

  async function open() {
    const ctx = head.audioCtx, rate = ctx.sampleRate, t0 = Math.round(ctx.currentTime * rate);
    const s = { id: ++st.streams, ctx, rate, t0, end: t0, pending: [], lastShown: -1, fps: null, cut: null, done: false,
      node: null, mic: null };
    sess = s;
    streams.set(s.id, s);
    if (!loaded.has(ctx)) { await ctx.audioWorklet.addModule(new URL("./clock-worklet.js", import.meta.url)); loaded.add(ctx); }
    if (sess !== s || ctx.state === "closed") return;
    const chunk = Math.round(rate * chunkMs / 1000), ch = new MessageChannel();
    s.node = new AudioWorkletNode(ctx, "headmotion-clock", { processorOptions: { samples: chunk } });
    const sink = ctx.createGain(); sink.gain.value = 0;
    s.node.connect(sink); sink.connect(ctx.destination);
    if (options.hear) { s.mic = ctx.createMediaStreamSource(options.hear); s.mic.connect(s.node); }
    worker.postMessage({ type: "open", id: s.id, rate, t0, chunk, options: streamOptions, hear: !!options.hear,
      record: !!options.record, clock: ch.port2 }, [ch.port2]);
    s.node.port.postMessage({ port: ch.port1 }, [ch.port1]);
  }

  function stopClock(s) {
    if (s.node) { try { s.node.disconnect(); } catch (e) { /* gone with its context */ } }
    if (s.mic) { try { s.mic.disconnect(); } catch (e) { /* idem */ } }
  }

  /** Speech that starts playing at the context's sample frame `at`. */
  function place(s, at, pcm) {
    s.end = Math.max(s.end, at + pcm.length);
    worker.postMessage({ type: "speech", id: s.id, at, pcm }, [pcm.buffer]);
  }

  // speakAudio (and speakText): the buffer source TalkingHead starts, when it starts it
  let source = head.audioSpeechSource;
  Object.defineProperty(head, "audioSpeechSource", {
    configurable: true, enumerable: true, get: () => source,
    set(src) {
      source = src;
      if (!src || typeof src.start !== "function" || src.__headmotion) return;
      const start = src.start;
      src.__headmotion = true;
      src.start = function (when = 0, ...rest) {
        start.call(this, when, ...rest);
        const s = sess;
        if (!running || !s || src.context !== s.ctx || !src.buffer) return;
        const at = Math.max(Math.round(Math.max(when, s.ctx.currentTime) * s.rate), s.end);
        s.end = at + Math.round(src.buffer.duration / src.playbackRate.value * s.rate);
        worker.postMessage({ type: "hold", id: s.id, at });
        played(src.buffer, s.rate, src.playbackRate.value).then((x) => { if (sess === s) place(s, at, s16(x)); });
      };
    },
  });

  // streamAudio: sent at once, handed on (with its visemes, in order) the whole frames of the lookahead later
  const originals = {};
  const hook = (name, fn) => { originals[name] = head[name]; head[name] = fn; };
  hook("streamAudio", function (r) {
    const s = sess, call = () => originals.streamAudio.call(head, r);
    if (!running || !s || !head.isStreaming || !head.streamWorkletNode || !r || s.ctx !== head.audioCtx) return call();
    const pcm = r.audio === undefined ? null : chunkPcm(r.audio), delay = holdS();
    if (pcm && pcm.length) place(s, Math.max(s.end, Math.round((s.ctx.currentTime + delay) * s.rate)), pcm);
    if (delay <= 0 && !forwards.length) return call();
    forwards.push({ call, due: performance.now() + delay * 1000 });
    if (forwards.length === 1) later();
    return undefined;
  });

  /** Hand the held chunks on in order, each when its time has come. */
  function later() {
    clearTimeout(timer);
    if (forwards.length) timer = setTimeout(() => {
      while (forwards.length && forwards[0].due <= performance.now() + 1) forwards.shift().call();
      later();
    }, Math.max(0, forwards[0].due - performance.now()));
  }
  for (const name of CUT_METHODS) {
    hook(name, function (...args) {
      if (name === "streamInterrupt" || name === "streamStop") { forwards = []; clearTimeout(timer); }
      const out = originals[name].apply(head, args);
      if (running && sess && sess.end > Math.round((sess.ctx.currentTime + 0.01) * sess.rate)) restart(true);
      return out;
    });
  }
  hook("initAudioGraph", function (...args) {
    const out = originals.initAudioGraph.apply(head, args);
    if (running && sess && sess.ctx !== head.audioCtx) restart(true);
    return out;
  });

  /** Seconds streamed audio is held: the whole frames of the lookahead (0 before the ready message). */
  function holdS() {
    const fps = sess && sess.fps, la = options.lookaheadMs || 0;
    return fps && la > 0 ? Math.floor(la * fps / 1000 + 1e-9) / fps : 0;
  }

  /** Interrupt the stream (its head settles from the frame shown, if `settleIt`) and open another. */
  function restart(settleIt) {
    const s = sess;
    if (s && !s.cut) {
      s.cut = { at: performance.now(), first: s.lastShown + 1, frames: [] };
      s.pending = [];
      stopClock(s);
      if (settleIt && s.fps) settling.push(s);
      worker.postMessage({ type: "cut", id: s.id, shown: s.lastShown + 1 });
    }
    open().catch((e) => { st.error = String(e); });
  }

  // TalkingHead's animation loop: after its pose, the frame due goes on the neck and head
  const update = head.opt.update;
  head.opt.update = function (dt) {
    if (update) update.call(this, dt);
    if (running) apply();
  };
  HEAD_TURNS.forEach((k) => head.setFixedValue(k, 0));

  function apply() {
    const now = performance.now();
    let f = null, latency = null, from = null;
    while (settling.length) {  // a cut stream's settling, at its own pace from the cut
      const o = settling[0], c = o.cut, due = (x) => c.at + (x.frame - c.first) * 1000 / o.fps <= now;
      while (c.frames.length && due(c.frames[0])) { f = c.frames.shift(); from = o; }
      if (c.frames.length || !o.done) break;
      settling.shift();
    }
    const s = sess;
    if (!settling.length && s && s.pending.length && s.ctx.state === "running") {
      const clock = audible(s.ctx), t = clock.now - s.t0 / s.rate;
      while (s.pending.length && s.pending[0].time <= t) { f = s.pending.shift(); from = s; }
      if (from === s) latency = now - clock.perf(s.t0 / s.rate + f.time);
    }
    if (f) {
      last = f.rotvec;
      from.lastShown = f.frame;
    }
    bones.pose(last);
    if (f) {
      st.shown.push({ frame: f.frame, time: f.time, at: now, latencyMs: latency, rotation: bones.rotation(), stream: from.id });
      if (st.shown.length > KEEP) st.shown.splice(0, st.shown.length - KEEP);
    }
  }

  await open();
  const lat = () => st.shown.slice(-200).map((x) => x.latencyMs).filter((x) => x !== null);
  return Object.assign(st, {
    neckShare,
    headRotation: () => bones.rotation(),
    latencyMs: () => { for (let i = st.shown.length - 1; i >= 0; i--) if (st.shown[i].latencyMs !== null) return st.shown[i].latencyMs; return null; },
    latencyStats: () => { const l = lat(); return { median: quantile(l, 0.5), p95: quantile(l, 0.95), n: l.length }; },
    audioDelayS: holdS,
    sentAudio: () => new Promise((resolve) => {  // (with options.record)
      const s = sess;
      replies.set(s.id, (m) => resolve({ sampleRate: s.rate, stream: s.id, speech: m.speech, hear: m.hear }));
      worker.postMessage({ type: "sent", id: s.id });
    }),
    stop() {
      if (!running) return;
      running = false;
      for (const [name, fn] of Object.entries(originals)) head[name] = fn;
      clearTimeout(timer);
      forwards.splice(0).forEach((f) => f.call());  // held audio: to TalkingHead now
      Object.defineProperty(head, "audioSpeechSource", { configurable: true, enumerable: true, writable: true, value: source });
      head.opt.update = update;
      HEAD_TURNS.forEach((k) => head.setFixedValue(k, null));
      if (sess) { worker.postMessage({ type: "close", id: sess.id }); stopClock(sess); }
      setTimeout(() => worker.terminate(), 5000);  // after the last frames and the end
    },
  });
}
