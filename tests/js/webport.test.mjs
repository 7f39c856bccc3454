// SPDX-License-Identifier: Apache-2.0
// The library over the hub's own web port (server.web, flows over WebSocket at /flow): an
// account and the loopback dev account log in over ws: (the ws package's class on Node < 22),
// a large payload, a service call, a database and hub.stats. Skipped while the hub has no
// server.web (it refuses the key); run against ws/webport's hub it passed. Pages log in with page
// tokens (LOGIN_TOKEN): the page account's rights, a new token for each reconnection, connectPage().
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { startHub, waitFor, freePort, webRequire } from '../web/harness.mjs';
import * as skr from '../../satellite/js/src/node.js';

const WebSocket = globalThis.WebSocket ?? webRequire('ws');

async function webHub(port, web = {}) {
  try {
    return await startHub([], { users: [{ name: 'alice', password: 'pw' }], server: { web: { port, flows: true, dev_account: true, ...web } } });
  } catch (e) {
    if (/server\.web|"web"|\$\.server/.test(String(e.message))) return null;
    throw e;
  }
}

test('over the web port: accounts, payloads, services, databases, hub.stats', async (t) => {
  const port = await freePort();
  const hub = await webHub(port);
  if (!hub) {
    t.skip('this hub has no server.web yet');
    return;
  }
  const url = `ws:127.0.0.1:${port}/flow`;
  const a = await skr.connect(url, { WebSocket, user: 'alice', password: 'pw' });
  const b = await skr.connect(url, { WebSocket });
  try {
    assert.deepEqual([a.session.user, b.session.user], ['alice', 'guest']);
    const ch = await a.createChannel('overweb');
    const got = [];
    b.subscribe('alice.overweb', (m) => got.push(Buffer.from(m.payload)));
    await waitFor('subscribed', () => ch.hasSubscribers, 5000, 10);
    const big = new Uint8Array(1000000).map((_, i) => i & 0xff);
    ch.publish('x');
    ch.publish(big);
    await waitFor('both payloads', () => got.length === 2, 10000, 10);
    assert.ok(got[1].equals(Buffer.from(big)), '1 MB byte-exact');
    await a.serve('echo', (c, v) => v);
    await waitFor('listed', () => b.channelByName('alice.echo'), 5000, 10);
    assert.deepEqual(await b.call('alice.echo', 'x', [1, 'y']), [1n, 'y']);
    await a.db().set('k', 2.5);
    assert.equal(await b.db('alice').get('k'), 2.5);
    let stats;
    const s = b.stats((x) => { stats = x; });
    await waitFor('hub.stats', () => stats, 10000, 50);
    s.close();
    await assert.rejects(skr.connect(url, { WebSocket, user: 'alice', password: 'wrong' }), skr.AuthFailedError);
  } finally {
    a.close();
    b.close();
    await hub.stop();
  }
});

test('a page token logs in as the read-only page account, a new one for each reconnection', async (t) => {
  const port = await freePort();
  const hub = await webHub(port, { token_ttl_ms: 1000 });
  if (!hub) {
    t.skip('this hub has no server.web yet');
    return;
  }
  const url = `ws:127.0.0.1:${port}/flow`;
  const a = await skr.connect(url, { WebSocket, user: 'alice', password: 'pw' });
  let fetched = 0;
  const fetchToken = skr.pageToken(url);
  const page = await skr.connect(url, { WebSocket, token: () => { fetched++; return fetchToken(); } });
  /** @type {import('../../satellite/js/src/hub.js').Hub | undefined} */
  let viaPage;
  const location = Object.getOwnPropertyDescriptor(globalThis, 'location');
  try {
    assert.equal(page.session.user, 'web-page');
    const ch = await a.createChannel('cam');
    const got = [];
    page.subscribe('alice.cam', (m) => got.push(Buffer.from(m.payload).toString()));
    await waitFor('subscribed', () => ch.hasSubscribers, 5000, 10);
    ch.publish('frame');
    await waitFor('a frame', () => got.length === 1, 5000, 10);
    await assert.rejects(page.createChannel('mine'), skr.PermissionDeniedError);
    await a.db().set('k', 1.5);
    assert.equal(await page.db('alice').get('k'), 1.5);
    await assert.rejects(page.db('alice').set('k', 2), skr.PermissionDeniedError);

    // After the first token expired, the connection is lost: the reconnection fetches another.
    await new Promise((r) => setTimeout(r, 1100));
    let back = 0;
    page.on('online', () => { back++; });
    page.transport.close();
    await waitFor('online again with a new token', () => back === 1, 5000, 10);
    assert.equal(fetched, 2);
    assert.equal(page.session.user, 'web-page');

    // A string token is one login's: expired, the login is refused.
    const old = await fetchToken();
    await new Promise((r) => setTimeout(r, 1100));
    await assert.rejects(skr.connect(url, { WebSocket, token: old, reconnect: false }), skr.AuthFailedError);

    // connectPage(): a page served by the hub, its token from its own origin.
    Object.defineProperty(globalThis, 'location', { value: { protocol: 'http:', host: `127.0.0.1:${port}`, href: `http://127.0.0.1:${port}/index.html` }, configurable: true });
    const browser = await import('../../satellite/js/src/index.js');
    viaPage = await browser.connectPage({ WebSocket });
    assert.equal(viaPage.session.user, 'web-page');
  } finally {
    if (location) Object.defineProperty(globalThis, 'location', location);
    else delete globalThis.location;
    viaPage?.close();
    page.close();
    a.close();
    await hub.stop();
  }
});
