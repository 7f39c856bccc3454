// SPDX-License-Identifier: Apache-2.0
// The WebSocket transport (ws: and wss:): subprotocol skrobot-flow.v1, binary messages each holding
// whole frames (the hub's web port never cuts a frame across two messages), handed out as views
// without reassembly. Browsers and Node >= 22 use the global WebSocket; older Node passes the `ws`
// package's class as options.WebSocket.
import { messageFrames, DEFAULT_MAX_FRAME_BYTES } from './frames.js';
import { ClosedError, ProtocolError } from './errors.js';

export const SUBPROTOCOL = 'skrobot-flow.v1';

/**
 * Opens a WebSocket transport to `url`.
 * @param {string} url ws://host:port/flow
 * @param {{maxFrameBytes?: number, timeoutMs?: number, WebSocket?: any}} [options]
 * @returns {Promise<import('./transport-node.js').Transport>}
 */
export function openWebSocket(url, options = {}) {
  const WS = options.WebSocket ?? globalThis.WebSocket;
  if (!WS) {
    return Promise.reject(new TypeError('no WebSocket: on Node < 22 pass the ws package as options.WebSocket'));
  }
  const max = options.maxFrameBytes ?? DEFAULT_MAX_FRAME_BYTES;
  return new Promise((resolve, reject) => {
    const ws = new WS(url, SUBPROTOCOL);
    ws.binaryType = 'arraybuffer';
    let opened = false;
    let closed = false;
    let failure = null;
    const timer = setTimeout(() => { failure = new ClosedError('connecting timed out'); ws.close(); }, options.timeoutMs ?? 10000);
    /** @type {import('./transport-node.js').Transport} */
    const t = {
      onframes: () => {},
      onclose: () => {},
      buffered: () => ws.bufferedAmount ?? 0,
      send(parts) {
        if (closed || ws.readyState !== 1) return;
        if (parts.length === 1) {
          ws.send(parts[0]);
          return;
        }
        // One message of whole frames: browsers cannot gather, so the parts are joined once.
        let n = 0;
        for (const p of parts) n += p.byteLength;
        const out = new Uint8Array(n);
        let at = 0;
        for (const p of parts) { out.set(p, at); at += p.byteLength; }
        ws.send(out);
      },
      close(reason) {
        if (closed) return;
        failure = failure ?? reason ?? null;
        ws.close(reason ? 1002 : 1000);
      },
    };
    ws.onopen = () => {
      clearTimeout(timer);
      if (ws.protocol !== SUBPROTOCOL) {
        failure = new ProtocolError(`the server chose subprotocol "${ws.protocol}", not ${SUBPROTOCOL}`);
        ws.close(1002);
        return;
      }
      opened = true;
      resolve(t);
    };
    ws.onmessage = (event) => {
      if (closed) return;
      if (typeof event.data === 'string') {
        failure = new ProtocolError('a text message on a flow');
        ws.close(1003);
        return;
      }
      const data = event.data instanceof ArrayBuffer ? new Uint8Array(event.data)
        : new Uint8Array(event.data.buffer, event.data.byteOffset, event.data.byteLength);
      let frames;
      try {
        frames = messageFrames(data, max);
      } catch (e) {
        failure = /** @type {Error} */ (e);
        ws.close(1007);
        return;
      }
      if (frames.length) t.onframes(frames);
    };
    // Browsers say nothing of why; the ws package names it (e.g. a subprotocol not asked for).
    ws.onerror = (event) => {
      if (!opened && !failure && event?.message) failure = new ClosedError(`WebSocket: ${event.message}`);
    };
    ws.onclose = (event) => {
      clearTimeout(timer);
      if (closed) return;
      closed = true;
      const why = failure ?? (event.code === 1000 ? null : new ClosedError(`WebSocket closed (${event.code} ${event.reason || ''})`.trim()));
      if (!opened) reject(why ?? new ClosedError('the WebSocket closed'));
      else t.onclose(why);
    };
  });
}
