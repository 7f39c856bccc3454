// SPDX-License-Identifier: Apache-2.0
// The 32-byte media frame header of docs/channels.md ("SKMF", little-endian) over views: make a
// frame to publish, parse a received payload without copying its pixels or samples. The format
// codes come from media-codes.js, generated from media_frame.hpp.
import { ENCODINGS, HEADER_BYTES, MESSAGE_ENCODING } from './media-codes.js';
import { asBytes } from './bytes.js';

export { ENCODINGS, HEADER_BYTES, MESSAGE_ENCODING };

/** Format code by encoding name ({jpeg: 1, mono8: 2, ...}). */
export const FORMAT = Object.freeze(Object.fromEntries(ENCODINGS.map((e) => [e.encoding, e.format])));

/** The row of a format code, or undefined. @param {number} format */
export function encodingOf(format) {
  return ENCODINGS.find((e) => e.format === format);
}

/** Bytes of a raw payload of width x height; 0 when not raw or the size is not allowed. */
export function rawPayloadBytes(info, width, height) {
  if (!info || info.bitsPerPixel === 0 || width === 0 || height === 0) return 0;
  if (info.evenSize && (width % 2 !== 0 || height % 2 !== 0)) return 0;
  return (width * height * info.bitsPerPixel) / 8;
}

/**
 * Header + payload as one Uint8Array (one copy of the payload, into the frame to publish).
 * @param {{format: number, seq: number | bigint, captureNs?: bigint, width?: number, height?: number, channels?: number, sampleRate?: number}} h
 * @param {ArrayBuffer | ArrayBufferView} payload
 * @returns {Uint8Array}
 */
export function makeMediaFrame(h, payload) {
  const bytes = asBytes(payload);
  const out = new Uint8Array(HEADER_BYTES + bytes.byteLength);
  const v = new DataView(out.buffer);
  out.set([0x53, 0x4b, 0x4d, 0x46]);  // "SKMF"
  v.setUint16(4, HEADER_BYTES, true);
  v.setUint8(6, h.format);
  v.setBigUint64(8, BigInt(h.seq), true);
  v.setBigInt64(16, BigInt(h.captureNs ?? 0n), true);
  const audio = encodingOf(h.format)?.video === false;
  v.setUint16(24, audio ? h.channels ?? 0 : h.width ?? 0, true);
  v.setUint16(26, audio ? 0 : h.height ?? 0, true);
  v.setUint32(28, audio ? h.sampleRate ?? 0 : 0, true);
  out.set(bytes, HEADER_BYTES);
  return out;
}

/**
 * The header fields and the payload (a view) of a received frame, or null when it is not a
 * well-formed one (as parseFrame in media_frame.hpp).
 * @param {ArrayBuffer | ArrayBufferView} data
 */
export function parseMediaFrame(data) {
  const bytes = asBytes(data);
  if (bytes.byteLength < HEADER_BYTES) return null;
  const v = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  if (v.getUint32(0, true) !== 0x464d4b53) return null;
  const headerBytes = v.getUint16(4, true);
  if (headerBytes < HEADER_BYTES || headerBytes > bytes.byteLength) return null;
  const format = v.getUint8(6);
  const info = encodingOf(format);
  if (!info) return null;
  const a = v.getUint16(24, true);
  const b = v.getUint16(26, true);
  const rate = v.getUint32(28, true);
  const size = bytes.byteLength - headerBytes;
  if (!info.video && (a === 0 || rate === 0 || size % (2 * a) !== 0)) return null;
  if (info.video && info.bitsPerPixel !== 0) {
    const n = rawPayloadBytes(info, a, b);
    if (n === 0 || n !== size) return null;
  }
  return {
    format, encoding: info.encoding, seq: v.getBigUint64(8, true), captureNs: v.getBigInt64(16, true),
    width: info.video ? a : 0, height: info.video ? b : 0, channels: info.video ? 0 : a,
    sampleRate: info.video ? 0 : rate, payload: bytes.subarray(headerBytes),
  };
}
