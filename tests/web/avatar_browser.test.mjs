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
    // Colours of its own, close to the defaults (the screenshots are docs/images').
    { name: 'websocket-ui', config: { avatar_light: '#80e8ff', avatar_eyes: '#36bfe6',
      faces: 'face-detect.faces', speech: 'speech.say',
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
  // The config's colours: the lips' light and the irises' texture.
  await waitFor('the colours', async () => (await state()).colours?.light === '#80e8ff');
  const [lips, iris] = await page.evaluate(() => {
    const m = window.skrobot.avatar.materials;
    // The iris at 62% of its ring (web/js/avatar-look.js), between two fibres.
    const c = m.eye.map.image.getContext('2d').getImageData(1, 33, 1, 1).data;
    return [m.lips.color.getHexString(), [...c].slice(0, 3)];
  });
  assert.equal(lips, '80e8ff');
  assert.ok([0x36, 0xbf, 0xe6].every((v, i) => Math.abs(iris[i] - v) <= 8), `iris ${iris}`);
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

// The lips' opening and width for the pose held now, read back from the scene: the mesh's
// positions with its morph targets applied as the GPU applies them.
function mouthShape() {
  const a = window.skrobot.avatar;
  const lips = a.parts.mouth.find((m) => m.name === 'mouth-lips');
  const infl = lips.morphTargetInfluences;
  const pos = lips.geometry.attributes.position;
  const targets = lips.geometry.morphAttributes.position;
  const at = (i) => {
    const p = [pos.getX(i), pos.getY(i), pos.getZ(i)];
    targets.forEach((t, k) => {
      if (!infl[k]) return;
      p[0] += infl[k] * (t.getX(i) - pos.getX(i));
      p[1] += infl[k] * (t.getY(i) - pos.getY(i));
      p[2] += infl[k] * (t.getZ(i) - pos.getZ(i));
    });
    return p;
  };
  const n = pos.count / 4;  // rows: upper inner, upper outer, lower inner, lower outer
  const mid = (n - 1) / 2;
  const dict = lips.morphTargetDictionary;
  const weights = Object.fromEntries(Object.entries(dict).map(([name, k]) => [name, infl[k]]));
  return { gap: at(mid)[1] - at(2 * n + mid)[1], width: at(2 * n - 1)[0] - at(n)[0], weights };
}

test('each viseme reaches its mouth shape, read back from the scene', async () => {
  const visemes = await page.evaluate(() => Object.keys(window.skrobot.avatar.parts.mouth[0].morphTargetDictionary)
    .filter((n) => !n.startsWith('x-')));
  assert.equal(visemes.length, 15, visemes.join(' '));
  const shapes = {};
  // Screenshots at the page's full resolution with reflections, whatever they cost here.
  await page.evaluate(() => window.skrobot.avatar.setQuality('high'));
  for (const v of visemes) {
    await page.evaluate((v) => window.skrobot.avatar.pose({ viseme: v, gaze: [0, 0], blink: false }), v);
    await waitFor(`the viseme ${v}`, async () => (await state()).visemes[v] > 0.98, 5000, 20);
    shapes[v] = await page.evaluate(mouthShape);
    const others = Object.entries(shapes[v].weights).filter(([n]) => n !== v && !n.startsWith('x-'));
    if (v !== 'sil') assert.ok(shapes[v].weights[v] > 0.98, `${v}: ${JSON.stringify(shapes[v].weights)}`);
    assert.ok(others.every(([, w]) => w < 0.02), `${v}: ${JSON.stringify(shapes[v].weights)}`);
    if (['sil', 'aa', 'O', 'FF'].includes(v)) {
      await page.locator('#stage').screenshot({ path: path.join(out, `avatar-${v === 'sil' ? 'neutral' : `viseme-${v}`}.jpg`), quality: 88 });
    }
  }
  await page.evaluate(() => { window.skrobot.avatar.pose(null); window.skrobot.avatar.setQuality('auto'); });
  const g = (v) => shapes[v].gap;
  const w = (v) => shapes[v].width;
  console.log(Object.entries(shapes).map(([v, s]) => `${v} gap ${s.gap.toFixed(3)} width ${s.width.toFixed(3)}`).join('; '));
  // The jaw: open vowels most, closed lips least.
  assert.ok(g('aa') > g('O') && g('O') > g('E') && g('E') > g('kk') && g('kk') > g('FF') && g('FF') > g('PP'),
    JSON.stringify(shapes));
  assert.ok(g('PP') < 0.01 && g('sil') < 0.02);
  // Spread lips wide, rounded ones narrow.
  assert.ok(w('I') > w('sil') && w('sil') > w('O') && w('O') > w('U'), JSON.stringify(shapes));
});

test('each expression from the hub reaches its face: brows, lids, mouth, head, ears', async () => {
  const face = () => page.evaluate(() => {
    const a = window.skrobot.avatar;
    const brow = (name) => {
      const b = a.parts.brows.find((m) => m.name === name);
      return Object.fromEntries(Object.entries(b.morphTargetDictionary).map(([n, k]) => [n, b.morphTargetInfluences[k]]));
    };
    const s = a.state;
    return { weights: s.expressionWeights, lids: s.lids, head: s.head, right: brow('brow-right'), left: brow('brow-left'),
      ear: a.parts.ears[0].ring.material.color.g, mouth: window.skrobot.avatar.parts.mouth[0].morphTargetInfluences.slice() };
  });
  const seen = {};
  await page.evaluate(() => window.skrobot.avatar.pose({ gaze: [0, 0], blink: false }));  // for the screenshots
  for (const name of ['neutral', 'happy', 'surprised', 'thinking', 'listening', 'sad']) {
    await hub.flowctl('call', 'websocket-ui.say', 'expression', JSON.stringify({ name, duration_ms: 6000 }));
    await waitFor(`the expression ${name}`, async () => (await state()).expressionWeights[name] > 0.98, 5000, 20);
    await new Promise((r) => setTimeout(r, 1200));  // the head follows more slowly
    seen[name] = await face();
    if (name === 'happy' || name === 'surprised') {
      await page.evaluate(() => window.skrobot.avatar.setQuality('high'));
      await page.locator('#stage').screenshot({ path: path.join(out, `avatar-${name === 'happy' ? 'smile' : name}.jpg`), quality: 88 });
    }
  }
  await page.evaluate(() => { window.skrobot.avatar.setQuality('auto'); window.skrobot.avatar.pose(null); });
  const { neutral, happy, surprised, thinking, listening, sad } = seen;
  console.log(JSON.stringify({ lids: Object.fromEntries(Object.entries(seen).map(([n, f]) => [n, f.lids])) }));
  assert.ok(happy.lids.lower > neutral.lids.lower + 8, 'a smile raises the lower lids');
  assert.ok(happy.left.raise > 0.3 && surprised.left.raise > 0.95 && surprised.right.raise > 0.95);
  assert.ok(surprised.lids.upper > neutral.lids.upper + 8, 'surprise opens the eyes wide');
  assert.ok(thinking.left.raise > thinking.right.raise + 0.5, 'thinking: one brow up');
  assert.ok(thinking.lids.upper < neutral.lids.upper - 8 && thinking.head.roll < -0.05,
    JSON.stringify({ thinking: [thinking.lids, thinking.head, thinking.weights], neutral: neutral.lids }));
  assert.ok(listening.head.roll > 0.08 && listening.ear > neutral.ear * 1.5,
    `listening: head tilted, ears lit: ${JSON.stringify({ listening: [listening.head, listening.ear], neutral: neutral.ear })}`);
  assert.ok(sad.left.worry > 0.95 && sad.right.worry > 0.95 && sad.head.pitch > neutral.head.pitch + 0.05);
  // Each has its own mouth shape (x-<name>), none at neutral.
  const mouthWeight = (f, n) => page.evaluate(([n, infl]) =>
    infl[window.skrobot.avatar.parts.mouth[0].morphTargetDictionary[`x-${n}`]], [n, f.mouth]);
  for (const n of ['happy', 'surprised', 'thinking', 'listening', 'sad']) {
    assert.ok(await mouthWeight(seen[n], n) > 0.98, n);
    assert.ok(await mouthWeight(neutral, n) < 0.02, `neutral has no ${n}`);
  }
  await hub.flowctl('call', 'websocket-ui.say', 'expression', JSON.stringify({ name: 'neutral', duration_ms: 100 }));
});

test('idle: breathing, head sway and saccades', async () => {
  const samples = [];
  for (let i = 0; i < 16; i++) {
    samples.push(await page.evaluate(() => {
      const a = window.skrobot.avatar;
      return { breath: a.state.breath, saccades: a.state.saccades, yaw: a.parts.neck.rotation.y, body: a.parts.body.position.y };
    }));
    await new Promise((r) => setTimeout(r, 250));
  }
  const range = (k) => Math.max(...samples.map((s) => s[k])) - Math.min(...samples.map((s) => s[k]));
  assert.ok(range('breath') > 0.8, `breath ${range('breath')}`);
  assert.ok(range('body') > 0.01, 'the chest rises and falls');
  assert.ok(range('yaw') > 0.005, 'the head sways');
  assert.ok(samples[15].saccades - samples[0].saccades >= 1, 'the eyes jump');
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
  // Lip sync on the audio clock: many visemes, each blending into the next.
  const seenVisemes = new Set();
  let blended = 0;
  for (let i = 0; i < 40; i++) {
    const st = await state();
    if (!st.speaking) break;
    seenVisemes.add(st.viseme);
    if (Object.values(st.visemes).filter((x) => x > 0.2).length >= 2) blended++;
    await new Promise((r) => setTimeout(r, 30));
  }
  assert.ok(seenVisemes.size >= 5, `visemes ${[...seenVisemes]}`);
  assert.ok(blended >= 2, `frames between two shapes: ${blended}`);
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

// The budget of docs/websocket-ui.md on this machine's software renderer (SwiftShader), with a
// 1280x720 page, camera and microphone off, while the avatar speaks and idles:
// SKROBOT_AVATAR_FRAMES_S seconds of frames (6 by default).
test('the frame-time budget: triangles, draw calls, median and p95 frame time', async () => {
  for (const id of ['#camera-toggle', '#mic-toggle']) {
    if ((await page.textContent(id)).startsWith('Stop')) await page.click(id);
  }
  assert.deepEqual(page.viewportSize(), { width: 1280, height: 720 });
  // The resolution settles first (docs/websocket-ui.md, "Quality").
  let last = -1;
  await waitFor('the resolution to settle', async () => {
    const { lowered, ratio } = (await state()).quality;
    const settled = lowered === last || ratio <= 0.45;
    last = lowered;
    return settled;
  }, 60000, 3000);
  const seconds = Number(process.env.SKROBOT_AVATAR_FRAMES_S || 6);
  await hub.flowctl('call', 'websocket-ui.say', 'say', JSON.stringify({
    text: 'I am measuring how fast I can draw myself while I talk to you, which takes a few seconds.' }),
  '--timeout-ms', '20000');
  const m = await page.evaluate((ms) => new Promise((resolve) => {
    const gaps = [];
    let last = null;
    const t0 = performance.now();
    const step = (now) => {
      if (last !== null) gaps.push(now - last);
      last = now;
      if (now - t0 < ms) requestAnimationFrame(step);
      else resolve({ gaps, cost: window.skrobot.avatar.cost, quality: window.skrobot.state.quality,
        canvas: [window.skrobot.avatar.renderer.domElement.width, window.skrobot.avatar.renderer.domElement.height] });
    };
    requestAnimationFrame(step);
  }), seconds * 1000);
  const sorted = [...m.gaps].sort((a, b) => a - b);
  const q = (p) => sorted[Math.min(sorted.length - 1, Math.floor(p * sorted.length))];
  const figures = { frames: sorted.length, median_ms: q(0.5), p95_ms: q(0.95), ...m.cost, canvas: m.canvas, quality: m.quality };
  console.log(`avatar frame budget: ${JSON.stringify(figures)}`);
  assert.ok(m.cost.triangles < 60000 && m.cost.calls < 40, JSON.stringify(m.cost));
  assert.ok(q(0.5) < 33, `median frame ${q(0.5).toFixed(1)} ms`);
  assert.ok(q(0.95) < 50, `p95 frame ${q(0.95).toFixed(1)} ms`);
});
