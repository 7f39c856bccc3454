/**
 * The frames of one message that holds whole frames, as views; a message that ends inside a
 * frame is a ProtocolError.
 * @param {Uint8Array} message
 * @param {number} [maxFrameBytes]
 * @returns {Frame[]}
 */
export function messageFrames(message: Uint8Array, maxFrameBytes?: number): Frame[];
export const FRAME_HEADER_BYTES: 5;
export const DEFAULT_MAX_FRAME_BYTES: number;
/** Cuts a byte stream into frames. */
export class FrameSplitter {
    constructor(maxFrameBytes?: number);
    maxFrameBytes: number;
    /** @type {Uint8Array[]} */
    chunks: Uint8Array[];
    buffered: number;
    /**
     * Adds what the socket gave and returns the frames now complete.
     * @param {Uint8Array} chunk
     * @returns {Frame[]}
     */
    push(chunk: Uint8Array): Frame[];
    peek(n: any): Uint8Array<any>;
    take(n: any): Uint8Array<any>;
}
export type Frame = {
    code: number;
    body: Uint8Array;
};
