// SPDX-License-Identifier: Apache-2.0
// The avatar page: connects to websocket-ui, streams camera and microphone, executes the avatar's
// commands. window.skrobot exposes the live state (used by the browser tests).
import { Avatar } from './avatar.js';
import { Camera } from './camera.js';
import { Link } from './link.js';
import { Microphone } from './microphone.js';
import { Overlay } from './overlay.js';
import { Voice } from './voice.js';

const $ = (id) => document.getElementById(id);
const scheme = location.protocol === 'https:' ? 'wss' : 'ws';
const link = new Link(`${scheme}://${location.host}/ws`);
const avatar = new Avatar($('avatar'));
const camera = new Camera($('camera-video'), link);
const mic = new Microphone(link);
const voice = new Voice();
const overlay = new Overlay($('overlay'));
const counts = { commands: 0, detections: 0, codes: 0, said: 0, closes: [], dialogue: [] };

// What the agent heard and answered (its dialogue channel), newest last, the last six shown.
function showDialogue(d) {
  const heard = d.heard ? `“${d.heard}”` : d.event === 'code_seen' ? `code: ${d.code}` : d.event || '';
  const answer = d.ignored ? `(${d.ignored})` : d.answer || '';
  counts.dialogue.push({ heard: d.heard || '', event: d.event || '', intent: d.intent ?? null, answer });
  const li = document.createElement('li');
  const q = document.createElement('span');
  q.className = 'heard';
  q.textContent = heard;
  const a = document.createElement('span');
  a.className = 'answer';
  a.textContent = answer;
  li.append(q, a);
  const list = $('dialogue');
  list.append(li);
  while (list.children.length > 6) list.firstElementChild.remove();
}

if (!avatar.hasWebGL) {
  $('avatar').hidden = true;
  $('no-webgl').hidden = false;
}

link.addEventListener('command', ({ detail: msg }) => {
  counts.commands++;
  const now = performance.now();
  switch (msg.type) {
    case 'welcome':
      camera.configure(msg.camera);
      avatar.configure(msg.avatar);
      mic.sampleRate = msg.mic_sample_rate;
      break;
    case 'gaze': case 'blink': case 'expression':
      avatar.command(msg, now);
      break;
    case 'speech':
      voice.onSpeech(msg);
      break;
    case 'faces': case 'motion':
      counts.detections++;
      overlay.set(msg.type, msg.data);
      break;
    case 'codes':
      counts.codes++;
      overlay.set('codes', msg.data);
      $('codes').textContent = (msg.data.codes || []).map((c) => `${c.type}: ${c.text}`).join('  ');
      break;
    case 'said':
      counts.said++;
      break;
    case 'dialogue':
      showDialogue(msg.data);
      break;
    default:
  }
});
link.addEventListener('binary', ({ detail }) => voice.onFrame(detail));
link.addEventListener('close', ({ detail }) => counts.closes.push(detail));

async function toggle(button, device, label) {
  voice.resume(); // a click is the gesture browsers want before sound
  try {
    if (device.running) device.stop(); else await device.start();
  } catch (e) {
    $('status').textContent = `${label}: ${e.message}`;
  }
  button.classList.toggle('on', device.running);
  button.textContent = `${device.running ? 'Stop' : 'Start'} ${label}`;
}
$('camera-toggle').addEventListener('click', () => toggle($('camera-toggle'), camera, 'camera'));
$('mic-toggle').addEventListener('click', () => toggle($('mic-toggle'), mic, 'microphone'));
$('say-form').addEventListener('submit', (e) => {
  e.preventDefault();
  voice.resume();
  const text = $('say-text').value.trim();
  if (text) link.sendJson({ type: 'say', text });
  $('say-text').value = '';
});

let last = performance.now();
let statusAt = 0;
function frame(now) {
  const dt = Math.max(0, Math.min(0.1, (now - last) / 1000));  // rAF time may precede `last`
  last = now;
  const mouth = voice.mouth();
  avatar.update(now, dt, mouth);
  const caption = mouth.speaking ? mouth.text : '';
  if ($('caption').textContent !== caption) $('caption').textContent = caption;
  overlay.draw();
  $('mic-level').value = mic.running ? Math.max(-60, mic.levelDb) : -60;
  if (now - statusAt > 500) {
    statusAt = now;
    const parts = [link.connected ? 'connected' : 'disconnected'];
    if (camera.running) parts.push(`${camera.fps().toFixed(1)} frames/s sent`);
    if (mic.running) parts.push(`mic ${mic.levelDb.toFixed(0)} dBFS`);
    parts.push(`gaze: ${avatar.state.gaze.source}`);
    $('status').textContent = parts.join(' · ');
  }
  requestAnimationFrame(frame);
}
requestAnimationFrame(frame);

window.skrobot = {
  link, avatar, camera, mic, voice, overlay, counts,
  get state() {
    return {
      connected: link.connected, framesSent: link.sentFrames, framesSkipped: link.skippedFrames,
      micFrames: mic.frames, micLevelDb: mic.levelDb, voiceFramesReceived: voice.framesReceived,
      voiceFramesPlayed: voice.framesPlayed, audioTime: voice.ctx.currentTime, audioState: voice.ctx.state,
      boxesDrawn: overlay.boxesDrawn, webgl: avatar.hasWebGL, ...counts, ...avatar.state,
    };
  },
};
