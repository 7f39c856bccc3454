// SPDX-License-Identifier: Apache-2.0
// docs/javascript-satellites.md, "A page in ten minutes", run as written: its files (the code
// blocks marked file=...) go to a new directory, its shell commands run there (skrobot being the
// build's), and Debian's chromium opens the page with the astronaut picture as its camera: the
// page publishes the camera through the library and shows face-detect's faces. Only the web
// port (a free one instead of 8081) and the Unix socket's path (the test's directory) change;
// HOME is the test's directory, so the users file and the data stay there.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync, spawn } from 'node:child_process';
import { mkdirSync, mkdtempSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { env, freePort, launchChromium, outDir, waitFor } from './harness.mjs';

const ASTRONAUT = '/usr/lib/python3/dist-packages/skimage/data/astronaut.png';  // python3-skimage

// The section's code blocks: files by their file= name, and the shell commands.
function section() {
  const doc = readFileSync(path.join(env.source, 'docs/javascript-satellites.md'), 'utf8');
  const start = doc.indexOf('## A page in ten minutes');
  const text = doc.slice(start, doc.indexOf('\n## ', start + 1));
  const files = {};
  let shell = null;
  for (const m of text.matchAll(/```(\w+)([^\n]*)\n([\s\S]*?)```/g)) {
    const name = /file=(\S+)/.exec(m[2])?.[1];
    if (name) files[name] = m[3];
    else if (m[1] === 'sh') shell = m[3];
  }
  return { files, shell };
}

test('the ten-minute page: the camera goes to face-detect through the library, the faces come back', async (t) => {
  const { files, shell } = section();
  assert.deepEqual(Object.keys(files).sort(), ['mypage/hub.json', 'mypage/index.html', 'mypage/main.js']);
  const commands = shell.split('\n').map((l) => l.replace(/#.*/, '').trim()).filter(Boolean);
  assert.deepEqual(commands, ['cd mypage', 'skrobot user add lab --config hub.json', 'skrobot --config hub.json']);

  const home = mkdtempSync(path.join(os.tmpdir(), 'skrobot-jspage-'));
  t.after(() => rmSync(home, { recursive: true, force: true }));
  for (const [name, body] of Object.entries(files)) {
    mkdirSync(path.dirname(path.join(home, name)), { recursive: true });
    writeFileSync(path.join(home, name), body);
  }
  const dir = path.join(home, 'mypage');
  const port = await freePort();
  const config = JSON.parse(files['mypage/hub.json']);
  assert.equal(config.server.web.port, 8081);
  config.server.web.port = port;
  config.server.unix_path = path.join(home, 'hub.sock');
  writeFileSync(path.join(dir, 'hub.json'), JSON.stringify(config, null, 2));
  const childEnv = { ...process.env, HOME: home };
  const argv = (line) => line.split(/\s+/).slice(1);

  execFileSync(env.skrobot, argv(commands[1]), { cwd: dir, env: childEnv, input: 'any password\n' });
  const proc = spawn(env.skrobot, argv(commands[2]), { cwd: dir, env: childEnv, stdio: ['ignore', 'pipe', 'pipe'] });
  let log = '';
  proc.stdout.on('data', (d) => { log += d; });
  proc.stderr.on('data', (d) => { log += d; });
  t.after(async () => {
    proc.kill('SIGINT');
    let timer;
    await Promise.race([new Promise((r) => proc.on('exit', r)), new Promise((r) => { timer = setTimeout(r, 10000); })]);
    clearTimeout(timer);
    proc.kill('SIGKILL');
  });
  await waitFor('HUB-READY', () => {
    if (proc.exitCode !== null) throw new Error(`hub exited ${proc.exitCode}:\n${log}`);
    return log.includes('HUB-READY');
  }, 30000, 50);

  const out = outDir('javascript_page');
  const y4m = path.join(out, 'astronaut.y4m');
  execFileSync('/usr/bin/python3', [path.join(env.source, 'tests/web/make_y4m.py'), ASTRONAUT, y4m,
    '--width', '640', '--height', '360', '--frames', '10', '--place', 'center']);
  const browser = await launchChromium({ y4m });
  t.after(() => browser.close());
  const page = await browser.context.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  await page.goto(`http://127.0.0.1:${port}/mypage/`);
  const faces = await waitFor('faces on the page', async () => {
    const text = await page.textContent('#faces');
    return text.startsWith('[{') ? JSON.parse(text) : null;
  }, 60000, 200).catch((e) => { throw new Error(`${e.message}\npage: ${errors.join('\n')}\n${log.slice(-3000)}`); });
  // The astronaut's face: one box, in the middle third of the 640x360 frame.
  const f = faces[0];
  assert.ok(f.w > 40 && f.x + f.w / 2 > 213 && f.x + f.w / 2 < 427, JSON.stringify(faces));
  await page.screenshot({ path: path.join(out, 'page.png') });
  assert.match(log, /FLOW-LOGIN [^\n]*\blab\b[^\n]* logged in/, 'the page logged in as lab');
  assert.deepEqual(errors, []);
});
