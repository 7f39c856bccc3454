// SPDX-License-Identifier: Apache-2.0
// The avatar on screen: a friendly robot (robot-head.js) that executes what the hub decides
// (gaze, blinks, expressions) and what the voice plays (visemes on the audio clock), and lives
// when idle (avatar-motion.js). State is kept even when WebGL is missing, so the page still works.
import * as THREE from '../vendor/three.module.js';
import {
  addLights, GLOW, makeEnvironment, makeMaterials, setColours, softwareRenderer,
} from './avatar-look.js';
import {
  approach, ExpressionBlend, expressionName, Idle, VISEME_NAMES, visemeWeights,
} from './avatar-motion.js';
import { lidAngles, MOUTH_TARGETS } from './robot-face.js';
import { makeRobot } from './robot-head.js';

const MAX_YAW = 0.5;    // radians the eyes turn at the image edge
const MAX_PITCH = 0.32;
// Resolution: lowered in steps while a quarter of the last FRAMES frames took more than SLOW_MS
// (their 75th percentile: a mix of fast and slow frames, whose median flips between the two,
// still counts as slow), down to MIN_RATIO of the page's pixels.
const FRAMES = 45;
const SLOW_MS = 21;
const MIN_RATIO = 0.45;

export class Avatar {
  constructor(canvas) {
    this.state = {
      gaze: { x: 0, y: 0, source: 'idle' }, eyes: { yaw: 0, pitch: 0 }, eyelid: 0, blinks: 0,
      mouth: { open: 0, wide: 0, round: 0 }, maxMouthOpen: 0, speaking: false, expression: 'neutral',
      expressions: [], viseme: 'sil', visemes: {}, expressionWeights: {},
      head: { yaw: 0, pitch: 0, roll: 0 }, breath: 0, saccades: 0, lids: { upper: 0, lower: 0 },
    };
    this.blink = null;  // { start, close, hold, open } in ms
    this.expression = { name: 'neutral', weight: 0, until: 0 };
    this.blend = new ExpressionBlend();
    this.idle = new Idle(7);
    this.held = null;   // a pose held for tests and screenshots: {viseme, expression}
    this.renderer = null;
    const software = softwareRenderer();
    try {
      this.renderer = new THREE.WebGLRenderer({ canvas, antialias: !software, alpha: true, powerPreference: 'low-power' });
    } catch (e) {
      console.warn('no WebGL:', e.message);
      return;
    }
    this.renderer.toneMapping = THREE.ACESFilmicToneMapping;
    this.renderer.toneMappingExposure = 1.05;
    this.scene = new THREE.Scene();
    this.environment = null;  // the studio, made when reflections are first on
    this.scene.environmentIntensity = 0.8;
    this.gaps = [];
    this.quality = { software, mode: 'auto', ratio: 1, reflections: false, lowered: 0 };
    this.setQuality('auto');
    this.state.quality = this.quality;
    addLights(this.scene);
    this.camera = new THREE.PerspectiveCamera(22, 1, 0.5, 30);
    this.camera.position.set(0, -0.12, 8.6);
    this.camera.lookAt(0, -0.2, 0);
    this.materials = makeMaterials();
    this.light = GLOW.clone();  // the light's colour at full strength
    this.parts = makeRobot(this.materials);
    this.scene.add(this.parts.root);
    // Each mouth target's influence slot, and what drives it: a viseme's weight or an
    // expression's ("x-happy"). The mouth's meshes have the same targets: one array for all.
    const slots = this.parts.mouth[0].morphTargetDictionary;
    for (const m of this.parts.mouth) m.morphTargetInfluences = this.parts.mouth[0].morphTargetInfluences;
    this.mouthTargets = MOUTH_TARGETS.map(([name]) => ({
      slot: slots[name], expression: name.startsWith('x-') ? name.slice(2) : null, viseme: name,
    }));
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
      case 'expression': {
        const name = expressionName(msg.name);
        if (!name) break;
        this.expression = { name, weight: msg.weight ?? 1, until: now + (msg.duration_ms ?? 2000) };
        this.state.expressions.push(name);
        break;
      }
      default:
    }
  }

  // 'auto': full resolution, reflections and multisampling unless WebGL is drawn in software,
  // then lower resolution while frames are slow. 'high': everything at the page's resolution
  // whatever it costs (screenshots).
  setQuality(mode) {
    const q = this.quality;
    const full = Math.min(window.devicePixelRatio, 2);
    q.mode = mode;
    q.ratio = full;
    q.reflections = mode === 'high' || !q.software;
    if (q.reflections && !this.environment) this.environment = makeEnvironment(this.renderer);
    this.scene.environment = q.reflections ? this.environment : null;
    this.renderer.setPixelRatio(q.ratio);
    this.gaps = [];
  }

  // The governor: one step down when the recent frames are slow.
  pace(dt) {
    const q = this.quality;
    if (q.mode !== 'auto' || dt <= 0) return;
    this.gaps.push(dt * 1000);
    if (this.gaps.length < FRAMES) return;
    const slow = [...this.gaps].sort((a, b) => a - b)[Math.floor(FRAMES * 0.75)];
    this.gaps = [];
    if (slow > SLOW_MS && q.ratio > MIN_RATIO) {
      q.ratio = Math.max(MIN_RATIO, Math.round((q.ratio - 0.1) * 100) / 100);
      q.lowered++;
      this.renderer.setPixelRatio(q.ratio);
    }
  }

  // The colours websocket-ui's config names (its welcome's `avatar`: {light, eyes}).
  configure(colours) {
    this.state.colours = { ...this.state.colours, ...colours };
    if (this.hasWebGL && colours) setColours(this.materials, this.light, colours);
  }

  // Holds a pose until pose(null): {viseme, expression, gaze: [x, y], blink: false}, each optional.
  pose(p) {
    this.held = p;
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
    if (now > this.expression.until) this.expression = { name: 'neutral', weight: 0, until: Infinity };
    const expression = this.held?.expression ?? this.expression.name;
    s.expression = expression;
    s.expressionWeights = this.blend.update(expression, this.held?.expression ? 1 : this.expression.weight || 1, dt);
    const idle = this.idle.update(now, s.gaze.source === 'face');
    s.saccades = this.idle.saccades;
    s.breath = idle.breath;
    // The camera image is the robot's view: a person on the image's left stands on the avatar's
    // right, which is the viewer's right, so the eyes turn toward -x.
    const [lookX, lookY] = this.blend.look();
    const [gx, gy] = this.held?.gaze ?? [s.gaze.x, s.gaze.y];
    const yaw = -(gx + idle.offset[0] + lookX) * MAX_YAW;
    const pitch = (gy + idle.offset[1] + lookY) * MAX_PITCH;
    s.eyes.yaw = approach(s.eyes.yaw, yaw, dt, 0.025);  // saccades: fast
    s.eyes.pitch = approach(s.eyes.pitch, pitch, dt, 0.025);
    s.head.yaw = approach(s.head.yaw, s.eyes.yaw * 0.35, dt, 0.45) ;
    s.head.pitch = approach(s.head.pitch, s.eyes.pitch * 0.3 + this.blend.sum('head', 'nod'), dt, 0.45);
    s.head.roll = approach(s.head.roll, this.blend.sum('head', 'tilt'), dt, 0.35);
    s.eyelid = this.held?.blink === false ? 0 : this.eyelidAt(now);
    // The mouth: the hub's jaw, spread and rounding for the state, the visemes for the shape.
    const m = 1 - Math.exp(-dt * 25);
    s.mouth.open += (mouth.open - s.mouth.open) * m;
    s.mouth.wide += (mouth.wide - s.mouth.wide) * m;
    s.mouth.round += (mouth.round - s.mouth.round) * m;
    s.speaking = mouth.speaking;
    if (s.speaking) s.maxMouthOpen = Math.max(s.maxMouthOpen, s.mouth.open);
    const held = this.held?.viseme;
    const v = held ? { weights: Object.fromEntries(VISEME_NAMES.map((n) => [n, n === held ? 1 : 0])), current: held }
      : visemeWeights(mouth.speaking ? mouth.timeline : null, mouth.ms ?? 0);
    s.viseme = v.current;
    for (const n of VISEME_NAMES) s.visemes[n] = approach(s.visemes[n] ?? 0, v.weights[n], dt, held ? 0.02 : 0.03);
    if (this.hasWebGL) {
      this.pace(dt);
      this.render(now, idle);
    }
  }

  render(now, idle) {
    const { parts, state: s, blend } = this;
    parts.neck.rotation.set(s.head.pitch + idle.sway[1], s.head.yaw + idle.sway[0], s.head.roll);
    parts.body.position.y = -1.95 + 0.012 * s.breath;
    parts.body.scale.set(1 + 0.006 * s.breath, 1, 1 + 0.006 * s.breath);
    parts.neck.position.y = -1.0 + 0.012 * s.breath;
    // Eyes and lids.
    const squint = blend.sum('lids', 'squint');
    const droop = blend.sum('lids', 'droop');
    const lids = lidAngles(s.eyelid, squint, droop);
    // Where the expression holds the lids' edges, blinks aside (degrees).
    const rest = lidAngles(0, squint, droop);
    s.lids = { upper: rest.upperEdge, lower: rest.lowerEdge };
    for (const e of parts.eyes) {
      e.ball.rotation.set(s.eyes.pitch, s.eyes.yaw, 0);
      e.upper.rotation.x = lids.upper;
      e.lower.rotation.x = lids.lower;
    }
    // Brows: both from the expressions, the robot's left one higher when thinking.
    const lift = blend.sum('brows', 'lift');
    parts.brows.forEach((b, i) => {
      const f = b.morphTargetInfluences;
      f[0] = blend.sum('brows', 'raise') + (i === 1 ? lift : -0.3 * lift);
      f[1] = blend.sum('brows', 'frown');
      f[2] = blend.sum('brows', 'worry');
    });
    // The mouth: visemes, and the expressions' shapes on top.
    const f = parts.mouth[0].morphTargetInfluences;
    for (const t of this.mouthTargets) {
      if (t.expression) f[t.slot] = blend.weights[t.expression] ?? 0;
      else f[t.slot] = t.viseme === 'sil' ? 0 : s.visemes[t.viseme];
    }
    // Ears and antenna: brighter when listening or speaking.
    const glow = Math.min(1, 0.35 + blend.glow() + (s.speaking ? 0.25 + 0.2 * Math.sin(now / 90) : 0));
    for (const e of parts.ears) e.ring.material.color.copy(this.light).multiplyScalar(0.35 + 0.9 * glow);
    this.resize();
    this.renderer.render(this.scene, this.camera);
  }

  resize() {
    const canvas = this.renderer.domElement;
    const w = canvas.clientWidth;
    const h = canvas.clientHeight;
    if (canvas.width !== Math.floor(w * this.renderer.getPixelRatio()) || this.camera.aspect !== w / h) {
      this.renderer.setSize(w, h, false);
      this.camera.aspect = w / h;
      // Keep the head and shoulders in view on a narrow stage.
      this.camera.fov = w / h < 1 ? 22 / Math.max(0.6, w / h) : 22;
      this.camera.updateProjectionMatrix();
    }
  }

  // What the scene costs: triangles and draw calls of the last frame.
  get cost() {
    if (!this.hasWebGL) return null;
    const r = this.renderer.info.render;
    return { triangles: r.triangles, calls: r.calls };
  }
}

