/* The avatar page's Pipecat client for tests/test_integration_pipecat_browser.py: Pipecat's own
 * browser client (PipecatClient with its WebSocketTransport and WavMediaManager: the microphone
 * in, the bot's audio played) connected to the pipeline's FastAPI WebSocket on the same server.
 * Each headmotion message (HeadMotionProcessor(rtvi=True) → onServerMessage) is timed by the audio
 * the page plays: window.headmotionAvatar.follow(message, position) with the bot audio given to the
 * player when it came, and played(position) as the player plays it, counted in its audio graph
 * (WavMediaManager's player keeps no jitter buffer: when it runs dry the rest of the voice comes
 * later, and the head waits as long).  The page also records what it plays (the player's output,
 * tapped in the audio graph) and when each frame reached the bones, in window.pipecatRecord, for
 * the test to measure against. */
import { PipecatClient } from "@pipecat-ai/client-js";
import { WavMediaManager, WebSocketTransport } from "@pipecat-ai/websocket-transport";

const rec = window.pipecatRecord = { played: [], clock: [], messages: [], errors: [], received: [], state: "new", rate: null };

const NativeNode = window.AudioWorkletNode;

// The player's played-audio clock, and what it plays.  WavStreamPlayer gives each run of audio a
// "stream_processor" node, which plays what it is written in 128-sample blocks and ends when it
// runs dry (a partial block left unplayed).  A node on each passes on every block it outputs — the
// count so far, the audio clock's frame and the samples — to the page, which keeps the samples for
// the test (pipecatRecord.played: {node, f, x}).  The position, in seconds of the bot audio given
// to the player: every sample written to ended nodes (played or dropped) plus the samples the live
// node has played (at most its whole blocks written).
const PLAYED = `class Played extends AudioWorkletProcessor {
  constructor() { super(); this.n = 0; }
  process(inputs) {
    const x = inputs[0] && inputs[0][0];
    if (x) { this.n += x.length; this.port.postMessage([this.n, currentFrame + x.length, x.slice()]); }
    return true;
  }
}
registerProcessor("hm-played", Played);`;
const playedUrl = URL.createObjectURL(new Blob([PLAYED], { type: "text/javascript" }));
const loaded = new WeakMap();  // AudioWorklet → its promise of the module above
const addModule = AudioWorklet.prototype.addModule;
AudioWorklet.prototype.addModule = function (url, options) {  // it loads with the player's module
  if (!loaded.has(this)) loaded.set(this, addModule.call(this, playedUrl));
  return Promise.all([addModule.call(this, url, options), loaded.get(this)]).then(() => undefined);
};
const player = { written: 0, passed: 0, live: null, rate: null, latency: 0, stoppedAt: -Infinity, nodes: 0 };
function position() {
  const live = player.live;
  let now = 0;
  if (live) {
    const full = (n) => Math.floor(n / 128) * 128;
    now = Math.min(live.counted, full(live.written));
    // moved on by the audio clock since the counted block was rendered (its message is late when the
    // page's thread is busy), through the audio written before that block only: a node may have run
    // dry since, and what is written to it then is dropped (WavStreamPlayer learns that a node ended
    // from its message)
    const ago = live.ctx.currentTime - live.frame / live.ctx.sampleRate;
    if (ago > 0) {
      const renderedAt = performance.now() - 1000 * ago;
      let before = 0;
      for (const [t, n] of live.writes) { if (t > renderedAt) break; before = n; }
      now = Math.max(now, Math.min(live.counted + Math.round(ago * live.ctx.sampleRate), full(before)));
    }
  }
  const late = live ? player.latency : Math.max(0, player.latency - (performance.now() - player.stoppedAt) / 1000);
  return (player.passed + now) / (player.rate || 1) - late;
}
function report() {  // the page's played-audio clock; idle once the last audio given has been heard
  const idle = !player.live && performance.now() - player.stoppedAt >= 1000 * player.latency;
  window.headmotionAvatar.played(position(), idle);
}
function countPlayed(node, ctx) {
  const run = { written: 0, counted: 0, frame: Infinity, writes: [], ctx, id: player.nodes++ };
  player.rate = rec.rate = ctx.sampleRate;
  player.latency = (ctx.outputLatency || 0);
  const post = node.port.postMessage.bind(node.port);
  node.port.postMessage = (m, transfer) => {
    if (m && m.event === "write") {
      run.written += m.buffer.length; player.written += m.buffer.length;
      run.writes.push([performance.now(), run.written]);
      if (run.writes.length > 256) run.writes.splice(0, 128);
    }
    return transfer === undefined ? post(m) : post(m, transfer);
  };
  const count = new NativeNode(ctx, "hm-played");
  const sink = ctx.createGain(); sink.gain.value = 0;
  node.connect(count); count.connect(sink); sink.connect(ctx.destination);
  count.port.onmessage = (e) => {
    const [n, frame, x] = e.data;
    run.counted = n; run.frame = frame; player.latency = ctx.outputLatency || 0;
    rec.played.push({ node: run.id, f: frame - x.length, x: Array.from(x) });
    if (rec.played.length % 8 === 1) rec.clock.push({ wall: performance.now(), ctx: ctx.currentTime, out: ctx.outputLatency || 0 });
    report();
  };
  node.port.addEventListener("message", (e) => {
    if (!e.data || e.data.event !== "stop") return;
    player.passed += run.written;  // its full blocks played, the rest dropped
    if (player.live === run) player.live = null;
    player.stoppedAt = performance.now();
    count.port.onmessage = null; count.disconnect(); sink.disconnect();
    report();
    setTimeout(report, 1000 * player.latency + 1);
  });
  player.live = run;
}

window.AudioWorkletNode = class extends NativeNode {
  constructor(ctx, name, options) {
    super(ctx, name, options);
    if (name !== "stream_processor") return;
    try { countPlayed(this, ctx); } catch (e) { rec.errors.push(`played clock: ${e}`); }
  }
};

// The bot's audio as it arrives (before the player): when, and its samples.
const media = new WavMediaManager(undefined, 16000);
const buffer = media.bufferBotAudio.bind(media);
media.bufferBotAudio = (data, id) => {
  const pcm = data instanceof Int16Array ? data : new Int16Array(data);
  rec.received.push({ at: performance.now(), n: pcm.length, x: Array.from(pcm) });
  return buffer(data, id);
};
const client = new PipecatClient({
  transport: new WebSocketTransport({ mediaManager: media }),
  enableMic: true,
  enableCam: false,
  callbacks: {
    onServerMessage: (msg) => {
      const at = performance.now();
      const shown = window.headmotionAvatar.follow(msg, player.written / (player.rate || 1));
      report();
      rec.messages.push({ at, msg, shown });
    },
    onTransportStateChanged: (state) => { rec.state = state; },
    onError: (e) => rec.errors.push(JSON.stringify(e && e.data || String(e))),
  },
});
client.connect({ wsUrl: `ws://${location.host}/ws` }).catch((e) => rec.errors.push(`connect: ${e}`));
window.pipecatClient = client;
