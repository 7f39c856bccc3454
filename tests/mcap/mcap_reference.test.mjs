// SPDX-License-Identifier: Apache-2.0
// flowctl record, play and mcap against the reference MCAP implementation, @mcap/core (with
// @mcap/support's zstd and lz4): every file flowctl writes reads with McapIndexedReader, a
// recorder killed with SIGKILL leaves a file McapStreamReader reads (CRCs checked) up to its last
// chunk, and flowctl reads what McapWriter writes. Image channels are written as
// foxglove.RawImage / foxglove.CompressedImage (checked against @foxglove/schemas) and played back
// as the same media frames.
import assert from 'node:assert/strict';
import { spawn, execFile } from 'node:child_process';
import { mkdtempSync, readFileSync, writeFileSync, rmSync } from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { promisify } from 'node:util';
import { after, before, test } from 'node:test';

import { env, sleep, startHub, validate, waitFor, webRequire } from '../web/harness.mjs';

const run = promisify(execFile);
const { McapIndexedReader, McapStreamReader, McapWriter } = webRequire('@mcap/core');
const { loadDecompressHandlers } = webRequire('@mcap/support');
const zstd = webRequire('@foxglove/wasm-zstd');
const schemas = webRequire('@foxglove/schemas/jsonschema');

let hub;
let dir;
let decompressHandlers;

before(async () => {
  hub = await startHub([]);
  dir = mkdtempSync(path.join(os.tmpdir(), 'skrobot-mcap-'));
  decompressHandlers = await loadDecompressHandlers();
  await zstd.isLoaded;
});
after(async () => {
  await hub?.stop();
  if (dir) rmSync(dir, { recursive: true, force: true });
});

const flowctl = (...args) => run(env.flowctl, ['--address', hub.address, ...args], { timeout: 30000 });

// Starts flowctl record; resolves once it runs (each `flowctl pub` then waits for it to subscribe).
async function startRecorder(file, args) {
  const proc = spawn(env.flowctl, ['--address', hub.address, '--json', 'record', '-o', file, ...args],
    { stdio: ['ignore', 'pipe', 'pipe'] });
  let out = '';
  proc.stdout.on('data', (d) => { out += d; });
  proc.stderr.on('data', (d) => { out += d; });
  const exited = new Promise((resolve) => proc.on('exit', (code, signal) => resolve({ code, signal })));
  await waitFor('the recorder', () => out.includes('recording to'), 10000, 20);
  return { proc, exited, get out() { return out; } };
}

// Publishes, in order: 8 runs of `flowctl pub` with 4 distinct JSON messages each on guest.seq
// (each run re-creates the channel and waits for the recorder), and 6 binary payloads on
// guest.blob. Returns what each channel carried, in order.
// `gapMs`: a pause between the two channels' messages (a recorder flushing more often then
// writes them in separate chunks).
async function publish(gapMs = 0) {
  const seq = [];
  for (let run = 0; run < 8; run++) {
    const payload = JSON.stringify({ run, text: `run ${run}` });
    await flowctl('pub', 'guest.seq', payload, '--repeat', '4', '--mime', 'application/json',
      '--wait-ms', '5000');
    for (let i = 0; i < 4; i++) seq.push(payload);
  }
  await sleep(gapMs);
  const blob = Buffer.alloc(3000);
  for (let i = 0; i < blob.length; i++) blob[i] = (i * 7 + 3) & 0xff;
  const blobFile = path.join(dir, 'blob.bin');
  writeFileSync(blobFile, blob);
  await flowctl('pub', 'guest.blob', '--file', blobFile, '--repeat', '6', '--mime',
    'application/x-test', '--wait-ms', '5000');
  return { seq, blob: Array(6).fill(blob) };
}

// Where each whole Chunk record (opcode 0x06) of an MCAP file begins and ends.
function chunks(buf) {
  const out = [];
  for (let at = 8; at + 9 <= buf.length;) {
    const end = at + 9 + Number(buf.readBigUInt64LE(at + 1));
    if (end > buf.length) break;
    if (buf[at] === 0x06) out.push({ at, end });
    at = end;
  }
  return out;
}

const readable = (buf) => ({
  size: async () => BigInt(buf.length),
  read: async (offset, length) => buf.subarray(Number(offset), Number(offset + length)),
});

// Every record of `buf` through the streaming reader with CRC checks.
function streamRecords(buf) {
  const reader = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  reader.append(buf);
  const records = [];
  for (let r; (r = reader.nextRecord());) records.push(r);
  return { records, done: reader.done() };
}

function byTopic(channels, messages) {
  const out = {};
  for (const m of messages) {
    const topic = channels.get(m.channelId).topic;
    (out[topic] ??= []).push(m);
  }
  return out;
}

for (const compression of ['zstd', 'lz4']) {
  test(`flowctl record (${compression}): McapIndexedReader reads it all`, async () => {
    const file = path.join(dir, `run-${compression}.mcap`);
    const startNs = BigInt(Date.now()) * 1000000n;
    const rec = await startRecorder(file, ['--compression', compression, '--chunk-kb', '4',
      'guest.seq', 'guest.blob']);
    const sent = await publish();
    await sleep(200);
    const endNs = BigInt(Date.now()) * 1000000n;
    rec.proc.kill('SIGINT');
    assert.equal((await rec.exited).code, 0, rec.out);
    const summary = JSON.parse(rec.out.slice(rec.out.indexOf('{')));
    assert.equal(summary.dropped, 0);
    assert.equal(summary.messages, sent.seq.length + sent.blob.length);

    const buf = readFileSync(file);
    const reader = await McapIndexedReader.Initialize({ readable: readable(buf), decompressHandlers });
    assert.equal(reader.header.library, 'skrobot flowctl');
    assert.ok(reader.chunkIndexes.length >= 2, 'several chunks');
    for (const c of reader.chunkIndexes) assert.equal(c.compression, compression);
    const topics = [...reader.channelsById.values()].map((c) => `${c.topic} ${c.messageEncoding}`);
    assert.deepEqual(topics.sort(), ['guest.blob application/x-test', 'guest.seq json']);
    const messages = [];
    for await (const m of reader.readMessages()) messages.push(m);
    const got = byTopic(reader.channelsById, messages);
    assert.deepEqual(got['guest.seq'].map((m) => Buffer.from(m.data).toString()), sent.seq);
    assert.deepEqual(got['guest.blob'].map((m) => Buffer.from(m.data)), sent.blob);
    let last = 0n;
    for (const m of messages) {
      assert.ok(m.logTime >= last, 'log times in order');
      assert.ok(m.logTime >= startNs && m.logTime <= endNs, 'log time is the receipt time');
      assert.equal(m.publishTime, m.logTime, 'no capture time: publish time = log time');
      last = m.logTime;
    }
    assert.equal(reader.statistics.messageCount, BigInt(messages.length));
    assert.equal(reader.statistics.channelMessageCounts.get(
      [...reader.channelsById.values()].find((c) => c.topic === 'guest.seq').id), 32n);
    // Properties: one metadata record per (re)subscription of a channel.
    const metadata = [];
    for await (const m of reader.readMetadata({ name: 'skrobot.channel_properties' })) metadata.push(m);
    assert.ok(metadata.filter((m) => m.metadata.get('channel') === 'guest.seq').length >= 8);
    for (const m of metadata) JSON.parse(m.metadata.get('properties'));

    const { records, done } = streamRecords(buf);
    assert.ok(done, 'the streaming reader reads to the footer');
    assert.equal(records.filter((r) => r.type === 'Message').length, messages.length);

    // flowctl reads what it wrote.
    const info = JSON.parse((await flowctl('--json', 'mcap', 'info', file)).stdout);
    assert.equal(info.complete, true);
    assert.equal(info.indexed, true);
    assert.equal(info.messages, messages.length);
    assert.deepEqual(Object.keys(info.chunks), [compression]);
  });
}

test('a recorder killed with SIGKILL: McapStreamReader reads it up to its last chunk', async () => {
  const file = path.join(dir, 'killed.mcap');
  const rec = await startRecorder(file, ['--flush-ms', '100', 'guest.seq', 'guest.blob']);
  const sent = await publish(300);  // two chunks at least
  await sleep(400);  // a flush after the last message
  rec.proc.kill('SIGKILL');
  await rec.exited;
  const buf = readFileSync(file);
  await assert.rejects(McapIndexedReader.Initialize({ readable: readable(buf), decompressHandlers }));
  const { records, done } = streamRecords(buf);
  assert.equal(done, false);
  const channels = new Map(records.filter((r) => r.type === 'Channel').map((c) => [c.id, c]));
  const got = byTopic(channels, records.filter((r) => r.type === 'Message'));
  assert.deepEqual(got['guest.seq'].map((m) => Buffer.from(m.data).toString()), sent.seq);
  assert.deepEqual(got['guest.blob'].map((m) => Buffer.from(m.data)), sent.blob);

  // Cut in the middle of the last chunk as well: what is read is a prefix of what was sent.
  const whole = records.filter((r) => r.type === 'Message');
  const written = chunks(buf);
  assert.ok(written.length >= 2, `${written.length} chunks`);
  const last = written[written.length - 1];
  const part = streamRecords(buf.subarray(0, Math.floor((last.at + last.end) / 2)));
  assert.equal(part.done, false);
  const partMessages = part.records.filter((r) => r.type === 'Message');
  assert.ok(partMessages.length > 0 && partMessages.length < whole.length,
    `${partMessages.length} of ${whole.length}`);
  partMessages.forEach((m, i) => assert.deepEqual(Buffer.from(m.data), Buffer.from(whole[i].data)));
  // flowctl reads the same.
  const info = JSON.parse((await flowctl('--json', 'mcap', 'info', file)).stdout);
  assert.equal(info.complete, false);
  assert.equal(info.messages, whole.length);
});

// An MCAP file written by @mcap/core's McapWriter, a schema, two channels: `mode` zstd (chunks
// compressed), none (chunks uncompressed) or unchunked (messages in the data section, no index).
async function writeReference(file, mode) {
  const parts = [];
  let size = 0n;
  const writer = new McapWriter({
    writable: { write: async (b) => { parts.push(Buffer.from(b)); size += BigInt(b.length); }, position: () => size },
    chunkSize: 1024,
    useChunks: mode !== 'unchunked',
    compressChunk: mode === 'zstd'
      ? (data) => ({ compression: 'zstd', compressedData: zstd.compress(data, 3) })
      : undefined,
  });
  await writer.start({ profile: '', library: 'node test' });
  const schema = await writer.registerSchema({ name: 'Point', encoding: 'jsonschema',
    data: Buffer.from('{"type":"object"}') });
  const points = await writer.registerChannel({ topic: 'robot.points', schemaId: schema,
    messageEncoding: 'json', metadata: new Map() });
  const raw = await writer.registerChannel({ topic: 'robot.raw', schemaId: 0,
    messageEncoding: 'application/octet-stream', metadata: new Map([['mime', 'application/x-raw']]) });
  const sent = [];
  const t0 = BigInt(Date.now()) * 1000000n;
  for (let i = 0; i < 40; i++) {
    const json = i % 2 === 0;
    const data = json ? Buffer.from(JSON.stringify({ x: i, y: -i })) : Buffer.alloc(50 + i, i);
    const logTime = t0 + BigInt(i) * 10000000n;  // 10 ms apart
    await writer.addMessage({ channelId: json ? points : raw, sequence: i, logTime,
      publishTime: logTime - 1000n, data });
    sent.push({ topic: json ? 'robot.points' : 'robot.raw', data, logTime });
  }
  await writer.addMetadata({ name: 'run', metadata: new Map([['robot', 'nao']]) });
  await writer.end();
  writeFileSync(file, Buffer.concat(parts));
  return sent;
}

for (const mode of ['zstd', 'none', 'unchunked']) {
  test(`flowctl reads McapWriter's files (${mode})`, async () => {
    const file = path.join(dir, `reference-${mode}.mcap`);
    const sent = await writeReference(file, mode);
    const info = JSON.parse((await flowctl('--json', 'mcap', 'info', file)).stdout);
    assert.equal(info.complete, true);
    assert.equal(info.indexed, true);  // a summary, if not chunk indexes
    assert.deepEqual(Object.keys(info.chunks), mode === 'unchunked' ? [] : [mode]);
    assert.equal(info.library, 'node test');
    assert.equal(info.messages, sent.length);
    assert.deepEqual(info.channels.map((c) => [c.topic, c.messages]),
      [['robot.points', 20], ['robot.raw', 20]]);
    assert.equal(info.channels[1].mime, 'application/x-raw');
    const text = (await flowctl('mcap', 'cat', file)).stdout.trim().split('\n');
    assert.equal(text.length, sent.length);
    // Times as BigInt from the text (JSON.parse would round them to doubles).
    const time = (line, key) => BigInt(line.match(new RegExp(`"${key}":(\\d+)`))[1]);
    text.forEach((line, i) => {
      const l = JSON.parse(line);
      assert.equal(l.topic, sent[i].topic);
      assert.equal(time(line, 'log_time'), sent[i].logTime);
      assert.equal(time(line, 'publish_time'), sent[i].logTime - 1000n);
      const data = typeof l.data === 'string' ? Buffer.from(l.data) : Buffer.from(l.data.$base64, 'base64');
      assert.deepEqual(data, sent[i].data);
    });

    if (mode === 'none') return;
    // And plays it: robot.points comes back as guest.points, in order, about 10 ms apart.
    const echo = spawn(env.flowctl, ['--address', hub.address, 'echo', 'guest.points', '--wait',
      '--count', '20'], { stdio: ['ignore', 'pipe', 'pipe'] });
    let echoed = '';
    echo.stdout.on('data', (d) => { echoed += d; });
    const echoExit = new Promise((resolve) => echo.on('exit', resolve));
    const played = JSON.parse((await flowctl('--json', 'play', file, '--wait-ms', '5000')).stdout);
    assert.equal(played.messages, 40);
    assert.equal(await Promise.race([echoExit, sleep(10000).then(() => 'timeout')]), 0);
    assert.deepEqual(echoed.trim().split('\n'),
      sent.filter((s) => s.topic === 'robot.points').map((s) => s.data.toString()));
  });
}

// A media frame (docs/channels.md): format code, seq, capture time, size, payload.
function mediaFrame(format, seq, captureNs, width, height, payload) {
  const h = Buffer.alloc(32);
  h.write('SKMF', 0, 'latin1');
  h.writeUInt16LE(32, 4);
  h.writeUInt8(format, 6);
  h.writeBigUInt64LE(BigInt(seq), 8);
  h.writeBigInt64LE(captureNs, 16);
  h.writeUInt16LE(width, 24);
  h.writeUInt16LE(height, 26);
  return Buffer.concat([h, payload]);
}

test('image channels are recorded as Foxglove images and played back as the same frames', async () => {
  // 4x2 frames: rgb8 (format 4), mono16 (8), i420 (10, recorded as nv12) and a JPEG (1).
  const kinds = [
    { name: 'rgb', format: 4, encoding: 'rgb8', bytes: 24, schema: 'RawImage', step: 12 },
    { name: 'depth', format: 8, encoding: 'mono16', bytes: 16, schema: 'RawImage', step: 8 },
    { name: 'yuv', format: 10, encoding: 'i420', bytes: 12, schema: 'RawImage', step: 4 },
    { name: 'jpg', format: 1, encoding: 'jpeg', bytes: 40, schema: 'CompressedImage' },
  ];
  const file = path.join(dir, 'images.mcap');
  const rec = await startRecorder(file, kinds.map((k) => `guest.${k.name}`));
  const sent = {};
  for (const [i, k] of kinds.entries()) {
    sent[k.name] = [];
    // Two runs of `flowctl pub` (each re-creates the channel), each frame published twice.
    for (const run of [0, 1]) {
      const pixels = Buffer.from(Array.from({ length: k.bytes }, (_, b) => (b * 13 + i * 31 + run * 7) & 0xff));
      const frame = mediaFrame(k.format, 100 + run, 1700000000123456789n + BigInt(run), 4, 2, pixels);
      const frameFile = path.join(dir, `${k.name}-${run}.frame`);
      writeFileSync(frameFile, frame);
      const props = { message_encoding: 'skrobot.media', encoding: k.encoding, width: 4, height: 2 };
      const mime = k.format === 1 ? 'image/jpeg' : 'application/octet-stream';
      await flowctl('pub', `guest.${k.name}`, '--file', frameFile, '--repeat', '2', '--mime', mime,
        '--props', JSON.stringify(props), '--wait-ms', '5000');
      sent[k.name].push({ frame, pixels, seq: 100 + run, nsec: 123456789 + run }, { frame, pixels, seq: 100 + run, nsec: 123456789 + run });
    }
  }
  await sleep(200);
  rec.proc.kill('SIGINT');
  assert.equal((await rec.exited).code, 0, rec.out);
  const summary = JSON.parse(rec.out.slice(rec.out.indexOf('{')));
  assert.equal(summary.messages, 16, rec.out);
  assert.ok(!summary.unconverted, rec.out);  // every message was a frame of its channel's kind

  // Read with the reference reader: each image channel is `json` with the Foxglove schema, and
  // each message validates against @foxglove/schemas with the frame's pixels, seq and time.
  const reader = await McapIndexedReader.Initialize({ readable: readable(readFileSync(file)), decompressHandlers });
  const messages = [];
  for await (const m of reader.readMessages()) messages.push(m);
  const got = byTopic(reader.channelsById, messages);
  for (const k of kinds) {
    const channel = [...reader.channelsById.values()].find((c) => c.topic === `guest.${k.name}`);
    assert.equal(channel.messageEncoding, 'json', k.name);
    const schema = reader.schemasById.get(channel.schemaId);
    assert.equal(schema.name, `foxglove.${k.schema}`);
    assert.equal(schema.encoding, 'jsonschema');
    assert.deepEqual(JSON.parse(new TextDecoder().decode(schema.data)).required, schemas[k.schema].required);
    assert.equal(got[`guest.${k.name}`].length, 4, k.name);
    got[`guest.${k.name}`].forEach((m, n) => {
      const img = JSON.parse(Buffer.from(m.data).toString());
      assert.deepEqual(validate(schemas[k.schema], img), [], k.name);
      const want = sent[k.name][n];
      assert.equal(img.frame_id, `guest.${k.name}`);
      assert.deepEqual(img.timestamp, { sec: 1700000000, nsec: want.nsec });
      assert.equal(img.seq, want.seq);
      assert.equal(m.publishTime, 1700000000000000000n + BigInt(want.nsec), 'publish time = capture time');
      let pixels = want.pixels;
      if (k.encoding === 'i420') {  // shown as nv12: U and V interleaved
        pixels = Buffer.concat([pixels.subarray(0, 8), Buffer.from([pixels[8], pixels[10], pixels[9], pixels[11]])]);
      }
      assert.deepEqual(Buffer.from(img.data, 'base64'), pixels, k.name);
      if (k.schema === 'RawImage') {
        assert.equal(img.encoding, k.encoding === 'i420' ? 'nv12' : k.encoding);
        assert.deepEqual([img.width, img.height, img.step], [4, 2, k.step]);
      } else {
        assert.equal(img.format, 'jpeg');
      }
    });
  }

  // Play it: each channel comes back with the same frames, byte for byte.
  const echoes = kinds.map((k) => {
    const echo = spawn(env.flowctl, ['--address', hub.address, 'echo', `guest.${k.name}`, '--wait',
      '--count', '4', '--format', 'hex'], { stdio: ['ignore', 'pipe', 'pipe'] });
    const e = { out: '', exited: new Promise((resolve) => echo.on('exit', resolve)) };
    echo.stdout.on('data', (d) => { e.out += d; });
    return e;
  });
  const played = JSON.parse((await flowctl('--json', 'play', file, '--wait-ms', '5000')).stdout);
  assert.equal(played.messages, 16);
  for (const [i, k] of kinds.entries()) {
    assert.equal(await Promise.race([echoes[i].exited, sleep(10000).then(() => 'timeout')]), 0, k.name);
    assert.deepEqual(echoes[i].out.trim().split('\n'), sent[k.name].map((s) => s.frame.toString('hex')), k.name);
  }
});

test('a message of an image channel that is not such a frame is counted, not recorded', async () => {
  const file = path.join(dir, 'not-image.mcap');
  const rec = await startRecorder(file, ['guest.notframe']);
  await flowctl('pub', 'guest.notframe', 'not a frame', '--repeat', '3', '--mime',
    'application/octet-stream', '--props', '{"encoding":"bgr8","width":4,"height":2}', '--wait-ms', '5000');
  await sleep(200);
  rec.proc.kill('SIGINT');
  assert.equal((await rec.exited).code, 0, rec.out);
  const summary = JSON.parse(rec.out.slice(rec.out.indexOf('{')));
  assert.equal(summary.unconverted, 3, rec.out);
  assert.equal(summary.channels[0].unconverted, 3, rec.out);
  assert.equal(summary.messages, 0, rec.out);
  assert.match(rec.out, /RECORD-NOT-IMAGE 3 messages/);
  const reader = await McapIndexedReader.Initialize({ readable: readable(readFileSync(file)), decompressHandlers });
  assert.equal(reader.statistics.messageCount, 0n);
});

// Typed channels (docs/channels.md) are recorded with their own message encoding and schema: a
// `json` channel with a JSON Schema, and a `cdr` channel of geometry_msgs/msg/Twist with its
// `ros2msg` schema (MCAP's ROS 2 profile), encoded and decoded by the npm ROS 2 reference,
// @foxglove/rosmsg2-serialization, from the schema text in the file.
test('typed channels are recorded with their schemas; cdr with ros2msg decodes by the ROS 2 reference', async () => {
  const { MessageReader, MessageWriter } = webRequire('@foxglove/rosmsg2-serialization');
  const { parse } = webRequire('@foxglove/rosmsg');
  const twistSchema = 'geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n' +
    '================================================================================\n' +
    'MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n';
  const poseSchema = JSON.stringify({ type: 'object', required: ['x', 'y'], properties: { x: { type: 'number' }, y: { type: 'number' } } });
  const file = path.join(dir, 'typed.mcap');
  const rec = await startRecorder(file, ['guest.cmd_vel', 'guest.pose']);
  const twist = { linear: { x: 0.2, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0.5 } };
  const cdr = new MessageWriter(parse(twistSchema, { ros2: true })).writeMessage(twist);
  const cdrFile = path.join(dir, 'twist.cdr');
  writeFileSync(cdrFile, cdr);
  writeFileSync(path.join(dir, 'twist.msg'), twistSchema);
  writeFileSync(path.join(dir, 'pose.json'), poseSchema);
  await flowctl('pub', 'guest.cmd_vel', '--file', cdrFile, '--repeat', '2', '--mime', 'application/octet-stream',
    '--encoding', 'cdr', '--schema-name', 'geometry_msgs/msg/Twist', '--schema-encoding', 'ros2msg',
    '--schema-file', path.join(dir, 'twist.msg'), '--wait-ms', '5000');
  await flowctl('pub', 'guest.pose', '{"x": 1.5, "y": -2}', '--mime', 'application/json', '--encoding', 'json',
    '--schema-name', 'lab.Pose', '--schema-encoding', 'jsonschema', '--schema-file', path.join(dir, 'pose.json'),
    '--wait-ms', '5000');
  // A type that breaks the rules is refused before anything is sent.
  await assert.rejects(flowctl('pub', 'guest.bad', 'x', '--encoding', 'cdr'), /needs a schema/);
  await sleep(200);
  rec.proc.kill('SIGINT');
  assert.equal((await rec.exited).code, 0, rec.out);

  const reader = await McapIndexedReader.Initialize({ readable: readable(readFileSync(file)), decompressHandlers });
  const messages = [];
  for await (const m of reader.readMessages()) messages.push(m);
  const got = byTopic(reader.channelsById, messages);
  const channel = (topic) => [...reader.channelsById.values()].find((c) => c.topic === topic);
  const cmd = channel('guest.cmd_vel');
  const cmdSchema = reader.schemasById.get(cmd.schemaId);
  assert.equal(cmd.messageEncoding, 'cdr');
  assert.deepEqual([cmdSchema.name, cmdSchema.encoding], ['geometry_msgs/msg/Twist', 'ros2msg']);
  const decode = new MessageReader(parse(new TextDecoder().decode(cmdSchema.data), { ros2: true }));
  assert.equal(got['guest.cmd_vel'].length, 2);
  for (const m of got['guest.cmd_vel']) assert.deepEqual(decode.readMessage(m.data), twist);
  const pose = channel('guest.pose');
  const poseRecorded = reader.schemasById.get(pose.schemaId);
  assert.equal(pose.messageEncoding, 'json');
  assert.deepEqual([poseRecorded.name, poseRecorded.encoding], ['lab.Pose', 'jsonschema']);
  const schema = JSON.parse(new TextDecoder().decode(poseRecorded.data));
  for (const m of got['guest.pose']) assert.deepEqual(validate(schema, JSON.parse(Buffer.from(m.data).toString())), []);
});
