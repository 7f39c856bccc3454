// SPDX-License-Identifier: Apache-2.0
// A module's WebSocket endpoint on the hub's web port (plugin ABI 1.8), through the C module
// tests/modules/ws_echo.c, which uses every call: text and binary echoed whole, a message over
// the endpoint's limit (only that connection closes, 1009), a module's close code, a refused
// one, a slow client whose droppable messages go while the rest arrive in order, the upgrade's
// checks (path, subprotocol, Origin) and the endpoint's end (1001 for its clients).
import assert from 'node:assert/strict';
import path from 'node:path';
import { after, before, test } from 'node:test';

import { freePort, sleep, startHub, waitFor, webRequire } from './harness.mjs';

const WebSocket = webRequire('ws');
const QUEUE = 64 * 1024;  // the module's max_queued_bytes for one client

let hub;
let port;

// Opens /echo (or `pathname`); resolves { ws, messages, closed } once open, rejects with the
// refusal.
function open(pathname = '/echo', { protocol = 'echo.v1', origin } = {}) {
  return new Promise((resolve, reject) => {
    const ws = new WebSocket(`ws://127.0.0.1:${port}${pathname}`, protocol ? [protocol] : [],
      origin ? { origin } : {});
    const messages = [];
    const closed = new Promise((r) => ws.on('close', (code, reason) => r({ code, reason: reason.toString() })));
    ws.on('message', (data, binary) => messages.push(binary ? data : data.toString()));
    ws.on('open', () => resolve({ ws, messages, closed }));
    ws.on('unexpected-response', (_req, res) => reject(new Error(`refused: HTTP ${res.statusCode}`)));
    ws.on('error', reject);
  });
}

before(async () => {
  port = await freePort();
  hub = await startHub([{
    name: 'test_ws_echo', path: path.join(process.env.SKROBOT_TEST_MODULE_DIR, 'test_ws_echo.so'),
    config: { queue: QUEUE },
  }], { server: { web: { port } } });
});
after(async () => { if (hub) await hub.stop(); });

test('text and binary come back whole; over the limit only that connection closes (1009)', async () => {
  const a = await open();
  await waitFor('hello', () => a.messages[0]);
  assert.equal(a.messages[0], 'hello ws:127.0.0.1');
  a.ws.send('a text message');
  const bytes = Buffer.from(Array.from({ length: 4096 }, (_, i) => i & 0xFF));
  a.ws.send(bytes);
  await waitFor('both back', () => a.messages.length === 3);
  assert.equal(a.messages[1], 'a text message');
  assert.ok(Buffer.isBuffer(a.messages[2]) && a.messages[2].equals(bytes), 'binary, byte for byte');

  const big = await open();
  big.ws.send(Buffer.alloc(4097));
  assert.equal((await big.closed).code, 1009);
  a.ws.send('still here');
  await waitFor('the other connection goes on', () => a.messages.includes('still here'));
  assert.match(hub.log, /FLOW-PROTOCOL ws:127\.0\.0\.1: a message of more than 4096 bytes \(close 1009\)/);
  a.ws.close();
  await a.closed;
});

test("the module's close codes: one it may send, one it may not", async () => {
  const c = await open();
  c.ws.send('close 4001');
  assert.deepEqual(await c.closed, { code: 4001, reason: 'asked' });
  await waitFor('the closed event', () => /WSECHO-CLOSED \d+ closed by the module \(4001 asked\)/.test(hub.log));
  const r = await open();
  r.ws.send('close 1005');  // reserved: never sent on the wire
  await waitFor('the refusal', () => r.messages.includes('refused 1'));  // SKR_ERR_INVALID_ARGUMENT
  r.ws.close();
  await r.closed;
});

test("a slow client loses droppable messages, oldest first, and keeps the rest in order", async () => {
  const s = await open();
  await waitFor('hello', () => s.messages.length === 1);
  // 4000 messages of 4 KiB at once, far more than the 64 KiB the module lets wait for one client,
  // while this client reads nothing.
  s.ws._socket.pause();
  s.ws.send('burst 4000 4096');
  await sleep(1500);
  s.ws._socket.resume();
  await waitFor('end', () => s.messages.includes('end'), 20000);
  const got = s.messages.filter((m) => Buffer.isBuffer(m)).map((m) => m.readUInt32LE(0));
  assert.ok(got.length < 4000, `${got.length} of 4000 arrived: none was dropped`);
  assert.equal(got.at(-1), 3999, 'the newest arrives');
  assert.ok(got.every((v, i) => i === 0 || v > got[i - 1]), 'in order');
  assert.equal(s.messages.at(-1), 'end', 'the message that may not be dropped comes last');
  s.ws.close();
  await s.closed;
  await waitFor('the drop count', () => /MODULE-WS connection \d+: \d+ messages dropped for a slow client/.test(hub.log));
  console.log(`slow client: ${got.length} of 4000 arrived (queue ${QUEUE} bytes)`);
});

test('the upgrade is checked like /flow, and the endpoint goes with 1001', async () => {
  await assert.rejects(open('/other'), /HTTP 404/);
  await assert.rejects(open('/echo', { protocol: 'other.v1' }), /HTTP 400/);
  await assert.rejects(open('/echo', { origin: 'http://evil.example' }), /HTTP 403/);
  const one = await open();
  const two = await open();
  one.ws.send('unserve');
  assert.equal((await one.closed).code, 1001);
  assert.equal((await two.closed).code, 1001);
  await assert.rejects(open(), /HTTP 404/);
  assert.ok(hub.alive());
  const exit = await hub.stop();
  assert.deepEqual(exit, { code: 0, signal: null }, hub.log.slice(-3000));
});
