// SPDX-License-Identifier: Apache-2.0
// The microphone: PCM 16-bit mono at the hub's rate (22050 Hz), resampled in an AudioWorklet.
import { FORMAT, makeFrame } from './media-frame.js';

export class Microphone {
  constructor(link) {
    this.link = link;
    this.sampleRate = 22050;
    this.ctx = null;
    this.stream = null;
    this.node = null;
    this.seq = 0; // sample counter
    this.levelDb = -100;
    this.frames = 0;
  }

  get running() { return this.stream !== null; }

  async start() {
    this.stream = await navigator.mediaDevices.getUserMedia({
      audio: { channelCount: 1, echoCancellation: true, noiseSuppression: true }, video: false,
    });
    this.ctx = new AudioContext();
    await this.ctx.audioWorklet.addModule('js/mic-worklet.js');
    const source = this.ctx.createMediaStreamSource(this.stream);
    this.node = new AudioWorkletNode(this.ctx, 'mic-capture', {
      processorOptions: { targetRate: this.sampleRate, chunk: 1024 },
    });
    this.node.port.onmessage = ({ data }) => this.send(data.pcm, data.rms);
    source.connect(this.node);
    await this.ctx.resume();
  }

  send(pcm, rms) {
    this.levelDb = rms > 0 ? 20 * Math.log10(rms) : -100;
    const frame = makeFrame({
      format: FORMAT.pcm, seq: this.seq, captureMs: Date.now(), channels: 1, sampleRate: this.sampleRate,
    }, pcm);
    this.seq += pcm.length; // a skipped frame leaves a gap the hub can see
    if (this.link.sendFrame(frame)) this.frames++;
  }

  stop() {
    if (this.stream) this.stream.getTracks().forEach((t) => t.stop());
    if (this.ctx) this.ctx.close();
    this.stream = null;
    this.ctx = null;
    this.node = null;
  }
}
