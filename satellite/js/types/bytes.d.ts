/** Encodes a string as UTF-8. @param {string} s @returns {Uint8Array} */
export function encodeUtf8(s: string): Uint8Array;
/** Decodes UTF-8, throwing ProtocolError on bad bytes. @param {Uint8Array} bytes @returns {string} */
export function decodeUtf8(bytes: Uint8Array): string;
/**
 * A Uint8Array view of bytes given as an ArrayBuffer, a typed array or a DataView (no copy).
 * @param {ArrayBuffer | ArrayBufferView} data
 * @returns {Uint8Array}
 */
export function asBytes(data: ArrayBuffer | ArrayBufferView): Uint8Array;
/** Reads a body field by field; every read checks the bytes left and throws ProtocolError. */
export class ByteReader {
    /** @param {Uint8Array} bytes */
    constructor(bytes: Uint8Array);
    /** @type {Uint8Array} */
    bytes: Uint8Array;
    view: DataView<ArrayBufferLike>;
    at: number;
    /** @returns {number} bytes not read yet */
    get remaining(): number;
    /** @param {number} n @param {string} what */
    need(n: number, what: string): void;
    u8(what?: string): number;
    u16(what?: string): number;
    u32(what?: string): number;
    /** @returns {bigint} */
    u64(what?: string): bigint;
    /** @returns {bigint} */
    i64(what?: string): bigint;
    f64(what?: string): number;
    /** n bytes as a view into the body. @param {number} n @returns {Uint8Array} */
    raw(n: number, what?: string): Uint8Array;
    str16(what?: string): string;
    str32(what?: string): string;
    /** The bytes left, as a view. @returns {Uint8Array} */
    rest(): Uint8Array;
    /** Throws unless everything was read. @param {string} what */
    done(what: string): void;
}
/** Appends little-endian fields to a growing buffer. */
export class ByteWriter {
    constructor(capacity?: number);
    buf: Uint8Array<ArrayBuffer>;
    view: DataView<ArrayBuffer>;
    length: number;
    /** @param {number} n */
    room(n: number): void;
    u8(v: any): this;
    u16(v: any): this;
    u32(v: any): this;
    /** @param {bigint | number} v */
    u64(v: bigint | number): this;
    /** @param {bigint | number} v */
    i64(v: bigint | number): this;
    f64(v: any): this;
    /** @param {Uint8Array} bytes */
    raw(bytes: Uint8Array): this;
    /** @param {string} s */
    str16(s: string): this;
    /** @param {string} s */
    str32(s: string): this;
    /** @param {number} at @param {number} v */
    patchU32(at: number, v: number): void;
    /** The bytes written, as a view. @returns {Uint8Array} */
    bytes(): Uint8Array;
}
