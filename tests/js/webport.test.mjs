// SPDX-License-Identifier: Apache-2.0
// The library over the hub's own web port (server.web, flows over WebSocket at /flow): an
// account and the loopback dev account log in over ws: (the ws package's class on Node < 22),
// a large payload, a service call, a database and hub.stats. Skipped while the hub has no
// server.web (it refuses the key); run against ws/webport's hub it passed.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { startHub, waitFor, freePort, webRequire } from '../web/harness.mjs';
import * as skr from '../../satellite/js/src/node.js';

const WebSocket = globalThis.WebSocket ?? webRequire('ws');

async function webHub(port) {
  try {
    return await startHub([], { users: [{ name: 'alice', password: 'pw' }], server: { web: { port, flows: true, dev_account: true } } });
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
