// SPDX-License-Identifier: Apache-2.0
// Frames encoded and decoded from the catalogue's rows (catalogue.js, generated from
// catalogue.h and messages.h): one table, no layout written by hand. A decoded frame is a plain
// object of its fields by their wire names (chan_id); a part (ChannelInfo) lies in place, a list is
// `items`; `rest` and bytes are views into the frame, never copies.
import { CODES, PARTS, PROTOCOL_MAJOR, CATALOGUE_MINOR } from './catalogue.js';
import { ByteReader, ByteWriter, asBytes } from './bytes.js';
import { readVariant, writeVariant } from './variant.js';
import { ProtocolError } from './errors.js';

export { PROTOCOL_MAJOR, CATALOGUE_MINOR };

/** The row of each code. @type {ReadonlyMap<number, typeof CODES[number]>} */
export const BY_CODE = new Map(CODES.map((row) => [row.code, row]));
/** The code of each wire name ("PUBLISH" -> 0x44). @type {Readonly<Record<string, number>>} */
export const CODE = Object.freeze(Object.fromEntries(CODES.map((row) => [row.name, row.code])));

/** The wire name of a code, "UNKNOWN" when the catalogue lacks it. @param {number} code */
export function codeName(code) {
  return BY_CODE.get(code)?.name ?? 'UNKNOWN';
}

function writeFields(w, fields, m) {
  for (const f of fields) {
    const [type, name] = f;
    switch (type) {
      case 'u8': w.u8(num(m, name, 0xff)); break;
      case 'u16': w.u16(num(m, name, 0xffff)); break;
      case 'u32': w.u32(num(m, name, 0xffffffff)); break;
      case 'u64': w.u64(m[name] ?? 0n); break;
      case 'str16': w.str16(m[name] ?? ''); break;
      case 'str32': w.str32(m[name] ?? ''); break;
      case 'value': w.u8(0); writeVariant(w, m[name]); break;  // encoding 0: binary
      case 'rest': break;  // appended by the caller as its own part (never copied here)
      case 'part': writeFields(w, PARTS[name], m); break;
      case 'list': {
        const items = m[f[2]] ?? [];
        w.u32(items.length);
        for (const item of items) writeFields(w, PARTS[name], item);
        break;
      }
      default: throw new TypeError(`unknown field type ${type}`);
    }
  }
}

function num(m, name, max) {
  const v = m[name] ?? 0;
  if (!Number.isInteger(v) || v < 0 || v > max) throw new RangeError(`${name}: ${v} is not an integer in 0..${max}`);
  return v;
}

/**
 * Encodes one frame: [head] or [head, payload] when the row ends in `rest` (the payload is the
 * caller's view, never copied). The length field covers both.
 * @param {string} name the wire name ("SUBSCRIBE")
 * @param {Record<string, any>} [fields]
 * @returns {Uint8Array[]}
 */
export function encodeFrame(name, fields = {}) {
  const row = CODES.find((r) => r.name === name);
  if (!row) throw new TypeError(`no code named ${name}`);
  const w = new ByteWriter(64);
  w.u32(0).u8(row.code);
  writeFields(w, row.body, fields);
  const last = row.body[row.body.length - 1];
  const rest = last && last[0] === 'rest' ? asBytes(fields[last[1]] ?? new Uint8Array(0)) : null;
  w.patchU32(0, w.length - 4 + (rest ? rest.byteLength : 0));
  return rest && rest.byteLength > 0 ? [w.bytes(), rest] : [w.bytes()];
}

function readFields(r, fields, out, limits) {
  for (const f of fields) {
    const [type, name] = f;
    switch (type) {
      case 'u8': out[name] = r.u8(name); break;
      case 'u16': out[name] = r.u16(name); break;
      case 'u32': out[name] = r.u32(name); break;
      case 'u64': out[name] = r.u64(name); break;
      case 'str16': out[name] = r.str16(name); break;
      case 'str32': out[name] = r.str32(name); break;
      case 'value': {
        const enc = r.u8(`${name} encoding`);
        if (enc === 0) out[name] = readVariant(r, limits);
        else if (enc === 1) out[name] = JSON.parse(r.str32(name));
        else throw new ProtocolError(`${name}: unknown value encoding ${enc}`);
        break;
      }
      case 'rest': out[name] = r.rest(); break;
      case 'part': readFields(r, PARTS[name], out, limits); break;
      case 'list': {
        const n = r.u32('count');
        if (n > r.remaining) throw new ProtocolError(`count ${n} exceeds the ${r.remaining} bytes left`);
        const items = [];
        for (let i = 0; i < n; ++i) items.push(readFields(r, PARTS[name], {}, limits));
        out[f[2]] = items;
        break;
      }
      default: throw new TypeError(`unknown field type ${type}`);
    }
  }
  return out;
}

/**
 * Decodes a frame body (the bytes after the code) by its code's row; `reply` decodes a REPLY_OK
 * body as the reply of request `code`. Throws ProtocolError for an unknown code, a short body,
 * trailing bytes or a bad value.
 * @param {number} code
 * @param {Uint8Array} body
 * @param {{reply?: boolean, maxDepth?: number, maxBytes?: number}} [options]
 * @returns {Record<string, any>}
 */
export function decodeBody(code, body, options = {}) {
  const row = BY_CODE.get(code);
  if (!row) throw new ProtocolError(`unknown code 0x${code.toString(16).padStart(2, '0')}`);
  const fields = options.reply ? row.reply : row.body;
  if (!fields) throw new ProtocolError(`${row.name} has no reply body`);
  const r = new ByteReader(body);
  try {
    const out = readFields(r, fields, {}, options);
    r.done(row.name);
    return out;
  } catch (e) {
    if (e instanceof ProtocolError && !e.message.startsWith(row.name)) e.message = `${row.name}: ${e.message}`;
    throw e;
  }
}
