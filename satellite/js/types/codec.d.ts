/** The wire name of a code, "UNKNOWN" when the catalogue lacks it. @param {number} code */
export function codeName(code: number): string;
/**
 * Encodes one frame: [head] or [head, payload] when the row ends in `rest` (the payload is the
 * caller's view, never copied). The length field covers both.
 * @param {string} name the wire name ("SUBSCRIBE")
 * @param {Record<string, any>} [fields]
 * @returns {Uint8Array[]}
 */
export function encodeFrame(name: string, fields?: Record<string, any>): Uint8Array[];
/**
 * Decodes a frame body (the bytes after the code) by its code's row; `reply` decodes a REPLY_OK
 * body as the reply of request `code`. Throws ProtocolError for an unknown code, a short body,
 * trailing bytes or a bad value.
 * @param {number} code
 * @param {Uint8Array} body
 * @param {{reply?: boolean, maxDepth?: number, maxBytes?: number}} [options]
 * @returns {Record<string, any>}
 */
export function decodeBody(code: number, body: Uint8Array, options?: {
    reply?: boolean;
    maxDepth?: number;
    maxBytes?: number;
}): Record<string, any>;
/** The row of each code. @type {ReadonlyMap<number, typeof CODES[number]>} */
export const BY_CODE: ReadonlyMap<number, (typeof CODES)[number]>;
/** The code of each wire name ("PUBLISH" -> 0x44). @type {Readonly<Record<string, number>>} */
export const CODE: Readonly<Record<string, number>>;
import { PROTOCOL_MAJOR } from './catalogue.js';
import { CATALOGUE_MINOR } from './catalogue.js';
import { CODES } from './catalogue.js';
export { PROTOCOL_MAJOR, CATALOGUE_MINOR };
