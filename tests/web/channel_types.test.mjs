// SPDX-License-Identifier: Apache-2.0
// The hub's own modules declare what their channels carry (docs/channels.md, "Typed channels"),
// and what they publish is what they declare: a hub with the demo's detectors on a video file,
// fft-audio on a tone and qrcode on a QR code this test publishes, the simulated Nao and the agent. Each channel's type
// is read through the JavaScript library, checked by its rules (typeProblem), and its JSON Schema
// compiled by Ajv (npm, the reference validator; harness.mjs's validate) against real messages.
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { after, before, test } from 'node:test';

import { startHub, validate, waitFor, webRequire } from './harness.mjs';
import * as skr from '../../satellite/js/src/node.js';

const VIDEO = '/usr/share/doc/opencv-doc/examples/data/vtest.avi';  // opencv-doc
const Ajv = webRequire('ajv');  // strict here: the hub's own schemas use no unknown keyword
const RATE = 22050;

let hub;
let client;
let toneTimer;
let qrTimer;

// A QR code made at test time by the qrencode CLI (Debian's qrencode), as a mono8 media frame:
// 6 pixels a module, black on white.
function qrFrame(text, seq) {
  const rows = execFileSync('qrencode', ['-t', 'ASCII', '-m', '2', text]).toString().split('\n').filter((r) => r.length);
  const modules = rows.map((r) => Array.from({ length: r.length / 2 }, (_, i) => r[2 * i] === '#'));
  const k = 6;
  const width = modules[0].length * k;
  const height = modules.length * k;
  const pixels = new Uint8Array(width * height);
  for (let y = 0; y < height; y++) {
    for (let x = 0; x < width; x++) pixels[y * width + x] = modules[Math.floor(y / k)][Math.floor(x / k)] ? 0 : 255;
  }
  return skr.makeMediaFrame({ format: skr.FORMAT.mono8, seq: BigInt(seq), width, height }, pixels);
}

before(async () => {
  hub = await startHub([
    { name: 'video-source', config: { file: VIDEO, fps: 15 } },
    { name: 'video-mono', config: { input: 'video-source.video' } },
    { name: 'face-detect', config: { input: 'video-mono.mono' } },
    { name: 'motion', config: { input: 'video-mono.mono' } },
    { name: 'qrcode', config: { input: 'guest.qr', repeat_ms: 0 } },
    { name: 'fft-audio', config: { input: 'guest.tone' } },
    { name: 'nao-bridge', config: { backend: 'simulated' } },
    { name: 'speech', config: {} },
    { name: 'agent', config: { say: 'speech.say', expression: '', nao: '', faces: '', codes: '' } },
  ]);
  client = await skr.connect(hub.address, { clientName: 'channel types' });
  // A 440 Hz tone, 100 ms a frame, as a microphone would publish it.
  const tone = await client.createChannel('tone', { mime: skr.encodingOf(skr.FORMAT.s16le).mime });
  let seq = 0n;
  toneTimer = setInterval(() => {
    const samples = new Int16Array(RATE / 10);
    for (let i = 0; i < samples.length; i++) samples[i] = Math.round(8000 * Math.sin((2 * Math.PI * 440 * (Number(seq) + i)) / RATE));
    tone.publish(skr.makeMediaFrame({ format: skr.FORMAT.s16le, seq, channels: 1, sampleRate: RATE }, samples));
    seq += BigInt(samples.length);
  }, 100);
  const qr = await client.createChannel('qr', { mime: skr.encodingOf(skr.FORMAT.mono8).mime });
  let qrSeq = 0;
  qrTimer = setInterval(() => qr.publish(qrFrame('https://example.org/skrobot', qrSeq++)), 200);
});

after(async () => {
  clearInterval(toneTimer);
  clearInterval(qrTimer);
  client?.close();
  if (hub) await hub.stop();
});

// The channel's declared type and a few of its messages, each checked against its schema.
async function checkChannel(name, count, nudge = () => {}) {
  const info = await waitFor(`channel ${name}`, () => client.channelByName(name), 30000);
  const type = skr.channelType(info.props);
  assert.equal(skr.typeProblem(type), null, `${name}: ${skr.typeProblem(type)}`);
  assert.equal(type.messageEncoding, 'json', name);
  assert.equal(type.schemaEncoding, 'jsonschema', name);
  const schema = JSON.parse(type.schema);
  assert.equal(schema.title, type.schemaName, `${name}: the schema's title is its name`);
  new Ajv({ strict: true }).compile(schema);  // throws on a schema Ajv does not take strictly
  const seen = [];
  const sub = client.subscribe(name, (m) => {
    if (seen.length < count) seen.push(m.json());
  });
  try {
    await waitFor(`${count} messages on ${name}`, () => { nudge(); return seen.length >= count; }, 30000, 200);
  } finally {
    sub.close();
  }
  for (const message of seen) {
    assert.deepEqual(validate(schema, message), [], `${name} (${type.schemaName}): ${JSON.stringify(message).slice(0, 300)}`);
  }
  return { type, seen };
}

test('the detectors publish what their channels declare', async () => {
  for (const [name, schemaName] of [['face-detect.faces', 'skrobot.vision.Faces'],
    ['motion.motion', 'skrobot.vision.Motion'], ['qrcode.codes', 'skrobot.vision.Codes']]) {
    const { type } = await checkChannel(name, 3);
    assert.equal(type.schemaName, schemaName);
  }
  const codes = await checkChannel('qrcode.codes', 1);
  assert.equal(codes.seen[0].codes[0]?.text, 'https://example.org/skrobot');
  const motion = await checkChannel('motion.motion', 20);
  assert.ok(motion.seen.some((m) => m.regions.length > 0), 'people walk in vtest.avi');
});

test('fft-audio, the Nao and the agent publish what their channels declare', async () => {
  const spectrum = await checkChannel('fft-audio.spectrum', 3);
  assert.ok(spectrum.seen.some((m) => Math.abs(m.peak_hz - 440) < 25), 'the tone is at 440 Hz');
  await checkChannel('fft-audio.bands', 3);
  const joints = await checkChannel('nao-bridge.joints', 3);
  assert.equal(joints.type.schemaName, 'skrobot.nao.Joints');
  const dialogue = await checkChannel('agent.dialogue', 1, () => {
    client.call('agent.command', 'hear', { text: 'hello' }, { timeoutMs: 10000 }).catch(() => {});
  });
  assert.equal(dialogue.seen[0].heard, 'hello');
});

test('a type that breaks the rules is refused before the channel is made', async () => {
  await assert.rejects(client.createChannel('bad', { type: { messageEncoding: 'cdr' } }), /needs a schema/);
  const ok = await client.createChannel('twist', {
    type: { messageEncoding: 'json', schemaName: 'lab.Twist', schemaEncoding: 'jsonschema', schema: '{"type":"object"}' },
  });
  const info = await waitFor('the typed channel', () => client.channelByName(ok.name), 10000);
  assert.deepEqual(skr.channelType(info.props), {
    messageEncoding: 'json', schemaName: 'lab.Twist', schemaEncoding: 'jsonschema', schema: '{"type":"object"}',
  });
  const text = await hub.flowctl('info', ok.name);
  assert.match(text, /type {9}json lab\.Twist \(jsonschema, 17-byte schema\)/);
  assert.match(text, /"schema":"\(17 bytes\)"/);
});
