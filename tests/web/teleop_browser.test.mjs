// SPDX-License-Identifier: Apache-2.0
// The teleoperation page (examples/teleop) in Debian's chromium, served by the hub's web port
// with the JavaScript library at /skrobot/: it logs in with a page token as the `teleop` account,
// drives the simulated Nao through nao-bridge's queue (keys and the joystick: walk commands, then
// one stop), calls its command service from a button, and shows its state and video-source's
// camera. A Node.js satellite (the library over local:) watches what the page publishes.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import path from 'node:path';
import { env, freePort, launchChromium, outDir, startHub, waitFor, sleep } from './harness.mjs';
import * as skr from '../../satellite/js/src/node.js';

const VIDEO = '/usr/share/doc/opencv-doc/examples/data/vtest.avi';  // opencv-doc

test('the teleop page drives the simulated Nao, calls its service and shows its state and camera', async (t) => {
  const port = await freePort();
  const hub = await startHub([
    { name: 'nao-bridge', config: { backend: 'simulated', queues: ['teleop.walk'] } },
    { name: 'video-source', config: { file: VIDEO, fps: 10 } },
  ], {
    users: [{ name: 'teleop' }],
    server: { web: { port, flows: true, page_account: 'teleop',
                     mounts: { '/teleop': path.join(env.source, 'examples/teleop') } } },
  });
  t.after(() => hub.stop());
  const watcher = await skr.connect(hub.address, { clientName: 'teleop watcher' });
  t.after(() => watcher.close());
  const walk = [];
  const results = [];
  let posture = null;
  watcher.subscribe('teleop.walk', (m) => walk.push(m.json()));
  watcher.subscribe('nao-bridge.results', (m) => results.push(m.json()));
  watcher.subscribe('nao-bridge.posture', (m) => { posture = m.json(); });

  const browser = await launchChromium();
  t.after(() => browser.close());
  const page = await browser.context.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  await page.goto(`http://127.0.0.1:${port}/teleop/?camera=video-source.video`);
  await waitFor('the page online', async () => (await page.getAttribute('body', 'data-ready')) === 'true', 30000);
  assert.equal(await page.textContent('#status'), 'online as teleop');
  assert.equal(await page.getAttribute('body', 'data-drive'), 'teleop.walk');

  // State and camera.
  await waitFor('the robot status on the page', async () =>
    /"connected":true/.test(await page.textContent('dd[data-channel="nao-bridge.status"]').catch(() => '')), 20000);
  await waitFor('camera frames drawn', async () => page.evaluate(() => {
    const c = document.getElementById('camera');
    if (c.hidden || c.width < 100) return false;
    const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    let lit = 0;
    for (let i = 0; i < d.length; i += 4 * 97) if (d[i] + d[i + 1] + d[i + 2] > 60) lit++;
    return lit > 100;
  }), 20000);

  // The service buttons: a resting robot wakes, then stands.
  for (const [cmd, selector] of [['wake', 'button[data-cmd="wake"]'], ['posture', 'button[data-args*="Stand"]']]) {
    await page.click(selector);
    await waitFor(`the ${cmd} answer`, async () => {
      const text = await page.textContent('#answer');
      if (/error/.test(text)) throw new Error(text);
      return text.startsWith(`${cmd}: `) && /"ok":true/.test(text);
    }, 30000);
  }

  await waitFor('the robot standing', () => posture?.posture === 'Stand' && posture.moving === false, 20000, 50);

  // Keys: ArrowUp held walks forward at the slider's speed (0.5); let go: one stop.
  await page.keyboard.down('ArrowUp');
  await waitFor('walk commands at about 10 Hz', () => walk.length >= 8, 10000, 20);
  await page.keyboard.up('ArrowUp');
  await waitFor('the stop', () => walk.at(-1)?.cmd === 'stop', 5000, 20);
  const walks = walk.slice(0, -1);
  assert.ok(walks.every((c) => c.cmd === 'walk' && c.x === 0.5 && c.y === 0 && c.theta === 0), JSON.stringify(walks));
  assert.equal(walk.filter((c) => c.cmd === 'stop').length, 1, JSON.stringify(walk));
  await waitFor('the queue ran them', () => results.filter((r) => r.queue === 'teleop.walk').length === walk.length, 10000, 20);
  assert.ok(results.every((r) => r.ok === true), JSON.stringify(results));
  await waitFor('the robot moved forward', () => posture?.odometry?.x > 0.01, 10000, 50);
  await sleep(300);
  assert.equal(walk.at(-1).cmd, 'stop', 'nothing sent after the stop');

  // The joystick: dragged up and to the left, forward and turning left; released, one stop.
  const before = walk.length;
  const box = await page.locator('#pad').boundingBox();
  const cx = box.x + box.width / 2;
  const cy = box.y + box.height / 2;
  await page.mouse.move(cx, cy);
  await page.mouse.down();
  await page.mouse.move(cx - box.width * 0.3, cy - box.height * 0.4, { steps: 4 });
  await waitFor('joystick commands', () => walk.length >= before + 3, 10000, 20);
  await page.mouse.up();
  await waitFor('the joystick stop', () => walk.at(-1)?.cmd === 'stop', 5000, 20);
  const last = walk.slice(before, -1).at(-1);
  assert.ok(last.x > 0.3 && last.theta > 0.2 && last.y === 0, JSON.stringify(last));
  const shots = outDir('teleop_browser');
  await page.screenshot({ path: path.join(shots, 'teleop.png') });
  assert.deepEqual(errors, []);
});
