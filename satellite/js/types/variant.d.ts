/**
 * Appends the binary encoding of `value`.
 * @param {ByteWriter} w
 * @param {unknown} value
 * @param {number} [depth]
 */
export function writeVariant(w: ByteWriter, value: unknown, depth?: number): void;
/**
 * The binary encoding of one value.
 * @param {unknown} value
 * @returns {Uint8Array}
 */
export function encodeVariant(value: unknown): Uint8Array;
/**
 * Reads one value at the reader's position.
 * @param {ByteReader} r
 * @param {{maxDepth?: number, maxBytes?: number}} [limits]
 * @returns {unknown}
 */
export function readVariant(r: ByteReader, limits?: {
    maxDepth?: number;
    maxBytes?: number;
}): unknown;
/**
 * Decodes one whole encoded value (trailing bytes are an error).
 * @param {ArrayBuffer | ArrayBufferView} data
 * @param {{maxDepth?: number, maxBytes?: number}} [limits]
 * @returns {unknown}
 */
export function decodeVariant(data: ArrayBuffer | ArrayBufferView, limits?: {
    maxDepth?: number;
    maxBytes?: number;
}): unknown;
export const TAG: Readonly<{
    null: 0;
    bool: 1;
    int64: 2;
    uint64: 3;
    float64: 4;
    string: 5;
    bytes: 6;
    list: 7;
    map: 8;
}>;
export const MAX_DEPTH: 32;
export const MAX_VALUE_BYTES: number;
/** A number (or BigInt) with its wire type forced. */
export class Typed {
    /** @param {'int64' | 'uint64' | 'float64'} type @param {number | bigint} value */
    constructor(type: "int64" | "uint64" | "float64", value: number | bigint);
    type: "int64" | "uint64" | "float64";
    value: number | bigint;
}
/** Wrappers that force a value's wire type. */
export const Variant: Readonly<{
    /** float64, also for an integer. @param {number | bigint} v */
    f64: (v: number | bigint) => Typed;
    /** int64. @param {number | bigint} v */
    i64: (v: number | bigint) => Typed;
    /** uint64. @param {number | bigint} v */
    u64: (v: number | bigint) => Typed;
}>;
import { ByteWriter } from './bytes.js';
import { ByteReader } from './bytes.js';
