// @headmotion/client: audio thread of stream(MediaStream) — hands each 128-sample block of the
// first input channel to the page.
class HeadmotionCapture extends AudioWorkletProcessor {
  process(inputs) {
    const x = inputs[0] && inputs[0][0];
    if (x) this.port.postMessage(x.slice(0));
    return true;
  }
}
registerProcessor("headmotion-capture", HeadmotionCapture);
