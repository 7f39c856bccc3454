// SPDX-License-Identifier: Apache-2.0
// The avatar on screen: executes what the hub decides (gaze, blinks, expressions) and what the
// voice plays (mouth shapes). State is kept even when WebGL is missing, so the page still works.
import * as THREE from '../vendor/three.module.js';
import { makeHead } from './head-geometry.js';

const MAX_YAW = 0.55; // radians the eyes turn at the image edge
const MAX_PITCH = 0.35;

export class Avatar {
  constructor(canvas) {
    this.state = {
      gaze: { x: 0, y: 0, source: 'idle' }, eyes: { yaw: 0, pitch: 0 }, eyelid: 0, blinks: 0,
      mouth: { open: 0, wide: 0, round: 0 }, maxMouthOpen: 0, speaking: false, expression: 'neutral',
      expressions: [],
    };
    this.blink = null; // { start, close, hold, open } in ms
    this.expression = { name: 'neutral', weight: 0, until: 0 };
    this.renderer = null;
    try {
      this.renderer = new THREE.WebGLRenderer({ canvas, antialias: true });
    } catch (e) {
      console.warn('no WebGL:', e.message);
      return;
    }
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0x20252c);
    this.camera = new THREE.PerspectiveCamera(30, 1, 0.1, 20);
    this.camera.position.set(0, 0, 5.2);
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x303040, 1.4));
    const key = new THREE.DirectionalLight(0xffffff, 1.6);
    key.position.set(2, 3, 4);
    this.scene.add(key);
    this.parts = makeHead();
    this.scene.add(this.parts.head);
  }

  get hasWebGL() { return this.renderer !== null; }

  command(msg, now) {
    switch (msg.type) {
      case 'gaze':
        this.state.gaze = { x: msg.x, y: msg.y, source: msg.source };
        break;
      case 'blink':
        this.blink = { start: now, close: msg.close_ms, hold: msg.hold_ms, open: msg.open_ms };
        this.state.blinks++;
        break;
      case 'expression':
        this.expression = { name: msg.name, weight: msg.weight ?? 1, until: now + (msg.duration_ms ?? 2000) };
        this.state.expressions.push(msg.name);
        break;
      default:
    }
  }

  eyelidAt(now) {
    const b = this.blink;
    if (!b) return 0;
    const t = now - b.start;
    if (t < b.close) return t / b.close;
    if (t < b.close + b.hold) return 1;
    if (t < b.close + b.hold + b.open) return 1 - (t - b.close - b.hold) / b.open;
    this.blink = null;
    return 0;
  }

  // One animation frame: `mouth` from the voice, `dt` in seconds.
  update(now, dt, mouth) {
    const s = this.state;
    // The camera image is the robot's view: a person on the image's left stands on the avatar's
    // right, which is the viewer's right, so the eyes turn toward -x.
    const yaw = -s.gaze.x * MAX_YAW;
    const pitch = s.gaze.y * MAX_PITCH;
    const k = 1 - Math.exp(-dt * 18); // fast, saccade-like
    s.eyes.yaw += (yaw - s.eyes.yaw) * k;
    s.eyes.pitch += (pitch - s.eyes.pitch) * k;
    s.eyelid = this.eyelidAt(now);
    const m = 1 - Math.exp(-dt * 25);
    s.mouth.open += (mouth.open - s.mouth.open) * m;
    s.mouth.wide += (mouth.wide - s.mouth.wide) * m;
    s.mouth.round += (mouth.round - s.mouth.round) * m;
    s.speaking = mouth.speaking;
    if (s.speaking) s.maxMouthOpen = Math.max(s.maxMouthOpen, s.mouth.open);
    if (now > this.expression.until) this.expression = { name: 'neutral', weight: 0, until: Infinity };
    s.expression = this.expression.name;
    if (this.hasWebGL) this.render(now);
  }

  render(now) {
    const { parts, state: s } = this;
    for (const e of parts.eyes) {
      e.group.rotation.set(s.eyes.pitch, s.eyes.yaw, 0);
      e.lid.morphTargetInfluences[0] = s.eyelid;
    }
    parts.head.rotation.y = s.eyes.yaw * 0.3 + Math.sin(now / 2300) * 0.03;
    parts.head.rotation.x = s.eyes.pitch * 0.25 + Math.sin(now / 3100) * 0.02;
    const f = parts.face.morphTargetInfluences;
    f[0] = s.mouth.open; f[1] = s.mouth.wide; f[2] = s.mouth.round;
    for (const mesh of [parts.lips, parts.opening]) {
      const i = mesh.morphTargetInfluences;
      i[0] = s.mouth.open; i[1] = s.mouth.wide; i[2] = s.mouth.round;
    }
    const happy = this.expression.name === 'happy' ? this.expression.weight : 0;
    // A smile widens the mouth a little unless speech shapes it.
    if (!s.speaking) f[1] = Math.max(f[1], 0.6 * happy);
    const surprised = this.expression.name === 'surprised' ? this.expression.weight : 0;
    parts.brows.forEach((b, i) => {
      b.position.y = 0.36 + 0.05 * surprised + 0.02 * happy;
      b.rotation.z = (i ? 1 : -1) * (0.08 + 0.1 * happy);
    });
    const canvas = this.renderer.domElement;
    const w = canvas.clientWidth;
    const h = canvas.clientHeight;
    if (canvas.width !== Math.floor(w * this.renderer.getPixelRatio()) || this.camera.aspect !== w / h) {
      this.renderer.setSize(w, h, false);
      this.camera.aspect = w / h;
      this.camera.updateProjectionMatrix();
    }
    this.renderer.render(this.scene, this.camera);
  }
}
