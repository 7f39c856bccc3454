// SPDX-License-Identifier: Apache-2.0
// The network page (/network) in Debian's chromium against a real hub with 200 channels
// (SKROBOT_NETWORK_CHANNELS for more): the graph's nodes, edges and live rates, the
// busiest-channels table, previews of JSON, JPEG, gray, rgb8, audio and detections, a channel's
// properties, editing a variable and a module's settings as an administrator page account. Then
// the avatar demo's hub (config/default.json): its graph at "fit" on a 1280x720 and a 1920x1080
// page, the wheel's zoom, and an edit and the modules' settings refused to the read-only page
// account. The page is served by the hub's web port and is a satellite on the JavaScript library
// (page tokens, hub.stats, maxHz subscriptions, database watches, ADMIN). Screenshots go to
// <build>/test-output/network_browser/ (docs/images/network-*.jpg are two of them).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import { existsSync, readFileSync } from 'node:fs';
import path from 'node:path';
import { env, freePort, launchChromium, outDir, startHub, waitFor } from './harness.mjs';

const CHANNELS = Number(process.env.SKROBOT_NETWORK_CHANNELS || 200);
const JPEG = '/usr/share/doc/opencv-doc/examples/data/HappyFish.jpg';  // opencv-doc
test('the network page shows the hub live, previews channels and edits as its account', async (t) => {
  assert.ok(existsSync(JPEG), `${JPEG} (Debian's opencv-doc) is missing`);
  const port = await freePort();
  // Edits from the page act as the page account: an administrator may write any database.
  // Boards' lines: the UDP port on (loopback, any free port) and a serial port whose device is
  // not plugged in; the page lists both.
  const tty = `/tmp/skrobot-network-browser-${process.pid}-tty`;
  // A module whose declared settings the page changes (docs/observability.md, "Settings").
  const hub = await startHub([{ name: 'example', config: { period_ms: 1000, greeting: 'hello' } }], {
    users: [{ name: 'netadmin', role: 'admin' }],
    server: {
      web: { port, flows: true, page_account: 'netadmin' },
      udp: { address: '127.0.0.1', port: 0 }, serial: [{ device: tty, baud: 115200 }],
    },
    // A supervised satellite (docs/robot.md), and one whose program is missing.
    satellites: [{ name: 'sleeper', command: ['sleep', '1000'] },
      { name: 'ghost', command: ['no-such-program-here'] }],
  });
  t.after(() => hub.stop());
  const traffic = spawn('python3', [path.join(env.source, 'tests/web/network_traffic.py'),
    '--channels', String(CHANNELS), '--jpeg', JPEG], {
    env: { ...process.env, ROBOT_ADDRESS: hub.address, PYTHONPATH: path.join(env.source, 'satellite/python') },
    stdio: ['ignore', 'pipe', 'pipe'],
  });
  let trafficLog = '';
  traffic.stdout.on('data', (d) => { trafficLog += d; });
  traffic.stderr.on('data', (d) => { trafficLog += d; });
  t.after(() => traffic.kill('SIGKILL'));
  await waitFor('the traffic satellite', () => {
    if (traffic.exitCode !== null) throw new Error(`traffic exited ${traffic.exitCode}: ${trafficLog}`);
    return trafficLog.includes('ready');
  }, 60000);

  const browser = await launchChromium();
  t.after(() => browser.close());
  const page = await browser.context.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  const shots = outDir('network_browser');
  await page.goto(`http://127.0.0.1:${port}/network`);

  // Boards' lines: the serial port away (its device absent), the UDP port with no session open.
  await waitFor("the boards' lines table", async () =>
    !(await page.locator('#serial').isHidden()), 30000);
  const lines = await page.locator('#serial tbody tr').allTextContents();
  assert.equal(lines.length, 2, lines.join(' | '));
  assert.ok(lines[0].startsWith(`${tty}away0 B0 B00`), lines[0]);
  assert.match(lines[1], /^udp :\d+0 open/, lines[1]);
  // The satellites the hub supervises.
  await waitFor('the satellites table', async () => !(await page.locator('#satellites').isHidden()), 30000);
  const sats = await page.locator('#satellites tbody tr').allTextContents();
  assert.equal(sats.length, 2, sats.join(' | '));
  assert.match(sats[0], /^sleeperrunning\d+\d+ s0-$/, sats[0]);
  assert.match(sats[1], /^ghostfailed--0no program no-such-program-here/, sats[1]);

  // Every channel and both flows of the satellite, with publish and subscribe edges.
  const want = CHANNELS + 5;
  await waitFor(`${want} channel nodes`, async () =>
    (await page.locator('#graph .node.channel').count()) >= want, 30000);
  assert.equal(await page.locator('#graph .node.channel[data-id^="c:hub."]').count(), 0,
    "the hub's own channels are hidden by default");
  assert.ok(await page.locator('#graph .edge.publish').count() >= want);
  assert.equal(await page.locator('#graph .edge.subscribe').count(), 10, 'the listener follows ten');
  // Live rates on the edges: the JSON channels at 1 Hz, the camera at 5.
  await waitFor('rates on the edges', async () => {
    const c7 = await page.locator('[data-edge="p:guest.c007"]').textContent();
    const cam = await page.locator('[data-edge="p:guest.camera"]').textContent();
    return /^(0\.9|1|1\.1) Hz · \d/.test(c7) && /^(4\.\d|5|5\.\d) Hz · [\d.]+ kB\/s/.test(cam);
  }, 20000);
  // Still keeping up at this size: three more updates within five seconds.
  const before = Number(await page.evaluate(() => document.body.dataset.updates));
  await waitFor('three more updates', async () =>
    Number(await page.evaluate(() => document.body.dataset.updates)) >= before + 3, 5000);
  const top = await page.locator('#top tbody tr').evaluateAll((rows) => rows.map((r) => r.dataset.channel));
  assert.deepEqual(top.slice(0, 2).sort(), ['guest.audio', 'guest.camera'], `the busiest first: ${top}`);
  await page.screenshot({ path: path.join(shots, 'network-all.jpg'), quality: 85 });

  // Filtering: one channel, its publisher and subscriber; click it.
  const pick = async (name) => {
    await page.fill('#filter', name);
    await waitFor(`${name} alone`, async () =>
      (await page.locator('#graph .node.channel').count()) === 1, 5000);
    await page.locator(`#graph .node[data-id="c:${name}"]`).click();
    await waitFor(`${name}'s details`, async () =>
      (await page.locator('#details-title').textContent()) === name, 5000);
  };
  await pick('guest.c003');
  // The page previews by subscribing: it becomes the channel's third flow.
  await waitFor('the owner, the listener and this page', async () =>
    (await page.locator('#graph .node.flow').count()) === 3, 10000);
  assert.equal(await page.locator('#status').textContent(), 'connected as netadmin');
  await waitFor('a JSON preview', async () =>
    /"i": 3,/.test(await page.locator('#preview pre').textContent().catch(() => '')), 10000);
  await waitFor('the channel properties', async () =>
    (await page.locator('#db tbody tr[data-key="index"] td').nth(1).textContent().catch(() => '')) === '3', 10000);
  assert.match(await page.locator('#facts').textContent(), /guest\/.*subscribers.*guest\//s);

  // Editing a variable: a value that is not JSON stays in the page; then the change.
  await page.fill('#set-key', 'gain');
  await page.fill('#set-value', '2.5x');
  await page.click('#set-form button');
  await waitFor('the refusal', async () => /not JSON/.test(await page.locator('#db-status').textContent()), 5000);
  assert.equal(await hub.dbGet('guest.c003', 'gain'), undefined);
  await page.fill('#set-value', '2.5');
  await page.click('#set-form button');
  await waitFor('the change', async () => /gain set/.test(await page.locator('#db-status').textContent()), 5000);
  assert.equal(await hub.dbGet('guest.c003', 'gain'), 2.5);
  await waitFor('the new row', async () =>
    (await page.locator('#db tbody tr[data-key="gain"] td').nth(1).textContent().catch(() => '')) === '2.5', 5000);

  // The modules, and one's settings: its declared keys with their rules; a value out of range
  // refused by the hub; two changes given in place and saved into the config file.
  await waitFor('the modules table', async () => !(await page.locator('#modules').isHidden()), 10000);
  const example = page.locator('#modules tbody tr[data-module="example"]');
  assert.equal(await example.textContent(), 'examplestarted1.0.02');
  await example.click();
  const row = (k) => page.locator(`#settings-keys tbody tr[data-key="${k}"]`);
  await waitFor('its settings', async () => (await page.locator('#settings-keys tbody tr').count()) === 2, 10000);
  assert.equal(await page.locator('#details-title').textContent(), 'module example');
  assert.match(await row('period_ms').textContent(), /integer, 1 to 3600000, default 1000the EXAMPLE-TICK period/);
  assert.equal(await row('period_ms').locator('input').inputValue(), '1000');
  assert.equal(await row('greeting').locator('input').inputValue(), 'hello');
  await row('period_ms').locator('input').fill('0');
  await page.click('#settings-form button[type=submit]');
  await waitFor('the refusal', async () => /period_ms/.test(await page.locator('#settings-status').textContent()), 10000);
  assert.equal(await page.locator('#settings-status').getAttribute('class'), 'error');
  assert.doesNotMatch(hub.log, /HUB-MODULE-CONFIG/);
  await row('period_ms').locator('input').fill('200');
  await row('greeting').locator('input').fill('hi from the page');
  await page.click('#settings-save');
  await waitFor('applied in place and saved', async () =>
    /^example reconfigured, saved in .*config\.json$/.test(await page.locator('#settings-status').textContent()), 10000);
  const saved = JSON.parse(readFileSync(path.join(hub.dir, 'config.json'), 'utf8'));
  assert.deepEqual(saved.modules[0].config, { period_ms: 200, greeting: 'hi from the page' });
  await waitFor('the module ticking with its new greeting', () => /EXAMPLE-TICK.*hi from the page/.test(hub.log), 10000);
  await waitFor('the values read back', async () => (await row('period_ms').locator('input').inputValue()) === '200', 10000);
  await page.screenshot({ path: path.join(shots, 'network-settings.png') });

  // Frames, audio and detections.
  await pick('guest.camera');
  await waitFor('the JPEG preview', async () =>
    (await page.locator('#preview').getAttribute('data-kind')) === 'jpeg', 10000);
  const size = await page.evaluate(() => {
    const c = document.querySelector('#preview canvas.frame');
    return [c.width, c.height];
  });
  assert.ok(size[0] > 100 && size[1] > 100, `a decoded frame (${size})`);
  await pick('guest.gray');
  await waitFor('the gray preview', async () =>
    (await page.locator('#preview').getAttribute('data-kind')) === 'gray', 10000);
  assert.deepEqual(await page.evaluate(() => {
    const c = document.querySelector('#preview canvas.frame');
    return [c.width, c.height, [...c.getContext('2d').getImageData(10, 5, 1, 1).data]];
  }), [64, 48, [30, 30, 30, 255]], 'gray level (x + y) * 2 at (10, 5)');
  await pick('guest.colour');
  await waitFor('the rgb8 preview', async () =>
    (await page.locator('#preview').getAttribute('data-kind')) === 'raw', 10000);
  assert.deepEqual(await page.evaluate(() => {
    const c = document.querySelector('#preview canvas.frame');
    return [c.width, c.height, [...c.getContext('2d').getImageData(10, 5, 1, 1).data]];
  }), [16, 12, [40, 25, 100, 255]], 'rgb8 (x * 4, y * 5, 100) at (10, 5)');
  await pick('guest.audio');
  await waitFor('the audio level', async () => {
    const level = Number(await page.locator('#preview').getAttribute('data-level'));
    return level > -16 && level < -13;  // a sine of amplitude 8000: -15.2 dBFS
  }, 10000);
  await pick('guest.faces');
  await waitFor('a face drawn on its camera frame', async () =>
    (await page.locator('#preview').getAttribute('data-kind')) === 'detections' &&
    (await page.locator('#preview').getAttribute('data-boxes')) === '1', 10000);
  await page.setViewportSize({ width: 1280, height: 1040 });  // the whole panel
  await page.screenshot({ path: path.join(shots, 'network-detections.jpg'), quality: 85 });

  // A flow's database.
  await page.fill('#filter', '');
  await page.locator('#top tbody tr[data-channel="guest.camera"]').click();
  assert.equal(await page.locator('#details-title').textContent(), 'guest.camera');
  assert.deepEqual(errors, [], 'no errors in the page');
  assert.ok(hub.alive(), hub.log);
  traffic.kill('SIGKILL');
  const exit = await hub.stop();
  assert.deepEqual(exit, { code: 0, signal: null }, `the hub stops cleanly (a sanitizer report fails it):\n${hub.log.slice(-4000)}`);
});

// The graph at "fit", as the page shows it: the share of the pane covered by the drawing's box,
// the smallest label on the screen (its font size times the view's scale, CSS pixels), the scale.
function measureGraph() {
  const svg = document.querySelector('#graph');
  const pane = svg.getBoundingClientRect();
  const boxes = ['g.nodes', 'g.edges'].map((s) => svg.querySelector(s).getBoundingClientRect());
  const clip = (lo, hi, a, b) => Math.max(0, Math.min(hi, b) - Math.max(lo, a));
  const w = clip(pane.left, pane.right, Math.min(...boxes.map((b) => b.left)), Math.max(...boxes.map((b) => b.right)));
  const h = clip(pane.top, pane.bottom, Math.min(...boxes.map((b) => b.top)), Math.max(...boxes.map((b) => b.bottom)));
  const scale = svg.getScreenCTM().a;
  const labels = [...svg.querySelectorAll('text')].filter((t) => t.textContent);
  const font = (t) => parseFloat(getComputedStyle(t).fontSize) * scale;
  const smallest = labels.reduce((a, t) => (font(t) < font(a) ? t : a), labels[0]);
  return {
    pane: `${Math.round(pane.width)}x${Math.round(pane.height)}`, covered: (w * h) / (pane.width * pane.height),
    smallestPx: font(smallest), smallest: smallest.textContent, labels: labels.length, scale,
  };
}

test("the demo's graph fills the pane at fit with readable labels, the wheel zooms in steps, and the read-only page may not edit", async (t) => {
  const port = await freePort();
  const own = { 'foxglove-bridge': { port: await freePort() } };
  const demo = JSON.parse(readFileSync(path.join(env.source, 'config/default.json'), 'utf8'));
  // The demo's web port, on a free port (the page account: the built-in read-only web-page); it
  // also upgrades websocket-ui's /ws.
  const hub = await startHub(demo.modules.filter((m) => m.enabled !== false)
    .map((m) => ({ ...m, config: { ...m.config, ...own[m.name] } })), { server: { web: { ...demo.server.web, port } } });
  t.after(() => hub.stop());
  const browser = await launchChromium();
  t.after(() => browser.close());
  const page = await browser.context.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  const shots = outDir('network_browser');
  for (const [width, height] of [[1280, 720], [1920, 1080]]) {
    await page.setViewportSize({ width, height });
    await page.goto(`http://127.0.0.1:${port}/network`);
    await waitFor("the demo's 22 channels", async () =>
      (await page.locator('#graph .node.channel').count()) === 22 &&
      (await page.locator('#graph .edge-label').first().textContent()) !== '', 30000);
    const m = await page.evaluate(measureGraph);
    console.log(`${width}x${height}: ${JSON.stringify(m)}`);
    await page.screenshot({ path: path.join(shots, `network-fit-${width}.png`) });
    assert.ok(m.covered >= 0.5, `the graph covers ${(m.covered * 100).toFixed(0)}% of the pane (${m.pane}) at ${width}x${height}`);
    assert.ok(m.smallestPx >= 11, `"${m.smallest}" is ${m.smallestPx.toFixed(1)} px at ${width}x${height}`);
  }
  // The wheel, over the middle of the graph: a notch (100 pixels), a fast spin, and back.
  const pane = await page.locator('#graph').boundingBox();
  await page.mouse.move(pane.x + pane.width / 2, pane.y + pane.height / 2);
  const scale = () => page.evaluate(() => document.querySelector('#graph').getScreenCTM().a);
  for (const deltaY of [-100, -1000, 1000, 100]) {
    const before = await scale();
    await page.mouse.wheel(0, deltaY);
    const after = await waitFor('the zoom', async () => {
      const s = await scale();
      return s !== before && s;
    }, 5000, 20);
    const k = deltaY < 0 ? after / before : before / after;
    console.log(`wheel ${deltaY}: zoom ${k.toFixed(3)}`);
    // getScreenCTM() is single precision.
    assert.ok(k > 1 && k <= 1.25 * (1 + 1e-6), `one wheel event of ${deltaY} zoomed by ${k}`);
  }
  await page.click('#fit');
  assert.ok((await page.evaluate(measureGraph)).covered >= 0.5, 'fit again');
  // The built-in page account reads every database and writes none.
  await page.fill('#filter', 'fft-audio.bands');
  await page.locator('#graph .node[data-id="c:fft-audio.bands"]').click();
  await waitFor("the channel's details", async () =>
    (await page.locator('#details-title').textContent()) === 'fft-audio.bands', 5000);
  await page.fill('#set-key', 'gain');
  await page.fill('#set-value', '2');
  await page.click('#set-form button');
  await waitFor('the refusal', async () =>
    /^gain: permission_denied/.test(await page.locator('#db-status').textContent()), 5000);
  assert.equal(await hub.dbGet('fft-audio.bands', 'gain'), undefined);
  // A module's settings are an administrator's: the page says so.
  await page.locator('#modules tbody tr[data-module="fft-audio"]').click();
  await waitFor('settings refused', async () =>
    /^Only an administrator .* logs in as web-page/.test(await page.locator('#settings-note').textContent()), 10000);
  assert.ok(await page.locator('#settings-form').isHidden());
  assert.deepEqual(errors, [], 'no errors in the page');
  const exit = await hub.stop();
  assert.deepEqual(exit, { code: 0, signal: null }, `the hub stops cleanly:\n${hub.log.slice(-4000)}`);
});
