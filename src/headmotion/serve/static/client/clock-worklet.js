// @headmotion/client: audio thread of talkinghead.js — the clock of the AudioContext the avatar
// plays its voice on.  Every `processorOptions.samples` samples it posts {start, samples}: the
// context's sample frame at which the block began (`currentFrame`) and the block of its first input
// channel (the other party's microphone), or `samples: null` when nothing is connected; to the
// MessagePort it is given ({port}: the driver's worker), else to its own.
class HeadmotionClock extends AudioWorkletProcessor {
  constructor(options) {
    super();
    const n = Math.max(128, Math.floor((options && options.processorOptions && options.processorOptions.samples) || 128));
    this.buf = new Float32Array(n);
    this.n = 0;
    this.start = null;
    this.heard = false;
    this.out = this.port;
    this.port.onmessage = (e) => { if (e.data && e.data.port) this.out = e.data.port; };
  }

  process(inputs) {
    const x = inputs[0] && inputs[0][0];
    const len = x ? x.length : 128;
    if (x) this.heard = true;
    let i = 0;
    while (i < len) {
      if (this.n === 0) this.start = currentFrame + i;
      const take = Math.min(len - i, this.buf.length - this.n);
      if (x) this.buf.set(x.subarray(i, i + take), this.n);
      else this.buf.fill(0, this.n, this.n + take);
      this.n += take; i += take;
      if (this.n === this.buf.length) {
        this.out.postMessage({ start: this.start, samples: this.heard ? this.buf.slice(0) : null });
        this.n = 0; this.heard = false;
      }
    }
    return true;
  }
}
registerProcessor("headmotion-clock", HeadmotionClock);
