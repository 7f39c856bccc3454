// SPDX-License-Identifier: Apache-2.0
// skrobot for browsers (and any runtime with a global WebSocket): ws: and wss: addresses only.
import { Hub } from './hub.js';
import { parseAddress } from './address.js';
import { openWebSocket } from './transport-ws.js';
import { pageToken } from './page-token.js';

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

/**
 * For a page served by the hub's web port: connects to its /flow and logs in with a page token
 * fetched from /skrobot/token of the page's origin, a new one at each reconnection; the session
 * has the hub's page account (server.web.page_account, by default the read-only `web-page`).
 * @param {import('./hub.js').HubOptions} [options]
 * @returns {Promise<Hub>}
 */
export async function connectPage(options = {}) {
  return connect(undefined, { ...options, token: pageToken() });
}
