// SPDX-License-Identifier: Apache-2.0
// foxglove-bridge in a real hub, against the reference client @foxglove/ws-protocol 0.8.0 and the
// schemas of @foxglove/schemas 2.1.0 (web/node_modules): serverInfo, advertised channels and
// their schemas, data while subscribed (and none after), a channel advertised again when its
// properties change its schema, a service call, parameters backed by
// databases (a refused set too), the connection graph, and a malformed client closed alone.
import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import { readFileSync, writeFileSync, mkdtempSync } from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { after, before, test } from 'node:test';

import { env, freePort, sleep, startHub, validate, waitFor, webRequire } from '../web/harness.mjs';
import * as skr from '../../satellite/js/src/node.js';

const WebSocket = webRequire('ws');
const { FoxgloveClient } = webRequire('@foxglove/ws-protocol');
const schemas = webRequire('@foxglove/schemas/jsonschema');
const POSE_SCHEMA = '{"type":"object","properties":{"x":{"type":"number"}}}';
const TWIST_MSG = 'geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n' +
  '================================================================================\n' +
  'MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n';
const TWIST = { linear: { x: 0.2, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0.5 } };
const TWIST_CDR = (() => {
  const { MessageWriter } = webRequire('@foxglove/rosmsg2-serialization');
  const { parse } = webRequire('@foxglove/rosmsg');
  return new MessageWriter(parse(TWIST_MSG, { ros2: true })).writeMessage(TWIST);
})();

let hub;
let port;
let uiPort;
const publishers = [];

function mediaFrame(seq, payload, format = 1, width = 128, height = 128) {
  const h = Buffer.alloc(32);
  h.write('SKMF', 0, 'latin1');
  h.writeUInt16LE(32, 4);
  h.writeUInt8(format, 6);
  h.writeBigUInt64LE(BigInt(seq), 8);
  h.writeBigInt64LE(1700000000123456789n, 16);
  h.writeUInt16LE(width, 24);
  h.writeUInt16LE(height, 26);
  return Buffer.concat([h, payload]);
}
// 8x4 bgr8 pixels (format 5, docs/channels.md), every byte different.
const rawPixels = Buffer.from(Array.from({ length: 8 * 4 * 3 }, (_, i) => i));

// `flowctl pub` at 20 Hz until the test ends.
function publish(channel, args) {
  const p = spawn(env.flowctl, ['--address', hub.address, 'pub', channel, ...args, '--rate', '20',
    '--wait-ms', '0'], { stdio: 'ignore' });
  publishers.push(p);
  return p;
}

// A connected reference client with everything it was told.
async function connect() {
  const ws = new WebSocket(`ws://127.0.0.1:${port}/`, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
  const client = new FoxgloveClient({ ws });
  const seen = { channels: new Map(), services: new Map(), messages: [], status: [], params: [],
    graph: [], responses: [], failures: [], closed: null };
  client.on('serverInfo', (i) => { seen.info = i; });
  client.on('advertise', (cs) => cs.forEach((c) => seen.channels.set(c.topic, c)));
  client.on('unadvertise', (ids) => {
    for (const [t, c] of seen.channels) if (ids.includes(c.id)) seen.channels.delete(t);
  });
  client.on('advertiseServices', (ss) => ss.forEach((s) => seen.services.set(s.name, s)));
  client.on('message', (m) => seen.messages.push(m));
  client.on('status', (s) => seen.status.push(s));
  client.on('parameterValues', (p) => seen.params.push(p));
  client.on('connectionGraphUpdate', (g) => seen.graph.push(g));
  client.on('serviceCallResponse', (r) => seen.responses.push(r));
  client.on('serviceCallFailure', (f) => seen.failures.push(f));
  client.on('close', (e) => { seen.closed = e; });
  client.on('error', () => {});
  await waitFor('serverInfo', () => seen.info, 10000);
  return { client, seen, ws };
}

const decode = (m) => JSON.parse(Buffer.from(m.data.buffer, m.data.byteOffset, m.data.byteLength).toString());
// What the bridge's last count in the log says it could not convert.
const skippedCount = () => Math.max(0, ...[...hub.log.matchAll(/(\d+) that could not be converted skipped/g)]
  .map((m) => Number(m[1])));

before(async () => {
  port = await freePort();
  uiPort = await freePort();
  // The bridge acts as the account "foxglove": it may write its own database only, and may not
  // subscribe to guest.secret.
  hub = await startHub([{ name: 'nao-bridge', config: { backend: 'simulated' } },
    { name: 'websocket-ui', config: { port: uiPort } },
    { name: 'foxglove-bridge', account: 'foxglove', config: {
      port, annotations: ['guest.faces'], joints: ['nao-bridge.joints'],
      parameters: ['foxglove-bridge', 'guest'], max_message_bytes: 4096 } }], { users: [{ name: 'foxglove', rules: {
    db_write: ['foxglove-bridge'], subscribe: ['**', '!guest.secret'] } }] });
  const jpeg = readFileSync('/usr/share/doc/opencv-doc/examples/data/HappyFish.jpg');
  const dir = mkdtempSync(path.join(os.tmpdir(), 'skrobot-fg-'));
  writeFileSync(path.join(dir, 'frame'), mediaFrame(1, jpeg));
  publish('guest.numbers', ['{"n":1,"x":0.5}', '--mime', 'application/json']);
  publish('guest.camera', ['--file', path.join(dir, 'frame'), '--mime', 'image/jpeg']);
  writeFileSync(path.join(dir, 'raw'), mediaFrame(2, rawPixels, 5, 8, 4));
  publish('guest.raw', ['--file', path.join(dir, 'raw'), '--mime', 'application/octet-stream',
    '--props', '{"message_encoding":"skrobot.media","encoding":"bgr8","width":8,"height":4}']);
  publish('guest.secret', ['{"pin":1234}', '--mime', 'application/json']);
  // Typed channels (docs/channels.md): advertised with their own encoding and schema.
  writeFileSync(path.join(dir, 'pose.json'), POSE_SCHEMA);
  publish('guest.pose', ['{"x":1.5}', '--mime', 'application/json', '--encoding', 'json', '--schema-name',
    'lab.Pose', '--schema-encoding', 'jsonschema', '--schema-file', path.join(dir, 'pose.json')]);
  writeFileSync(path.join(dir, 'twist.msg'), TWIST_MSG);
  writeFileSync(path.join(dir, 'twist.cdr'), TWIST_CDR);
  publish('guest.cmd_vel', ['--file', path.join(dir, 'twist.cdr'), '--mime', 'application/octet-stream',
    '--encoding', 'cdr', '--schema-name', 'geometry_msgs/msg/Twist', '--schema-encoding', 'ros2msg',
    '--schema-file', path.join(dir, 'twist.msg')]);
  publish('guest.faces', ['{"capture_ns":1700000000123456789,"width":128,"height":128,'
    + '"faces":[{"x":10,"y":20,"w":30,"h":40,"score":0.9}]}', '--mime', 'application/json']);
  await waitFor('the publishers\' channels', async () => {
    const ls = await hub.flowctl('ls');
    return ['guest.numbers', 'guest.camera', 'guest.faces', 'guest.secret', 'guest.raw', 'guest.pose',
      'guest.cmd_vel'].every((c) => ls.includes(c));
  });
});

after(async () => {
  for (const p of publishers) p.kill('SIGINT');
  if (hub) await hub.stop();
});

test('serverInfo names the capabilities; channels and services are advertised', { timeout: 60000 }, async () => {
  const { client, seen } = await connect();
  assert.equal(seen.info.name, 'skrobot');
  for (const cap of ['parameters', 'parametersSubscribe', 'services', 'connectionGraph']) {
    assert.ok(seen.info.capabilities.includes(cap), cap);
  }
  await waitFor('advertised channels', () => ['guest.numbers', 'guest.camera', 'guest.faces']
    .every((t) => seen.channels.has(t)), 10000);
  const num = seen.channels.get('guest.numbers');
  assert.equal(num.encoding, 'json');
  assert.equal(num.schemaEncoding, 'jsonschema');
  assert.equal(JSON.parse(num.schema).type, 'object');
  const cam = seen.channels.get('guest.camera');
  assert.equal(cam.schemaName, 'foxglove.CompressedImage');
  const faces = seen.channels.get('guest.faces');
  assert.equal(faces.schemaName, 'foxglove.ImageAnnotations');
  // The advertised schemas have the reference schemas' required fields.
  assert.deepEqual(JSON.parse(cam.schema).required, schemas.CompressedImage.required);
  assert.deepEqual(JSON.parse(faces.schema).required, schemas.ImageAnnotations.required);
  await waitFor('the raw channel', () => seen.channels.has('guest.raw'), 10000);
  const raw = seen.channels.get('guest.raw');
  assert.equal(raw.schemaName, 'foxglove.RawImage');
  assert.deepEqual(JSON.parse(raw.schema).required, schemas.RawImage.required);
  assert.ok(seen.services.has('hub.inspect'));
  assert.ok(seen.services.get('hub.inspect').request.schema);
  // Typed channels, as their properties declare them.
  await waitFor('the typed channels', () => seen.channels.has('guest.pose') && seen.channels.has('guest.cmd_vel'), 10000);
  const pose = seen.channels.get('guest.pose');
  assert.deepEqual([pose.encoding, pose.schemaName, pose.schemaEncoding, pose.schema],
    ['json', 'lab.Pose', 'jsonschema', POSE_SCHEMA]);
  const twist = seen.channels.get('guest.cmd_vel');
  assert.deepEqual([twist.encoding, twist.schemaName, twist.schemaEncoding, twist.schema],
    ['cdr', 'geometry_msgs/msg/Twist', 'ros2msg', TWIST_MSG]);
  // Its messages come as they were published: CDR the ROS 2 reference decodes by that schema.
  const sub = client.subscribe(twist.id);
  await waitFor('a Twist', () => seen.messages.some((m) => m.subscriptionId === sub), 10000);
  const m = seen.messages.find((x) => x.subscriptionId === sub);
  const { MessageReader } = webRequire('@foxglove/rosmsg2-serialization');
  const { parse } = webRequire('@foxglove/rosmsg');
  const bytes = new Uint8Array(m.data.buffer, m.data.byteOffset, m.data.byteLength);
  assert.deepEqual(new MessageReader(parse(twist.schema, { ros2: true })).readMessage(bytes), TWIST);
  client.close();
});

test('data flows while subscribed, in the reference schemas, and stops after unsubscribe', { timeout: 60000 }, async () => {
  const { client, seen } = await connect();
  await waitFor('channels', () => seen.channels.has('guest.camera') && seen.channels.has('guest.faces'));
  const subscribers = async (name) => JSON.parse(await hub.flowctl('--json', 'ls'))
    .find((c) => c.name === name)?.subscribers;
  assert.equal(await subscribers('guest.numbers'), 0, 'no client: the bridge does not subscribe');
  const sNum = client.subscribe(seen.channels.get('guest.numbers').id);
  const sCam = client.subscribe(seen.channels.get('guest.camera').id);
  const sFaces = client.subscribe(seen.channels.get('guest.faces').id);
  await waitFor('messages on all three', () => [sNum, sCam, sFaces]
    .every((s) => seen.messages.some((m) => m.subscriptionId === s)), 10000);
  assert.equal(await subscribers('guest.numbers'), 1);
  const num = decode(seen.messages.find((m) => m.subscriptionId === sNum));
  assert.deepEqual(num, { n: 1, x: 0.5 });
  const camMsg = seen.messages.find((m) => m.subscriptionId === sCam);
  assert.equal(camMsg.timestamp, 1700000000123456789n, 'log time = capture time');
  const cam = decode(camMsg);
  assert.deepEqual(validate(schemas.CompressedImage, cam), []);
  assert.equal(cam.format, 'jpeg');
  const jpeg = Buffer.from(cam.data, 'base64');
  assert.equal(jpeg.readUInt16BE(0), 0xffd8, 'a JPEG');
  assert.deepEqual(jpeg, readFileSync('/usr/share/doc/opencv-doc/examples/data/HappyFish.jpg'));
  const faces = decode(seen.messages.find((m) => m.subscriptionId === sFaces));
  assert.deepEqual(validate(schemas.ImageAnnotations, faces), []);
  assert.equal(faces.points.length, 1);
  assert.deepEqual(faces.points[0].points[2], { x: 40, y: 60 });

  client.unsubscribe(sNum);
  client.unsubscribe(sCam);
  client.unsubscribe(sFaces);
  await waitFor('the bridge lets the channel go', async () => (await subscribers('guest.numbers')) === 0);
  await sleep(300);
  const count = seen.messages.length;
  await sleep(1000);
  assert.equal(seen.messages.length, count, 'no message after unsubscribe');
  client.close();
  // The log counts what the bridge forwarded (the camera's frames are converted on its thread).
  await waitFor('the counts in the log', () =>
    /FOXGLOVE-CLIENT client \d+ left: .*; [1-9]\d* messages forwarded, \d+ that could not be converted skipped, \d+ replaced/.test(hub.log));
});

test('JSON messages come in order, converted off the loop; one that does not parse is skipped', { timeout: 60000 }, async () => {
  const sat = await skr.connect(hub.address, { clientName: 'foxglove burst' });
  const burst = await sat.createChannel('burst', { mime: 'application/json' });
  const { client, seen } = await connect();
  await waitFor('the burst channel', () => seen.channels.has('guest.burst'), 10000);
  const sub = client.subscribe(seen.channels.get('guest.burst').id);
  await waitFor('the bridge subscribes', async () => JSON.parse(await hub.flowctl('--json', 'ls'))
    .find((c) => c.name === 'guest.burst')?.subscribers === 1);
  const skippedBefore = skippedCount();
  // Back to back, faster than one a turn of the loop: none may be replaced by a newer one.
  for (let i = 0; i < 500; ++i) burst.publish(i === 250 ? '{"i": 250' : JSON.stringify({ i, pad: 'x'.repeat(i) }));
  const got = () => seen.messages.filter((m) => m.subscriptionId === sub).map((m) => decode(m).i);
  await waitFor('499 messages', () => got().length >= 499, 10000);
  await sleep(300);
  assert.deepEqual(got(), [...Array(500).keys()].filter((i) => i !== 250));
  client.close();
  sat.close();
  await waitFor('the skipped one counted', () => skippedCount() > skippedBefore, 10000);
});

test('raw frames come as foxglove.RawImage in the reference schema', { timeout: 60000 }, async () => {
  const { client, seen } = await connect();
  await waitFor('the raw channel', () => seen.channels.has('guest.raw'), 10000);
  const sub = client.subscribe(seen.channels.get('guest.raw').id);
  await waitFor('a raw image', () => seen.messages.some((m) => m.subscriptionId === sub), 10000);
  const msg = seen.messages.find((m) => m.subscriptionId === sub);
  assert.equal(msg.timestamp, 1700000000123456789n, 'log time = capture time');
  const img = decode(msg);
  assert.deepEqual(validate(schemas.RawImage, img), []);
  assert.equal(img.encoding, 'bgr8');
  assert.equal(img.width, 8);
  assert.equal(img.height, 4);
  assert.equal(img.step, 24);
  assert.deepEqual(Buffer.from(img.data, 'base64'), rawPixels);
  client.unsubscribe(sub);
  client.close();
});

test('a channel told its raw encoding after it was created is advertised as foxglove.RawImage', { timeout: 60000 }, async (t) => {
  // A satellite creates guest.late without properties (bytes: nothing Foxglove shows), then sets
  // them with CHAN_SET_PROPS.
  const sat = spawn('python3', [path.join(env.source, 'tests/foxglove/late_properties.py')], {
    env: { ...process.env, ROBOT_ADDRESS: hub.address, PYTHONPATH: path.join(env.source, 'satellite/python') },
    stdio: ['pipe', 'pipe', 'pipe'],
  });
  let out = '';
  sat.stdout.on('data', (d) => { out += d; });
  sat.stderr.on('data', (d) => { out += d; });
  t.after(() => sat.kill('SIGKILL'));
  await waitFor('the late satellite', () => {
    if (sat.exitCode !== null) throw new Error(`late_properties.py exited ${sat.exitCode}: ${out}`);
    return out.includes('ready');
  }, 30000);
  const props = (p) => sat.stdin.write(`props ${JSON.stringify(p)}\n`);
  const { client, seen } = await connect();
  const unadvertised = [];
  client.on('unadvertise', (ids) => unadvertised.push(...ids));
  await waitFor('the other channels', () => seen.channels.has('guest.numbers'), 10000);
  assert.ok((await hub.flowctl('ls')).includes('guest.late'));
  await sleep(300);
  assert.equal(seen.channels.has('guest.late'), false, 'bytes are not advertised');

  props({ message_encoding: 'skrobot.media', encoding: 'rgb8', width: 4, height: 2 });
  await waitFor('guest.late advertised', () => seen.channels.has('guest.late'), 10000);
  const first = seen.channels.get('guest.late');
  assert.equal(first.schemaName, 'foxglove.RawImage');
  assert.deepEqual(JSON.parse(first.schema).required, schemas.RawImage.required);
  const sub = client.subscribe(first.id);
  await waitFor('a raw image', () => seen.messages.some((m) => m.subscriptionId === sub), 10000);
  const img = decode(seen.messages.find((m) => m.subscriptionId === sub));
  assert.deepEqual(validate(schemas.RawImage, img), []);
  assert.deepEqual([img.encoding, img.width, img.height, img.step], ['rgb8', 4, 2, 12]);
  assert.deepEqual(Buffer.from(img.data, 'base64'), Buffer.from(Array.from({ length: 24 }, (_, i) => i)));

  // Its encoding removed: unadvertised, and the client's subscription ends with it.
  props({ encoding: null });
  await waitFor('guest.late unadvertised', () => unadvertised.includes(first.id), 10000);
  assert.equal(seen.channels.has('guest.late'), false);
  await sleep(300);
  const count = seen.messages.filter((m) => m.subscriptionId === sub).length;
  await sleep(700);
  assert.equal(seen.messages.filter((m) => m.subscriptionId === sub).length, count, 'no message after unadvertise');

  // A raw encoding again: advertised under a new id.
  props({ encoding: 'bgr8' });
  await waitFor('guest.late advertised again', () => seen.channels.has('guest.late'), 10000);
  const second = seen.channels.get('guest.late');
  assert.notEqual(second.id, first.id);
  assert.equal(second.schemaName, 'foxglove.RawImage');
  assert.match(hub.log, /FOXGLOVE-READVERTISE guest\.late: its properties changed its schema from none to foxglove\.RawImage/);
  client.close();
});

test('the Nao\'s joints come by name, to plot', { timeout: 60000 }, async () => {
  const { client, seen } = await connect();
  await waitFor('the joints channel', () => seen.channels.has('nao-bridge.joints'));
  const ch = seen.channels.get('nao-bridge.joints');
  assert.equal(ch.schemaName, 'skrobot.JointPositions');
  const sub = client.subscribe(ch.id);
  await waitFor('joint states', () => seen.messages.some((m) => m.subscriptionId === sub), 10000);
  const j = decode(seen.messages.find((m) => m.subscriptionId === sub));
  assert.equal(j.angles.length, 26);
  assert.equal(Object.keys(j.positions).length, 26);
  assert.equal(typeof j.positions.HeadYaw, 'number');
  assert.equal(j.positions.RHand, j.angles[25]);
  client.close();
});

test('a channel the account may not subscribe to is refused with a status', { timeout: 60000 }, async () => {
  const { client, seen } = await connect();
  await waitFor('channels', () => seen.channels.has('guest.secret'));
  client.subscribe(seen.channels.get('guest.secret').id);
  await waitFor('the refusal', () => seen.status.some((s) => /cannot subscribe to guest\.secret/.test(s.message)));
  await sleep(500);
  assert.equal(seen.messages.length, 0);
  assert.equal(seen.closed, null);
  client.close();
});

test('a service call goes to the hub service and its answer comes back', { timeout: 60000 }, async () => {
  const { client, seen } = await connect();
  await waitFor('services', () => seen.services.has('hub.inspect'));
  const id = seen.services.get('hub.inspect').id;
  client.sendServiceCallRequest({ serviceId: id, callId: 11, encoding: 'json',
    data: new Uint8Array(Buffer.from('{"command":"stats"}')) });
  await waitFor('the response', () => seen.responses.length > 0, 10000);
  const r = seen.responses[0];
  assert.equal(r.callId, 11);
  assert.equal(r.encoding, 'json');
  const stats = JSON.parse(Buffer.from(r.data).toString());
  assert.ok(stats.channels.some((c) => c.name === 'guest.numbers'));
  // A call to no service fails, the connection stays.
  client.sendServiceCallRequest({ serviceId: 99999, callId: 12, encoding: 'json',
    data: new Uint8Array(Buffer.from('{"command":"stats"}')) });
  await waitFor('the failure', () => seen.failures.some((f) => f.callId === 12));
  assert.equal(seen.closed, null);
  client.close();
});

test('parameters are database variables: get, set, updates, and a refused set', { timeout: 60000 }, async () => {
  await hub.flowctl('db', 'set', '--db', 'guest', 'speed', '2');
  const { client, seen } = await connect();
  client.getParameters([], 'all');
  await waitFor('parameterValues', () => seen.params.find((p) => p.id === 'all'));
  const all = seen.params.find((p) => p.id === 'all');
  assert.deepEqual(all.parameters.find((p) => p.name === 'guest/speed'), { name: 'guest/speed', value: 2 });

  client.subscribeParameterUpdates(['foxglove-bridge/gain', 'guest/speed']);
  await sleep(200);
  client.setParameters([{ name: 'foxglove-bridge/gain', value: { level: 3 } }], 'set1');
  await waitFor('the set answer', () => seen.params.find((p) => p.id === 'set1'));
  assert.deepEqual(seen.params.find((p) => p.id === 'set1').parameters,
    [{ name: 'foxglove-bridge/gain', value: { level: 3 } }]);
  assert.deepEqual(await hub.dbGet('foxglove-bridge', 'gain'), { level: 3 });
  // Another client's change reaches the subscriber.
  await hub.flowctl('db', 'set', '--db', 'guest', 'speed', '5');
  await waitFor('the update', () => seen.params.some((p) => p.id === undefined
    && p.parameters.some((q) => q.name === 'guest/speed' && q.value === 5)));
  // guest is shown, but the account may not write it: refused with a status message, the value
  // stays.
  client.setParameters([{ name: 'guest/speed', value: 9 }], 'set2');
  await waitFor('the refusal', () => seen.status.some((s) => /guest\/speed.*refused/.test(s.message)));
  await waitFor('the set2 answer', () => seen.params.find((p) => p.id === 'set2'));
  assert.equal(seen.params.find((p) => p.id === 'set2').parameters[0].value, 5);
  assert.equal(await hub.dbGet('guest', 'speed'), 5);
  assert.match(hub.log, /FOXGLOVE-PARAM .*guest\/speed refused/);
  client.close();
});

test('the connection graph comes from the hub statistics', { timeout: 60000 }, async () => {
  const { client, seen } = await connect();
  await waitFor('channels', () => seen.channels.has('guest.numbers'));
  const sub = client.subscribe(seen.channels.get('guest.numbers').id);
  client.subscribeConnectionGraph();
  await waitFor('a graph with the publishers', () => seen.graph.some((g) =>
    g.publishedTopics.some((t) => t.name === 'guest.numbers')), 10000);
  const first = seen.graph.find((g) => g.publishedTopics.some((t) => t.name === 'guest.numbers'));
  assert.ok(first.advertisedServices.some((s) => s.name === 'hub.inspect'));
  await waitFor('the bridge as a subscriber', () => seen.graph.some((g) => g.subscribedTopics.some(
    (t) => t.name === 'guest.numbers' && t.subscriberIds.some((id) => id.includes('foxglove-bridge')))), 10000);
  client.unsubscribe(sub);
  client.close();
});

test('a malformed message closes only its client, with a reason', { timeout: 60000 }, async () => {
  const good = await connect();
  const bad = new WebSocket(`ws://127.0.0.1:${port}/`, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
  const closed = new Promise((r) => bad.on('close', (code, reason) => r({ code, reason: reason.toString() })));
  await new Promise((r) => bad.on('open', r));
  bad.send('{"op":"subscribe","subscriptions":[{"id":"x"}]}');
  const c = await closed;
  assert.equal(c.code, 1007);
  assert.match(c.reason, /malformed/);
  // Oversized: refused before it is buffered.
  const big = new WebSocket(`ws://127.0.0.1:${port}/`, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
  const bigClosed = new Promise((r) => big.on('close', (code) => r(code)));
  await new Promise((r) => big.on('open', r));
  big.send('x'.repeat(10000));
  assert.equal(await bigClosed, 1009);
  // A binary message with a lying length.
  const liar = new WebSocket(`ws://127.0.0.1:${port}/`, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
  const liarClosed = new Promise((r) => liar.on('close', (code) => r(code)));
  await new Promise((r) => liar.on('open', r));
  const b = Buffer.alloc(13);
  b.writeUInt8(2, 0);
  b.writeUInt32LE(100, 9);
  liar.send(b);
  assert.equal(await liarClosed, 1003);
  assert.match(hub.log, /FOXGLOVE-REFUSED client \d+: malformed message/);
  // The good client goes on: a request still gets its answer.
  good.client.getParameters([], 'still');
  await waitFor('an answer', () => good.seen.params.find((p) => p.id === 'still'));
  assert.equal(good.seen.closed, null);
  assert.ok(hub.alive());
  good.client.close();
});

test('beside websocket-ui: both listen, the bridge serves no files', { timeout: 60000 }, async () => {
  const page = await fetch(`http://127.0.0.1:${uiPort}/`);
  assert.equal(page.status, 200);
  assert.match(await page.text(), /<html/i);
  const none = await fetch(`http://127.0.0.1:${port}/`);
  assert.equal(none.status, 404);
  await none.text();
  // Another subprotocol is refused at the handshake.
  const other = new WebSocket(`ws://127.0.0.1:${port}/`, ['skrobot-avatar.v1']);
  const refused = await new Promise((r) => {
    other.on('unexpected-response', (_q, res) => r(res.statusCode));
    other.on('error', () => r('error'));
    other.on('open', () => r('open'));
  });
  assert.notEqual(refused, 'open');
  const { client, seen } = await connect();
  assert.ok(seen.info);
  client.close();
});
