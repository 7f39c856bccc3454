// SPDX-License-Identifier: Apache-2.0
// skrobot for Node.js: local:, tcp:, tls: (node:net, node:tls) and ws:/wss: (the global WebSocket
// of Node >= 22, else the optional peer package `ws`). The address defaults to ROBOT_ADDRESS, the
// account to ROBOT_USER / ROBOT_PASSWORD.
import { Hub } from './hub.js';
import { parseAddress, DEFAULT_ADDRESS } from './address.js';
import { openStream } from './transport-node.js';
import { openWebSocket } from './transport-ws.js';

export * from './common.js';

async function webSocketClass(options) {
  if (options.WebSocket) return options.WebSocket;
  if (globalThis.WebSocket) return globalThis.WebSocket;
  try {
    return (await import('ws')).default;
  } catch {
    throw new TypeError('ws: addresses on Node < 22 need the package ws (npm install ws)');
  }
}

/**
 * Connects to a hub and logs in; resolves once online (rejects on a refused login or no hub).
 * @param {string} [address] local:/path, tcp:host:port, tls:host:port, ws:host:port/flow
 * @param {import('./hub.js').HubOptions} [options]
 * @returns {Promise<Hub>}
 */
export async function connect(address, options = {}) {
  const parsed = parseAddress(address ?? process.env.ROBOT_ADDRESS ?? DEFAULT_ADDRESS);
  const hub = new Hub(parsed, options, async (a, o) => {
    if (a.kind === 'ws' || a.kind === 'wss') return openWebSocket(a.url, { ...o, WebSocket: await webSocketClass(o) });
    return openStream(a, o);
  });
  await hub.start();
  return hub;
}
