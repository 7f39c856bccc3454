/** The row of a format code, or undefined. @param {number} format */
export function encodingOf(format: number): Readonly<{
    encoding: "jpeg";
    format: 1;
    video: true;
    bitsPerPixel: 0;
    evenSize: false;
    mime: "image/jpeg";
}> | Readonly<{
    encoding: "mono8";
    format: 2;
    video: true;
    bitsPerPixel: 8;
    evenSize: false;
    mime: "application/octet-stream";
}> | Readonly<{
    encoding: "s16le";
    format: 3;
    video: false;
    bitsPerPixel: 0;
    evenSize: false;
    mime: "audio/L16";
}> | Readonly<{
    encoding: "rgb8";
    format: 4;
    video: true;
    bitsPerPixel: 24;
    evenSize: false;
    mime: "application/octet-stream";
}> | Readonly<{
    encoding: "bgr8";
    format: 5;
    video: true;
    bitsPerPixel: 24;
    evenSize: false;
    mime: "application/octet-stream";
}> | Readonly<{
    encoding: "rgba8";
    format: 6;
    video: true;
    bitsPerPixel: 32;
    evenSize: false;
    mime: "application/octet-stream";
}> | Readonly<{
    encoding: "bgra8";
    format: 7;
    video: true;
    bitsPerPixel: 32;
    evenSize: false;
    mime: "application/octet-stream";
}> | Readonly<{
    encoding: "mono16";
    format: 8;
    video: true;
    bitsPerPixel: 16;
    evenSize: false;
    mime: "application/octet-stream";
}> | Readonly<{
    encoding: "nv12";
    format: 9;
    video: true;
    bitsPerPixel: 12;
    evenSize: true;
    mime: "application/octet-stream";
}> | Readonly<{
    encoding: "i420";
    format: 10;
    video: true;
    bitsPerPixel: 12;
    evenSize: true;
    mime: "application/octet-stream";
}>;
/** Bytes of a raw payload of width x height; 0 when not raw or the size is not allowed. */
export function rawPayloadBytes(info: any, width: any, height: any): number;
/**
 * Header + payload as one Uint8Array (one copy of the payload, into the frame to publish).
 * @param {{format: number, seq: number | bigint, captureNs?: bigint, width?: number, height?: number, channels?: number, sampleRate?: number}} h
 * @param {ArrayBuffer | ArrayBufferView} payload
 * @returns {Uint8Array}
 */
export function makeMediaFrame(h: {
    format: number;
    seq: number | bigint;
    captureNs?: bigint;
    width?: number;
    height?: number;
    channels?: number;
    sampleRate?: number;
}, payload: ArrayBuffer | ArrayBufferView): Uint8Array;
/**
 * The header fields and the payload (a view) of a received frame, or null when it is not a
 * well-formed one (as parseFrame in media_frame.hpp).
 * @param {ArrayBuffer | ArrayBufferView} data
 */
export function parseMediaFrame(data: ArrayBuffer | ArrayBufferView): {
    format: number;
    encoding: "jpeg" | "mono8" | "s16le" | "rgb8" | "bgr8" | "rgba8" | "bgra8" | "mono16" | "nv12" | "i420";
    seq: bigint;
    captureNs: bigint;
    width: number;
    height: number;
    channels: number;
    sampleRate: number;
    payload: Uint8Array<ArrayBufferLike>;
};
/** Format code by encoding name ({jpeg: 1, mono8: 2, ...}). */
export const FORMAT: Readonly<{
    [k: string]: 1 | 2 | 8 | 3 | 4 | 5 | 6 | 7 | 9 | 10;
}>;
import { ENCODINGS } from './media-codes.js';
import { HEADER_BYTES } from './media-codes.js';
import { MESSAGE_ENCODING } from './media-codes.js';
export { ENCODINGS, HEADER_BYTES, MESSAGE_ENCODING };
