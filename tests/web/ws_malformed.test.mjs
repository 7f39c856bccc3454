// SPDX-License-Identifier: Apache-2.0
// websocket-ui against bad clients (node `ws`): oversized frames, bad JSON, binary that is not a
// media frame, the wrong path, no subprotocol, a foreign origin. Each is refused and only that
// connection closes; the hub and a well-behaved browser go on. Also the HTTP side: MIME types,
// the content security policy, no inline scripts. Twice: on the hub's web port (websocket-ui's
// endpoint, plugin ABI 1.8, the default) and on websocket-ui's own port (libwebsockets).
import assert from 'node:assert/strict';
import { mkdtempSync, writeFileSync, readFileSync } from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { after, before, describe, test } from 'node:test';

import { freePort, startHub, waitFor, webRequire, env } from './harness.mjs';

const WebSocket = webRequire('ws');
const SUBPROTOCOL = 'skrobot-avatar.v1';
const MAX = 64 * 1024;

let hub;
let port;
let root;
let onHub;  // the suite running: the hub's web port, or websocket-ui's own

function header({ format, seq = 0, width = 0, height = 0, channels = 0, rate = 0 }) {
  const h = Buffer.alloc(32);
  h.write('SKMF', 0, 'latin1');
  h.writeUInt16LE(32, 4);
  h.writeUInt8(format, 6);
  h.writeBigUInt64LE(BigInt(seq), 8);
  h.writeBigInt64LE(BigInt(Date.now()) * 1000000n, 16);
  h.writeUInt16LE(format === 3 ? channels : width, 24);
  h.writeUInt16LE(format === 3 ? 0 : height, 26);
  h.writeUInt32LE(format === 3 ? rate : 0, 28);
  return h;
}
const jpegFrame = (seq) => Buffer.concat([header({ format: 1, seq, width: 640, height: 360 }),
  readFileSync('/usr/share/doc/opencv-doc/examples/data/HappyFish.jpg')]);

// Opens a socket; resolves { ws, messages, closed } once open, or rejects with the refusal.
function open(pathname = '/ws', { protocol = SUBPROTOCOL, origin } = {}) {
  return new Promise((resolve, reject) => {
    const ws = new WebSocket(`ws://127.0.0.1:${port}${pathname}`, protocol ? [protocol] : [],
      origin ? { origin } : {});
    const messages = [];
    const closed = new Promise((r) => ws.on('close', (code, reason) => r({ code, reason: reason.toString() })));
    ws.on('message', (data, binary) => messages.push(binary ? data : JSON.parse(data.toString())));
    ws.on('open', () => resolve({ ws, messages, closed }));
    ws.on('unexpected-response', (_req, res) => reject(new Error(`refused: HTTP ${res.statusCode}`)));
    ws.on('error', reject);
  });
}

for (const mode of ['web port', 'own port']) {
describe(`websocket-ui on the ${mode}`, () => {
before(async () => {
  onHub = mode === 'web port';
  port = await freePort();
  root = mkdtempSync(path.join(os.tmpdir(), 'skrobot-webroot-'));
  writeFileSync(path.join(root, 'index.html'), readFileSync(path.join(env.source, 'web/index.html')));
  for (const ext of ['js', 'mjs', 'css', 'json', 'glb', 'wasm']) writeFileSync(path.join(root, `a.${ext}`), 'x');
  const config = { max_message_bytes: MAX, handover_ms: 30000 };
  hub = onHub
    ? await startHub([{ name: 'websocket-ui', config }], { server: { web: { port, root } } })
    : await startHub([{ name: 'websocket-ui', config: { ...config, port, web_root: root } }]);
});
after(async () => { if (hub) await hub.stop(); });

test('serves files with the right MIME types and a strict content security policy', async () => {
  const types = { js: 'text/javascript', mjs: 'text/javascript', css: 'text/css', json: 'application/json',
    glb: 'model/gltf-binary', wasm: 'application/wasm' };
  for (const [ext, type] of Object.entries(types)) {
    const res = await fetch(`http://127.0.0.1:${port}/a.${ext}`);
    assert.equal(res.status, 200, ext);
    assert.equal(res.headers.get('content-type'), type, ext);
  }
  const res = await fetch(`http://127.0.0.1:${port}/`);
  const csp = res.headers.get('content-security-policy');
  assert.match(csp, /script-src 'self'/);
  assert.doesNotMatch(csp, /unsafe-inline/);
  const html = await res.text();
  // Every <script> has a src: nothing inline for the policy to allow.
  for (const tag of html.match(/<script[^>]*>/g)) assert.match(tag, /\ssrc=/);
  assert.equal((await fetch(`http://127.0.0.1:${port}/missing.js`)).status, 404);
});

test('bad messages close only their own connection', async () => {
  const good = await open();
  const welcome = await waitFor('welcome', () => good.messages.find((m) => m.type === 'welcome'));
  // The character's colours, the config's defaults.
  assert.deepEqual(welcome.avatar, { light: '#7fe6ff', eyes: '#38c2e8' });

  const big = await open();
  big.ws.send(Buffer.alloc(MAX + 1));
  assert.equal((await big.closed).code, 1009);

  const badJson = await open();
  badJson.ws.send('{"type": "say", "text": ');
  assert.equal((await badJson.closed).code, 1007);

  const unknown = await open();
  unknown.ws.send(JSON.stringify({ type: 'shutdown' }));
  assert.equal((await unknown.closed).code, 1007);

  const rawJpeg = await open();
  rawJpeg.ws.send(readFileSync('/usr/share/doc/opencv-doc/examples/data/HappyFish.jpg'));
  const c = await rawJpeg.closed;
  assert.equal(c.code, 1003);
  assert.match(c.reason, /not a media frame/);

  const stereo = await open();
  stereo.ws.send(Buffer.concat([header({ format: 3, channels: 2, rate: 22050 }), Buffer.alloc(400)]));
  assert.equal((await stereo.closed).code, 1003);

  // Refused during the handshake (an HTTP error or a dropped connection, never an open socket).
  await assert.rejects(open('/other'));
  await assert.rejects(open('/ws', { protocol: null }));
  await assert.rejects(open('/ws', { origin: 'http://evil.example' }));

  // The good browser is still served: its frames reach the channel, commands still come.
  const before = good.messages.length;
  for (let i = 0; i < 5; i++) good.ws.send(jpegFrame(i));
  await waitFor('camera_frames', async () => (await hub.dbGet('websocket-ui', 'camera_frames')) >= 5, 15000);
  // A second page's camera waits while the first one is sending: no interleaved cameras.
  const second = await open();
  for (let i = 0; i < 3; i++) second.ws.send(jpegFrame(i));
  for (let i = 5; i < 8; i++) good.ws.send(jpegFrame(i));
  await waitFor('camera_ignored', async () => (await hub.dbGet('websocket-ui', 'camera_ignored')) === 3, 15000);
  await waitFor('camera_frames', async () => (await hub.dbGet('websocket-ui', 'camera_frames')) === 8, 15000);
  await waitFor('more commands', () => good.messages.length > before, 10000);
  assert.equal(good.ws.readyState, WebSocket.OPEN);
  if (onHub) {
    // The web port refuses the big message (before keeping it) and the handshakes; the module
    // the other four.
    await waitFor('refused count', async () => (await hub.dbGet('websocket-ui', 'refused')) === 4, 10000);
    assert.match(hub.log, /FLOW-PROTOCOL ws:127\.0\.0\.1: a message of more than 65536 bytes \(close 1009\)/);
    assert.match(hub.log, /WSUI-REFUSED browser \d+: unknown message type 'shutdown'/);
    assert.match(hub.log, /FLOW-WS-REFUSED .*WebSocket on \/other/);
    assert.match(hub.log, /FLOW-WS-REFUSED .*WebSocket on \/ws without the subprotocol skrobot-avatar\.v1/);
    assert.match(hub.log, /FLOW-WS-REFUSED .*Origin "http:\/\/evil\.example"/);
  } else {
    const refused = await waitFor('refused count', async () => {
      const n = await hub.dbGet('websocket-ui', 'refused');
      const h = await hub.dbGet('websocket-ui', 'refused_handshakes');
      return n >= 5 && h >= 3 ? [n, h] : 0;
    }, 10000);
    assert.deepEqual(refused, [5, 3]); // messages, handshakes
    assert.match(hub.log, /WSUI-REFUSED browser \d+: message over 65536 bytes/);
    assert.match(hub.log, /WSUI-REFUSED connection: WebSocket on path '\/other'/);
  }
  assert.ok(hub.alive());
  // When the first page leaves, the second one's camera takes over at once.
  good.ws.close();
  await good.closed;
  await waitFor('browser gone', async () => (await hub.dbGet('websocket-ui', 'browsers')) === 1, 15000);
  for (let i = 0; i < 2; i++) second.ws.send(jpegFrame(10 + i));
  await waitFor('second camera', async () => (await hub.dbGet('websocket-ui', 'camera_frames')) === 10, 15000);
  assert.equal(await hub.dbGet('websocket-ui', 'camera_ignored'), 3);
  second.ws.close();
});

// On the web port the host closes an endpoint's connections with 1001 when the module stops (its
// own libwebsockets server just drops them: 1006).
test('the module going away closes its browsers, with 1001 on the web port, which counts them', async () => {
  const page = await open();
  await waitFor('welcome', () => page.messages.find((m) => m.type === 'welcome'));
  if (onHub) {
    const stats = JSON.parse(await hub.flowctl('echo', 'hub.stats', '--format', 'text', '--count', '1'));
    assert.ok(stats.web.endpoint_upgrades >= 8, JSON.stringify(stats.web));
  }
  const exit = await hub.stop();
  assert.deepEqual(exit, { code: 0, signal: null }, hub.log.slice(-3000));
  const { code } = await page.closed;
  assert.equal(code, onHub ? 1001 : 1006);
});
});
}
