/* The avatar page's Pipecat client for tests/test_integration_pipecat_browser.py: Pipecat's own
 * browser client (PipecatClient with its WebSocketTransport and WavMediaManager: the microphone
 * in, the bot's audio played) connected to the pipeline's FastAPI WebSocket on the same server.
 * Each headmotion message (HeadMotionProcessor(rtvi=True) → onServerMessage) puts the newest
 * frame on the avatar's bones (window.headmotionAvatar.setRotvec); the page records what it plays
 * (the player's output, tapped in the audio graph) and when each frame reached the bones, in
 * window.pipecatRecord, for the test to measure against. */
import { PipecatClient } from "@pipecat-ai/client-js";
import { WavMediaManager, WebSocketTransport } from "@pipecat-ai/websocket-transport";

const rec = window.pipecatRecord = { played: [], clock: [], messages: [], errors: [], received: [], state: "new", rate: null };

// What the page plays: every "stream_processor" node (the player's) also feeds a tap that posts
// its output in ~20 ms blocks with the audio clock's frame number.
const TAP = `class Tap extends AudioWorkletProcessor {
  constructor() { super(); this.buf = new Float32Array(480); this.n = 0; this.start = 0; }
  process(inputs) {
    const x = inputs[0] && inputs[0][0];
    if (!x) return true;
    if (this.n === 0) this.start = currentFrame;
    this.buf.set(x, this.n); this.n += x.length;
    if (this.n + 128 > this.buf.length) { this.port.postMessage({ f: this.start, x: this.buf.slice(0, this.n) }); this.n = 0; }
    return true;
  }
}
registerProcessor("hm-play-tap", Tap);`;
const tapUrl = URL.createObjectURL(new Blob([TAP], { type: "text/javascript" }));
const taps = new Map();
async function tapOf(ctx) {
  if (!taps.has(ctx)) {
    taps.set(ctx, (async () => {
      await ctx.audioWorklet.addModule(tapUrl);
      const node = new NativeNode(ctx, "hm-play-tap");
      const sink = ctx.createGain(); sink.gain.value = 0; node.connect(sink); sink.connect(ctx.destination);
      rec.rate = ctx.sampleRate;
      node.port.onmessage = (e) => {
        rec.played.push({ f: e.data.f, x: Array.from(e.data.x) });
        rec.clock.push({ wall: performance.now(), ctx: ctx.currentTime, out: ctx.outputLatency || 0, base: ctx.baseLatency || 0 });
      };
      return node;
    })());
  }
  return taps.get(ctx);
}
const NativeNode = window.AudioWorkletNode;
window.AudioWorkletNode = class extends NativeNode {
  constructor(ctx, name, options) {
    super(ctx, name, options);
    if (name === "stream_processor") tapOf(ctx).then((tap) => this.connect(tap)).catch((e) => rec.errors.push(String(e)));
  }
};

// The bot's audio as it arrives (before the player): when, and how many samples.
const media = new WavMediaManager(undefined, 16000);
const buffer = media.bufferBotAudio.bind(media);
media.bufferBotAudio = (data, id) => {
  rec.received.push({ at: performance.now(), n: data instanceof Int16Array ? data.length : data.byteLength / 2 });
  return buffer(data, id);
};
const client = new PipecatClient({
  transport: new WebSocketTransport({ mediaManager: media }),
  enableMic: true,
  enableCam: false,
  callbacks: {
    onServerMessage: (msg) => {
      const at = performance.now();
      if (msg && msg.type === "frames" && msg.frames.length) window.headmotionAvatar.setRotvec(msg.frames.at(-1).rotvec);
      rec.messages.push({ at, msg, bones: window.headmotionAvatar.headRotation() });
    },
    onTransportStateChanged: (state) => { rec.state = state; },
    onError: (e) => rec.errors.push(JSON.stringify(e && e.data || String(e))),
  },
});
client.connect({ wsUrl: `ws://${location.host}/ws` }).catch((e) => rec.errors.push(`connect: ${e}`));
window.pipecatClient = client;
