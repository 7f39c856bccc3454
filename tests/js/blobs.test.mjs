// SPDX-License-Identifier: Apache-2.0
// Blob channels in the JavaScript library against a real hub over local: listing, uploads from
// bytes, a Blob, a Node Readable and a WHATWG ReadableStream, downloads as an async iterator and
// as a ReadableStream (byte-exact, a few MB made here), progress, AbortSignal (the hub left with
// no upload under way), refusals as FlowError subclasses, the same files through flowctl (the C++
// client) and PySketch, and change events. The bounded-memory case (a large file under a 16 MB
// old space) runs where SKROBOT_JS_BLOB_LARGE=1 (CTest js.blobs_large, release build only):
// SKROBOT_JS_BLOB_BYTES sets its size (default 64 MiB; 1073741824 for the 1 GB run).
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { execFile } from 'node:child_process';
import { readdirSync, readFileSync, writeFileSync } from 'node:fs';
import path from 'node:path';
import { Readable } from 'node:stream';
import { promisify } from 'node:util';
import { fileURLToPath } from 'node:url';
import { startHub, waitFor, env } from '../web/harness.mjs';
import * as skr from '../../satellite/js/src/node.js';

const run = promisify(execFile);
let hub;
let a;
let files;

before(async () => {
  hub = await startHub([], {
    users: [{ name: 'reader', password: 'secret' }, { name: 'small', password: 'secret', limits: { blob_mib: 1 } }],
  });
  a = await skr.connect(hub.address, { clientName: 'js-blobs' });
  files = await a.createBlobChannel('files');
});

after(async () => {
  a?.close();
  await hub?.stop();
});

// Deterministic bytes (not all equal, so that a chunk out of place shows).
function pattern(n, seed = 1) {
  const out = new Uint8Array(n);
  let x = seed;
  for (let i = 0; i < n; ++i) {
    x = (x * 1103515245 + 12345) >>> 0;
    out[i] = x >>> 24;
  }
  return out;
}

const same = (x, y) => x.byteLength === y.byteLength && Buffer.from(x.buffer, x.byteOffset, x.byteLength).equals(Buffer.from(y.buffer, y.byteOffset, y.byteLength));

function checkProgress(events, total) {
  assert.ok(events.length > 0, 'progress events');
  for (let i = 1; i < events.length; ++i) assert.ok(events[i].bytes >= events[i - 1].bytes, `progress went back: ${JSON.stringify(events)}`);
  for (const e of events) assert.equal(e.total, total);
  assert.equal(events.at(-1).bytes, total);
}

const uploadsUnderWay = () => readdirSync(path.join(hub.dir, 'data', 'blobs', 'guest.files', 'uploads'));

test('create and list: the channel, directories and files with their sizes and versions', async () => {
  assert.equal(files.name, 'guest.files');
  assert.deepEqual(await files.list(), []);
  await files.mkdir('maps/old');
  const r = await files.upload('maps/a.txt', new TextEncoder().encode('hello'));
  assert.equal(r.size, 5);
  assert.equal(typeof r.version, 'bigint');
  const root = await files.list();
  assert.deepEqual(root.map((e) => [e.name, e.dir]), [['maps', true]]);
  const maps = await files.list('maps');
  assert.deepEqual(maps.map((e) => [e.name, e.dir, e.size]), [['a.txt', false, 5], ['old', true, 0]]);
  assert.equal(maps[0].version, r.version);
  assert.equal(typeof maps[0].mtimeNs, 'bigint');
  // The same channel again, files and all; and another user's view of it.
  const again = await a.createBlobChannel('files');
  assert.equal((await again.list('maps')).length, 2);
  await files.remove('maps/a.txt');
  await files.rmdir('maps/old');
  assert.deepEqual(await files.list('maps'), []);
});

test('upload then download byte-exact from every source, progress monotonic to the total', async () => {
  const data = pattern(5 * 1024 * 1024 + 7);
  const sources = {
    bytes: () => data,
    blob: () => new Blob([data.subarray(0, 1000), data.subarray(1000)]),
    readable: () => Readable.from((function* () {
      for (let at = 0; at < data.byteLength; at += 65536) yield Buffer.from(data.subarray(at, at + 65536));
    })()),
    webstream: () => new Blob([data]).stream(),
  };
  for (const [kind, make] of Object.entries(sources)) {
    const up = [];
    const r = await files.upload(`${kind}.bin`, make(), { size: data.byteLength, onProgress: (p) => up.push(p) });
    assert.equal(r.size, data.byteLength, kind);
    checkProgress(up, data.byteLength);
    assert.ok(up.length >= 5, `${kind}: a progress event per chunk (${up.length})`);
    // As an async iterator of views, and as a ReadableStream.
    const down = [];
    const d = files.download(`${kind}.bin`, { onProgress: (p) => down.push(p) });
    const parts = [];
    for await (const c of d) parts.push(c.slice());
    assert.equal(d.size, data.byteLength);
    assert.equal(d.version, r.version);
    assert.ok(same(Buffer.concat(parts), data), `${kind}: downloaded byte-exact`);
    checkProgress(down, data.byteLength);
    const fromStream = new Uint8Array(await new Response(files.download(`${kind}.bin`).stream()).arrayBuffer());
    assert.ok(same(fromStream, data), `${kind}: the ReadableStream byte-exact`);
  }
  // Small chunks and a small window: many requests in order; an empty file.
  const r = await files.upload('small-chunks.bin', data.subarray(0, 100000), { chunkBytes: 4096, window: 3 });
  assert.equal(r.size, 100000);
  assert.ok(same(await files.get('small-chunks.bin', { chunkBytes: 5000, window: 2 }), data.subarray(0, 100000)));
  await files.upload('empty', new Uint8Array(0));
  assert.equal((await files.get('empty')).byteLength, 0);
  // A stream that gives other than the size announced is refused, and its upload dropped.
  await assert.rejects(files.upload('short.bin', Readable.from([Buffer.alloc(10)]), { size: 11 }), skr.InvalidArgumentError);
  await assert.rejects(files.upload('long.bin', Readable.from([Buffer.alloc(12)]), { size: 11 }), skr.InvalidArgumentError);
  await assert.rejects(files.upload('nosize.bin', Readable.from([Buffer.alloc(12)])), TypeError);
  assert.deepEqual(uploadsUnderWay(), []);
});

test('abort mid-transfer: the upload is dropped on the hub, the old file stays, the connection goes on', async () => {
  const old = pattern(1000, 7);
  await files.upload('aborted.bin', old);
  const data = pattern(6 * 1024 * 1024, 3);
  const ac = new AbortController();
  const seen = [];
  await assert.rejects(files.upload('aborted.bin', data, {
    chunkBytes: 256 * 1024,
    signal: ac.signal,
    onProgress: (p) => {
      seen.push(p.bytes);
      if (p.bytes >= 1024 * 1024) ac.abort(new Error('stopped by the test'));
    },
  }), /stopped by the test/);
  assert.ok(seen.at(-1) < data.byteLength, 'stopped before the end');
  assert.deepEqual(uploadsUnderWay(), [], 'no upload left under way on the hub');
  assert.ok(same(await files.get('aborted.bin'), old), 'the old version stays');
  // A download aborted in the middle, and one the caller stops reading.
  await files.upload('big.bin', data);
  const ac2 = new AbortController();
  let got = 0;
  await assert.rejects((async () => {
    for await (const c of files.download('big.bin', { chunkBytes: 256 * 1024, signal: ac2.signal })) {
      got += c.byteLength;
      if (got >= 1024 * 1024) ac2.abort(new Error('download stopped'));
    }
  })(), /download stopped/);
  assert.ok(got < data.byteLength);
  for await (const c of files.download('big.bin')) {
    assert.ok(c.byteLength > 0);
    break;
  }
  const reader = files.download('big.bin').stream().getReader();
  await reader.read();
  await reader.cancel();
  assert.ok(same(await files.get('big.bin'), data), 'the connection answers in order after all three');
  // Aborted before it began.
  await assert.rejects(files.upload('x', data, { signal: AbortSignal.abort(new Error('early')) }), /early/);
  assert.deepEqual(uploadsUnderWay(), []);
});

test('refusals are FlowError subclasses: permission_denied, not_found, limit_exceeded, invalid_argument', async () => {
  const reader = await skr.connect(hub.address, { user: 'reader', password: 'secret' });
  try {
    const theirs = reader.blobChannel('guest.files');
    const e = await theirs.upload('refused.bin', pattern(100)).catch((x) => x);
    assert.ok(e instanceof skr.PermissionDeniedError, `${e}`);
    assert.equal(e.code, 'permission_denied');
    await assert.rejects(theirs.mkdir('d'), skr.PermissionDeniedError);
    assert.ok((await theirs.list()).length > 0, 'reading is allowed');
    await assert.rejects(theirs.get('no-such-file'), skr.NotFoundError);
    await assert.rejects(reader.blobChannel('guest.nothing').list(), skr.NotFoundError);
    await assert.rejects(reader.blobChannel('hub.stats').list(), skr.InvalidArgumentError);
    await assert.rejects(files.list('../etc'), skr.InvalidArgumentError);
  } finally {
    reader.close();
  }
  const small = await skr.connect(hub.address, { user: 'small', password: 'secret' });
  try {
    const mine = await small.createBlobChannel('quota');
    const e = await mine.upload('big.bin', pattern(2 * 1024 * 1024)).catch((x) => x);
    assert.ok(e instanceof skr.LimitExceededError, `${e}`);
    await mine.upload('fits.bin', pattern(1000));
  } finally {
    small.close();
  }
  assert.deepEqual(uploadsUnderWay(), []);
});

test('the same files through flowctl (the C++ client) and PySketch, both ways', async () => {
  const data = pattern(3 * 1024 * 1024 + 1, 11);
  await files.upload('interop/js.bin', data);
  const local = path.join(hub.dir, 'from-cpp.bin');
  await hub.flowctl('blob', 'get', 'guest.files', 'interop/js.bin', local);
  assert.ok(same(readFileSync(local), data), 'flowctl downloads what JS uploaded');
  const py = `
import sys
from PySketch.flowsync import FlowSync
s = FlowSync(sys.argv[1], "guest", "password")
assert s.connect(), s.lastError
data = s.blobGet("guest.files", "interop/js.bin")
assert data is not None, s.lastError
sys.stdout.write("%d %s\\n" % (len(data), __import__("hashlib").sha256(data).hexdigest()))
assert s.blobPut("guest.files", "interop/py.bin", data[::-1]), s.lastError
`;
  const { stdout } = await run('python3', ['-c', py, hub.address], {
    env: { ...process.env, PYTHONPATH: path.join(env.source, 'satellite/python'), PYTHONDONTWRITEBYTECODE: '1' },
  });
  const { createHash } = await import('node:crypto');
  assert.equal(stdout.trim(), `${data.byteLength} ${createHash('sha256').update(data).digest('hex')}`);
  assert.ok(same(await files.get('interop/py.bin'), Buffer.from(data).reverse()), 'JS downloads what PySketch uploaded');
  const cppFile = path.join(hub.dir, 'to-js.bin');
  writeFileSync(cppFile, pattern(2000000, 5));
  await hub.flowctl('blob', 'put', 'files', cppFile, 'interop/cpp.bin');
  assert.ok(same(await files.get('interop/cpp.bin'), pattern(2000000, 5)), 'JS downloads what flowctl uploaded');
});

test('change events: a subscriber hears of written and removed files', async () => {
  const events = [];
  const off = a.on('blobchanged', (e) => events.push(e));
  const s = a.subscribe('guest.files');
  await waitFor('subscribed', () => s.id !== 0, 5000, 10);
  await new Promise((r) => setTimeout(r, 200));
  const r = await files.upload('watched.txt', new TextEncoder().encode('v1'));
  await files.remove('watched.txt');
  await waitFor('two events', () => events.length >= 2, 5000, 10);
  assert.deepEqual(events.slice(0, 2).map((e) => [e.channel, e.change, e.path]),
    [['guest.files', 'written', 'watched.txt'], ['guest.files', 'removed', 'watched.txt']]);
  assert.equal(events[0].size, 2);
  assert.equal(events[0].version, r.version);
  s.close();
  off();
});

test('a lost synchronous connection fails what waits with ClosedError; the next request opens another', async () => {
  const conn = await a.syncConnection();
  const pending = files.list();
  conn.transport.close(new Error('cut by the test'));
  await assert.rejects(pending, skr.ClosedError);
  assert.ok((await files.list()).length > 0);
  assert.notEqual(await a.syncConnection(), conn);
});

const large = process.env.SKROBOT_JS_BLOB_LARGE === '1';
test('bounded memory: a large file up and down under a 16 MB old space, under 32 MB live', { skip: !large && 'SKROBOT_JS_BLOB_LARGE=1 (js.blobs_large)', timeout: 1800000 }, async () => {
  const bytes = Number(process.env.SKROBOT_JS_BLOB_BYTES ?? 64 * 1024 * 1024);
  const peer = fileURLToPath(new URL('blob_memory_peer.mjs', import.meta.url));
  const { stdout } = await run(process.execPath, ['--max-old-space-size=16', '--expose-gc', peer, hub.address, String(bytes)], {
    timeout: 1700000, maxBuffer: 1 << 20,
  });
  const r = JSON.parse(stdout.trim().split('\n').at(-1));
  console.log(`bounded memory: ${JSON.stringify(r)}`);
  assert.equal(r.stored, bytes);
  assert.equal(r.received, bytes);
  assert.equal(r.got, r.sent, 'downloaded byte-exact (SHA-256)');
  assert.ok(r.livePeakBytes < 32 * 1024 * 1024, `live heap + arrayBuffers peaked at ${r.livePeakBytes} bytes`);
  await files.hub.blobChannel('guest.big').remove('big.bin');
});
