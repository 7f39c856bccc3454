// SPDX-License-Identifier: Apache-2.0
// Run by blobs.test.mjs under `node --max-old-space-size=16 --expose-gc`: uploads BYTES generated
// on the fly in 64 KiB pieces (never held whole) to guest.big:big.bin, downloads it, and prints
// one JSON line: both SHA-256 digests, the times, and two peaks of heapUsed + arrayBuffers
// (process.memoryUsage()): `live`, sampled every 10 ms right after a full collection (what the
// process holds), and `raw`, sampled at each progress event without one (with the garbage that V8
// has not collected yet: it collects ArrayBuffers when their bytes outgrow a soft limit of its own).
// Usage: node [--expose-gc] blob_memory_peer.mjs ADDRESS BYTES
import { createHash } from 'node:crypto';
import * as skr from '../../satellite/js/src/node.js';

const [address, bytesText] = process.argv.slice(2);
const total = Number(bytesText);
const gc = /** @type {() => void} */ (globalThis.gc);
const usage = () => {
  const m = process.memoryUsage();
  return m.heapUsed + m.arrayBuffers;
};
let live = 0;
let raw = 0;
const timer = setInterval(() => {
  raw = Math.max(raw, usage());
  if (!gc) return;  // without --expose-gc: the raw peak only
  gc();
  live = Math.max(live, usage());
}, 10);
const onProgress = () => { raw = Math.max(raw, usage()); };

// Deterministic bytes in fresh 64 KiB pieces (as a file stream gives them), hashed as they go.
async function* generated(hash) {
  const piece = 64 * 1024;
  let x = 0x12345678;
  for (let at = 0; at < total; at += piece) {
    const n = Math.min(piece, total - at);
    const words = new Uint32Array(Math.ceil(n / 4));
    for (let i = 0; i < words.length; ++i) {
      x ^= x << 13; x ^= x >>> 17; x ^= x << 5;
      words[i] = x >>> 0;
    }
    const bytes = new Uint8Array(words.buffer, 0, n);
    hash.update(bytes);
    yield bytes;
  }
}

const hub = await skr.connect(address, { clientName: 'js-blob-memory' });
const ch = await hub.createBlobChannel('big');
const sent = createHash('sha256');
let t0 = performance.now();
const put = await ch.upload('big.bin', generated(sent), { size: total, onProgress });
const uploadS = (performance.now() - t0) / 1000;
const got = createHash('sha256');
let received = 0;
t0 = performance.now();
for await (const c of ch.download('big.bin', { onProgress })) {
  got.update(c);
  received += c.byteLength;
}
const downloadS = (performance.now() - t0) / 1000;
clearInterval(timer);
hub.close();
console.log(JSON.stringify({
  bytes: total, stored: put.size, received, sent: sent.digest('hex'), got: got.digest('hex'),
  uploadS, downloadS, livePeakBytes: live, rawPeakBytes: raw,
}));
