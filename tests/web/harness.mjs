// SPDX-License-Identifier: Apache-2.0
// Test harness for the web tests: a real hub (the skrobot binary) with a generated config, flowctl
// against it, and Debian's chromium through playwright-core. Paths come from CTest's environment.
import { spawn, execFile } from 'node:child_process';
import { createRequire } from 'node:module';
import { mkdtempSync, rmSync, writeFileSync, mkdirSync } from 'node:fs';
import net from 'node:net';
import os from 'node:os';
import path from 'node:path';
import { promisify } from 'node:util';

const run = promisify(execFile);

export const env = {
  skrobot: process.env.SKROBOT_BIN,
  flowctl: process.env.FLOWCTL_BIN,
  moduleDir: process.env.SKROBOT_MODULE_DIR,
  out: process.env.SKROBOT_TEST_OUT || os.tmpdir(),
  source: process.env.SKROBOT_SOURCE_DIR,
};

// npm packages are installed in web/ (web/package.json): resolve them from there.
export const webRequire = createRequire(new URL('../../web/package.json', import.meta.url));

export async function freePort() {
  return new Promise((resolve, reject) => {
    const s = net.createServer();
    s.listen(0, '127.0.0.1', () => {
      const { port } = s.address();
      s.close(() => resolve(port));
    });
    s.on('error', reject);
  });
}

export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// JSON Schema validation by Ajv (npm, web/package.json), one compiled validator per schema
// object: the errors found ("<path> <message>"), [] when none.
const validators = new WeakMap();
export function validate(schema, value) {
  let check = validators.get(schema);
  if (!check) {
    const Ajv = webRequire('ajv');
    check = new Ajv({ strict: false, allErrors: true }).compile(schema);
    validators.set(schema, check);
  }
  return check(value) ? [] : check.errors.map((e) => `$${e.instancePath} ${e.message}`);
}

// Polls fn() until it returns a truthy value; throws with `what` after timeoutMs.
export async function waitFor(what, fn, timeoutMs = 30000, everyMs = 100) {
  const until = Date.now() + timeoutMs;
  let last;
  for (;;) {
    try {
      last = await fn();
      if (last) return last;
    } catch (e) {
      last = e;
    }
    if (Date.now() > until) throw new Error(`timed out waiting for ${what} (last: ${last})`);
    await sleep(everyMs);
  }
}

// Starts the hub with `modules` (entries of the config's "modules" list, names resolved in the
// build's module directory) and `users` ([{name, password, role, rules: {action: [patterns]}}],
// added to its users file first).
// Resolves once it logged HUB-READY.
export async function startHub(modules, { users = [], server = {}, satellites = [] } = {}) {
  const dir = mkdtempSync(path.join(os.tmpdir(), 'skrobot-web-'));
  const socket = path.join(dir, 'hub.sock');
  const usersFile = path.join(dir, 'data', 'users.json');
  for (const u of users) {
    mkdirSync(path.dirname(usersFile), { recursive: true });
    await new Promise((resolve, reject) => {
      const p = execFile(env.skrobot, ['user', 'add', u.name, '--users', usersFile, '--password-stdin'],
        (e) => (e ? reject(e) : resolve()));
      p.stdin.end(`${u.password || 'password'}\n`);
    });
    if (u.role) await run(env.skrobot, ['user', 'role', u.name, u.role, '--users', usersFile]);
    for (const [action, patterns] of Object.entries(u.rules || {})) {
      await run(env.skrobot, ['user', 'rule', u.name, action, ...patterns, '--users', usersFile]);
    }
    for (const [what, n] of Object.entries(u.limits || {})) {
      await run(env.skrobot, ['user', 'limit', u.name, what, String(n), '--users', usersFile]);
    }
  }
  const config = {
    app_name: 'WebTest', server: { unix_path: socket, ...server }, data_dir: path.join(dir, 'data'),
    accounts: { dev_account: { user: 'guest', password: 'password' } },
    module_paths: [env.moduleDir], modules, satellites,
  };
  writeFileSync(path.join(dir, 'config.json'), JSON.stringify(config, null, 2));
  const proc = spawn(env.skrobot, ['--config', path.join(dir, 'config.json')], { stdio: ['ignore', 'pipe', 'pipe'] });
  let log = '';
  proc.stdout.on('data', (d) => { log += d; });
  proc.stderr.on('data', (d) => { log += d; });
  const exited = new Promise((resolve) => proc.on('exit', (code, signal) => resolve({ code, signal })));
  await waitFor('HUB-READY', () => {
    if (proc.exitCode !== null) throw new Error(`hub exited ${proc.exitCode}:\n${log}`);
    return log.includes('HUB-READY');
  }, 30000, 50);
  const hub = {
    proc, dir, socket, address: `local:${socket}`,
    get log() { return log; },
    alive: () => proc.exitCode === null && proc.signalCode === null,
    async flowctl(...args) {
      const { stdout } = await run(env.flowctl, ['--address', hub.address, ...args], { timeout: 20000 });
      return stdout.trim();
    },
    async dbGet(db, key) {
      try {
        return JSON.parse(await hub.flowctl('--json', 'db', 'get', '--db', db, key));
      } catch {
        return undefined;
      }
    },
    async stop() {
      if (hub.alive()) proc.kill('SIGINT');
      // A timer of its own, cleared: a pending one would keep node running 10 s after the test.
      let timer;
      const r = await Promise.race([exited, new Promise((resolve) => { timer = setTimeout(resolve, 10000, null); })]);
      clearTimeout(timer);
      if (!r) proc.kill('SIGKILL');
      rmSync(dir, { recursive: true, force: true });
      return r;
    },
  };
  return hub;
}

// Debian's chromium, headless, with a fake camera (a .y4m file) and microphone (a .wav file,
// played in a loop; else a beep).
export async function launchChromium({ y4m, wav } = {}) {
  const { chromium } = webRequire('playwright-core');
  const userData = mkdtempSync(path.join(os.tmpdir(), 'skrobot-chromium-'));
  const args = [
    '--no-sandbox', '--disable-gpu', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
    '--disable-quic', '--no-first-run', '--disable-background-networking',
    '--disable-component-update', '--disable-sync', '--autoplay-policy=no-user-gesture-required',
    '--use-fake-ui-for-media-stream', '--use-fake-device-for-media-stream',
  ];
  if (y4m) args.push(`--use-file-for-fake-video-capture=${y4m}`);
  if (wav) args.push(`--use-file-for-fake-audio-capture=${wav}`);
  const browser = await chromium.launch({ executablePath: '/usr/bin/chromium', headless: true, args });
  const context = await browser.newContext({ viewport: { width: 1280, height: 720 } });
  return {
    browser, context,
    async close() {
      await browser.close();
      rmSync(userData, { recursive: true, force: true });
    },
  };
}

export function outDir(name) {
  const d = path.join(env.out, name);
  mkdirSync(d, { recursive: true });
  return d;
}
