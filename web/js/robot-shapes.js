// SPDX-License-Identifier: Apache-2.0
// The robot head's shapes, generated: the sculpted shell (a superellipsoid tapered toward the
// chin), the face screen set into its front, and the helpers that build meshes from functions
// (grids, lathes, tapered tubes, shapes drawn on the screen). No three.js objects at module
// level: these run once at start-up. Units: the head is about 2 high; +z is its front, +y up.
import * as THREE from '../vendor/three.module.js';

const spow = (v, e) => Math.sign(v) * Math.abs(v) ** e;
export const smoothstep = (e0, e1, x) => {
  const t = Math.min(1, Math.max(0, (x - e0) / (e1 - e0)));
  return t * t * (3 - 2 * t);
};

// A point of the shell at azimuth `th` (0: the front, +x for positive) and elevation `ph`.
export function shellPoint(th, ph) {
  const c = Math.cos(ph);
  let x = spow(Math.sin(th), 0.78) * spow(c, 0.72);
  let z = spow(Math.cos(th), 0.78) * spow(c, 0.72);
  const y = spow(Math.sin(ph), 0.72);
  // Narrower toward the chin, a little flatter at the back, cheeks just fuller.
  const jaw = y < 0 ? 1 - 0.2 * (-y) ** 1.6 : 1 - 0.05 * y * y;
  x *= jaw * (1 + 0.03 * Math.exp(-(((y + 0.25) / 0.3) ** 2)));
  z *= (z < 0 ? 0.92 : 1) * (y < 0 ? 1 - 0.08 * (-y) ** 1.6 : 1);
  return new THREE.Vector3(x * 1.0, y * 1.04, z * 0.9);
}

// The outward normal there (numerical).
export function shellNormal(th, ph) {
  const e = 1e-3;
  const du = shellPoint(th + e, ph).sub(shellPoint(th - e, ph));
  const dv = shellPoint(th, ph + e).sub(shellPoint(th, ph - e));
  return du.cross(dv).normalize();
}

// The face screen: a rounded patch of the shell's front, raised a little; (a, b) are its own
// coordinates (about the arc lengths across and up from its centre), `lift` is above it.
export const SCREEN = { ph: -0.06, halfA: 0.86, halfB: 0.6, power: 3.2 };

export function screenEdge(alpha) {
  const c = Math.cos(alpha);
  const s = Math.sin(alpha);
  const k = (Math.abs(c) ** SCREEN.power + Math.abs(s) ** SCREEN.power) ** (-1 / SCREEN.power);
  return [SCREEN.halfA * c * k, SCREEN.halfB * s * k];
}

export function facePoint(a, b, lift = 0) {
  const th = a;
  const ph = SCREEN.ph + b / 1.04;
  const p = shellPoint(th, ph);
  return p.addScaledVector(shellNormal(th, ph), 0.018 + lift);
}

export function faceNormal(a, b) {
  return shellNormal(a, SCREEN.ph + b / 1.04);
}

// A grid mesh: fn(u, v) -> Vector3 for u, v in 0..1 (nu x nv quads); normals computed.
export function gridGeometry(nu, nv, fn, { uv = false } = {}) {
  const pos = [];
  const uvs = [];
  for (let j = 0; j <= nv; j++) {
    for (let i = 0; i <= nu; i++) {
      const p = fn(i / nu, j / nv);
      pos.push(p.x, p.y, p.z);
      uvs.push(i / nu, 1 - j / nv);
    }
  }
  const index = [];
  for (let j = 0; j < nv; j++) {
    for (let i = 0; i < nu; i++) {
      const a = j * (nu + 1) + i;
      const b = a + nu + 1;
      index.push(a, b, a + 1, a + 1, b, b + 1);
    }
  }
  const geo = new THREE.BufferGeometry();
  geo.setAttribute('position', new THREE.Float32BufferAttribute(pos, 3));
  if (uv) geo.setAttribute('uv', new THREE.Float32BufferAttribute(uvs, 2));
  geo.setIndex(index);
  geo.computeVertexNormals();
  return geo;
}

// The whole shell.
export function shellGeometry() {
  return gridGeometry(72, 48, (u, v) => shellPoint((u - 0.5) * 2 * Math.PI, (0.5 - v) * Math.PI));
}

// The screen: rings from its centre to its rounded edge, rising to a soft rim.
export function screenGeometry() {
  return gridGeometry(64, 12, (u, v) => {
    const [ea, eb] = screenEdge(u * 2 * Math.PI);
    const s = Math.sqrt(v);
    return facePoint(ea * s, eb * s, -0.01 * smoothstep(0.85, 1, s));
  });
}

// The bezel: a rounded lip around the screen's edge (a tube swept along it).
export function bezelGeometry(radius) {
  return gridGeometry(96, 8, (u, v) => {
    const alpha = u * 2 * Math.PI;
    const [ea, eb] = screenEdge(alpha);
    const centre = facePoint(ea * 1.015, eb * 1.015, -0.004);
    const n = faceNormal(ea, eb);
    const [na, nb] = screenEdge(alpha + 1e-3);
    const along = facePoint(na, nb).sub(facePoint(ea, eb)).normalize();
    const side = new THREE.Vector3().crossVectors(along, n).normalize();
    const w = v * 2 * Math.PI;
    return centre.addScaledVector(n, radius * Math.sin(w)).addScaledVector(side, radius * 1.4 * Math.cos(w));
  });
}

// A lathe from a profile of [radius, height] points (around +y).
export function latheGeometry(profile, segments = 48) {
  return new THREE.LatheGeometry(profile.map(([r, h]) => new THREE.Vector2(r, h)), segments);
}

// A tube along `points` (Vector3), its radius radiusAt(t) for t in 0..1, ends closed round.
export function taperedTube(points, radiusAt, { segments = 24, sides = 10 } = {}) {
  const curve = new THREE.CatmullRomCurve3(points);
  const frames = curve.computeFrenetFrames(segments, false);
  return gridGeometry(sides, segments, (u, v) => {
    const i = Math.round(v * segments);
    const p = curve.getPointAt(v);
    const r = radiusAt(v);
    const w = u * 2 * Math.PI;
    return p.addScaledVector(frames.normals[i], r * Math.cos(w)).addScaledVector(frames.binormals[i], r * Math.sin(w));
  });
}

// Positions on the screen, `lift` above it, of 2D points [a, b] (a flat list: a fan's centre
// and outline, or strips' rows one after the other).
export function screenPositions(points, lift) {
  const out = new Float32Array(points.length * 3);
  points.forEach(([a, b], i) => facePoint(a, b, lift).toArray(out, i * 3));
  return out;
}

export function fanIndex(n, closed = true) {
  const index = [];
  for (let i = 1; i < n + (closed ? 1 : 0); i++) index.push(0, i, (i % n) + 1);
  return index;
}

// Triangles between two rows of n points (the second row follows the first).
export function stripIndex(n) {
  const index = [];
  for (let i = 0; i < n - 1; i++) index.push(i, n + i, i + 1, i + 1, n + i, n + i + 1);
  return index;
}

// A geometry whose positions come from make(params) for the base and each named target
// (absolute morph targets, in the order of `targets`).
export function morphedGeometry(make, base, targets, index) {
  const geo = new THREE.BufferGeometry();
  geo.setAttribute('position', new THREE.BufferAttribute(make(base), 3));
  geo.setIndex(index);
  geo.morphAttributes.position = targets.map(([name, params]) => {
    const attr = new THREE.BufferAttribute(make({ ...base, ...params }), 3);
    attr.name = name;
    return attr;
  });
  geo.computeVertexNormals();
  geo.computeBoundingSphere();
  geo.boundingSphere.radius *= 1.5;  // room for the targets
  return geo;
}
