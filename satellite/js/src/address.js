// SPDX-License-Identifier: Apache-2.0
// A hub's address, as ROBOT_ADDRESS and flowctl's --address write it (docs/flow-protocol.md,
// "Addresses"): local:/path, tcp:host[:port], tls:host[:port] (port 9000 by default; IPv6 as
// tcp:[::1]:9000), and the WebSocket forms ws:host[:port][/path] and wss:... (also written as
// ws://... URLs; the path defaults to /flow, the port to 80 or 443 as for any URL).

export const DEFAULT_ADDRESS = 'local:/tmp/Robot';
export const DEFAULT_TCP_PORT = 9000;

/**
 * @typedef {{kind: 'local', path: string}
 *   | {kind: 'tcp' | 'tls', host: string, port: number}
 *   | {kind: 'ws' | 'wss', url: string}} Address
 */

function hostPort(text, whole, defaultPort) {
  let host = text;
  let port = defaultPort;
  if (text.startsWith('[')) {
    const end = text.indexOf(']');
    if (end < 0) throw new TypeError(`address ${whole}: unclosed [`);
    host = text.slice(1, end);
    const tail = text.slice(end + 1);
    if (tail) {
      if (!tail.startsWith(':')) throw new TypeError(`address ${whole}: expected :port after ]`);
      port = portOf(tail.slice(1), whole);
    }
  } else {
    const colon = text.lastIndexOf(':');
    if (colon >= 0) {
      host = text.slice(0, colon);
      port = portOf(text.slice(colon + 1), whole);
    }
  }
  if (!host) throw new TypeError(`address ${whole}: no host`);
  return { host, port };
}

function portOf(text, whole) {
  const port = Number(text);
  if (!/^[0-9]+$/.test(text) || port < 1 || port > 65535) throw new TypeError(`address ${whole}: bad port ${text}`);
  return port;
}

/**
 * Parses an address; throws TypeError naming what is wrong.
 * @param {string} text
 * @returns {Address}
 */
export function parseAddress(text) {
  if (text.startsWith('local:')) {
    const path = text.slice('local:'.length);
    if (!path) throw new TypeError(`address ${text}: no socket path`);
    return { kind: 'local', path };
  }
  for (const kind of /** @type {const} */ (['tcp', 'tls'])) {
    if (text.startsWith(`${kind}:`)) {
      return { kind, ...hostPort(text.slice(4).replace(/^\/\//, ''), text, DEFAULT_TCP_PORT) };
    }
  }
  const ws = /^(wss?):(\/\/)?([^/]+)(\/.*)?$/.exec(text);
  if (ws) {
    const kind = /** @type {'ws' | 'wss'} */ (ws[1]);
    const { host, port } = hostPort(ws[3], text, kind === 'ws' ? 80 : 443);
    const h = host.includes(':') ? `[${host}]` : host;
    return { kind, url: `${kind}://${h}:${port}${ws[4] || '/flow'}` };
  }
  throw new TypeError(`address ${text}: expected local:, tcp:, tls:, ws: or wss:`);
}
