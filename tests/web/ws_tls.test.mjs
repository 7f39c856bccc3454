// SPDX-License-Identifier: Apache-2.0
// websocket-ui reachable elsewhere: a configured address, and TLS with a certificate (made here
// with openssl) serving HTTPS and WSS only. A half TLS config fails the module, not the hub.
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { mkdtempSync, readFileSync } from 'node:fs';
import https from 'node:https';
import os from 'node:os';
import path from 'node:path';
import { test } from 'node:test';

import { freePort, startHub, waitFor, webRequire } from './harness.mjs';

const WebSocket = webRequire('ws');

function certificate() {
  const dir = mkdtempSync(path.join(os.tmpdir(), 'skrobot-tls-'));
  const cert = path.join(dir, 'cert.pem');
  const key = path.join(dir, 'key.pem');
  execFileSync('openssl', ['req', '-x509', '-newkey', 'rsa:2048', '-nodes', '-days', '1',
    '-subj', '/CN=127.0.0.2', '-addext', 'subjectAltName=IP:127.0.0.2',
    '-keyout', key, '-out', cert], { stdio: 'ignore' });
  return { cert, key, ca: readFileSync(cert) };
}

function get(url, ca) {
  return new Promise((resolve, reject) => {
    https.get(url, { ca }, (res) => {
      let body = '';
      res.on('data', (d) => { body += d; });
      res.on('end', () => resolve({ status: res.statusCode, body }));
    }).on('error', reject);
  });
}

test('a configured address and TLS: HTTPS and WSS there, nothing on 127.0.0.1', async () => {
  const tls = certificate();
  const port = await freePort();
  const hub = await startHub([{ name: 'websocket-ui',
    config: { address: '127.0.0.2', port, tls_cert: tls.cert, tls_key: tls.key } }]);
  try {
    const page = await get(`https://127.0.0.2:${port}/`, tls.ca);
    assert.equal(page.status, 200);
    assert.match(page.body, /skrobot avatar/);
    // Plain HTTP is not served on the TLS port, and the loopback default is not bound.
    await assert.rejects(fetch(`http://127.0.0.2:${port}/`).then((r) => r.text()));
    await assert.rejects(fetch(`http://127.0.0.1:${port}/`));
    const ws = new WebSocket(`wss://127.0.0.2:${port}/ws`, ['skrobot-avatar.v1'], { ca: tls.ca });
    const welcome = await new Promise((resolve, reject) => {
      ws.on('message', (d) => resolve(JSON.parse(d.toString())));
      ws.on('error', reject);
    });
    assert.equal(welcome.type, 'welcome');
    ws.close();
  } finally {
    await hub.stop();
  }
});

test('a certificate without its key fails the module with the reason; the hub goes on', async () => {
  const tls = certificate();
  const hub = await startHub([{ name: 'websocket-ui', config: { port: await freePort(), tls_cert: tls.cert } }]);
  try {
    await waitFor('the failure', () => /MODULE-START.*websocket-ui.*TLS needs both tls_cert and tls_key/.test(hub.log));
    assert.ok(hub.alive());
    assert.match(hub.log, /HUB-READY 0 modules running, 1 failed/);
  } finally {
    await hub.stop();
  }
});
