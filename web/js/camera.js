// SPDX-License-Identifier: Apache-2.0
// The camera: preview in a <video>, and JPEG frames of the configured size and rate to the hub.
import { FORMAT, JPEG_MIME, makeFrame } from './media-frame.js';

export class Camera {
  constructor(video, link) {
    this.video = video;
    this.link = link;
    this.stream = null;
    this.timer = null;
    this.seq = 0;
    this.settings = { width: 640, height: 360, fps: 15, jpeg_quality: 0.7 };
    this.canvas = document.createElement('canvas');
    this.sentTimes = [];
  }

  configure(camera) {
    Object.assign(this.settings, camera);
  }

  get running() { return this.stream !== null; }

  async start() {
    const { width, height, fps } = this.settings;
    this.stream = await navigator.mediaDevices.getUserMedia({
      video: { width: { ideal: width }, height: { ideal: height }, frameRate: { ideal: fps } },
      audio: false,
    });
    this.video.srcObject = this.stream;
    await this.video.play();
    this.canvas.width = width;
    this.canvas.height = height;
    this.timer = setInterval(() => this.capture(), 1000 / fps);
  }

  stop() {
    clearInterval(this.timer);
    this.timer = null;
    if (this.stream) this.stream.getTracks().forEach((t) => t.stop());
    this.stream = null;
    this.video.srcObject = null;
  }

  // Frames per second actually sent, over the last two seconds.
  fps() {
    const now = performance.now();
    this.sentTimes = this.sentTimes.filter((t) => now - t < 2000);
    return this.sentTimes.length / 2;
  }

  // Synchronous encode (toDataURL, ~4 ms for 640x360): Chromium runs the asynchronous encoders
  // (toBlob, convertToBlob) as low-priority tasks that arrive a second late on a busy page.
  capture() {
    if (this.video.readyState < 2) return;
    const { width, height, jpeg_quality: quality } = this.settings;
    // A CPU canvas: reading a GPU canvas back for the encoder stalls software renderers.
    const ctx = this.canvas.getContext('2d', { willReadFrequently: true });
    ctx.drawImage(this.video, 0, 0, width, height); // scaled to the channel's size
    const captureMs = Date.now();
    const url = this.canvas.toDataURL(JPEG_MIME, quality);
    const b64 = atob(url.slice(url.indexOf(',') + 1));
    const jpeg = new Uint8Array(b64.length);
    for (let i = 0; i < b64.length; i++) jpeg[i] = b64.charCodeAt(i);
    const frame = makeFrame({ format: FORMAT.jpeg, seq: this.seq++, captureMs, width, height }, jpeg);
    if (this.link.sendFrame(frame)) this.sentTimes.push(performance.now());
  }
}
