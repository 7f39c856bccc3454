// SPDX-License-Identifier: Apache-2.0
// The 32-byte media frame header of docs/channels.md, little-endian, and raw frames as canvas
// pixels. The format codes come from media-codes.js, generated from media_frame.hpp.
import { ENCODINGS, HEADER_BYTES } from './media-codes.js';

export { ENCODINGS, HEADER_BYTES };

// Format code by encoding name, plus the older names the pages use: y8 (mono8), pcm (s16le).
export const FORMAT = Object.freeze({
  ...Object.fromEntries(ENCODINGS.map((e) => [e.encoding, e.format])),
  y8: ENCODINGS.find((e) => e.encoding === 'mono8').format,
  pcm: ENCODINGS.find((e) => e.encoding === 's16le').format,
});

// The row of a format code, or undefined.
export function encodingOf(format) {
  return ENCODINGS.find((e) => e.format === format);
}

// The mime type of a JPEG frame's payload (for a Blob or the canvas's encoder).
export const JPEG_MIME = encodingOf(FORMAT.jpeg).mime;

// Bytes of a raw payload of width x height; 0 when the encoding is not raw or the size is not
// allowed (zero, or odd for nv12/i420). As rawPayloadBytes in media_frame.hpp.
export function rawPayloadBytes(info, width, height) {
  if (!info || info.bitsPerPixel === 0 || width === 0 || height === 0) return 0;
  if (info.evenSize && (width % 2 !== 0 || height % 2 !== 0)) return 0;
  return width * height * info.bitsPerPixel / 8;
}

// Header + payload (an ArrayBuffer or typed array) as one ArrayBuffer.
export function makeFrame({ format, seq, captureMs, width = 0, height = 0, channels = 0, sampleRate = 0 }, payload) {
  const bytes = payload instanceof ArrayBuffer ? new Uint8Array(payload)
    : new Uint8Array(payload.buffer, payload.byteOffset, payload.byteLength);
  const out = new ArrayBuffer(HEADER_BYTES + bytes.byteLength);
  const v = new DataView(out);
  v.setUint8(0, 0x53); v.setUint8(1, 0x4b); v.setUint8(2, 0x4d); v.setUint8(3, 0x46); // "SKMF"
  v.setUint16(4, HEADER_BYTES, true);
  v.setUint8(6, format);
  v.setUint8(7, 0);
  v.setBigUint64(8, BigInt(seq), true);
  v.setBigInt64(16, BigInt(Math.round(captureMs)) * 1000000n, true);
  const audio = encodingOf(format)?.video === false;
  v.setUint16(24, audio ? channels : width, true);
  v.setUint16(26, audio ? 0 : height, true);
  v.setUint32(28, audio ? sampleRate : 0, true);
  new Uint8Array(out, HEADER_BYTES).set(bytes);
  return out;
}

// The header fields, the encoding's row and the payload of a received frame, or null when it is
// not a well-formed one (as parseFrame in media_frame.hpp: an unknown format, audio without
// channels or rate or with a partial sample, a raw payload that is not exactly its size).
export function parseFrame(buffer) {
  if (buffer.byteLength < HEADER_BYTES) return null;
  const v = new DataView(buffer);
  if (v.getUint32(0, true) !== 0x464d4b53) return null;
  const headerBytes = v.getUint16(4, true);
  if (headerBytes < HEADER_BYTES || headerBytes > buffer.byteLength) return null;
  const format = v.getUint8(6);
  const info = encodingOf(format);
  if (!info) return null;
  const a = v.getUint16(24, true);
  const b = v.getUint16(26, true);
  const rate = v.getUint32(28, true);
  const size = buffer.byteLength - headerBytes;
  if (!info.video && (a === 0 || rate === 0 || size % (2 * a) !== 0)) return null;
  if (info.video && info.bitsPerPixel !== 0) {
    const bytes = rawPayloadBytes(info, a, b);
    if (bytes === 0 || bytes !== size) return null;
  }
  return {
    format,
    encoding: info.encoding,
    seq: Number(v.getBigUint64(8, true)),
    captureNs: v.getBigInt64(16, true),
    width: info.video ? a : 0,
    height: info.video ? b : 0,
    channels: info.video ? 0 : a,
    sampleRate: info.video ? 0 : rate,
    payload: buffer.slice(headerBytes),
  };
}

// Whether a parsed frame is packed pixels that rawToRgba converts.
export function isRawImage(frame) {
  const info = frame && encodingOf(frame.format);
  return Boolean(info && info.video && info.bitsPerPixel !== 0);
}

// BT.601 limited range, as OpenCV's COLOR_YUV2BGR_NV12 / _I420 (vision-common's decode).
function yuvToRgba(out, i, y, u, v) {
  const c = 298 * (y - 16) + 128;
  const d = u - 128;
  const e = v - 128;
  out[i] = (c + 409 * e) >> 8;
  out[i + 1] = (c - 100 * d - 208 * e) >> 8;
  out[i + 2] = (c + 516 * d) >> 8;
  out[i + 3] = 255;
}

// A raw frame (parseFrame's result) as the RGBA bytes of ImageData(width, height): a
// Uint8ClampedArray of width * height * 4, or null when the frame is not raw pixels.
// mono16 shows its high byte (as vision-common's 1/256).
export function rawToRgba(frame) {
  if (!isRawImage(frame)) return null;
  const { width: w, height: h, encoding } = frame;
  const src = new Uint8Array(frame.payload);
  const n = w * h;
  const out = new Uint8ClampedArray(n * 4);
  // Packed pixels: the offsets of red, green and blue in a pixel, and its bytes (4: with alpha).
  const packed = { rgb8: [0, 1, 2, 3], bgr8: [2, 1, 0, 3], rgba8: [0, 1, 2, 4], bgra8: [2, 1, 0, 4] }[encoding];
  if (packed) {
    const [r, g, b, step] = packed;
    for (let p = 0, s = 0, o = 0; p < n; p++, s += step, o += 4) {
      out[o] = src[s + r];
      out[o + 1] = src[s + g];
      out[o + 2] = src[s + b];
      out[o + 3] = step === 4 ? src[s + 3] : 255;
    }
    return out;
  }
  if (encoding === 'mono8' || encoding === 'mono16') {
    const deep = encoding === 'mono16';
    for (let p = 0, o = 0; p < n; p++, o += 4) {
      const g = deep ? src[2 * p + 1] : src[p];
      out[o] = out[o + 1] = out[o + 2] = g;
      out[o + 3] = 255;
    }
    return out;
  }
  // nv12: Y plane, then interleaved U,V at half resolution; i420: Y, U plane, V plane.
  const cw = w / 2;
  const chroma = n;
  for (let y = 0; y < h; y++) {
    for (let x = 0; x < w; x++) {
      const c = (y >> 1) * cw + (x >> 1);
      const u = encoding === 'nv12' ? src[chroma + 2 * c] : src[chroma + c];
      const v = encoding === 'nv12' ? src[chroma + 2 * c + 1] : src[chroma + n / 4 + c];
      yuvToRgba(out, 4 * (y * w + x), src[y * w + x], u, v);
    }
  }
  return out;
}
