// SPDX-License-Identifier: Apache-2.0
// The robot's face on its screen: eyes (eyeball with iris and pupil, upper and lower lids that
// close over it), brows with morph targets for expressions, and a mouth (lips, teeth, tongue,
// the dark inside) with a morph target for each viseme and expression, all drawn from one
// parametric outline so every shape is the same mesh moved.
import * as THREE from '../vendor/three.module.js';
import { EXPRESSIONS, VISEMES, VISEME_NAMES } from './avatar-motion.js';
import {
  faceNormal, facePoint, fanIndex, latheGeometry, morphedGeometry, screenPositions, stripIndex, taperedTube,
} from './robot-shapes.js';

export const EYE = { a: 0.34, b: 0.07, radius: 0.21 };
const MOUTH_B = -0.32;
const N = 33;  // points along each lip

// At rest: closed, the corners a little up.
const MOUTH_REST = {
  open: 0, wide: 0, round: 0, press: 0, smile: 0.3, sad: 0, smirk: 0, teeth: 0, lowTeeth: 0,
  tongueUp: 0, tongueOut: 0, lowerIn: 0,
};

// The mouth's outline for shape `p`: per point along it (t from -1 to 1), x and the inner and
// outer edges of both lips.
function mouthCurves(p) {
  const W = 0.23 * (1 + 0.32 * p.wide - 0.42 * p.round + 0.16 * p.smile - 0.06 * p.sad);
  const H = Math.max(0, 0.016 + 0.3 * p.open - 0.016 * p.press);
  const power = 2 + 2.6 * (1 - p.round);
  const thick = (1 + 0.45 * p.round) * (1 - 0.3 * p.press);
  const out = [];
  for (let i = 0; i < N; i++) {
    const t = -1 + (2 * i) / (N - 1);
    const f = (1 - Math.abs(t) ** power) ** (1 / power);
    const lift = (0.065 * p.smile - 0.055 * p.sad) * t * t + 0.05 * p.smirk * Math.max(0, t) ** 2 -
      0.012 * p.smirk * Math.max(0, -t);
    const body = 0.3 + 0.7 * Math.sqrt(Math.max(0, 1 - t * t));
    const upIn = MOUTH_B + lift + 0.38 * H * f;
    const loIn = MOUTH_B + lift - 0.62 * H * f + 0.022 * p.lowerIn * f;
    const bow = 0.011 * Math.exp(-((t / 0.16) ** 2)) * (1 - p.round);
    out.push({
      t, x: t * W, xo: t * (W + 0.022),
      upIn, upOut: upIn + 0.06 * thick * body - bow,
      loIn, loOut: loIn - 0.07 * thick * body * (1 - 0.45 * p.lowerIn),
    });
  }
  return out;
}

const at = (curves, x, key) => {
  const c = curves.find((q, i) => i === curves.length - 1 || curves[i + 1].x >= x);
  return c[key];
};

// Positions of each mouth part for shape `p` (same vertex count whatever the shape).
const PARTS = {
  lips(p) {
    const c = mouthCurves(p);
    const rows = [c.map((q) => [q.x, q.upIn]), c.map((q) => [q.xo, q.upOut]),
      c.map((q) => [q.x, q.loIn]), c.map((q) => [q.xo, q.loOut])];
    return screenPositions(rows.flat(), 0.012);
  },
  inside(p) {
    const c = mouthCurves(p);
    const outline = [...c.map((q) => [q.x, q.upIn]), ...c.slice(1, -1).reverse().map((q) => [q.x, q.loIn])];
    const mid = c[(N - 1) / 2];
    return screenPositions([[0, (mid.upIn + mid.loIn) / 2], ...outline], 0.004);
  },
  teeth(p) {
    const c = mouthCurves(p).filter((q) => Math.abs(q.t) <= 0.76);
    const gap = (q) => q.upIn - q.loIn;
    const rows = [
      c.map((q) => [q.x, q.upIn + 0.004]),
      c.map((q) => [q.x, q.upIn - Math.min(0.05 * p.teeth, 0.55 * gap(q))]),
      c.map((q) => [q.x, q.loIn + Math.min(0.036 * p.lowTeeth, 0.4 * gap(q))]),
      c.map((q) => [q.x, q.loIn - 0.004]),
    ];
    return screenPositions(rows.flat(), 0.008);
  },
  tongue(p) {
    const c = mouthCurves(p);
    const mid = c[(N - 1) / 2];
    const gap = mid.upIn - mid.loIn;
    const W = c[N - 1].x;
    const cy = mid.loIn + gap * (0.22 + 0.42 * p.tongueUp) - 0.01 * p.tongueOut;
    const rx = 0.5 * W;
    const ry = Math.min(0.05, 0.28 * gap) + 0.018 * p.tongueOut;
    const pts = [[0, cy]];
    for (let i = 0; i < 24; i++) {
      const w = (i / 24) * 2 * Math.PI;
      const x = rx * Math.cos(w);
      const y = cy + ry * Math.sin(w);
      pts.push([x, Math.min(at(c, x, 'upIn') - 0.003, Math.max(at(c, x, 'loIn') - 0.02 * p.tongueOut, y))]);
    }
    return screenPositions(pts, 0.006);
  },
};

const INDEX = {
  lips: [...stripIndex(N), ...stripIndex(N).map((i) => i + 2 * N)],
  inside: fanIndex(2 * N - 2),
  teeth: (() => {
    const n = mouthCurves(MOUTH_REST).filter((q) => Math.abs(q.t) <= 0.76).length;
    return [...stripIndex(n), ...stripIndex(n).map((i) => i + 2 * n)];
  })(),
  tongue: fanIndex(24),
};

// The mouth's targets: one per viseme, then one per expression ("x-happy"...).
export const MOUTH_TARGETS = [
  ...VISEME_NAMES.map((v) => [v, VISEMES[v]]),
  ...Object.keys(EXPRESSIONS).filter((e) => e !== 'neutral').map((e) => [`x-${e}`, EXPRESSIONS[e].mouth ?? {}]),
];

export function makeMouth(materials) {
  return ['inside', 'tongue', 'teeth', 'lips'].map((part) => {
    const geo = morphedGeometry(PARTS[part], MOUTH_REST, MOUTH_TARGETS, INDEX[part]);
    const mesh = new THREE.Mesh(geo, materials[part]);
    mesh.name = `mouth-${part}`;
    return mesh;
  });
}

// A brow (side -1: the robot's right, on the viewer's left): a tapered stroke with targets
// raise, frown (inner end down and in) and worry (inner end up).
const BROW_TARGETS = [['raise', { raise: 1 }], ['frown', { frown: 1 }], ['worry', { worry: 1 }]];
function browPositions(side) {
  return ({ raise = 0, frown = 0, worry = 0 }) => {
    const pts = [];
    for (let i = 0; i <= 4; i++) {
      const u = i / 4;  // inner to outer
      const a = side * (0.16 + 0.36 * u + 0.025 * frown * (1 - u));
      const b = 0.33 + 0.04 * Math.sin(Math.PI * u) + 0.075 * raise +
        (1 - u) * (-0.06 * frown + 0.07 * worry) - 0.025 * worry * u;
      pts.push(facePoint(a, b, 0.012));
    }
    const radius = (v) => (0.042 - 0.018 * v) * Math.min(1, 3 * Math.sqrt(Math.max(0, v * (1 - v))));
    return taperedTube(pts, radius, { segments: 20, sides: 8 }).attributes.position.array;
  };
}

export function makeBrow(side, material) {
  const make = browPositions(side);
  const index = taperedTube([facePoint(0, 0), facePoint(0.1, 0), facePoint(0.2, 0)], () => 0.01,
    { segments: 20, sides: 8 }).index.array;
  const geo = morphedGeometry(make, {}, BROW_TARGETS, [...index]);
  const mesh = new THREE.Mesh(geo, material);
  mesh.name = side < 0 ? 'brow-right' : 'brow-left';
  return mesh;
}

// An eye: the group sits in the screen facing out (+z), its `ball` turns with the gaze, the lids
// (caps slightly larger than the ball, with a rounded edge) turn about x to close.
function lidGeometry(r, reach) {
  const profile = [];
  for (let i = 0; i <= 14; i++) {
    const t = (i / 14) * reach;
    profile.push([r * Math.sin(t), r * Math.cos(t)]);
  }
  const t = reach;
  const inner = r - 0.018;
  profile.push([(r - 0.009) * Math.sin(t + 0.05), (r - 0.009) * Math.cos(t + 0.05)]);
  profile.push([inner * Math.sin(t), inner * Math.cos(t)]);
  profile.push([inner * Math.sin(t * 0.5), inner * Math.cos(t * 0.5)]);
  profile.push([0, inner]);
  return latheGeometry(profile, 40);
}

export function makeEye(side, materials) {
  const group = new THREE.Group();
  const normal = faceNormal(side * EYE.a, EYE.b);
  group.position.copy(facePoint(side * EYE.a, EYE.b, -0.11));
  group.lookAt(group.position.clone().add(normal));
  const ballGeo = new THREE.SphereGeometry(EYE.radius, 32, 20);
  ballGeo.rotateX(Math.PI / 2);  // the texture's pole (the pupil) to +z
  const ball = new THREE.Mesh(ballGeo, materials.eye);
  const upper = new THREE.Mesh(lidGeometry(EYE.radius * 1.07, (100 / 180) * Math.PI), materials.lid);
  const lower = new THREE.Mesh(lidGeometry(EYE.radius * 1.06, (70 / 180) * Math.PI), materials.lid);
  lower.geometry.rotateZ(Math.PI);  // its pole down
  const lowerPivot = new THREE.Group();
  lowerPivot.add(lower);
  group.add(ball, upper, lowerPivot);
  return { group, ball, upper, lower: lowerPivot };
}

// Where the lids are: `close` 0 (open) to 1 (shut), `squint` raises the lower lid, `droop` lowers
// the upper one (negative: wider open). Returns the rotations about x of the upper lid and of
// the lower lid's pivot, and the elevations (degrees above the eye's middle, toward the front)
// of their edges. The upper cap spans 100 degrees from its pole, the lower 70.
export function lidAngles(close, squint, droop) {
  const deg = Math.PI / 180;
  const lowerEdge = -46 + 22 * squint;
  const open = 38 - 40 * Math.max(-0.6, droop);
  const upperEdge = open * (1 - close) + (lowerEdge - 4) * close;  // shut: over the lower lid
  return { upper: (-10 - upperEdge) * deg, lower: -(lowerEdge + 20) * deg, upperEdge, lowerEdge };
}
