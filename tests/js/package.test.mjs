// SPDX-License-Identifier: Apache-2.0
// The npm tarball (npm pack in satellite/js, as tools/bootstrap.sh package makes it): installed
// offline into an empty project (no runtime dependencies to fetch), it holds its sources and
// declarations, and a script of that project talks to a real hub through `import 'skrobot'`.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFile } from 'node:child_process';
import { existsSync, mkdtempSync, readdirSync, rmSync, writeFileSync } from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { promisify } from 'node:util';
import { fileURLToPath } from 'node:url';
import { startHub } from '../web/harness.mjs';

const run = promisify(execFile);
const lib = fileURLToPath(new URL('../../satellite/js/', import.meta.url));

test('npm pack, install offline into an empty project, run a script against a hub', async () => {
  const dir = mkdtempSync(path.join(os.tmpdir(), 'skrobot-pack-'));
  const hub = await startHub([]);
  try {
    const npmEnv = { ...process.env, npm_config_cache: path.join(dir, 'cache'), npm_config_update_notifier: 'false' };
    await run('npm', ['pack', '--pack-destination', dir, '--loglevel=error'], { cwd: lib, env: npmEnv });
    const tarball = readdirSync(dir).find((f) => f.endsWith('.tgz'));
    assert.ok(tarball, 'npm pack made a tarball');
    const project = path.join(dir, 'project');
    await run('mkdir', ['-p', project]);
    writeFileSync(path.join(project, 'package.json'), JSON.stringify({ name: 'user', private: true, type: 'module' }));
    await run('npm', ['install', '--offline', '--no-audit', '--no-fund', '--loglevel=error', path.join(dir, tarball)],
      { cwd: project, env: npmEnv });
    const installed = path.join(project, 'node_modules/skrobot');
    for (const f of ['src/node.js', 'src/index.js', 'src/catalogue.js', 'types/index.d.ts', 'package.json']) {
      assert.ok(existsSync(path.join(installed, f)), `the tarball holds ${f}`);
    }
    assert.ok(!existsSync(path.join(installed, 'node_modules')), 'no dependencies installed');
    writeFileSync(path.join(project, 'main.js'), `
      import { connect } from 'skrobot';
      const hub = await connect(process.argv[2]);
      const ch = await hub.createChannel('packed');
      const got = new Promise((r) => hub.subscribe('guest.packed', (m) => r(m.text())));
      await new Promise((r) => ch.onSubscribers(r));
      ch.publish('from the tarball');
      console.log(hub.session.user, await got);
      hub.close();
    `);
    const { stdout } = await run(process.execPath, ['main.js', hub.address], { cwd: project, timeout: 20000 });
    assert.equal(stdout.trim(), 'guest from the tarball');
  } finally {
    await hub.stop();
    rmSync(dir, { recursive: true, force: true });
  }
});
