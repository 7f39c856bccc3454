// SPDX-License-Identifier: Apache-2.0
// The library's pieces without a hub: the generated catalogue drives every row's encoding and
// decoding, frames come out of a byte stream and of a message as views with the length limit
// checked first, every catalogue error has its class, addresses parse as ROBOT_ADDRESS does, and
// media frames are docs/channels.md's.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import * as skr from '../../satellite/js/src/node.js';

const { CODES, PARTS, ERRORS, encodeFrame, decodeBody, FrameSplitter, messageFrames } = skr;

// A sample value for each field type.
function sample(fields, i = 1) {
  const out = {};
  for (const [type, name, extra] of fields) {
    if (type === 'u8') out[name] = i & 0xff;
    else if (type === 'u16') out[name] = 0x1234 + i;
    else if (type === 'u32') out[name] = 0x12345678 + i;
    else if (type === 'u64') out[name] = 2n ** 63n + BigInt(i);
    else if (type === 'str16') out[name] = `s${i}é`;
    else if (type === 'str32') out[name] = `text ${i}`;
    else if (type === 'value') out[name] = { n: BigInt(i), l: [true, 'x'] };
    else if (type === 'rest') out[name] = new Uint8Array([i, 0, 255]);
    else if (type === 'part') Object.assign(out, sample(PARTS[name], i + 1));
    else if (type === 'list') out[extra] = [sample(PARTS[name], i + 2), sample(PARTS[name], i + 3)];
    else assert.fail(`unknown field type ${type}`);
  }
  return out;
}

const join = (parts) => new Uint8Array(Buffer.concat(parts));

test('every row of the catalogue encodes and decodes back to its fields', () => {
  assert.ok(CODES.length >= 90);
  for (const row of CODES) {
    for (const [fields, reply] of [[row.body, false], [row.reply, true]]) {
      if (!fields) continue;
      const m = sample(fields);
      const frame = join(reply ? encodeBodyByHand(row.code, fields, m) : encodeFrame(row.name, m));
      const [f] = messageFrames(frame);
      assert.equal(f.code, row.code, row.name);
      assert.deepEqual(decodeBody(f.code, f.body, { reply }), m, `${row.name}${reply ? ' reply' : ''}`);
    }
  }
});

// A REPLY_OK body's fields, written by hand under the request's code (the codec encodes request
// and event bodies only; it decodes replies).
function encodeBodyByHand(code, fields, m) {
  const w = new skr.ByteWriter();
  w.u32(0).u8(code);
  const put = (fs, o) => {
    for (const [type, name, extra] of fs) {
      if (type === 'part') put(PARTS[name], o);
      else if (type === 'list') { w.u32(o[extra].length); for (const it of o[extra]) put(PARTS[name], it); }
      else if (type === 'value') { w.u8(0); skr.writeVariant(w, o[name]); }
      else if (type === 'rest') w.raw(o[name]);
      else w[type](o[name]);
    }
  };
  put(fields, m);
  w.patchU32(0, w.length - 4);
  return [w.bytes()];
}

test('a payload is handed to the transport as the caller\'s view, and decoded as a view', () => {
  const payload = new Uint8Array([1, 2, 3]);
  const parts = encodeFrame('PUBLISH', { chan_id: 7, payload });
  assert.equal(parts.length, 2);
  assert.equal(parts[1], payload);
  const frame = join(parts);
  const [f] = messageFrames(frame);
  const m = decodeBody(f.code, f.body);
  assert.equal(m.payload.buffer, frame.buffer);
});

test('a field out of its wire range is refused, never wrapped', () => {
  assert.throws(() => encodeFrame('SUBSCRIBE_QUEUE', { tag: 1, chan_id: 2, queue_bytes: 2 ** 32 }), /queue_bytes: 4294967296 is not an integer in 0..4294967295/);
  assert.throws(() => encodeFrame('SUBSCRIBE', { tag: 1, chan_id: 65536 }), RangeError);
  assert.throws(() => encodeFrame('SUBSCRIBE', { tag: -1, chan_id: 1 }), RangeError);
  assert.throws(() => encodeFrame('CHAN_ADD', { tag: 1, kind: 1, short_name: 'x'.repeat(65536) }), /str16 of 65536 bytes/);
});

test('bodies that do not match their row are ProtocolErrors', () => {
  assert.throws(() => decodeBody(skr.CODE.EV_DATA, new Uint8Array([1])), /EV_DATA: truncated/);
  assert.throws(() => decodeBody(skr.CODE.EV_STOP_PUBLISH, new Uint8Array([1, 0, 0])), /1 trailing bytes/);
  assert.throws(() => decodeBody(0x3f, new Uint8Array(0)), /unknown code 0x3f/);
  assert.throws(() => decodeBody(skr.CODE.EV_DB_CHANGED, new Uint8Array([1, 0, 0xff])), skr.ProtocolError);
});

test('FrameSplitter: frames cut anywhere come out whole, views when unsplit', () => {
  const frames = [
    encodeFrame('EV_DATA', { chan_id: 1, payload: new Uint8Array(1000).fill(7) }),
    encodeFrame('EV_START_PUBLISH', { chan_id: 2 }),
    encodeFrame('EV_ERROR', { command: 0x42, tag: 9, chan_id: 3, error: 5, message: 'no' }),
  ].map(join);
  const all = join(frames);
  for (const step of [1, 3, 7, 1000, all.length]) {
    const s = new FrameSplitter();
    const out = [];
    for (let at = 0; at < all.length; at += step) out.push(...s.push(all.subarray(at, at + step)));
    assert.deepEqual(out.map((f) => f.code), [0x97, 0x95, 0x99], `step ${step}`);
    assert.equal(decodeBody(out[2].code, out[2].body).message, 'no');
  }
  const whole = new FrameSplitter().push(all);
  assert.equal(whole[0].body.buffer, all.buffer, 'one chunk: views');
});

test('FrameSplitter refuses a length over its limit as soon as the 4 bytes arrive', () => {
  const s = new FrameSplitter(1024);
  assert.throws(() => s.push(new Uint8Array([0x01, 0x04, 0x00, 0x00])), /1025 bytes exceeds the limit of 1024/);
  assert.throws(() => new FrameSplitter().push(new Uint8Array([0, 0, 0, 0])), /length 0/);
  assert.throws(() => messageFrames(new Uint8Array([5, 0, 0, 0, 0x97, 1])), /ended inside a frame/);
});

test('every catalogue error has a FlowError subclass with its name as code', () => {
  for (const [name, value] of ERRORS) {
    if (name === 'ok') continue;
    const e = skr.errorFromWire(value, 'why');
    assert.ok(e instanceof skr.FlowError, name);
    assert.equal(e.code, name);
    assert.equal(e.message, 'why');
    assert.equal(skr.ERROR_CLASSES[name], e.constructor, name);
  }
  assert.ok(skr.errorFromWire(9, '') instanceof skr.TimeoutError);
  assert.ok(skr.errorFromWire(10, '') instanceof skr.OwnerGoneError);
});

test('addresses parse as ROBOT_ADDRESS does', () => {
  assert.deepEqual(skr.parseAddress('local:/tmp/Robot'), { kind: 'local', path: '/tmp/Robot' });
  assert.deepEqual(skr.parseAddress('tcp:robot.local'), { kind: 'tcp', host: 'robot.local', port: 9000 });
  assert.deepEqual(skr.parseAddress('tls:[::1]:9443'), { kind: 'tls', host: '::1', port: 9443 });
  assert.deepEqual(skr.parseAddress('ws:127.0.0.1:8080'), { kind: 'ws', url: 'ws://127.0.0.1:8080/flow' });
  assert.deepEqual(skr.parseAddress('wss://robot/x'), { kind: 'wss', url: 'wss://robot:443/x' });
  assert.throws(() => skr.parseAddress('tcp:host:99999'), /bad port/);
  assert.throws(() => skr.parseAddress('serial:/dev/ttyUSB0'), TypeError);
  assert.throws(() => skr.parseAddress('local:'), /no socket path/);
});

test('media frames: made and parsed as docs/channels.md, the payload a view', () => {
  const pixels = new Uint8Array(4 * 2 * 3).fill(9);
  const frame = skr.makeMediaFrame({ format: skr.FORMAT.rgb8, seq: 5, captureNs: 7n, width: 4, height: 2 }, pixels);
  assert.equal(Buffer.from(frame.subarray(0, 8)).toString('hex'), '534b4d4620000400');
  const p = skr.parseMediaFrame(frame);
  assert.equal(p.encoding, 'rgb8');
  assert.equal(p.seq, 5n);
  assert.equal(p.captureNs, 7n);
  assert.deepEqual([p.width, p.height], [4, 2]);
  assert.equal(p.payload.buffer, frame.buffer);
  assert.equal(skr.parseMediaFrame(frame.subarray(0, frame.length - 1)), null, 'a raw frame of the wrong size');
  const audio = skr.makeMediaFrame({ format: skr.FORMAT.s16le, seq: 1, channels: 2, sampleRate: 16000 }, new Uint8Array(8));
  assert.deepEqual([skr.parseMediaFrame(audio).channels, skr.parseMediaFrame(audio).sampleRate], [2, 16000]);
});
