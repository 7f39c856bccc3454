// SPDX-License-Identifier: Apache-2.0
// What the avatar's face does, without three.js: the viseme and expression vocabulary (the
// shapes its meshes are given as morph targets), lip sync with coarticulation on the audio clock,
// expressions that blend in and out, and life when idle (breathing, head sway, saccades).
// Pure: tests/web/avatar_motion.test.mjs runs it in node.

// The 15 visemes of websocket-ui (docs/websocket-ui.md, "Lips"), as mouth shapes: `open` (the
// jaw), `wide` (lips spread), `round` (lips rounded and pushed out), `press` (lips pressed
// together), `teeth` and `lowTeeth` (how much of the upper and lower teeth show), `tongueUp`
// (its tip behind the upper teeth), `tongueOut` (between the teeth), `lowerIn` (the lower lip
// under the upper teeth).
export const VISEMES = {
  sil: {},
  PP: { press: 1 },
  FF: { open: 0.07, teeth: 1, lowerIn: 1 },
  TH: { open: 0.16, teeth: 0.8, tongueOut: 1 },
  DD: { open: 0.22, teeth: 0.7, lowTeeth: 0.4, tongueUp: 0.8 },
  kk: { open: 0.32, teeth: 0.5, lowTeeth: 0.3 },
  CH: { open: 0.2, round: 0.6, teeth: 0.9, lowTeeth: 0.6 },
  SS: { open: 0.08, wide: 0.55, teeth: 1, lowTeeth: 0.8 },
  nn: { open: 0.18, wide: 0.2, tongueUp: 1 },
  RR: { open: 0.18, round: 0.45, teeth: 0.3 },
  aa: { open: 0.85, wide: 0.3, teeth: 0.4, lowTeeth: 0.2 },
  E: { open: 0.5, wide: 0.5, teeth: 0.6, lowTeeth: 0.3 },
  I: { open: 0.26, wide: 0.85, teeth: 0.9, lowTeeth: 0.6 },
  O: { open: 0.6, round: 0.75 },
  U: { open: 0.24, round: 1 },
};
export const VISEME_NAMES = Object.keys(VISEMES);

// Expressions: the mouth (`smile`, `sad`, `smirk` and the shapes above), the brows (`raise`,
// `frown`, `worry`: inner ends up; `lift`: the left one alone), the lids (`squint`: lower lids up,
// `droop`: upper lids down), the head (`tilt`, `nod` in radians), the gaze's offset
// (`lookX`, `lookY` in -1..1) and the ears' glow.
export const EXPRESSIONS = {
  neutral: {},
  happy: { mouth: { smile: 1, open: 0.12, teeth: 0.6 }, brows: { raise: 0.35 }, lids: { squint: 0.55 }, head: { tilt: 0.05 }, glow: 0.4 },
  surprised: { mouth: { open: 0.45, round: 0.55 }, brows: { raise: 1 }, lids: { droop: -0.35 }, head: { nod: -0.06 }, glow: 0.5 },
  thinking: { mouth: { smirk: 1, press: 0.4, smile: 0 }, brows: { lift: 1, frown: 0.3 }, lids: { droop: 0.35 }, head: { tilt: -0.1, nod: -0.05 }, look: [0.45, -0.5] },
  listening: { mouth: { smile: 0.3 }, brows: { raise: 0.25, worry: 0.2 }, lids: {}, head: { tilt: 0.12 }, glow: 1 },
  sad: { mouth: { sad: 1, smile: 0 }, brows: { worry: 1 }, lids: { droop: 0.3 }, head: { nod: 0.1 }, look: [0, 0.35] },
};
// Other names the agent's rules may use.
const ALIASES = { smile: 'happy', surprise: 'surprised', think: 'thinking', listen: 'listening' };
export const expressionName = (name) => (EXPRESSIONS[ALIASES[name] ?? name] ? ALIASES[name] ?? name : null);

// Lip sync: the viseme weights at `ms` of an utterance's timeline [{t_ms, v}] (sorted). Each
// shape starts moving toward the next LEAD_MS before its time and has arrived BLEND_MS later
// (anticipatory coarticulation), so a short viseme between two others is only partly reached.
export const LEAD_MS = 70;
export const BLEND_MS = 110;
export function visemeWeights(timeline, ms) {
  const w = Object.fromEntries(VISEME_NAMES.map((n) => [n, n === 'sil' ? 1 : 0]));
  let current = 'sil';
  for (const { t_ms: t, v } of timeline ?? []) {
    if (t - LEAD_MS > ms) break;
    const a = Math.min(1, (ms - t + LEAD_MS) / BLEND_MS);
    for (const n of VISEME_NAMES) w[n] *= 1 - a;
    current = v in VISEMES ? v : 'sil';
    w[current] += a;
  }
  return { weights: w, current };
}

// A first-order approach of `value` to `target` with time constant `tau` seconds.
export const approach = (value, target, dt, tau) => value + (target - value) * (1 - Math.exp(-Math.max(0, dt) / tau));

// The expression weights, each easing toward 1 for the expression shown and 0 for the others
// (about 0.15 s in, 0.3 s out).
export class ExpressionBlend {
  constructor() {
    this.weights = Object.fromEntries(Object.keys(EXPRESSIONS).map((n) => [n, n === 'neutral' ? 1 : 0]));
  }

  update(name, weight, dt) {
    for (const n of Object.keys(this.weights)) {
      const target = n === name ? weight : 0;
      this.weights[n] = approach(this.weights[n], target, dt, target > this.weights[n] ? 0.15 : 0.3);
    }
    return this.weights;
  }

  // The sum of each expression's `part.key` weighted.
  sum(part, key) {
    let s = 0;
    for (const [n, w] of Object.entries(this.weights)) {
      const v = EXPRESSIONS[n][part];
      if (v && typeof v[key] === 'number') s += w * v[key];
    }
    return s;
  }

  look() {
    let x = 0;
    let y = 0;
    for (const [n, w] of Object.entries(this.weights)) {
      const l = EXPRESSIONS[n].look;
      if (l) { x += w * l[0]; y += w * l[1]; }
    }
    return [x, y];
  }

  glow() {
    return Object.entries(this.weights).reduce((s, [n, w]) => s + w * (EXPRESSIONS[n].glow ?? 0), 0);
  }
}

// A small seeded generator (mulberry32), so that a test can replay the idle motions.
export function random(seed) {
  let a = seed >>> 0;
  return () => {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

// Life when idle: breathing (about 15 a minute), a head that sways a little, and saccades:
// the eyes jump every 0.4 to 2.8 s, mostly to points near what they look at and now and then
// (1 in 4 while they watch a face, more often when nothing holds them) a glance further away.
export class Idle {
  constructor(seed = 1) {
    this.rand = random(seed);
    this.next = 0;           // time of the next saccade, ms
    this.offset = [0, 0];    // where the eyes are off their target, -1..1
    this.saccades = 0;
  }

  update(now, watchingFace) {
    if (now >= this.next) {
      const far = this.rand() < (watchingFace ? 0.25 : 0.5);
      const reach = far ? 0.35 : 0.06;
      this.offset = [(this.rand() * 2 - 1) * reach, (this.rand() * 2 - 1) * reach * 0.6];
      this.next = now + 400 + this.rand() * (far ? 900 : 2400);
      this.saccades++;
    }
    const s = now / 1000;
    return {
      breath: Math.sin(s * 2 * Math.PI * 0.25),
      sway: [0.035 * Math.sin(s * 0.53) + 0.015 * Math.sin(s * 1.37 + 1), 0.02 * Math.sin(s * 0.71 + 2) + 0.01 * Math.sin(s * 1.9)],
      offset: this.offset,
    };
  }
}
