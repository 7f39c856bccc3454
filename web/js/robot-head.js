// SPDX-License-Identifier: Apache-2.0
// The robot, assembled: a body (shoulders, collar, neck) that breathes, and a head that turns on
// it: the sculpted shell, the face screen in its bezel, ears with a light ring, an antenna, and
// the face (robot-face.js). Everything is generated here; nothing is loaded.
import * as THREE from '../vendor/three.module.js';
import { makeBrow, makeEye, makeMouth } from './robot-face.js';
import {
  bezelGeometry, gridGeometry, latheGeometry, screenGeometry, shellGeometry, shellNormal, shellPoint,
} from './robot-shapes.js';

const spow = (v, e) => Math.sign(v) * Math.abs(v) ** e;

// Shoulders and chest: the top of a wide, flattened superellipsoid, going straight down below.
function torsoGeometry() {
  return gridGeometry(56, 20, (u, v) => {
    const th = (u - 0.5) * 2 * Math.PI;
    const ph = Math.PI / 2 - v * (Math.PI / 2 + 0.5);
    const c = Math.cos(ph);
    const x = 1.38 * spow(Math.sin(th), 0.62) * spow(c, 0.55);
    const z = 0.74 * spow(Math.cos(th), 0.62) * spow(c, 0.55);
    const y = 0.55 * spow(Math.sin(ph), 0.9);
    return new THREE.Vector3(x, y - (ph < 0 ? 0.4 * -ph : 0), z);
  });
}

function ear(side, materials) {
  const pod = new THREE.Mesh(latheGeometry([[0, 0.16], [0.14, 0.16], [0.2, 0.14], [0.235, 0.1],
    [0.25, 0.05], [0.25, -0.05], [0.2, -0.1]], 40), materials.trim);
  const ring = new THREE.Mesh(latheGeometry([[0.1, 0.166], [0.16, 0.166], [0.165, 0.158],
    [0.095, 0.158]], 40), materials.glow);
  const group = new THREE.Group();
  group.add(pod, ring);
  const th = (side * Math.PI) / 2;
  group.position.copy(shellPoint(th, -0.02)).addScaledVector(shellNormal(th, -0.02), -0.03);
  group.rotation.z = -side * (Math.PI / 2);  // the lathe's axis (+y) out of the side
  return { group, ring };
}

function antenna(materials) {
  const group = new THREE.Group();
  const stalk = new THREE.Mesh(latheGeometry([[0.09, -0.02], [0.085, 0.03], [0.05, 0.06],
    [0.02, 0.1], [0.016, 0.26], [0, 0.27]], 24), materials.metal);
  const tipProfile = [];
  for (let i = 0; i <= 10; i++) {
    const h = i / 10;
    tipProfile.push([0.05 * Math.sin(Math.PI * h) ** 0.7 * (1 - 0.25 * h), 0.25 + 0.13 * h]);
  }
  const tip = new THREE.Mesh(latheGeometry(tipProfile, 24), materials.glow);
  group.add(stalk, tip);
  group.position.copy(shellPoint(0, Math.PI / 2 - 0.25));
  group.rotation.x = -0.2;
  return { group, tip };
}

export function makeRobot(materials) {
  const root = new THREE.Group();
  const body = new THREE.Group();
  body.position.y = -1.95;
  const torso = new THREE.Mesh(torsoGeometry(), materials.shell);
  const collar = new THREE.Mesh(latheGeometry([[0.3, 0.56], [0.44, 0.57], [0.5, 0.62], [0.47, 0.68],
    [0.36, 0.7]], 48), materials.trim);
  const neck = new THREE.Mesh(latheGeometry([[0.3, 0.6], [0.3, 0.75], [0.27, 0.8], [0.27, 0.9],
    [0.3, 0.95], [0.3, 1.05], [0.26, 1.1], [0.25, 1.3]], 40), materials.metal);
  body.add(torso, collar, neck);

  // The head turns about a point in the neck.
  const neckPivot = new THREE.Group();
  neckPivot.position.y = -1.0;
  const head = new THREE.Group();
  head.position.y = 1.0;
  neckPivot.add(head);
  const shell = new THREE.Mesh(shellGeometry(), materials.shell);
  const screen = new THREE.Mesh(screenGeometry(), materials.screen);
  const bezel = new THREE.Mesh(bezelGeometry(0.022), materials.trim);
  const ears = [ear(-1, materials), ear(1, materials)];
  const aerial = antenna(materials);
  const eyes = [makeEye(-1, materials), makeEye(1, materials)];
  const brows = [makeBrow(-1, materials.glow), makeBrow(1, materials.glow)];
  const mouth = makeMouth(materials);
  head.add(shell, screen, bezel, aerial.group, ...ears.map((e) => e.group), ...eyes.map((e) => e.group),
    ...brows, ...mouth);
  root.add(body, neckPivot);
  return { root, body, neck: neckPivot, head, eyes, brows, mouth, ears, antenna: aerial, screen };
}
