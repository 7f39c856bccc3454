// SPDX-License-Identifier: Apache-2.0
// Bad clients on the hub's web port (server.web with flows): raw WebSocket connections (the ws
// package) send garbage, half frames, a text message, a frame over the limit before and after
// login, and an HTTP request that is not one. Each is closed alone, with the close code
// docs/flow-protocol.md ("WebSocket") gives (a frame over the limit: 1000 with the reason), and
// logged; a library client on the same port keeps
// its flow throughout, and the hub stays up.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import net from 'node:net';
import { startHub, waitFor, freePort, webRequire } from '../web/harness.mjs';
import * as skr from '../../satellite/js/src/node.js';

const WebSocket = globalThis.WebSocket ?? webRequire('ws');
const RawSocket = webRequire('ws');
const MAX_FRAME = 65536;

const concat = (parts) => Buffer.concat(parts.map((p) => Buffer.from(p.buffer, p.byteOffset, p.byteLength)));
const login = () => concat(skr.encodeFrame('LOGIN', {
  major: skr.PROTOCOL_MAJOR, minor: skr.CATALOGUE_MINOR, value_encoding: 0, client_name: 'attacker',
  user: 'guest', password: 'password',
}));
// A frame header announcing `length` bytes (u32 little-endian, then the code).
const header = (length, code = 0x30) => {
  const b = Buffer.alloc(5);
  b.writeUInt32LE(length, 0);
  b[4] = code;
  return b;
};

// Opens /flow, sends each of `messages` (Buffers binary, strings text) once open, resolves with
// the close code and reason and how many messages the hub sent first.
function attack(url, messages, { afterLogin = false } = {}) {
  return new Promise((resolve, reject) => {
    const ws = new RawSocket(url, skr.SUBPROTOCOL);
    let answered = 0;
    ws.on('open', () => {
      if (afterLogin) ws.send(login());
      else for (const m of messages) ws.send(m);
    });
    ws.on('message', () => {
      answered++;
      if (afterLogin && answered === 1) for (const m of messages) ws.send(m);
    });
    const timer = setTimeout(() => reject(new Error('the hub did not close the connection')), 10000);
    ws.on('close', (code, reason) => {
      clearTimeout(timer);
      resolve({ code, reason: String(reason), answered });
    });
    ws.on('error', () => {});
  });
}

test('bad clients on the web port are closed one by one; the others carry on', async (t) => {
  const port = await freePort();
  const hub = await startHub([], {
    server: { max_frame_bytes: MAX_FRAME, web: { port, flows: true, dev_account: true } },
  });
  t.after(() => hub.stop());
  const url = `ws://127.0.0.1:${port}/flow`;
  const good = await skr.connect(url, { WebSocket, clientName: 'good' });
  t.after(() => good.close());
  const ch = await good.createChannel('beat');
  const got = [];
  good.subscribe('guest.beat', (m) => got.push(m.text()));
  await waitFor('subscribed', () => ch.hasSubscribers, 5000, 10);
  let n = 0;
  const beat = async () => {
    const want = got.length + 1;
    ch.publish(String(++n));
    await waitFor(`beat ${n}`, () => got.length === want, 5000, 5);
  };
  await beat();

    // Before login: garbage (its first 4 bytes read as a huge length), half a frame, a text message.
  const garbage = Buffer.from('GET / HTTP/1.1\r\nHost: x\r\n\r\n' + '\xff'.repeat(64), 'latin1');
  const overLimit = (r, limit) => {
    assert.equal(r.code, 1000, JSON.stringify(r));
    assert.match(r.reason, new RegExp(`exceeds the limit of ${limit} bytes`), JSON.stringify(r));
  };
  overLimit(await attack(url, [garbage]), 4096);
  await beat();
  const half = login().subarray(0, 20);
  assert.equal((await attack(url, [half])).code, 1007);
  await beat();
  assert.equal((await attack(url, ['{"hello": "hub"}'])).code, 1003);
  await beat();
  // Before login the limit is 4096 bytes; after, server.max_frame_bytes: refused on the header,
  // before the body is even sent.
  overLimit(await attack(url, [header(4097)]), 4096);
  await beat();
  const over = await attack(url, [header(MAX_FRAME + 1)], { afterLogin: true });
  assert.ok(over.answered >= 1, 'the login was answered');
  overLimit(over, MAX_FRAME);
  await beat();
  // A whole frame and then half of the next one in the same message, after login.
  const mixed = await attack(url, [Buffer.concat([concat(skr.encodeFrame('CHAN_LIST', { tag: 1 })), header(100)])], { afterLogin: true });
  assert.equal(mixed.code, 1007);
  await beat();

  // Not WebSocket at all: an HTTP request head that never ends; answered 431 and closed.
  const raw = net.connect(port, '127.0.0.1');
  let reply = '';
  raw.on('data', (d) => { reply += d; });
  // 8 KiB + 1 bytes, all of which the hub reads before it refuses (no reset losing the answer).
  const head = 'GET /flow HTTP/1.1\r\nHost: 127.0.0.1\r\nX: ';
  raw.write(head.padEnd(8 * 1024 + 1, 'y'));
  await new Promise((r) => raw.on('close', r));
  assert.match(reply, /^HTTP\/1\.1 431 /, reply.slice(0, 200));
  await beat();

  assert.ok(hub.alive(), 'the hub is up');
  assert.equal(good.online, true);
  assert.ok((hub.log.match(/FLOW-PROTOCOL/g) ?? []).length >= 5, hub.log.slice(-3000));
});
