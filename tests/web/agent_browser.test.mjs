// SPDX-License-Identifier: Apache-2.0
// The listening loop end to end in Debian's chromium: the fake microphone plays a phrase made with
// espeak-ng (1 s of silence, "how are you", 3 s of silence, in a loop), the page streams it to
// websocket-ui.mic, skrobot-asr transcribes it with the agent's grammar, the agent answers, and
// the page shows what was heard and the answer, whose voice it plays with the caption.
import assert from 'node:assert/strict';
import { execFileSync, spawn } from 'node:child_process';
import path from 'node:path';
import { after, before, test } from 'node:test';

import { env, freePort, launchChromium, outDir, startHub, waitFor } from './harness.mjs';

let hub;
let asr;
let asrLog = '';
let chromium;
let page;
const out = outDir('web-agent');

before(async () => {
  const spoken = path.join(out, 'spoken.wav');
  const wav = path.join(out, 'how-are-you.wav');
  execFileSync(process.env.ESPEAK_NG_BIN, ['-v', 'en-us', '-s', '150', '-w', spoken, 'how are you']);
  execFileSync(process.env.SOX_BIN, [spoken, '-r', '48000', '-c', '1', '-b', '16', wav, 'pad', '1', '3']);
  const port = await freePort();
  hub = await startHub([
    { name: 'websocket-ui', config: { speech: 'speech.say', voice: 'speech.voice',
      phonemes: 'speech.phonemes', dialogue: 'agent.dialogue' } },
    { name: 'speech', config: {} },
    { name: 'agent', config: { say: 'websocket-ui.say', expression: 'websocket-ui.say', nao: '',
      faces: '', codes: '' } },
  ], { server: { web: { port } } });
  asr = spawn(process.env.ASR_BIN, ['--address', hub.address, '--name', 'asr'],
    { stdio: ['ignore', 'pipe', 'pipe'] });
  asr.stdout.on('data', (d) => { asrLog += d; });
  asr.stderr.on('data', (d) => { asrLog += d; });
  // The agent has handed the recogniser its grammar.
  await waitFor('the recogniser in grammar mode', () => asrLog.includes('ASR-MODE now in grammar mode'), 30000);
  chromium = await launchChromium({ wav });
  page = await chromium.context.newPage();
  page.on('pageerror', (e) => console.log('page error:', e.message));
  await page.goto(`http://127.0.0.1:${port}/`);
});

after(async () => {
  if (page) await page.screenshot({ path: path.join(out, 'agent.png') }).catch(() => {});
  if (chromium) await chromium.close();
  if (asr) asr.kill('SIGTERM');
  if (hub) {
    const r = await hub.stop();
    assert.ok(r && r.code === 0, `hub exit ${JSON.stringify(r)}`);
  }
});

const state = () => page.evaluate(() => window.skrobot.state);

test('what the microphone hears is transcribed, answered, shown and spoken', async () => {
  await waitFor('connected', async () => (await state()).connected);
  await page.click('#mic-toggle');
  const heard = await waitFor('the agent answers in the page', async () => {
    const d = (await state()).dialogue.filter((e) => e.intent === 'how_are_you');
    return d.length > 0 ? d[0] : null;
  }, 60000).catch((e) => { throw new Error(`${e.message}\nasr:\n${asrLog}\nhub:\n${hub.log}`); });
  assert.equal(heard.answer, 'I am fine, thank you.');
  assert.match(heard.heard, /how are you/);
  await waitFor('the answer spoken', async () => (await page.textContent('#caption')) === 'I am fine, thank you.', 20000);
  await waitFor('its voice in the page', async () => (await state()).voiceFramesReceived > 0, 20000);
  await page.screenshot({ path: path.join(out, 'agent-answered.png') });
  // The recogniser was paused while the avatar spoke (the robot does not hear itself).
  await waitFor('paused and resumed', () => asrLog.includes('ASR-PAUSE paused') && asrLog.includes('ASR-PAUSE listening again'), 20000);
});
