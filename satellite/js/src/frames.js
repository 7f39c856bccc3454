// SPDX-License-Identifier: Apache-2.0
// Frames (u32 length, u8 code, body) out of what a transport delivers, as views: a WebSocket
// message holds whole frames (messageFrames); a byte stream is cut by FrameSplitter, which checks
// each announced length against its limit before allocating anything and copies only a frame that
// straddles two reads.
import { ProtocolError } from './errors.js';

export const FRAME_HEADER_BYTES = 5;
export const DEFAULT_MAX_FRAME_BYTES = 16 * 1024 * 1024;

/** @typedef {{code: number, body: Uint8Array}} Frame */

function lengthAt(bytes, at) {
  return (bytes[at] | (bytes[at + 1] << 8) | (bytes[at + 2] << 16)) + bytes[at + 3] * 0x1000000;
}

function checkLength(length, max) {
  if (length === 0) throw new ProtocolError('a frame of length 0');
  if (length > max) throw new ProtocolError(`a frame of ${length} bytes exceeds the limit of ${max}`);
}

/**
 * The frames of one message that holds whole frames, as views; a message that ends inside a
 * frame is a ProtocolError.
 * @param {Uint8Array} message
 * @param {number} [maxFrameBytes]
 * @returns {Frame[]}
 */
export function messageFrames(message, maxFrameBytes = DEFAULT_MAX_FRAME_BYTES) {
  const out = [];
  let at = 0;
  while (at < message.byteLength) {
    if (message.byteLength - at < 4) throw new ProtocolError('a message ended inside a frame header');
    const length = lengthAt(message, at);
    checkLength(length, maxFrameBytes);
    if (message.byteLength - at - 4 < length) throw new ProtocolError('a message ended inside a frame');
    out.push({ code: message[at + 4], body: message.subarray(at + 5, at + 4 + length) });
    at += 4 + length;
  }
  return out;
}

/** Cuts a byte stream into frames. */
export class FrameSplitter {
  constructor(maxFrameBytes = DEFAULT_MAX_FRAME_BYTES) {
    this.maxFrameBytes = maxFrameBytes;
    /** @type {Uint8Array[]} */
    this.chunks = [];
    this.buffered = 0;
  }

  /**
   * Adds what the socket gave and returns the frames now complete.
   * @param {Uint8Array} chunk
   * @returns {Frame[]}
   */
  push(chunk) {
    if (chunk.byteLength > 0) {
      this.chunks.push(chunk);
      this.buffered += chunk.byteLength;
    }
    const out = [];
    for (;;) {
      if (this.buffered < 4) break;
      const head = this.peek(4);
      const length = lengthAt(head, 0);
      checkLength(length, this.maxFrameBytes);
      if (this.buffered < 4 + length) break;
      const frame = this.take(4 + length);
      out.push({ code: frame[4], body: frame.subarray(5) });
    }
    return out;
  }

  // The first n buffered bytes (a view when the first chunk holds them).
  peek(n) {
    const first = this.chunks[0];
    if (first.byteLength >= n) return first.subarray(0, n);
    const out = new Uint8Array(n);
    let at = 0;
    for (const c of this.chunks) {
      const k = Math.min(c.byteLength, n - at);
      out.set(c.subarray(0, k), at);
      at += k;
      if (at === n) break;
    }
    return out;
  }

  // Removes and returns the first n bytes: a view when one chunk holds them, else one copy.
  take(n) {
    this.buffered -= n;
    const first = this.chunks[0];
    if (first.byteLength >= n) {
      if (first.byteLength === n) this.chunks.shift();
      else this.chunks[0] = first.subarray(n);
      return first.subarray(0, n);
    }
    const out = new Uint8Array(n);
    let at = 0;
    while (at < n) {
      const c = this.chunks[0];
      const k = Math.min(c.byteLength, n - at);
      out.set(c.subarray(0, k), at);
      at += k;
      if (k === c.byteLength) this.chunks.shift();
      else this.chunks[0] = c.subarray(k);
    }
    return out;
  }
}
