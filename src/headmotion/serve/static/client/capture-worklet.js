// @headmotion/client: audio thread of stream(MediaStream) — hands the first input channel to the
// page in blocks of `processorOptions.samples` (the render quantum's 128 samples at least): one
// WebSocket message per block, so that a server is not asked to handle hundreds of tiny messages a
// second.
class HeadmotionCapture extends AudioWorkletProcessor {
  constructor(options) {
    super();
    const n = Math.max(128, Math.floor((options && options.processorOptions && options.processorOptions.samples) || 128));
    this.buf = new Float32Array(n);
    this.n = 0;
  }

  process(inputs) {
    const x = inputs[0] && inputs[0][0];
    if (!x) return true;
    let i = 0;
    while (i < x.length) {
      const take = Math.min(x.length - i, this.buf.length - this.n);
      this.buf.set(x.subarray(i, i + take), this.n);
      this.n += take; i += take;
      if (this.n === this.buf.length) { this.port.postMessage(this.buf.slice(0)); this.n = 0; }
    }
    return true;
  }
}
registerProcessor("headmotion-capture", HeadmotionCapture);
