// SPDX-License-Identifier: Apache-2.0
// The Node.js transports: local: (a Unix socket), tcp: and tls: through node:net and node:tls,
// the byte stream cut into frames by FrameSplitter. Frames go out as written (a payload view is
// handed to the socket, not copied), corked so that one call makes one write.
import net from 'node:net';
import tls from 'node:tls';
import { readFileSync } from 'node:fs';
import { FrameSplitter, DEFAULT_MAX_FRAME_BYTES } from './frames.js';
import { ClosedError } from './errors.js';

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
export function openStream(address, options = {}) {
  const splitter = new FrameSplitter(options.maxFrameBytes ?? DEFAULT_MAX_FRAME_BYTES);
  return new Promise((resolve, reject) => {
    let socket;
    const ready = address.kind === 'tls' ? 'secureConnect' : 'connect';
    if (address.kind === 'local') {
      socket = net.createConnection({ path: address.path });
    } else if (address.kind === 'tcp') {
      socket = net.createConnection({ host: address.host, port: address.port });
    } else if (address.kind === 'tls') {
      const files = options.tls ?? {};
      const ca = files.ca ?? process.env.ROBOT_TLS_CA;
      const cert = files.cert ?? process.env.ROBOT_TLS_CERT;
      const key = files.key ?? process.env.ROBOT_TLS_KEY;
      socket = tls.connect({
        host: address.host, port: address.port, servername: net.isIP(address.host) ? undefined : address.host,
        ca: ca ? readFileSync(ca) : undefined, cert: cert ? readFileSync(cert) : undefined,
        key: key ? readFileSync(key) : undefined, minVersion: 'TLSv1.2',
      });
    } else {
      reject(new TypeError(`${address.kind}: not a stream address`));
      return;
    }
    socket.setNoDelay?.(true);
    const timer = setTimeout(() => socket.destroy(new ClosedError('connecting timed out')), options.timeoutMs ?? 10000);
    let opened = false;
    let closed = false;
    /** @type {Transport} */
    const t = {
      onframes: () => {},
      onclose: () => {},
      buffered: () => socket.writableLength,
      send(parts) {
        if (closed) return;
        socket.cork();
        for (const p of parts) socket.write(p);
        socket.uncork();
      },
      close(reason) {
        if (!closed) socket.destroy(reason);
      },
    };
    socket.on(ready, () => {
      clearTimeout(timer);
      opened = true;
      resolve(t);
    });
    socket.on('data', (chunk) => {
      if (closed) return;
      let frames;
      try {
        frames = splitter.push(new Uint8Array(chunk.buffer, chunk.byteOffset, chunk.byteLength));
      } catch (e) {
        socket.destroy(/** @type {Error} */ (e));
        return;
      }
      if (frames.length) t.onframes(frames);
    });
    let lastError = null;
    socket.on('error', (e) => { lastError = e; });
    socket.on('close', () => {
      clearTimeout(timer);
      if (closed) return;
      closed = true;
      if (!opened) reject(lastError ?? new ClosedError('the connection closed'));
      else t.onclose(lastError);
    });
  });
}
