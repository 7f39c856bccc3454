// SPDX-License-Identifier: Apache-2.0
// Teleoperation page on the JavaScript library alone. The page logs in with a page token as the
// hub's page account (server.web.page_account; README.md), creates <account>.<drive> and
// publishes walk commands on it while the joystick or a key is held, {"cmd":"stop"} once on
// release: nao-bridge runs them when its config lists that channel in `queues`. The buttons call
// <robot>.command; the robot's state channels and an optional camera are shown.
//   ?robot=nao-bridge  &drive=walk  &camera=<video channel>  &rate=10 (commands a second)
import { connectPage, parseMediaFrame } from '/skrobot/index.js';

const params = new URLSearchParams(location.search);
const robot = params.get('robot') || 'nao-bridge';
const drive = params.get('drive') || 'walk';
const camera = params.get('camera') || '';
const rateHz = Math.min(Math.max(Number(params.get('rate')) || 10, 1), 50);
const STATES = ['status', 'battery', 'posture', 'sonar'];

const $ = (id) => document.getElementById(id);
$('robot').textContent = robot;

// The stick: x forward, y left, theta counter-clockwise, each in -1..1 before the speed factor.
const stick = { x: 0, y: 0, theta: 0 };
const keys = new Set();
let channel = null;
let moving = false;

function command() {
  const k = Number($('speed').value);
  const r = (v) => Math.round(Math.max(-1, Math.min(1, v)) * k * 100) / 100;
  return { cmd: 'walk', x: r(stick.x), y: r(stick.y), theta: r(stick.theta) };
}

// Called at rateHz and on every change: walk while the stick is off centre, stop once after.
function send() {
  if (!channel) return;
  const c = command();
  const still = c.x === 0 && c.y === 0 && c.theta === 0;
  if (still && !moving) return;
  const msg = still ? { cmd: 'stop' } : c;
  channel.publish(msg);  // an object goes as JSON
  moving = !still;
  $('command').textContent = still ? 'stopped' : `x ${c.x} y ${c.y} theta ${c.theta}`;
}

const KEYS = {
  ArrowUp: ['x', 1], w: ['x', 1], ArrowDown: ['x', -1], s: ['x', -1],
  ArrowLeft: ['theta', 1], a: ['theta', 1], ArrowRight: ['theta', -1], d: ['theta', -1],
  q: ['y', 1], e: ['y', -1],
};
function fromKeys() {
  stick.x = stick.y = stick.theta = 0;
  for (const k of keys) stick[KEYS[k][0]] += KEYS[k][1];
  send();
}
addEventListener('keydown', (ev) => {
  const k = ev.key.length === 1 ? ev.key.toLowerCase() : ev.key;
  if (!KEYS[k] || ev.target instanceof HTMLInputElement) return;
  ev.preventDefault();
  if (!keys.has(k)) keys.add(k), fromKeys();
});
addEventListener('keyup', (ev) => {
  const k = ev.key.length === 1 ? ev.key.toLowerCase() : ev.key;
  if (keys.delete(k)) fromKeys();
});
// Never leave the robot walking behind a hidden page or a lost focus.
function release() {
  keys.clear();
  stick.x = stick.y = stick.theta = 0;
  placeKnob(0, 0);
  send();
}
addEventListener('blur', release);
document.addEventListener('visibilitychange', () => { if (document.hidden) release(); });

const pad = $('pad');
function placeKnob(dx, dy) {
  $('knob').style.transform = `translate(${dx * 80}px, ${dy * 80}px)`;
}
function fromPointer(ev) {
  const r = pad.getBoundingClientRect();
  let dx = (ev.clientX - r.left - r.width / 2) / (r.width / 2);
  let dy = (ev.clientY - r.top - r.height / 2) / (r.height / 2);
  const n = Math.hypot(dx, dy);
  if (n > 1) dx /= n, dy /= n;
  placeKnob(dx, dy);
  stick.x = Math.abs(dy) < 0.1 ? 0 : -dy;  // up is forward
  stick.theta = Math.abs(dx) < 0.1 ? 0 : -dx;  // right turns clockwise
  stick.y = 0;
  send();
}
pad.addEventListener('pointerdown', (ev) => { pad.setPointerCapture(ev.pointerId); fromPointer(ev); });
pad.addEventListener('pointermove', (ev) => { if (pad.hasPointerCapture(ev.pointerId)) fromPointer(ev); });
pad.addEventListener('pointerup', release);
pad.addEventListener('pointercancel', release);
setInterval(() => { if (moving) send(); }, 1000 / rateHz);

function showState(name, text) {
  let dd = document.querySelector(`dd[data-channel="${CSS.escape(name)}"]`);
  if (!dd) {
    const dt = document.createElement('dt');
    dt.textContent = name;
    dd = document.createElement('dd');
    dd.dataset.channel = name;
    $('state').append(dt, dd);
  }
  dd.textContent = text;
}

// Camera frames: JPEG decoded by the browser, raw pixels copied into an ImageData.
let drawing = false;
async function draw(payload) {
  const f = parseMediaFrame(payload);
  if (!f || drawing || !f.width) return;
  const canvas = $('camera');
  canvas.hidden = false;
  const ctx = canvas.getContext('2d');
  if (canvas.width !== f.width || canvas.height !== f.height) {
    canvas.width = f.width;
    canvas.height = f.height;
  }
  if (f.encoding === 'jpeg') {
    drawing = true;  // one decode at a time: frames that arrive meanwhile are skipped
    try {
      // The Blob copies the view's bytes: the only copy of the frame.
      const bitmap = await createImageBitmap(new Blob([f.payload], { type: 'image/jpeg' }));
      ctx.drawImage(bitmap, 0, 0);
      bitmap.close();
    } catch { /* a corrupt frame is skipped */ } finally { drawing = false; }
    return;
  }
  const layout = { rgb8: [3, 0, 1, 2], bgr8: [3, 2, 1, 0], rgba8: [4, 0, 1, 2], bgra8: [4, 2, 1, 0], mono8: [1, 0, 0, 0] }[f.encoding];
  if (!layout) return;
  const [step, r, g, b] = layout;
  const img = ctx.createImageData(f.width, f.height);
  for (let i = 0, o = 0; o < img.data.length; i += step, o += 4) {
    img.data[o] = f.payload[i + r];
    img.data[o + 1] = f.payload[i + g];
    img.data[o + 2] = f.payload[i + b];
    img.data[o + 3] = 255;
  }
  ctx.putImageData(img, 0, 0);
}

const hub = await connectPage({ clientName: 'teleop page' });
hub.on('online', (s) => { $('status').textContent = `online as ${s.user}`; });
hub.on('offline', () => { $('status').textContent = 'offline, reconnecting…'; moving = false; });
hub.on('error', (e) => { $('status').textContent = `error: ${e.message}`; });
$('status').textContent = `online as ${hub.session.user}`;
channel = await hub.createChannel(drive, { mime: 'application/json', props: { content: 'walk commands (docs/nao.md)' } });
document.body.dataset.drive = channel.name;
for (const s of STATES) hub.subscribe(`${robot}.${s}`, (m) => showState(m.channel, m.text()), { maxHz: 5 });
if (camera) hub.subscribe(camera, (m) => draw(m.payload), { maxHz: 30 });

for (const button of document.querySelectorAll('button[data-cmd]')) {
  button.addEventListener('click', async () => {
    const cmd = button.dataset.cmd;
    $('answer').textContent = `${cmd}…`;
    try {
      const answer = await hub.call(`${robot}.command`, cmd, JSON.parse(button.dataset.args), { timeoutMs: 30000 });
      $('answer').textContent = `${cmd}: ${typeof answer === 'string' ? answer : JSON.stringify(answer, (k, v) => (typeof v === 'bigint' ? Number(v) : v))}`;
    } catch (e) {
      $('answer').textContent = `${cmd}: ${e.code ?? 'error'}: ${e.message}`;
    }
  });
}
document.body.dataset.ready = 'true';
