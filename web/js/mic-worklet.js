// SPDX-License-Identifier: Apache-2.0
// AudioWorklet: the microphone resampled (linear interpolation) to the hub's rate as 16-bit
// PCM, posted in chunks of `chunk` samples with the level (RMS) of each chunk.
class MicCapture extends AudioWorkletProcessor {
  constructor(options) {
    super();
    const { targetRate, chunk } = options.processorOptions;
    this.step = sampleRate / targetRate; // input samples per output sample
    this.pos = 0; // position of the next output sample in the input stream
    this.last = 0; // the previous block's last sample, for interpolation across blocks
    this.chunk = chunk;
    this.out = new Int16Array(chunk);
    this.fill = 0;
    this.sumSquares = 0;
  }

  process(inputs) {
    const input = inputs[0] && inputs[0][0];
    if (!input) return true;
    const n = input.length;
    while (this.pos < n) {
      const i = Math.floor(this.pos);
      const frac = this.pos - i;
      const a = i === 0 ? this.last : input[i - 1];
      const b = input[i];
      const s = Math.max(-1, Math.min(1, a + (b - a) * frac));
      this.sumSquares += s * s;
      this.out[this.fill++] = s < 0 ? s * 0x8000 : s * 0x7fff;
      if (this.fill === this.out.length) {
        const rms = Math.sqrt(this.sumSquares / this.fill);
        this.port.postMessage({ pcm: this.out, rms }, [this.out.buffer]);
        this.out = new Int16Array(this.chunk); // the old buffer went with the message
        this.fill = 0;
        this.sumSquares = 0;
      }
      this.pos += this.step;
    }
    this.pos -= n;
    this.last = input[n - 1];
    return true;
  }
}
registerProcessor('mic-capture', MicCapture);
