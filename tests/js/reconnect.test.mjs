// SPDX-License-Identifier: Apache-2.0
// The library when things go wrong: a hub restart (reconnection with backoff, channels
// re-created, subscriptions and followed sources resumed), a refused login, and garbage from the
// hub's side (a fake server), which closes that connection cleanly.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import { mkdtempSync, rmSync } from 'node:fs';
import net from 'node:net';
import os from 'node:os';
import path from 'node:path';
import { startHub, waitFor, sleep, env } from '../web/harness.mjs';
import * as skr from '../../satellite/js/src/node.js';

// Stops the hub and starts it again on the same config (and socket).
async function restart(hub) {
  hub.proc.kill('SIGKILL');
  await new Promise((r) => (hub.proc.exitCode !== null || hub.proc.signalCode ? r() : hub.proc.on('exit', r)));
  await sleep(300);
  const proc = spawn(env.skrobot, ['--config', path.join(hub.dir, 'config.json')], { stdio: ['ignore', 'pipe', 'pipe'] });
  let log = '';
  proc.stdout.on('data', (d) => { log += d; });
  proc.stderr.on('data', (d) => { log += d; });
  await waitFor('HUB-READY again', () => log.includes('HUB-READY'), 30000, 50);
  return proc;
}

test('a hub restart: reconnection, the channel re-created, the subscription and follow resumed', async () => {
  const hub = await startHub([]);
  let again;
  const a = await skr.connect(hub.address);
  const b = await skr.connect(hub.address);
  try {
    const ch = await a.createChannel('survivor');
    const src = await a.createChannel('beat', { kind: 'sync' });
    const got = [];
    b.subscribe('guest.survivor', (m) => got.push(m.text()));
    const pulses = [];
    b.follow('guest.beat', (p) => { pulses.push(p.seq); });
    await waitFor('subscribed', () => ch.hasSubscribers, 5000, 10);
    ch.publish('before');
    await waitFor('before', () => got.includes('before'), 5000, 10);
    const offline = [];
    const online = [];
    b.on('offline', (e) => offline.push(e));
    b.on('online', (s) => online.push(s));
    again = await restart(hub);
    await waitFor('both back online', () => a.online && b.online && online.length > 0, 20000, 20);
    assert.ok(offline.length >= 1, 'offline was reported');
    await waitFor('channel re-created and subscribed', () => ch.id && ch.hasSubscribers, 10000, 10);
    ch.publish('after');
    await waitFor('after', () => got.includes('after'), 5000, 10);
    await waitFor('follow resumed', () => b.followers.values().next().value.id !== 0, 5000, 10);
    await sleep(100);
    src.pulse();
    await waitFor('a pulse after the restart', () => pulses.length === 1, 5000, 10);
    assert.deepEqual(pulses, [1n], 'the new hub counts from 1');
  } finally {
    a.close();
    b.close();
    again?.kill('SIGKILL');
    await hub.stop();
  }
});

test('the reconnection backoff grows from 100 ms to 2 s while the hub is away', async () => {
  const dir = mkdtempSync(path.join(os.tmpdir(), 'skrobot-js-'));
  const sock = path.join(dir, 'fake.sock');
  const attempts = [];
  let serve = true;
  const server = net.createServer((s) => {
    attempts.push(Date.now());
    if (serve) {
      serve = false;
      // The first connection logs in for real: a reply as a hub gives.
      s.once('data', () => {
        s.write(okFrame(loginOk()));
        s.once('data', () => {
          const w = new skr.ByteWriter();
          w.u32(0);  // CHAN_LIST: no channels
          s.write(Buffer.concat([okFrame(w.bytes()), okFrame(new Uint8Array(0))]));
          setTimeout(() => s.destroy(), 50);
        });
      });
    } else {
      s.destroy();
    }
  });
  await new Promise((r) => server.listen(sock, r));
  const hub = await skr.connect(`local:${sock}`);
  try {
    await waitFor('7 attempts', () => attempts.length >= 7, 20000, 20);
    const gaps = attempts.slice(1).map((t, i) => t - attempts[i]);
    // 100, 200, 400, 800, 1600, 2000 (+ connection time)
    assert.ok(gaps[1] >= 90 && gaps[1] < 600, `first retry gap ${gaps[1]}`);
    assert.ok(gaps[5] >= 1900 && gaps[5] < 2600, `capped at 2 s: ${gaps}`);
    assert.ok(gaps[4] > gaps[2] * 2, `growing: ${gaps}`);
  } finally {
    hub.close();
    server.close();
    rmSync(dir, { recursive: true, force: true });
  }
});

function okFrame(body) {
  const w = new skr.ByteWriter();
  w.u32(body.byteLength + 1).u8(skr.CODE.REPLY_OK).raw(body);
  return w.bytes();
}

function loginOk() {
  const w = new skr.ByteWriter();
  w.u16(1).u16(skr.CATALOGUE_MINOR).u32(7).str16('Fake').str16('guest').str16('guest');
  return w.bytes();
}

test('a refused login rejects connect() with AuthFailedError; ROBOT_USER and ROBOT_PASSWORD are the default account', async () => {
  const hub = await startHub([], { users: [{ name: 'alice', password: 'right' }] });
  try {
    await assert.rejects(skr.connect(hub.address, { user: 'alice', password: 'wrong' }), (e) => {
      assert.ok(e instanceof skr.AuthFailedError, String(e));
      assert.equal(e.code, 'auth_failed');
      return true;
    });
    process.env.ROBOT_USER = 'alice';
    process.env.ROBOT_PASSWORD = 'right';
    const ok = await skr.connect(hub.address);
    assert.equal(ok.session.user, 'alice', 'ROBOT_USER and ROBOT_PASSWORD are the default account');
    ok.close();
    await waitFor('logged', () => hub.log.includes('FLOW-AUTH-FAILED'), 5000, 20);
  } finally {
    delete process.env.ROBOT_USER;
    delete process.env.ROBOT_PASSWORD;
    await hub.stop();
  }
});

// A fake hub that answers the LOGIN with `reply` (or, after a real-looking login, sends `after`).
async function fakeHub(t, { reply, after, withAsync }) {
  const dir = mkdtempSync(path.join(os.tmpdir(), 'skrobot-js-'));
  const sock = path.join(dir, 'fake.sock');
  const closed = [];
  const server = net.createServer((s) => {
    s.on('close', () => closed.push(true));
    s.on('error', () => {});
    s.once('data', () => {
      if (reply) {
        s.write(reply);
        return;
      }
      s.write(okFrame(loginOk()));
      s.once('data', () => {
        const w = new skr.ByteWriter();
        w.u32(0);
        s.write(Buffer.concat([okFrame(w.bytes()), okFrame(new Uint8Array(0)), withAsync ?? Buffer.alloc(0)]));
        if (after) setTimeout(() => s.write(after), 50);
      });
    });
  });
  await new Promise((r) => server.listen(sock, r));
  t.after(() => {
    server.close();
    rmSync(dir, { recursive: true, force: true });
  });
  return { address: `local:${sock}`, closed };
}

test('garbage from the hub during login: connect() rejects with ProtocolError, the socket closed', async (t) => {
  const cases = {
    'a frame over the limit': Buffer.from([0xff, 0xff, 0xff, 0x7f, 0x80]),
    'a zero length': Buffer.from([0, 0, 0, 0]),
    'an event before the reply': Buffer.from([3, 0, 0, 0, 0x95, 1, 0]),
    'a short login reply': Buffer.from([3, 0, 0, 0, 0x80, 1, 0]),
    'a reply error with bad UTF-8': Buffer.from([6, 0, 0, 0, 0x81, 3, 0, 1, 0, 0xff]),
  };
  for (const [what, reply] of Object.entries(cases)) {
    const fake = await fakeHub(t, { reply });
    await assert.rejects(skr.connect(fake.address, { timeoutMs: 2000 }), (e) => {
      assert.ok(e instanceof skr.ProtocolError, `${what}: ${e}`);
      return true;
    }, what);
    await waitFor(`${what}: the socket closed`, () => fake.closed.length === 1, 5000, 10);
  }
  // Silence: a hub that never answers the LOGIN is given up after timeoutMs.
  const silent = await fakeHub(t, { reply: Buffer.alloc(0) });
  await assert.rejects(skr.connect(silent.address, { timeoutMs: 300 }), /did not answer the login within 300 ms/);
  await waitFor('silence: the socket closed', () => silent.closed.length === 1, 5000, 10);
});

test('events in the same read as the GO_ASYNC reply are handled, not lost', async (t) => {
  const info = { tag: 0, id: 5, hash: 1n, kind: 1, name: 'bob.cam', owner: 'bob', owner_connection: 2, mime: '', subscribers: 0, props: null };
  const fake = await fakeHub(t, { withAsync: Buffer.concat(skr.encodeFrame('EV_CHAN_ADDED', info)) });
  const hub = await skr.connect(fake.address, { reconnect: false });
  try {
    await waitFor('the channel', () => hub.channelByName('bob.cam'), 2000, 10);
  } finally {
    hub.close();
  }
});

test('publish drops data while the hub does not read, instead of queueing without bound', async (t) => {
  const dir = mkdtempSync(path.join(os.tmpdir(), 'skrobot-js-'));
  const sock = path.join(dir, 'stuck.sock');
  const server = net.createServer((s) => {
    s.on('error', () => {});
    s.once('data', () => {
      s.write(okFrame(loginOk()));
      s.once('data', () => {
        const w = new skr.ByteWriter();
        w.u32(0);
        s.write(Buffer.concat([okFrame(w.bytes()), okFrame(new Uint8Array(0))]));
        s.once('data', (d) => {  // CHAN_ADD: answered, then nothing more is read
          const tag = d.readUInt32LE(5);
          s.write(Buffer.concat(skr.encodeFrame('EV_CHAN_ADDED', {
            tag, id: 9, hash: 1n, kind: 1, name: 'guest.stuck', owner: 'guest', owner_connection: 7, mime: '', subscribers: 0, props: null,
          })));
          s.pause();
        });
      });
    });
  });
  await new Promise((r) => server.listen(sock, r));
  t.after(() => {
    server.close();
    rmSync(dir, { recursive: true, force: true });
  });
  const hub = await skr.connect(`local:${sock}`, { reconnect: false, maxQueuedBytes: 4 * 1024 * 1024 });
  try {
    const ch = await hub.createChannel('stuck');
    const payload = new Uint8Array(1024 * 1024);
    let sent = 0;
    for (let i = 0; i < 64; ++i) if (ch.publish(payload)) sent += 1;
    assert.ok(sent >= 4 && sent < 64, `sent ${sent} of 64`);
    assert.equal(ch.dropped, 64 - sent);
    assert.ok(hub.transport.buffered() <= 5 * 1024 * 1024 + 64, `buffered ${hub.transport.buffered()}`);
  } finally {
    hub.close();
  }
});

test('garbage on the flow: the connection closes, offline reports the ProtocolError', async (t) => {
  const cases = {
    'an unknown code': Buffer.from([1, 0, 0, 0, 0x3f]),
    'a request code from the hub': Buffer.from([1, 0, 0, 0, 0x0f]),
    'EV_DATA too short': Buffer.from([2, 0, 0, 0, 0x97, 1]),
    'a bad value': Buffer.from([7, 0, 0, 0, 0x9c, 1, 0, 0, 0, 0, 0x09]),
  };
  for (const [what, after] of Object.entries(cases)) {
    const fake = await fakeHub(t, { after });
    const hub = await skr.connect(fake.address, { reconnect: false });
    const offline = new Promise((r) => hub.on('offline', r));
    const e = await offline;
    assert.ok(e instanceof skr.ProtocolError, `${what}: ${e}`);
    assert.equal(hub.online, false);
    await waitFor(`${what}: the socket closed`, () => fake.closed.length === 1, 5000, 10);
    hub.close();
  }
});
