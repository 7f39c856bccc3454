// SPDX-License-Identifier: Apache-2.0
// The JavaScript library against a real hub over local: (the skrobot binary, tests/web/harness.mjs):
// channels in every payload form with callbacks and async iterators, first/last subscriber
// events, services (answers, errors, timeouts, AbortSignal), databases, the sync pulse,
// hub.stats, media frames, and PySketch on the same channel with the same bytes.
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import path from 'node:path';
import { startHub, waitFor, sleep, env } from '../web/harness.mjs';
import * as skr from '../../satellite/js/src/node.js';

let hub;
let a;
let b;

before(async () => {
  hub = await startHub([], {
    users: [{ name: 'reader', password: 'secret', rules: { db_write: ['nothing-here'] } },
      { name: 'boss', password: 'secret', role: 'admin' }],
  });
  a = await skr.connect(hub.address, { clientName: 'js-a' });
  b = await skr.connect(hub.address, { clientName: 'js-b' });
});

after(async () => {
  a?.close();
  b?.close();
  await hub?.stop();
});

const bytes = (m) => [...m.payload];

test('login: the session, the channel list, the account from the options', async () => {
  assert.equal(a.session.user, 'guest');
  assert.equal(a.session.appName, 'WebTest');
  assert.equal(a.session.minor, skr.CATALOGUE_MINOR);
  assert.notEqual(a.session.connectionId, b.session.connectionId);
  assert.ok(a.channelByName('hub.stats'), 'the hub\'s own channels are listed at login');
  const r = await skr.connect(hub.address, { user: 'reader', password: 'secret' });
  assert.equal(r.session.user, 'reader');
  r.close();
});

test('channels: every payload form arrives byte-exact; first and last subscriber events', async () => {
  const ch = await a.createChannel('forms', { mime: 'application/octet-stream', props: { unit: 'm' } });
  assert.equal(ch.name, 'guest.forms');
  const events = [];
  ch.onSubscribers((on) => events.push(on));
  const got = [];
  const s = b.subscribe('guest.forms', (m) => got.push(m));
  await waitFor('first subscriber', () => ch.hasSubscribers, 5000, 10);
  assert.deepEqual(events, [true]);
  assert.equal(b.channelByName('guest.forms').props.unit, 'm');
  const f32 = new Float32Array([1.5, -2]);
  const ab = new Uint8Array([9, 8, 7]).buffer;
  const big = new Uint8Array(300000).map((_, i) => i & 0xff);
  for (const p of [ab, f32, 'héllo', { x: 1, y: [true] }, big.subarray(1)]) assert.equal(ch.publish(p), true);
  await waitFor('5 payloads', () => got.length === 5, 5000, 10);
  assert.deepEqual(bytes(got[0]), [9, 8, 7]);
  assert.deepEqual(new Float32Array(got[1].payload.slice().buffer), f32);
  assert.equal(got[2].text(), 'héllo');
  assert.deepEqual(got[3].json(), { x: 1, y: [true] });
  assert.equal(got[4].payload.byteLength, 299999);
  assert.ok(Buffer.from(got[4].payload).equals(Buffer.from(big.subarray(1))));
  assert.equal(got[0].channel, 'guest.forms');
  s.close();
  await waitFor('last subscriber left', () => !ch.hasSubscribers, 5000, 10);
  assert.deepEqual(events, [true, false]);
  ch.remove();
  await waitFor('removed everywhere', () => !b.channelByName('guest.forms'), 5000, 10);
});

test('a callback that throws goes to the error listeners; the flow carries on', async () => {
  const ch = await a.createChannel('throws');
  const errors = [];
  const off = b.on('error', (e) => errors.push(e.message));
  const got = [];
  const s = b.subscribe('guest.throws', (m) => {
    got.push(m.text());
    throw new Error(`callback failed on ${m.text()}`);
  });
  await waitFor('subscribed', () => ch.hasSubscribers, 5000, 10);
  ch.publish('one');
  ch.publish('two');
  await waitFor('both delivered', () => got.length === 2, 5000, 10);
  assert.deepEqual(errors, ['callback failed on one', 'callback failed on two']);
  assert.ok(b.online, 'still online');
  off();
  s.close();
  ch.remove();
});

test('channels: an async iterator, and a subscription made before the channel exists', async () => {
  const s = b.subscribe('guest.later');
  const ch = await a.createChannel('later');
  await waitFor('subscribed', () => ch.hasSubscribers, 5000, 10);
  for (let i = 0; i < 3; ++i) ch.publish(`m${i}`);
  const seen = [];
  for await (const m of s) {
    seen.push(m.text());
    if (seen.length === 3) break;  // ends the subscription
  }
  assert.deepEqual(seen, ['m0', 'm1', 'm2']);
  await waitFor('unsubscribed by break', () => !ch.hasSubscribers, 5000, 10);
  ch.remove();
});

test('a subscription asking for a larger queue: clamped by the hub, reported, subscribed all the same', async () => {
  const ch = await a.createChannel('video');
  const errors = [];
  const off = b.on('error', (e) => errors.push(e));
  const got = [];
  const s = b.subscribe('guest.video', (m) => got.push(m), { queueBytes: 1024 * 1024 * 1024 });
  await waitFor('the clamp reported', () => errors.length === 1, 5000, 10);
  assert.ok(errors[0] instanceof skr.LimitExceededError, String(errors[0]));
  assert.ok(ch.hasSubscribers, 'subscribed');
  ch.publish('frame');
  await waitFor('data', () => got.length === 1, 5000, 10);
  off();
  s.close();
  ch.remove();
});

test('services: answers, a handler\'s error, unknown channels, timeouts and aborts', async () => {
  let release;
  await a.serve('calc', async (command, value, { requester }) => {
    if (command === 'add') return value.reduce((x, y) => x + y, 0n);
    if (command === 'who') return requester;
    if (command === 'slow') return new Promise((r) => { release = r; });
    throw new Error(`no command ${command}`);
  });
  await waitFor('b knows the service', () => b.channelByName('guest.calc'), 5000, 10);
  assert.equal(await b.call('guest.calc', 'add', [1, 2, 3]), 6n);
  assert.equal(await b.call('guest.calc', 'who'), 'guest');
  assert.deepEqual(await b.call('guest.calc', 'nope'), { error: 'no command nope' });
  await assert.rejects(b.call('guest.none', 'x'), skr.NotFoundError);
  await assert.rejects(b.call('guest.calc', 'slow', null, { timeoutMs: 200 }), skr.TimeoutError);
  const ac = new AbortController();
  const p = b.call('guest.calc', 'slow', null, { signal: ac.signal });
  setTimeout(() => ac.abort(new Error('changed my mind')), 50);
  await assert.rejects(p, /changed my mind/);
  release?.('late');
  assert.equal(b.pending.size, 0, 'nothing left awaiting');
});

test('services: the owner leaving fails the call with OwnerGoneError', async () => {
  const owner = await skr.connect(hub.address);
  await owner.serve('leaving', () => new Promise(() => {}));
  await waitFor('listed', () => b.channelByName('guest.leaving'), 5000, 10);
  const p = b.call('guest.leaving', 'x');
  await sleep(100);
  owner.close();
  await assert.rejects(p, skr.OwnerGoneError);
});

test('databases: set, get, keys, all; absent keys and refused writes', async () => {
  const db = a.db();
  assert.equal(db.name, 'guest');
  await db.set('speed', 1.5);
  await db.set('pose', { x: 1n, tags: ['a'] });
  assert.equal(await b.db('guest').get('speed'), 1.5);
  assert.deepEqual(await b.db('guest').get('pose'), { x: 1n, tags: ['a'] });
  assert.ok((await b.db('guest').keys()).includes('speed'));
  assert.equal((await b.db('guest').getAll()).speed, 1.5);
  await db.delete('speed');
  await assert.rejects(b.db('guest').get('speed'), skr.NotFoundError);
  // Writes to two databases at once: each lands in its own (one current database per flow).
  const flowDb = `_flow.${a.session.connectionId}`;
  await Promise.all([a.db('guest').set('where', 'user db'), a.db(flowDb).set('where', 'flow db'),
    a.db('guest').set('where2', 'user db')]);
  assert.equal(await b.db('guest').get('where'), 'user db');
  assert.equal(await b.db('guest').get('where2'), 'user db');
  assert.equal(await b.db(flowDb).get('where'), 'flow db');
  await assert.rejects(b.db('no-such-db').get('x'), skr.NotFoundError);
  const r = await skr.connect(hub.address, { user: 'reader', password: 'secret' });
  try {
    await assert.rejects(r.db('guest').set('speed', 2), skr.PermissionDeniedError);
    assert.deepEqual(await r.db('guest').get('pose'), { x: 1n, tags: ['a'] }, 'reads still allowed');
  } finally {
    r.close();
  }
});

test('sync pulse: a follower gets each pulse and answers it', async () => {
  const src = await a.createChannel('tick', { kind: 'sync' });
  const pulses = [];
  const f = b.follow('guest.tick', (p) => { pulses.push(p); });
  await sleep(200);
  for (let i = 0; i < 3; ++i) {
    src.pulse();
    await waitFor(`pulse ${i + 1}`, () => pulses.length === i + 1, 5000, 5);
  }
  assert.deepEqual(pulses.map((p) => p.seq), [1n, 2n, 3n]);
  assert.ok(pulses.every((p) => p.dropped === 0), 'each answered before the next: nothing dropped');
  assert.equal(typeof pulses[0].sourceTimeNs, 'bigint');
  f.close();
  src.remove();
});

test('hub.stats: the hub\'s figures, with this client among its flows', async () => {
  let stats;
  const s = a.stats((st) => { stats = st; });
  await waitFor('hub.stats', () => stats, 10000, 50);
  s.close();
  assert.ok(typeof stats.hub === 'string' && stats.hub.length > 0, "the hub's name");
  assert.ok(JSON.stringify(stats.flows).includes('js-a'), 'the client name is shown');
});

test('admin: an administrator\'s command is answered; another account\'s is refused', async () => {
  const boss = await skr.connect(hub.address, { user: 'boss', password: 'secret', clientName: 'js-boss' });
  try {
    const flows = await boss.admin('flows');
    assert.ok(flows.some((f) => f.client === 'js-a' && f.user === 'guest'), JSON.stringify(flows, (k, v) => (typeof v === 'bigint' ? Number(v) : v)));
    await assert.rejects(boss.admin('module_config', { name: 'no-such-module' }), skr.NotFoundError);
    await assert.rejects(a.admin('flows'), skr.PermissionDeniedError);
  } finally {
    boss.close();
  }
});

test('media frames published by one client parse on the other', async () => {
  const ch = await a.createChannel('camera', { mime: skr.ENCODINGS.find((e) => e.encoding === 'rgb8').mime });
  const got = [];
  const s = b.subscribe('guest.camera', (m) => got.push(skr.parseMediaFrame(m.payload)));
  await waitFor('subscribed', () => ch.hasSubscribers, 5000, 10);
  ch.publish(skr.makeMediaFrame({ format: skr.FORMAT.rgb8, seq: 1, width: 2, height: 2 }, new Uint8Array(12).fill(200)));
  await waitFor('a frame', () => got.length === 1, 5000, 10);
  assert.deepEqual([got[0].encoding, got[0].width, got[0].height, got[0].payload[11]], ['rgb8', 2, 2, 200]);
  s.close();
  ch.remove();
});

// PySketch (satellite/python) beside the library: SKROBOT_SOURCE_DIR/satellite/python on PYTHONPATH.
function pysketch(...args) {
  const p = spawn('python3', [path.join(env.source, 'tests/js/pysketch_peer.py'), hub.address, ...args], {
    env: { ...process.env, PYTHONPATH: path.join(env.source, 'satellite/python'), PYTHONDONTWRITEBYTECODE: '1' },
    stdio: ['pipe', 'pipe', 'pipe'],
  });
  let out = '';
  p.stdout.on('data', (d) => { out += d; });
  p.stderr.on('data', (d) => { out += d; });
  const exited = new Promise((r) => p.on('exit', r));
  return { p, exited, get out() { return out; } };
}

test('PySketch and JavaScript on one channel: the same bytes both ways', async () => {
  const payloads = ['00', '0102ff', Buffer.from('héllo').toString('hex'), 'ab'.repeat(30000)];
  // PySketch publishes, JavaScript subscribes.
  const pub = pysketch('pub', 'frompy', ...payloads);
  try {
    const seen = new Set();
    const s = a.subscribe('guest.frompy', (m) => seen.add(Buffer.from(m.payload).toString('hex')));
    await waitFor('every PySketch payload', () => payloads.every((h) => seen.has(h)), 20000, 20);
    s.close();
    assert.deepEqual([...seen].sort(), [...payloads].sort());
  } finally {
    pub.p.stdin.end();
    await pub.exited;
  }
  // JavaScript publishes, PySketch subscribes.
  const ch = await a.createChannel('fromjs');
  const sub = pysketch('sub', 'guest.fromjs', '8');
  const timer = setInterval(() => { for (const h of payloads) ch.publish(Buffer.from(h, 'hex')); }, 50);
  try {
    assert.equal(await sub.exited, 0, sub.out);
  } finally {
    clearInterval(timer);
  }
  const lines = sub.out.split('\n').filter((l) => /^[0-9a-f]+$/.test(l));
  assert.ok(lines.length >= 8, sub.out.slice(0, 500));
  assert.ok(lines.every((l) => payloads.includes(l)), 'every payload byte-exact');
  ch.remove();
});
