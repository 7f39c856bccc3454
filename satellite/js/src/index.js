// SPDX-License-Identifier: Apache-2.0
// skrobot for browsers (and any runtime with a global WebSocket): ws: and wss: addresses only.
import { Hub } from './hub.js';
import { parseAddress } from './address.js';
import { openWebSocket } from './transport-ws.js';

export * from './common.js';

/**
 * Connects to a hub's web port and logs in; resolves once online.
 * @param {string} [address] ws:host:port/flow; default: the page's own host, /flow
 * @param {import('./hub.js').HubOptions} [options]
 * @returns {Promise<Hub>}
 */
export async function connect(address, options = {}) {
  const loc = /** @type {any} */ (globalThis).location;
  const text = address ?? `${loc?.protocol === 'https:' ? 'wss' : 'ws'}://${loc?.host}/flow`;
  const parsed = parseAddress(text);
  if (parsed.kind !== 'ws' && parsed.kind !== 'wss') throw new TypeError(`${text}: a browser connects with ws: or wss: only`);
  const hub = new Hub(parsed, options, (a, o) => openWebSocket(/** @type {any} */ (a).url, o));
  await hub.start();
  return hub;
}
