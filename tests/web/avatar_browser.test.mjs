// SPDX-License-Identifier: Apache-2.0
// The avatar demo end to end in Debian's chromium: a fake camera showing astronaut.png (left half
// of the frame) and the fake microphone stream into the hub through websocket-ui; face-detect
// finds the face; the page draws the box; the avatar's eyes turn toward it; a `say` request to
// websocket-ui makes speech audio arrive in the page while the mouth moves; the agent's answer
// to what it heard is shown in the page's dialogue and spoken, with its expression.
import assert from 'node:assert/strict';
import { execFileSync, spawn } from 'node:child_process';
import path from 'node:path';
import { after, before, test } from 'node:test';

import { env, freePort, launchChromium, outDir, startHub, waitFor } from './harness.mjs';

const ASTRONAUT = '/usr/lib/python3/dist-packages/skimage/data/astronaut.png';
// The face in astronaut.png (512x512) is near x 170-260, y 55-180; the fake camera scales the
// image to 360x360 at the frame's left edge, so in the 640x360 frame it is near:
const FACE = { x: 120, y: 39, w: 63, h: 88 };

let hub;
let chromium;
let page;
let port;
const out = outDir('web-avatar');

function overlap(a, b) {
  const w = Math.min(a.x + a.w, b.x + b.w) - Math.max(a.x, b.x);
  const h = Math.min(a.y + a.h, b.y + b.h) - Math.max(a.y, b.y);
  return w > 0 && h > 0 ? (w * h) / (b.w * b.h) : 0;
}

before(async () => {
  const y4m = path.join(out, 'astronaut.y4m');
  execFileSync('/usr/bin/python3', [path.join(env.source, 'tests/web/make_y4m.py'), ASTRONAUT, y4m,
    '--frames', '15', '--place', 'left']);
  port = await freePort();
  hub = await startHub([
    // On the hub's web port (websocket-ui's default: no `port` of its own).
    { name: 'websocket-ui', config: { faces: 'face-detect.faces', speech: 'speech.say',
      voice: 'speech.voice', phonemes: 'speech.phonemes', dialogue: 'agent.dialogue' } },
    { name: 'face-detect', config: { input: 'websocket-ui.camera' } },
    { name: 'speech', config: {} },
    // The agent answers what it is told to hear (agent.command), not the faces: the tests above
    // make the avatar speak on their own.
    { name: 'agent', config: { faces: '', codes: '', nao: '' } },
  ], { server: { web: { port, flows: true } } });
  chromium = await launchChromium({ y4m });
  page = await chromium.context.newPage();
  page.on('pageerror', (e) => console.log('page error:', e.message));
  await page.goto(`http://127.0.0.1:${port}/`);
});

after(async () => {
  if (page) await page.screenshot({ path: path.join(out, 'avatar.png') }).catch(() => {});
  if (chromium) await chromium.close();
  if (hub) {
    const r = await hub.stop();
    assert.ok(r && r.code === 0, `hub exit ${JSON.stringify(r)}`);
  }
});

const state = () => page.evaluate(() => window.skrobot.state);

test('the page connects and draws the avatar with WebGL', async () => {
  await waitFor('connected', async () => (await state()).connected);
  assert.equal((await state()).webgl, true);
});

test('camera frames and microphone audio reach their channels', async () => {
  await page.click('#camera-toggle');
  await page.click('#mic-toggle');
  // Count frames on the channel itself, as a subscriber sees them.
  const echo = spawn(env.flowctl, ['--address', hub.address, 'echo', 'websocket-ui.camera',
    '--format', 'hex', '--count', '10'], { stdio: ['ignore', 'pipe', 'inherit'] });
  let lines = 0;
  echo.stdout.on('data', (d) => { lines += d.toString().split('\n').filter(Boolean).length; });
  const code = await new Promise((resolve) => {
    const t = setTimeout(() => { echo.kill(); resolve('timeout'); }, 60000);
    echo.on('exit', (c) => { clearTimeout(t); resolve(c); });
  });
  assert.equal(code, 0, `flowctl echo saw ${lines} frames`);
  assert.ok(lines >= 10);
  await waitFor('mic frames', async () => (await hub.dbGet('websocket-ui', 'mic_frames')) >= 10, 30000);
});

test('face-detect finds the face, the page draws its box, the eyes turn toward it', async () => {
  const faces = await waitFor('a face in the overlay', () => page.evaluate(() => {
    const f = window.skrobot.overlay.faces;
    return f && f.data.faces.length > 0 ? f.data : null;
  }), 60000);
  assert.equal(faces.width, 640);
  const best = Math.max(...faces.faces.map((f) => overlap(f, FACE)));
  assert.ok(best > 0.5, `face boxes ${JSON.stringify(faces.faces)} miss ${JSON.stringify(FACE)}`);
  await waitFor('a box drawn', async () => (await state()).boxesDrawn > 0);
  // The box's green edge is on the overlay canvas.
  const green = await page.evaluate(() => {
    const { data } = window.skrobot.overlay.faces;
    const f = data.faces[0];
    const c = document.getElementById('overlay');
    const px = c.getContext('2d').getImageData(Math.round(f.x + f.w / 2), Math.round(f.y), 1, 3).data;
    return Array.from(px);
  });
  assert.ok(green.some((v, i) => i % 4 === 1 && v > 200), `overlay pixels ${green}`);
  // Gaze: the face is on the image's left, so the avatar looks to the viewer's right.
  const s = await waitFor('gaze on the face', async () => {
    const st = await state();
    return st.gaze.source === 'face' && st.eyes.yaw > 0.1 ? st : null;
  }, 30000);
  assert.ok(s.gaze.x < -0.3, `gaze ${JSON.stringify(s.gaze)}`);
  // A face after none: the avatar smiles.
  assert.ok(s.expressions.includes('happy'), `expressions ${s.expressions}`);
  assert.equal(await hub.dbGet('websocket-ui', 'gaze_source'), 'face');
});

test('the avatar blinks', async () => {
  const before = (await state()).blinks;
  await waitFor('two more blinks', async () => (await state()).blinks >= before + 2, 15000);
});

test('a say request plays speech in the page and moves the mouth', async () => {
  const answer = JSON.parse(await hub.flowctl('--json', 'call', 'websocket-ui.say', 'say',
    JSON.stringify({ text: 'Hello! I can see you. Nice to meet you.', voice: 'en' }), '--timeout-ms', '20000'));
  assert.ok(answer.duration_ms > 1000, JSON.stringify(answer));
  await waitFor('voice audio in the page', async () => (await state()).voiceFramesReceived > 0, 20000);
  const speaking = await waitFor('speaking', async () => {
    const st = await state();
    return st.speaking && st.maxMouthOpen > 0.3 ? st : null;
  }, 20000);
  assert.ok(speaking.audioState === 'running');
  assert.equal(await page.textContent('#caption'), 'Hello! I can see you. Nice to meet you.');
  await page.screenshot({ path: path.join(out, 'avatar-speaking.png') });
  // Back at rest once the utterance has played.
  await waitFor('mouth at rest', async () => {
    const st = await state();
    return !st.speaking && st.mouth.open < 0.05;
  }, answer.duration_ms + 15000);
  const st = await state();
  assert.ok(st.voiceFramesPlayed > 0);
});

test('what the agent hears and answers is shown, spoken and smiled', async () => {
  const before = (await state()).expressions.length;
  const answer = JSON.parse(await hub.flowctl('--json', 'call', 'agent.command', 'hear',
    JSON.stringify({ text: 'How are you today?' }), '--timeout-ms', '20000'));
  assert.equal(answer.intent, 'how_are_you');
  assert.equal(answer.answer, 'I am fine, thank you.');
  const shown = await waitFor('the dialogue in the page', async () => {
    const d = (await state()).dialogue;
    return d.length > 0 ? d[d.length - 1] : null;
  }, 10000);
  assert.deepEqual(shown, { heard: 'How are you today?', event: '', intent: 'how_are_you',
    answer: 'I am fine, thank you.' });
  assert.equal(await page.textContent('#dialogue li:last-child .answer'), 'I am fine, thank you.');
  await waitFor('the answer spoken', async () => (await page.textContent('#caption')) === 'I am fine, thank you.', 20000);
  const st = await state();
  assert.ok(st.expressions.length > before && st.expressions[st.expressions.length - 1] === 'happy',
    `expressions ${st.expressions}`);
  await page.screenshot({ path: path.join(out, 'avatar-dialogue.png') });
});
