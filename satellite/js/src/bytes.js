// SPDX-License-Identifier: Apache-2.0
// Little-endian byte readers and writers over DataView (docs/flow-protocol.md, "Conventions"):
// u64 as BigInt, UTF-8 decoded fatally (bad bytes are an error, never U+FFFD), views never copied.
import { ProtocolError } from './errors.js';

const utf8 = new TextDecoder('utf-8', { fatal: true });
const utf8Out = new TextEncoder();

/** Encodes a string as UTF-8. @param {string} s @returns {Uint8Array} */
export function encodeUtf8(s) {
  return utf8Out.encode(s);
}

/** Decodes UTF-8, throwing ProtocolError on bad bytes. @param {Uint8Array} bytes @returns {string} */
export function decodeUtf8(bytes) {
  try {
    return utf8.decode(bytes);
  } catch {
    throw new ProtocolError('a string is not valid UTF-8');
  }
}

/**
 * A Uint8Array view of bytes given as an ArrayBuffer, a typed array or a DataView (no copy).
 * @param {ArrayBuffer | ArrayBufferView} data
 * @returns {Uint8Array}
 */
export function asBytes(data) {
  if (data instanceof Uint8Array) return data;
  if (data instanceof ArrayBuffer || (typeof SharedArrayBuffer !== 'undefined' && data instanceof SharedArrayBuffer)) {
    return new Uint8Array(data);
  }
  if (ArrayBuffer.isView(data)) return new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
  throw new TypeError('expected an ArrayBuffer or a typed array');
}

/** Reads a body field by field; every read checks the bytes left and throws ProtocolError. */
export class ByteReader {
  /** @param {Uint8Array} bytes */
  constructor(bytes) {
    /** @type {Uint8Array} */
    this.bytes = bytes;
    this.view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    this.at = 0;
  }

  /** @returns {number} bytes not read yet */
  get remaining() {
    return this.bytes.byteLength - this.at;
  }

  /** @param {number} n @param {string} what */
  need(n, what) {
    if (n > this.remaining) {
      throw new ProtocolError(`truncated: no room for ${what} (${this.remaining} bytes left)`);
    }
  }

  u8(what = 'u8') { this.need(1, what); return this.view.getUint8(this.at++); }
  u16(what = 'u16') { this.need(2, what); const v = this.view.getUint16(this.at, true); this.at += 2; return v; }
  u32(what = 'u32') { this.need(4, what); const v = this.view.getUint32(this.at, true); this.at += 4; return v; }
  /** @returns {bigint} */
  u64(what = 'u64') { this.need(8, what); const v = this.view.getBigUint64(this.at, true); this.at += 8; return v; }
  /** @returns {bigint} */
  i64(what = 'i64') { this.need(8, what); const v = this.view.getBigInt64(this.at, true); this.at += 8; return v; }
  f64(what = 'f64') { this.need(8, what); const v = this.view.getFloat64(this.at, true); this.at += 8; return v; }

  /** n bytes as a view into the body. @param {number} n @returns {Uint8Array} */
  raw(n, what = 'bytes') {
    this.need(n, what);
    const v = this.bytes.subarray(this.at, this.at + n);
    this.at += n;
    return v;
  }

  str16(what = 'str16') { return decodeUtf8(this.raw(this.u16(what), what)); }
  str32(what = 'str32') { return decodeUtf8(this.raw(this.u32(what), what)); }
  /** The bytes left, as a view. @returns {Uint8Array} */
  rest() { return this.raw(this.remaining); }

  /** Throws unless everything was read. @param {string} what */
  done(what) {
    if (this.remaining !== 0) throw new ProtocolError(`${what}: ${this.remaining} trailing bytes`);
  }
}

/** Appends little-endian fields to a growing buffer. */
export class ByteWriter {
  constructor(capacity = 256) {
    this.buf = new Uint8Array(capacity);
    this.view = new DataView(this.buf.buffer);
    this.length = 0;
  }

  /** @param {number} n */
  room(n) {
    if (this.length + n <= this.buf.byteLength) return;
    let size = this.buf.byteLength * 2;
    while (size < this.length + n) size *= 2;
    const next = new Uint8Array(size);
    next.set(this.buf.subarray(0, this.length));
    this.buf = next;
    this.view = new DataView(next.buffer);
  }

  u8(v) { this.room(1); this.view.setUint8(this.length, v); this.length += 1; return this; }
  u16(v) { this.room(2); this.view.setUint16(this.length, v, true); this.length += 2; return this; }
  u32(v) { this.room(4); this.view.setUint32(this.length, v, true); this.length += 4; return this; }
  /** @param {bigint | number} v */
  u64(v) { this.room(8); this.view.setBigUint64(this.length, BigInt(v), true); this.length += 8; return this; }
  /** @param {bigint | number} v */
  i64(v) { this.room(8); this.view.setBigInt64(this.length, BigInt(v), true); this.length += 8; return this; }
  f64(v) { this.room(8); this.view.setFloat64(this.length, v, true); this.length += 8; return this; }
  /** @param {Uint8Array} bytes */
  raw(bytes) { this.room(bytes.byteLength); this.buf.set(bytes, this.length); this.length += bytes.byteLength; return this; }

  /** @param {string} s */
  str16(s) {
    const b = encodeUtf8(s);
    if (b.byteLength > 0xffff) throw new RangeError(`a str16 of ${b.byteLength} bytes (at most 65535)`);
    return this.u16(b.byteLength).raw(b);
  }

  /** @param {string} s */
  str32(s) {
    const b = encodeUtf8(s);
    return this.u32(b.byteLength).raw(b);
  }

  /** @param {number} at @param {number} v */
  patchU32(at, v) { this.view.setUint32(at, v, true); }

  /** The bytes written, as a view. @returns {Uint8Array} */
  bytes() { return this.buf.subarray(0, this.length); }
}
