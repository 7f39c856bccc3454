// SPDX-License-Identifier: Apache-2.0
// Page tokens: a page served by the hub's web port logs in without a password. It fetches a
// short-lived token with POST /skrobot/token (same origin) and logs in with LOGIN_TOKEN as the
// hub's page account (server.web.page_account, by default the read-only `web-page`); a token is
// good only from the address that fetched it and until it expires, so each login fetches a new one.
import { parseAddress } from './address.js';
import { AuthFailedError, LimitExceededError, ProtocolError } from './errors.js';

/**
 * The URL of a hub's page tokens: /skrobot/token of the page's own origin, or of the hub whose
 * web port a ws:/wss: address names (ws://host:port/flow gives http://host:port/skrobot/token).
 * @param {string} [address] a ws: or wss: address; default: the page's origin
 * @returns {string}
 */
export function pageTokenUrl(address) {
  if (address === undefined) {
    const loc = /** @type {any} */ (globalThis).location;
    return loc?.href ? new URL('/skrobot/token', loc.href).href : '/skrobot/token';
  }
  const a = parseAddress(address);
  if (a.kind !== 'ws' && a.kind !== 'wss') throw new TypeError(`${address}: page tokens come from a ws: or wss: hub`);
  const u = new URL(a.url);
  return `${a.kind === 'wss' ? 'https' : 'http'}://${u.host}/skrobot/token`;
}

/**
 * A function that fetches a new page token each time it is called: the `token` option of
 * connect(), so that every login (the first and each reconnection) has a fresh one.
 * @param {string} [address] a ws: or wss: address of the hub; default: the page's own origin
 * @returns {() => Promise<string>}
 */
export function pageToken(address) {
  const url = pageTokenUrl(address);
  return async () => {
    const res = await fetch(url, { method: 'POST', credentials: 'same-origin', cache: 'no-store' });
    if (!res.ok) {
      const why = `POST ${url}: ${res.status} ${(await res.text()).trim()}`;
      throw res.status === 503 ? new LimitExceededError(why) : new AuthFailedError(why);
    }
    const body = await res.json();
    if (typeof body?.token !== 'string') throw new ProtocolError(`POST ${url}: no token in the answer`);
    return body.token;
  };
}
