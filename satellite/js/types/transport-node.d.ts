/**
 * @typedef {object} Transport
 * @property {(parts: Uint8Array[]) => void} send writes whole frames (all parts, in order)
 * @property {() => number} buffered bytes written but not yet taken by the socket
 * @property {(reason?: Error) => void} close
 * @property {(frames: {code: number, body: Uint8Array}[]) => void} onframes set by the hub
 * @property {(error: Error | null) => void} onclose set by the hub; called once
 */
/**
 * Opens a stream transport. Resolves once connected (for tls: once the handshake is done).
 * @param {import('./address.js').Address} address
 * @param {{maxFrameBytes?: number, timeoutMs?: number, tls?: {ca?: string, cert?: string, key?: string}}} [options]
 * @returns {Promise<Transport>}
 */
export function openStream(address: import("./address.js").Address, options?: {
    maxFrameBytes?: number;
    timeoutMs?: number;
    tls?: {
        ca?: string;
        cert?: string;
        key?: string;
    };
}): Promise<Transport>;
export type Transport = {
    /**
     * writes whole frames (all parts, in order)
     */
    send: (parts: Uint8Array[]) => void;
    /**
     * bytes written but not yet taken by the socket
     */
    buffered: () => number;
    close: (reason?: Error) => void;
    /**
     * set by the hub
     */
    onframes: (frames: {
        code: number;
        body: Uint8Array;
    }[]) => void;
    /**
     * set by the hub; called once
     */
    onclose: (error: Error | null) => void;
};
