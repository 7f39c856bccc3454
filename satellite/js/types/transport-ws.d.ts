/**
 * Opens a WebSocket transport to `url`.
 * @param {string} url ws://host:port/flow
 * @param {{maxFrameBytes?: number, timeoutMs?: number, WebSocket?: any}} [options]
 * @returns {Promise<import('./transport-node.js').Transport>}
 */
export function openWebSocket(url: string, options?: {
    maxFrameBytes?: number;
    timeoutMs?: number;
    WebSocket?: any;
}): Promise<import("./transport-node.js").Transport>;
export const SUBPROTOCOL: "skrobot-flow.v1";
