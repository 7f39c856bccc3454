// SPDX-License-Identifier: Apache-2.0
// The avatar's motion in node (web/js/avatar-motion.js, no browser): the visemes are websocket-ui's
// (plugins/websocket-ui/src/visemes.h), lip sync blends into the next shape ahead of its time
// (coarticulation), expressions ease in and out, and the idle saccades keep their bounds.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import {
  BLEND_MS, EXPRESSIONS, ExpressionBlend, expressionName, Idle, LEAD_MS, VISEME_NAMES, visemeWeights,
} from '../../web/js/avatar-motion.js';

const sum = (w) => Object.values(w).reduce((a, b) => a + b, 0);

test("the page's visemes are websocket-ui's, in its order", () => {
  const header = readFileSync(new URL('../../plugins/websocket-ui/src/visemes.h', import.meta.url), 'utf8');
  const list = header.match(/kVisemeNames[^{]*\{([^}]*)\}/);
  assert.ok(list, 'kVisemeNames in visemes.h');
  const names = [...list[1].matchAll(/"([^"]+)"/g)].map((m) => m[1]);
  assert.deepEqual(VISEME_NAMES, names);
  assert.ok(VISEME_NAMES.length >= 12);
});

test('lip sync: each shape is anticipated, reached, and a short one between two only partly', () => {
  const timeline = [{ t_ms: 0, v: 'PP' }, { t_ms: 200, v: 'aa' }, { t_ms: 240, v: 'FF' }, { t_ms: 500, v: 'sil' }];
  // Before anything: at rest.
  assert.equal(visemeWeights(timeline, -LEAD_MS - 1).weights.sil, 1);
  // PP reached once its blend is over, well before aa's lead.
  let w = visemeWeights(timeline, 100).weights;
  assert.equal(w.PP, 1);
  // aa begins LEAD_MS ahead of its time: soon after, PP and aa are both there.
  w = visemeWeights(timeline, 200 - LEAD_MS + 35).weights;
  assert.ok(w.aa > 0.25 && w.aa < 0.4 && w.PP > 0.6 && w.FF === 0, JSON.stringify(w));
  assert.ok(Math.abs(sum(w) - 1) < 1e-9);
  // aa lasts 40 ms: FF takes over before aa was fully reached.
  const peak = Math.max(...[150, 170, 190, 200, 210].map((ms) => visemeWeights(timeline, ms).weights.aa));
  assert.ok(peak < 1, `aa peaks at ${peak}`);
  w = visemeWeights(timeline, 240 - LEAD_MS + BLEND_MS + 1).weights;
  assert.equal(w.FF, 1);
  const r = visemeWeights(timeline, 600);
  assert.equal(r.current, 'sil');
  assert.equal(r.weights.sil, 1);
  // A viseme the page does not know is silence.
  assert.equal(visemeWeights([{ t_ms: 0, v: 'XX' }], 500).weights.sil, 1);
});

test('expressions ease in (about 0.15 s) and out; aliases name them', () => {
  const b = new ExpressionBlend();
  assert.equal(b.weights.neutral, 1);
  b.update('happy', 1, 0.15);
  assert.ok(b.weights.happy > 0.6 && b.weights.happy < 0.65, `${b.weights.happy}`);
  for (let i = 0; i < 30; i++) b.update('happy', 1, 1 / 30);
  assert.ok(b.weights.happy > 0.99 && b.weights.neutral < 0.05, JSON.stringify(b.weights));
  assert.ok(b.sum('brows', 'raise') > 0.3);
  b.update('sad', 1, 0.05);
  assert.ok(b.weights.happy > 0.8, 'going out slower than coming in');
  assert.deepEqual(Object.keys(EXPRESSIONS), ['neutral', 'happy', 'surprised', 'thinking', 'listening', 'sad']);
  assert.equal(expressionName('smile'), 'happy');
  assert.equal(expressionName('surprise'), 'surprised');
  assert.equal(expressionName('thinking'), 'thinking');
  assert.equal(expressionName('angry'), null);
});

test('idle: saccades every 0.4 to 2.8 s, mostly small while a face is watched; replayable', () => {
  const run = (seed, face) => {
    const idle = new Idle(seed);
    const jumps = [];
    let last = null;
    for (let t = 0; t < 120000; t += 10) {
      const o = idle.update(t, face).offset;
      if (o !== last) {
        jumps.push({ t, o });
        last = o;
      }
    }
    return jumps;
  };
  const jumps = run(3, true);
  const gaps = jumps.slice(1).map((j, i) => j.t - jumps[i].t);
  assert.ok(Math.min(...gaps) >= 400 && Math.max(...gaps) <= 2810, `${Math.min(...gaps)}..${Math.max(...gaps)}`);
  const far = jumps.filter((j) => Math.abs(j.o[0]) > 0.06).length / jumps.length;
  assert.ok(far > 0.1 && far < 0.3, `far glances ${far}`);
  assert.deepEqual(run(3, true).map((j) => j.t), jumps.map((j) => j.t), 'the same seed, the same saccades');
  const b = new Idle(1).update(1000, false).breath;
  assert.ok(b >= -1 && b <= 1);
});
