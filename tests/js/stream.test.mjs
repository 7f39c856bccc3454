// SPDX-License-Identifier: Apache-2.0
// The library over the hub's TCP port (tcp:) and over TLS (tls:, certificates made by
// tests/support/make_test_certs.sh): an account's login, a round trip, and a hub whose
// certificate is not trusted refused before any byte of the login is sent.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { mkdtempSync, rmSync } from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { startHub, waitFor, env } from '../web/harness.mjs';
import * as skr from '../../satellite/js/src/node.js';

const users = [{ name: 'alice', password: 'wonderland' }];
const account = { user: 'alice', password: 'wonderland' };

// The port the hub took (tcp_port 0: any free one), from its FLOW-LISTEN line.
function listening(hub) {
  return Number(/FLOW-LISTEN (?:TLS|TCP) 127\.0\.0\.1:(\d+)/.exec(hub.log)?.[1] ?? 0);
}

async function roundTrip(address, options) {
  const a = await skr.connect(address, options);
  try {
    const ch = await a.createChannel('loop');
    const got = new Promise((r) => a.subscribe('alice.loop', (m) => r(m.text())));
    await waitFor('subscribed', () => ch.hasSubscribers, 5000, 10);
    ch.publish('over the network');
    assert.equal(await got, 'over the network');
    assert.equal(a.session.user, 'alice');
  } finally {
    a.close();
  }
}

test('tcp: an account logs in and publishes to itself', async () => {
  const hub = await startHub([], { users, server: { tcp: true, tcp_port: 0 } });
  try {
    const port = await waitFor('the TCP port', () => listening(hub), 5000, 20);
    await roundTrip(`tcp:127.0.0.1:${port}`, account);
  } finally {
    await hub.stop();
  }
});

test('tls: the hub\'s certificate checked against the CA; an untrusted hub refused', async () => {
  const certs = mkdtempSync(path.join(os.tmpdir(), 'skrobot-js-certs-'));
  execFileSync('sh', [path.join(env.source, 'tests/support/make_test_certs.sh'), certs]);
  const hub = await startHub([], {
    users,
    server: { tcp: true, tcp_port: 0, tls: { cert: path.join(certs, 'hub.pem'), key: path.join(certs, 'hub.key') } },
  });
  try {
    const port = await waitFor('the TLS port', () => listening(hub), 5000, 20);
    await roundTrip(`tls:localhost:${port}`, { ...account, tls: { ca: path.join(certs, 'ca.pem') } });
    await assert.rejects(skr.connect(`tls:localhost:${port}`, { ...account, tls: { ca: path.join(certs, 'self-signed.pem') } }),
      (e) => /certificate/i.test(e.message));
    assert.doesNotMatch(hub.log, /FLOW-AUTH-FAILED/, 'no login was attempted');
  } finally {
    await hub.stop();
    rmSync(certs, { recursive: true, force: true });
  }
});
