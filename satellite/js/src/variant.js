// SPDX-License-Identifier: Apache-2.0
// The binary Variant (docs/flow-protocol.md, "Values"): tags 0-8, little-endian.
//
//   JavaScript -> wire: null/undefined null; boolean bool; a safe integer int64, another number
//   float64; a BigInt int64, or uint64 above 2^63-1; a string string; an ArrayBuffer or typed
//   array bytes; an Array list; a Map or a plain object map. Variant.f64(), .i64(), .u64() force a
//   number's type.
//   wire -> JavaScript: int64 and uint64 are BigInt, float64 a number, bytes a Uint8Array view into
//   the frame, a list an Array, a map a plain object (keys in wire order).
//
// Reading checks every count and length against the bytes left before allocating anything, and
// bounds the nesting (32, the outermost value at depth 1) and one value's encoded size (4 MiB by
// default, the hub's limit), as runtime/src/flow/variant_binary.cpp does.
import { ByteReader, ByteWriter, asBytes, decodeUtf8 } from './bytes.js';
import { ProtocolError } from './errors.js';

export const TAG = Object.freeze({
  null: 0, bool: 1, int64: 2, uint64: 3, float64: 4, string: 5, bytes: 6, list: 7, map: 8,
});

export const MAX_DEPTH = 32;
export const MAX_VALUE_BYTES = 4 * 1024 * 1024;

const I64_MIN = -(2n ** 63n);
const I64_MAX = 2n ** 63n - 1n;
const U64_MAX = 2n ** 64n - 1n;

/** A number (or BigInt) with its wire type forced. */
export class Typed {
  /** @param {'int64' | 'uint64' | 'float64'} type @param {number | bigint} value */
  constructor(type, value) {
    this.type = type;
    this.value = value;
  }
}

/** Wrappers that force a value's wire type. */
export const Variant = Object.freeze({
  /** float64, also for an integer. @param {number | bigint} v */
  f64: (v) => new Typed('float64', Number(v)),
  /** int64. @param {number | bigint} v */
  i64: (v) => new Typed('int64', BigInt(v)),
  /** uint64. @param {number | bigint} v */
  u64: (v) => new Typed('uint64', BigInt(v)),
});

/**
 * Appends the binary encoding of `value`.
 * @param {ByteWriter} w
 * @param {unknown} value
 * @param {number} [depth]
 */
export function writeVariant(w, value, depth = 1) {
  if (depth > MAX_DEPTH) throw new RangeError(`nesting depth ${depth} exceeds the limit of ${MAX_DEPTH}`);
  if (value === null || value === undefined) {
    w.u8(TAG.null);
  } else if (typeof value === 'boolean') {
    w.u8(TAG.bool).u8(value ? 1 : 0);
  } else if (typeof value === 'number') {
    if (Number.isSafeInteger(value) && !Object.is(value, -0)) w.u8(TAG.int64).i64(BigInt(value));
    else w.u8(TAG.float64).f64(value);
  } else if (typeof value === 'bigint') {
    writeBig(w, value, value > I64_MAX ? 'uint64' : 'int64');
  } else if (value instanceof Typed) {
    if (value.type === 'float64') w.u8(TAG.float64).f64(Number(value.value));
    else writeBig(w, BigInt(value.value), value.type);
  } else if (typeof value === 'string') {
    w.u8(TAG.string).str32(value);
  } else if (value instanceof ArrayBuffer || ArrayBuffer.isView(value)) {
    const b = asBytes(value);
    w.u8(TAG.bytes).u32(b.byteLength).raw(b);
  } else if (Array.isArray(value)) {
    w.u8(TAG.list).u32(value.length);
    for (const item of value) writeVariant(w, item, depth + 1);
  } else if (value instanceof Map) {
    w.u8(TAG.map).u32(value.size);
    for (const [k, v] of value) {
      if (typeof k !== 'string') throw new TypeError('a map key must be a string');
      w.str16(k);
      writeVariant(w, v, depth + 1);
    }
  } else if (typeof value === 'object') {
    const keys = Object.keys(value);
    w.u8(TAG.map).u32(keys.length);
    for (const k of keys) {
      w.str16(k);
      writeVariant(w, /** @type {Record<string, unknown>} */ (value)[k], depth + 1);
    }
  } else {
    throw new TypeError(`a ${typeof value} has no Variant form`);
  }
}

function writeBig(w, v, type) {
  if (type === 'uint64') {
    if (v < 0n || v > U64_MAX) throw new RangeError(`${v} is out of the uint64 range`);
    w.u8(TAG.uint64).u64(v);
  } else {
    if (v < I64_MIN || v > I64_MAX) throw new RangeError(`${v} is out of the int64 range`);
    w.u8(TAG.int64).i64(v);
  }
}

/**
 * The binary encoding of one value.
 * @param {unknown} value
 * @returns {Uint8Array}
 */
export function encodeVariant(value) {
  const w = new ByteWriter(64);
  writeVariant(w, value);
  return w.bytes();
}

/**
 * Reads one value at the reader's position.
 * @param {ByteReader} r
 * @param {{maxDepth?: number, maxBytes?: number}} [limits]
 * @returns {unknown}
 */
export function readVariant(r, limits = {}) {
  const maxDepth = limits.maxDepth ?? MAX_DEPTH;
  const maxBytes = limits.maxBytes ?? MAX_VALUE_BYTES;
  // The value may take at most maxBytes: read from a reader cut to that size.
  const start = r.at;
  const cut = r.remaining > maxBytes ? new ByteReader(r.bytes.subarray(start, start + maxBytes)) : null;
  const from = cut ?? r;
  const v = readValue(from, 1, maxDepth);
  if (cut) r.at = start + cut.at;
  return v;
}

function fail(r, why) {
  return new ProtocolError(`${why} (at byte ${r.at})`);
}

function readValue(r, depth, maxDepth) {
  if (depth > maxDepth) throw fail(r, `variant at depth ${depth} exceeds the limit of ${maxDepth}`);
  const tag = r.u8('tag');
  switch (tag) {
    case TAG.null: return null;
    case TAG.bool: {
      const b = r.u8('bool');
      if (b > 1) throw fail(r, `bad bool byte 0x${b.toString(16).padStart(2, '0')}`);
      return b === 1;
    }
    case TAG.int64: return r.i64('int64');
    case TAG.uint64: return r.u64('uint64');
    case TAG.float64: return r.f64('float64');
    case TAG.string: return decodeUtf8(lengthPrefixed(r, 'string'));
    case TAG.bytes: return lengthPrefixed(r, 'bytes');
    case TAG.list: {
      const n = count(r, 'list count', 1);
      const items = [];
      for (let i = 0; i < n; ++i) items.push(readValue(r, depth + 1, maxDepth));
      return items;
    }
    case TAG.map: {
      const n = count(r, 'map count', 3);
      /** @type {Record<string, unknown>} */
      const out = {};
      const seen = new Set();
      for (let i = 0; i < n; ++i) {
        const key = r.str16('map key (u16 length + bytes)');
        if (seen.has(key)) throw fail(r, `duplicate map key "${key}"`);
        seen.add(key);
        const v = readValue(r, depth + 1, maxDepth);
        Object.defineProperty(out, key, { value: v, enumerable: true, writable: true, configurable: true });
      }
      return out;
    }
    default:
      throw fail(r, `unknown variant tag 0x${tag.toString(16).padStart(2, '0')}`);
  }
}

function lengthPrefixed(r, what) {
  const n = r.u32(`${what} length`);
  if (n > r.remaining) throw fail(r, `${what} length ${n} exceeds the ${r.remaining} bytes left`);
  return r.raw(n, what);
}

function count(r, what, minBytes) {
  const n = r.u32(what);
  if (n > Math.floor(r.remaining / minBytes)) {
    throw fail(r, `${what} ${n} exceeds the ${r.remaining} bytes left (each element takes at least ${minBytes} byte${minBytes === 1 ? '' : 's'})`);
  }
  return n;
}

/**
 * Decodes one whole encoded value (trailing bytes are an error).
 * @param {ArrayBuffer | ArrayBufferView} data
 * @param {{maxDepth?: number, maxBytes?: number}} [limits]
 * @returns {unknown}
 */
export function decodeVariant(data, limits) {
  const r = new ByteReader(asBytes(data));
  const v = readVariant(r, limits);
  r.done('variant');
  return v;
}
