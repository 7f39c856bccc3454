// SPDX-License-Identifier: Apache-2.0
// The WebSocket transport (transport-ws.js) before the hub has its web port: a bridge made here
// with the `ws` package (web/node_modules) accepts subprotocol skrobot-flow.v1 and relays to a
// real hub's Unix socket, sending the hub's bytes as messages of whole frames (several frames a
// message, as the web port will). Both entry points (node.js, and index.js for browsers) connect
// through it with the ws package's class; bad servers close the connection cleanly.
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import net from 'node:net';
import { startHub, waitFor, webRequire } from '../web/harness.mjs';
import * as skr from '../../satellite/js/src/node.js';
import * as browser from '../../satellite/js/src/index.js';

const WebSocket = webRequire('ws');
const { WebSocketServer } = WebSocket;

let hub;
let bridge;
let url;

// Cuts a byte stream into whole frames (u32 length + rest), returned together, the rest kept.
function wholeFrames(state, chunk) {
  state.buf = Buffer.concat([state.buf, chunk]);
  let at = 0;
  while (state.buf.length - at >= 4 && state.buf.length - at >= 4 + state.buf.readUInt32LE(at)) at += 4 + state.buf.readUInt32LE(at);
  const out = state.buf.subarray(0, at);
  state.buf = state.buf.subarray(at);
  return out;
}

// A server on a free port: `onConnection(ws)` for each client choosing `protocol`.
async function server(onConnection, protocol = skr.SUBPROTOCOL) {
  const wss = new WebSocketServer({ host: '127.0.0.1', port: 0, handleProtocols: () => protocol });
  wss.on('connection', onConnection);
  await new Promise((r) => wss.on('listening', r));
  return { wss, url: `ws:127.0.0.1:${wss.address().port}/flow` };
}

before(async () => {
  hub = await startHub([]);
  ({ wss: bridge, url } = await server((ws) => {
    const sock = net.createConnection(hub.socket);
    const state = { buf: Buffer.alloc(0) };
    sock.on('data', (d) => {
      const frames = wholeFrames(state, d);
      if (frames.length) ws.send(frames, { binary: true });
    });
    sock.on('close', () => ws.close());
    sock.on('error', () => ws.close());
    ws.on('message', (m) => sock.write(m));
    ws.on('close', () => sock.destroy());
  }));
});

after(async () => {
  bridge?.close();
  await hub?.stop();
});

test('node.js over ws: channels, services and databases through whole-frame messages', async () => {
  const a = await skr.connect(url, { WebSocket });
  const b = await browser.connect(url, { WebSocket });
  try {
    assert.equal(a.session.user, 'guest');
    const ch = await a.createChannel('overws');
    const got = [];
    const s = b.subscribe('guest.overws', (m) => got.push(Buffer.from(m.payload)));
    await waitFor('subscribed', () => ch.hasSubscribers, 5000, 10);
    const big = new Uint8Array(600000).map((_, i) => (i * 7) & 0xff);
    ch.publish('small');
    ch.publish(big);
    await waitFor('both payloads', () => got.length === 2, 10000, 10);
    assert.equal(got[0].toString(), 'small');
    assert.ok(got[1].equals(Buffer.from(big)), '600 kB byte-exact');
    await a.serve('echo', (cmd, v) => v);
    await waitFor('b knows the service', () => b.channelByName('guest.echo'), 5000, 10);
    assert.deepEqual(await b.call('guest.echo', 'x', { n: 5n }), { n: 5n });
    await b.db().set('ws', 'yes');
    assert.equal(await a.db().get('ws'), 'yes');
    s.close();
  } finally {
    a.close();
    b.close();
  }
});

test('a browser connect() refuses stream addresses', async () => {
  await assert.rejects(browser.connect('local:/tmp/x'), /ws: or wss: only/);
});

test('a server choosing another subprotocol is refused (by the ws package, as by browsers)', async () => {
  const { wss, url: other } = await server(() => {}, 'something.else');
  try {
    await assert.rejects(skr.connect(other, { WebSocket }), (e) => {
      assert.ok(e instanceof skr.FlowError, String(e));
      assert.match(e.message, /subprotocol/);
      return true;
    });
  } finally {
    wss.close();
  }
});

test('a message ending inside a frame, or a text message, closes the connection', async () => {
  for (const [what, send] of [
    ['half a frame', (ws) => ws.send(Buffer.from([9, 0, 0, 0, 0x80, 1]))],
    ['text', (ws) => ws.send('hello')],
  ]) {
    const codes = [];
    const { wss, url: bad } = await server((ws) => {
      ws.on('close', (code) => codes.push(code));
      ws.once('message', () => send(ws));
    });
    try {
      await assert.rejects(skr.connect(bad, { WebSocket, timeoutMs: 3000 }), skr.ProtocolError, what);
      await waitFor(`${what}: closed`, () => codes.length === 1, 5000, 10);
      assert.equal(codes[0], what === 'text' ? 1003 : 1007, what);
    } finally {
      wss.close();
    }
  }
});
