// SPDX-License-Identifier: Apache-2.0
// The network page's preview of a channel's last message: JSON pretty-printed, text as text, JPEG
// and raw frames (every raw encoding of media-codes.js) as images (with a detector's boxes drawn on the frame they belong to), audio as
// a level meter and a spectrum, anything else as a hex dump. Content is shown as text, never as
// markup.
import { FORMAT, JPEG_MIME, isRawImage, parseFrame, rawToRgba } from './media-frame.js';
import { detectionBoxes } from './network-model.js';

const MAX_TEXT = 20000;

// A frame the preview draws: JPEG or raw pixels.
const isImage = (frame) => frame.format === FORMAT.jpeg || isRawImage(frame);
const FFT_SIZE = 1024;

function hexDump(bytes) {
  const lines = [];
  for (let i = 0; i < Math.min(bytes.length, 256); i += 16) {
    const row = [...bytes.subarray(i, i + 16)];
    const hex = row.map((b) => b.toString(16).padStart(2, '0')).join(' ');
    const ascii = row.map((b) => (b >= 32 && b < 127 ? String.fromCharCode(b) : '.')).join('');
    lines.push(`${i.toString(16).padStart(4, '0')}  ${hex.padEnd(48)} ${ascii}`);
  }
  return lines.join('\n');
}

// In-place radix-2 FFT magnitudes of `samples` (a power of two long), first half.
function spectrum(samples) {
  const n = samples.length;
  const re = Float64Array.from(samples, (v, i) => v * (0.5 - 0.5 * Math.cos((2 * Math.PI * i) / (n - 1))));
  const im = new Float64Array(n);
  for (let i = 1, j = 0; i < n; i++) {
    let bit = n >> 1;
    for (; j & bit; bit >>= 1) j ^= bit;
    j ^= bit;
    if (i < j) { [re[i], re[j]] = [re[j], re[i]]; }
  }
  for (let len = 2; len <= n; len <<= 1) {
    const ang = (-2 * Math.PI) / len;
    for (let i = 0; i < n; i += len) {
      for (let k = 0; k < len / 2; k++) {
        const wr = Math.cos(ang * k);
        const wi = Math.sin(ang * k);
        const a = i + k;
        const b = a + len / 2;
        const xr = re[b] * wr - im[b] * wi;
        const xi = re[b] * wi + im[b] * wr;
        re[b] = re[a] - xr; im[b] = im[a] - xi;
        re[a] += xr; im[a] += xi;
      }
    }
  }
  return Array.from({ length: n / 2 }, (_, k) => Math.hypot(re[k], im[k]) / n);
}

export class Preview {
  constructor(root) {
    this.root = root;
    this.channel = null;   // what is previewed
    this.source = null;    // the frames a detector's boxes belong to
    this.mime = '';
    this.lastDetection = null;
    this.frameBitmap = null;
    this.audio = [];
    this.count = 0;
  }

  // Starts showing `channel` (of `mime`); `source` is its frame channel when it is a detector's.
  show(channel, mime, source = null) {
    this.channel = channel;
    this.mime = mime || '';
    this.source = source;
    this.lastDetection = null;
    this.frameBitmap = null;
    this.audio = [];
    this.count = 0;
    this.root.replaceChildren();
    this.root.dataset.kind = 'waiting';
    const p = document.createElement('p');
    p.className = 'muted';
    p.textContent = channel ? 'waiting for a message…' : '';
    this.root.appendChild(p);
  }

  notice(text) {
    const p = document.createElement('p');
    p.className = 'muted';
    p.textContent = text;
    this.root.replaceChildren(p);
  }

  // A preview message; false when it is not for this view.
  async take(name, payload) {
    if (name !== this.channel && name !== this.source) return false;
    const frame = parseFrame(payload);
    if (name === this.source) {
      if (frame && isImage(frame)) {
        this.frameBitmap = await this.bitmap(frame);
        this.drawDetections();
      }
      return true;
    }
    this.count++;
    this.root.dataset.count = String(this.count);
    if (frame) {
      if (frame.format === FORMAT.pcm) return this.showAudio(frame), true;
      if (isImage(frame)) {
        this.frameBitmap = await this.bitmap(frame);
        this.showImage(frame);
        return true;
      }
    }
    const bytes = new Uint8Array(payload);
    let text = null;
    try { text = new TextDecoder('utf-8', { fatal: true }).decode(bytes); } catch { /* binary */ }
    if (text !== null) {
      const t = text.trimStart();
      if (this.mime.includes('json') || t.startsWith('{') || t.startsWith('[')) {
        try {
          const v = JSON.parse(text);
          if (this.source) {
            this.lastDetection = v;
            this.drawDetections(v);
            return true;
          }
          return this.showText(JSON.stringify(v, null, 2), 'json'), true;
        } catch { /* not JSON after all */ }
      }
      return this.showText(text, 'text'), true;
    }
    this.showText(`${bytes.length} bytes\n${hexDump(bytes)}`, 'binary');
    return true;
  }

  showText(text, kind) {
    const pre = document.createElement('pre');
    pre.textContent = text.length > MAX_TEXT ? `${text.slice(0, MAX_TEXT)}\n… (${text.length} characters)` : text;
    this.root.replaceChildren(pre);
    this.root.dataset.kind = kind;
  }

  async bitmap(frame) {
    if (frame.format === FORMAT.jpeg) return createImageBitmap(new Blob([frame.payload], { type: JPEG_MIME }));
    // parseFrame checked the raw payload's size against the width and height.
    return createImageBitmap(new ImageData(rawToRgba(frame), frame.width, frame.height));
  }

  canvas(width, height) {
    let c = this.root.querySelector('canvas.frame');
    if (!c) {
      c = document.createElement('canvas');
      c.className = 'frame';
      this.root.replaceChildren(c);
    }
    if (c.width !== width || c.height !== height) { c.width = width; c.height = height; }
    return c;
  }

  showImage(frame) {
    if (!this.frameBitmap) return;
    const c = this.canvas(this.frameBitmap.width, this.frameBitmap.height);
    c.getContext('2d').drawImage(this.frameBitmap, 0, 0);
    const gray = frame.encoding === 'mono8' || frame.encoding === 'mono16';
    this.root.dataset.kind = frame.format === FORMAT.jpeg ? 'jpeg' : gray ? 'gray' : 'raw';
    c.title = `frame ${frame.seq}, ${frame.width}x${frame.height}`;
  }

  // The detector's last boxes on its source's last frame (or on an empty frame of its size).
  drawDetections(msg = this.lastDetection) {
    if (!msg) return;
    const w = msg.width || this.frameBitmap?.width || 640;
    const h = msg.height || this.frameBitmap?.height || 360;
    const c = this.canvas(w, h);
    const g = c.getContext('2d');
    g.fillStyle = '#000';
    g.fillRect(0, 0, w, h);
    if (this.frameBitmap) g.drawImage(this.frameBitmap, 0, 0, w, h);
    const boxes = detectionBoxes(msg);
    g.lineWidth = Math.max(2, w / 320);
    g.strokeStyle = '#ffcc00';
    g.fillStyle = '#ffcc00';
    g.font = `${Math.max(12, Math.round(w / 40))}px sans-serif`;
    for (const b of boxes) {
      g.strokeRect(b.x, b.y, b.w, b.h);
      g.fillText(b.label, b.x, Math.max(12, b.y - 4));
    }
    this.root.dataset.kind = 'detections';
    this.root.dataset.boxes = String(boxes.length);
  }

  showAudio(frame) {
    const pcm = new Int16Array(frame.payload.slice(0, frame.payload.byteLength & ~1));
    const ch = Math.max(1, frame.channels);
    for (let i = 0; i < pcm.length; i += ch) this.audio.push(pcm[i] / 32768);
    if (this.audio.length > FFT_SIZE * 4) this.audio.splice(0, this.audio.length - FFT_SIZE * 4);
    let sum = 0;
    for (let i = 0; i < pcm.length; i++) sum += (pcm[i] / 32768) ** 2;
    const dbfs = pcm.length ? Math.max(-90, 10 * Math.log10(sum / pcm.length + 1e-12)) : -90;
    let meter = this.root.querySelector('meter');
    if (!meter) {
      meter = document.createElement('meter');
      Object.assign(meter, { min: -90, max: 0, low: -50, high: -6 });
      const label = document.createElement('span');
      label.className = 'level';
      const c = document.createElement('canvas');
      c.className = 'spectrum';
      c.width = 320;
      c.height = 100;
      this.root.replaceChildren(meter, label, c);
    }
    meter.value = dbfs;
    this.root.querySelector('.level').textContent = `${dbfs.toFixed(1)} dBFS, ${frame.sampleRate} Hz`;
    this.root.dataset.kind = 'audio';
    this.root.dataset.level = dbfs.toFixed(1);
    if (this.audio.length < FFT_SIZE) return;
    const mags = spectrum(this.audio.slice(-FFT_SIZE));
    const c = this.root.querySelector('canvas.spectrum');
    const g = c.getContext('2d');
    g.fillStyle = '#111';
    g.fillRect(0, 0, c.width, c.height);
    g.fillStyle = '#4fc3f7';
    const bars = 64;
    for (let b = 0; b < bars; b++) {
      // Logarithmic frequency bands from bin 1 to the last.
      const lo = Math.floor(Math.pow(mags.length, b / bars));
      const hi = Math.max(lo + 1, Math.floor(Math.pow(mags.length, (b + 1) / bars)));
      const m = Math.max(...mags.slice(lo, hi));
      const db = 20 * Math.log10(m + 1e-9);
      const height = Math.max(0, Math.min(1, (db + 100) / 100)) * c.height;
      g.fillRect((b * c.width) / bars, c.height - height, c.width / bars - 1, height);
    }
    c.title = `spectrum, 0 to ${frame.sampleRate / 2} Hz`;
  }
}
