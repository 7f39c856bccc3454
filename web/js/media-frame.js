// SPDX-License-Identifier: Apache-2.0
// The 32-byte media frame header of docs/channels.md, little-endian.
export const HEADER_BYTES = 32;
export const FORMAT = { jpeg: 1, y8: 2, pcm: 3 };

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
  const audio = format === FORMAT.pcm;
  v.setUint16(24, audio ? channels : width, true);
  v.setUint16(26, audio ? 0 : height, true);
  v.setUint32(28, audio ? sampleRate : 0, true);
  new Uint8Array(out, HEADER_BYTES).set(bytes);
  return out;
}

// The header fields and the payload of a received frame, or null when it is not one.
export function parseFrame(buffer) {
  if (buffer.byteLength < HEADER_BYTES) return null;
  const v = new DataView(buffer);
  if (v.getUint32(0, true) !== 0x464d4b53) return null;
  const headerBytes = v.getUint16(4, true);
  if (headerBytes < HEADER_BYTES || headerBytes > buffer.byteLength) return null;
  const format = v.getUint8(6);
  const a = v.getUint16(24, true);
  return {
    format,
    seq: Number(v.getBigUint64(8, true)),
    captureNs: v.getBigInt64(16, true),
    width: format === FORMAT.pcm ? 0 : a,
    height: format === FORMAT.pcm ? 0 : v.getUint16(26, true),
    channels: format === FORMAT.pcm ? a : 0,
    sampleRate: format === FORMAT.pcm ? v.getUint32(28, true) : 0,
    payload: buffer.slice(headerBytes),
  };
}
