// SPDX-License-Identifier: Apache-2.0
// How the robot looks: its physically based materials, the eyes' iris texture (drawn on a
// canvas), a soft studio to reflect (a generated room of light panels, prefiltered once), and a
// warm key light with a cool fill and a rim. The background is the page's (a gradient in CSS).
import * as THREE from '../vendor/three.module.js';

export const GLOW = new THREE.Color(0x7fe6ff);

// The eyeball's texture, its iris of `colour`: its top rows are the pole the pupil sits on
// (SphereGeometry's uv).
function eyeTexture(colour) {
  const base = new THREE.Color(colour);
  const shade = (l) => `#${base.clone().offsetHSL(0, 0, l).getHexString()}`;
  const w = 256;
  const h = 256;
  const c = document.createElement('canvas');
  c.width = w;
  c.height = h;
  const g = c.getContext('2d');
  const pupil = 0.072 * h;
  const iris = 0.19 * h;
  g.fillStyle = '#f4f6f9';
  g.fillRect(0, 0, w, h);
  // The white darkens a little toward the back.
  const back = g.createLinearGradient(0, iris, 0, h);
  back.addColorStop(0, 'rgba(200,210,225,0)');
  back.addColorStop(1, 'rgba(150,160,180,0.9)');
  g.fillStyle = back;
  g.fillRect(0, iris, w, h - iris);
  const ring = g.createLinearGradient(0, 0, 0, iris * 1.12);
  ring.addColorStop(0, '#0a1c2a');
  ring.addColorStop(pupil / (iris * 1.12), '#0a1c2a');
  ring.addColorStop(pupil / (iris * 1.12) + 0.02, shade(-0.12));
  ring.addColorStop(0.62, shade(0));
  ring.addColorStop(0.86, shade(-0.2));
  ring.addColorStop(0.9, shade(-0.36));
  ring.addColorStop(1, 'rgba(15,49,70,0)');
  g.fillStyle = ring;
  g.fillRect(0, 0, w, iris * 1.12);
  // Fibres across the iris.
  for (let x = 0; x < w; x += 3) {
    g.fillStyle = `rgba(${x % 2 ? '200,245,255' : '10,60,90'},0.22)`;
    g.fillRect(x, pupil + 2, 1, iris - pupil - 4);
  }
  g.fillStyle = '#05080c';
  g.fillRect(0, 0, w, pupil);
  const t = new THREE.CanvasTexture(c);
  t.colorSpace = THREE.SRGBColorSpace;
  t.anisotropy = 4;
  return t;
}

const shown = (colour) => new THREE.MeshBasicMaterial({
  color: new THREE.Color(colour), side: THREE.DoubleSide, toneMapped: false,
});

export const EYES = '#38c2e8';

export function makeMaterials() {
  const eyeMap = eyeTexture(EYES);
  return {
    shell: new THREE.MeshStandardMaterial({ color: 0xeef1f5, roughness: 0.32, metalness: 0.0 }),
    trim: new THREE.MeshStandardMaterial({ color: 0x9aa6b5, roughness: 0.35, metalness: 0.55 }),
    metal: new THREE.MeshStandardMaterial({ color: 0x3b4350, roughness: 0.4, metalness: 0.7 }),
    screen: new THREE.MeshStandardMaterial({ color: 0x0c1420, roughness: 0.14, metalness: 0.25 }),
    lid: new THREE.MeshStandardMaterial({ color: 0x5d6a78, roughness: 0.3, metalness: 0.4, side: THREE.DoubleSide }),
    eye: new THREE.MeshStandardMaterial({
      map: eyeMap, roughness: 0.08, metalness: 0, emissive: 0xffffff, emissiveMap: eyeMap, emissiveIntensity: 0.18,
    }),
    // The screen's drawings: exact colours, both sides (strips run either way).
    glow: shown(GLOW),
    lips: shown(GLOW),
    inside: shown(0x3a0f22),
    teeth: shown(0xe9f7ff),
    tongue: shown(0xff7d96),
  };
}

// The light's and the irises' colours (websocket-ui's avatar_light and avatar_eyes, "#rrggbb"):
// the light goes into `light`, which the avatar scales each frame.
export function setColours(materials, light, { light: glow, eyes } = {}) {
  if (glow) {
    light.set(glow);
    materials.lips.color.set(glow);
  }
  if (eyes) {
    const map = eyeTexture(eyes);
    materials.eye.map.dispose();
    materials.eye.map = map;
    materials.eye.emissiveMap = map;
    materials.eye.needsUpdate = true;
  }
}

// A studio to reflect: a dim room with a large warm panel up right, a cool one on the left and
// a strip behind, prefiltered for the materials' roughness.
export function makeEnvironment(renderer) {
  const room = new THREE.Scene();
  const walls = new THREE.Mesh(new THREE.BoxGeometry(20, 12, 20),
    new THREE.MeshBasicMaterial({ color: 0x2a3038, side: THREE.BackSide }));
  room.add(walls);
  const panel = (w, h, colour, intensity, position) => {
    const m = new THREE.Mesh(new THREE.PlaneGeometry(w, h),
      new THREE.MeshBasicMaterial({ color: new THREE.Color(colour).multiplyScalar(intensity), side: THREE.DoubleSide }));
    m.position.set(...position);
    m.lookAt(0, 0, 0);
    room.add(m);
  };
  panel(7, 5, 0xfff1e0, 4, [6, 4, 7]);
  panel(5, 6, 0xdfeaff, 1.6, [-8, 1, 5]);
  panel(10, 1.5, 0xffffff, 2.5, [0, 5, -8]);
  panel(12, 3, 0x8090a0, 0.8, [0, -5.5, 3]);
  const pmrem = new THREE.PMREMGenerator(renderer);
  const env = pmrem.fromScene(room, 0.02).texture;
  pmrem.dispose();
  return env;
}

// Whether WebGL is drawn in software (SwiftShader, llvmpipe): then the avatar starts without
// multisampling and reflections, and lowers its resolution until it keeps up.
export function softwareRenderer() {
  try {
    const gl = document.createElement('canvas').getContext('webgl2');
    const info = gl?.getExtension('WEBGL_debug_renderer_info');
    const name = info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : '';
    gl?.getExtension('WEBGL_lose_context')?.loseContext();
    return /swiftshader|llvmpipe|softpipe|software/i.test(name);
  } catch {
    return false;
  }
}

export function addLights(scene) {
  scene.add(new THREE.HemisphereLight(0xdfe8ff, 0x202430, 0.5));
  const key = new THREE.DirectionalLight(0xfff0e0, 1.6);
  key.position.set(3, 4, 5);
  const fill = new THREE.DirectionalLight(0xcfe0ff, 0.55);
  fill.position.set(-5, 1, 3);
  const rim = new THREE.DirectionalLight(0xffffff, 1.1);
  rim.position.set(-1, 3, -5);
  scene.add(key, fill, rim);
}
