// SPDX-License-Identifier: Apache-2.0
// The avatar's head, generated: a deformed sphere with morph targets for the jaw and the mouth
// shapes, lips and a mouth opening that follow them, eyes that rotate, and eyelids whose morph
// target closes them.
import * as THREE from '../vendor/three.module.js';

const MOUTH_Y = -0.42;
const FRONT_Z = 0.86;

function smoothstep(e0, e1, x) {
  const t = Math.min(1, Math.max(0, (x - e0) / (e1 - e0)));
  return t * t * (3 - 2 * t);
}

// Positions moved by fn(x, y, z) -> [x, y, z] as a named morph attribute (absolute positions).
function morph(name, base, fn) {
  const out = new Float32Array(base.length);
  for (let i = 0; i < base.length; i += 3) {
    const [x, y, z] = fn(base[i], base[i + 1], base[i + 2]);
    out[i] = x; out[i + 1] = y; out[i + 2] = z;
  }
  const attr = new THREE.BufferAttribute(out, 3);
  attr.name = name;
  return attr;
}

function skull() {
  const geo = new THREE.SphereGeometry(1, 96, 72);
  const p = geo.attributes.position.array;
  for (let i = 0; i < p.length; i += 3) {
    let x = p[i] * 0.8;
    let y = p[i + 1] * 1.08;
    let z = p[i + 2] * 0.92;
    if (y < -0.15) x *= 1 - 0.32 * smoothstep(-0.15, -1.0, y); // narrower jaw and chin
    if (z > 0) {
      // Nose: a soft bump on the front centre line.
      const d = Math.hypot(x / 0.11, (y + 0.12) / 0.2);
      z += 0.17 * Math.exp(-d * d);
      // Eye sockets.
      for (const ex of [-0.3, 0.3]) {
        const e = Math.hypot((x - ex) / 0.16, (y - 0.17) / 0.11);
        z -= 0.07 * Math.exp(-e * e);
      }
    }
    p[i] = x; p[i + 1] = y; p[i + 2] = z;
  }
  geo.computeVertexNormals();
  const base = Float32Array.from(p);
  const nearMouth = (x, y, z) => (z > 0.3 ? Math.exp(-((x / 0.38) ** 2) - (((y - MOUTH_Y) / 0.22) ** 2)) : 0);
  geo.morphAttributes.position = [
    morph('jawOpen', base, (x, y, z) => {
      const w = z > 0 ? smoothstep(MOUTH_Y + 0.02, MOUTH_Y - 0.15, y) : smoothstep(-0.2, -0.6, y) * 0.5;
      return [x, y - 0.2 * w, z - 0.04 * w];
    }),
    morph('mouthWide', base, (x, y, z) => [x + Math.sign(x) * 0.07 * nearMouth(x, y, z), y, z]),
    morph('mouthRound', base, (x, y, z) => {
      const m = nearMouth(x, y, z);
      return [x * (1 - 0.3 * m), y, z + 0.05 * m];
    }),
  ];
  return geo;
}

function lips() {
  const geo = new THREE.TorusGeometry(0.2, 0.035, 12, 64);
  const base = Float32Array.from(geo.attributes.position.array);
  geo.morphAttributes.position = [
    morph('open', base, (x, y, z) => [x * 0.92, y * 3.2 - 0.09, z]),
    morph('wide', base, (x, y, z) => [x * 1.35, y * 0.8, z]),
    morph('round', base, (x, y, z) => [x * 0.55, y * 1.5, z + 0.04]),
  ];
  return geo;
}

function mouthOpening() {
  const geo = new THREE.CircleGeometry(0.19, 48);
  const base = Float32Array.from(geo.attributes.position.array);
  geo.scale(1, 0.08, 1);
  geo.morphAttributes.position = [
    morph('open', base, (x, y, z) => [x * 0.92, y * 1.1 - 0.09, z]),
    morph('wide', base, (x, y, z) => [x * 1.35, y * 0.1, z]),
    morph('round', base, (x, y, z) => [x * 0.55, y * 0.45, z]),
  ];
  return geo;
}

// A shell over the top of the eye; its morph target "closed" reaches down over the front.
function eyelid(radius) {
  const open = new THREE.SphereGeometry(radius, 32, 16, 0, Math.PI * 2, 0, Math.PI * 0.36);
  const closed = new THREE.SphereGeometry(radius, 32, 16, 0, Math.PI * 2, 0, Math.PI * 0.97);
  const attr = closed.attributes.position.clone();
  attr.name = 'closed';
  open.morphAttributes.position = [attr];
  return open;
}

function eye(side, materials) {
  const group = new THREE.Group();
  group.position.set(side * 0.3, 0.17, FRONT_Z - 0.15);
  const ball = new THREE.Mesh(new THREE.SphereGeometry(0.13, 32, 24), materials.white);
  const iris = new THREE.Mesh(new THREE.CircleGeometry(0.062, 32), materials.iris);
  iris.position.z = 0.1305;
  const pupil = new THREE.Mesh(new THREE.CircleGeometry(0.028, 24), materials.pupil);
  pupil.position.z = 0.1315;
  group.add(ball, iris, pupil);
  const lid = new THREE.Mesh(eyelid(0.138), materials.lid);
  lid.position.copy(group.position);
  return { group, lid };
}

export function makeHead() {
  const materials = {
    skin: new THREE.MeshStandardMaterial({ color: 0xd9a47f, roughness: 0.65 }),
    lid: new THREE.MeshStandardMaterial({ color: 0xcf9873, roughness: 0.7, side: THREE.DoubleSide }),
    lips: new THREE.MeshStandardMaterial({ color: 0xa8545a, roughness: 0.5 }),
    mouth: new THREE.MeshBasicMaterial({ color: 0x2a0d10 }),
    white: new THREE.MeshStandardMaterial({ color: 0xf4f4f0, roughness: 0.3 }),
    iris: new THREE.MeshStandardMaterial({ color: 0x3c6e9e, roughness: 0.4 }),
    pupil: new THREE.MeshBasicMaterial({ color: 0x050505 }),
    brow: new THREE.MeshStandardMaterial({ color: 0x4a3326, roughness: 0.9 }),
  };
  const head = new THREE.Group();
  const face = new THREE.Mesh(skull(), materials.skin);
  const lipMesh = new THREE.Mesh(lips(), materials.lips);
  lipMesh.position.set(0, MOUTH_Y, FRONT_Z - 0.02);
  lipMesh.scale.set(1, 0.55, 0.6);
  const opening = new THREE.Mesh(mouthOpening(), materials.mouth);
  opening.position.set(0, MOUTH_Y, FRONT_Z - 0.005);
  const eyes = [eye(-1, materials), eye(1, materials)];
  const brows = [-1, 1].map((side) => {
    const b = new THREE.Mesh(new THREE.BoxGeometry(0.22, 0.035, 0.05), materials.brow);
    b.position.set(side * 0.3, 0.36, FRONT_Z - 0.1);
    b.rotation.z = side * -0.08;
    return b;
  });
  head.add(face, lipMesh, opening, ...brows);
  for (const e of eyes) head.add(e.group, e.lid);
  return { head, face, lips: lipMesh, opening, eyes, brows };
}
