// SPDX-License-Identifier: Apache-2.0
// The network page's model (web/js/network-model.js) in node: hub.stats to a graph, what is
// highlighted, the layered layout, detection boxes, the zoom of a wheel event.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { buildGraph, detectionBoxes, formatRate, layout } from '../../web/js/network-model.js';
import { wheelZoom } from '../../web/js/network-graph.js';
import { parseSetting, settingRule } from '../../web/js/network-settings.js';

const flow = (id, name, extra = {}) => ({
  id, name, user: name.split('/')[0], client: name.split('/')[1], kind: 'satellite',
  queue_fill: 0, dropped_per_s: 0, ...extra,
});
const channel = (name, owner, subs, extra = {}) => ({
  name, kind: 'streaming', mime: 'application/json', owner_flow: owner, subscriber_flows: subs,
  hz: 10, bytes_per_s: 1000, dropped_per_s: 0, ...extra,
});

const stats = {
  flows: [flow(1, 'hub/statistics'), flow(2, 'cam/cam'), flow(3, 'det/det'), flow(4, 'ui/ui', { queue_fill: 0.8 }),
    flow(5, 'flowctl/flowctl')],
  channels: [
    channel('hub.stats', 1, [4]),
    channel('cam.frames', 2, [3, 4], { dropped_per_s: 2, bytes_per_s: 2e6 }),
    channel('det.faces', 3, [4]),
    channel('det.cmd', 3, [], { kind: 'service', hz: 0 }),
    channel('gone.maps', 0, [], { kind: 'blob', hz: 0 }),
  ],
};

test('flows and channels become nodes, ownership and subscriptions edges', () => {
  const g = buildGraph(stats);
  assert.deepEqual([...g.nodes.keys()].sort(),
    ['c:cam.frames', 'c:det.cmd', 'c:det.faces', 'c:gone.maps', 'f:2', 'f:3', 'f:4', 'f:5']);
  assert.deepEqual(g.edges.map((e) => `${e.from}>${e.to}`).sort(),
    ['c:cam.frames>f:3', 'c:cam.frames>f:4', 'c:det.faces>f:4', 'f:2>c:cam.frames', 'f:3>c:det.cmd', 'f:3>c:det.faces']);
  const pub = g.edges.find((e) => e.id === 'p:cam.frames');
  assert.equal(pub.label, '10 Hz · 2.0 MB/s');
  assert.ok(pub.width > g.edges.find((e) => e.id === 'p:det.faces').width, 'wider for more bytes');
  assert.equal(g.edges.find((e) => e.id === 'p:det.cmd').service, true);
});

test('drops, slow subscribers, idle and orphaned channels are marked', () => {
  const g = buildGraph(stats);
  assert.ok(g.nodes.get('c:cam.frames').cls.includes('drop'));
  assert.ok(!g.nodes.get('c:det.faces').cls.includes('drop'));
  assert.ok(g.nodes.get('f:4').cls.includes('slow'), 'queue 80% full');
  assert.ok(!g.nodes.get('f:3').cls.includes('slow'));
  assert.deepEqual(g.edges.filter((e) => e.cls.includes('drop')).map((e) => e.id).sort(),
    ['p:cam.frames', 's:cam.frames>4'], 'the dropping channel and its slow subscriber');
  assert.ok(g.nodes.get('c:det.cmd').cls.includes('idle'));
  assert.ok(g.nodes.get('c:gone.maps').cls.includes('orphan'));
});

test('subscribers on a direct or shared-memory path are drawn as such', () => {
  const g = buildGraph({
    ...stats,
    channels: [channel('cam.frames', 2, [3, 4, 5], { subscriber_paths: ['shm', 'relay', 'direct'] })],
  });
  const edge = (to) => g.edges.find((e) => e.id === `s:cam.frames>${to}`);
  assert.ok(edge(3).cls.includes('path-shm'));
  assert.equal(edge(3).label, 'shared memory');
  assert.deepEqual(edge(4).cls, []);
  assert.equal(edge(4).label, '');
  assert.ok(edge(5).cls.includes('path-direct'));
  // A hub older than subscriber_paths: every subscriber relayed.
  assert.ok(buildGraph(stats).edges.every((e) => !e.cls.some((c) => c.startsWith('path-'))));
});

test("the hub's own channels on request; a filter keeps what it touches", () => {
  assert.ok(buildGraph(stats, { showHub: true }).nodes.has('c:hub.stats'));
  const g = buildGraph(stats, { filter: 'FACES' });
  assert.deepEqual([...g.nodes.keys()].sort(), ['c:det.faces', 'f:3', 'f:4']);
  assert.notEqual(g.topology, buildGraph(stats).topology);
  assert.equal(buildGraph(stats).topology, buildGraph({ ...stats }).topology);
});

// A publisher is left of its channel in the same band; any other edge of an acyclic graph goes
// right, or down to a later band.
function checkDirections(g, pos) {
  for (const e of g.edges) {
    const a = pos.get(e.from);
    const b = pos.get(e.to);
    if (e.kind === 'publish') assert.ok(a.band === b.band && a.x < b.x, `${e.id} goes right`);
    else assert.ok(a.band < b.band || (a.band === b.band && a.x < b.x), `${e.id} goes right or down`);
  }
}

test('the layout puts publishers left of their channels and nothing on top of anything', () => {
  const g = buildGraph(stats);
  const { pos } = layout(g);
  checkDirections(g, pos);
  const seen = new Set();
  for (const p of pos.values()) {
    const key = `${p.x},${p.y}`;
    assert.ok(!seen.has(key), `two nodes at ${key}`);
    seen.add(key);
  }
});

// The avatar demo's hub (config/default.json): 22 channels of 9 modules, and foxglove-bridge.
// owner: [channel, '!' for a service, ':' and its subscribers].
const DEMO = {
  'websocket-ui': ['camera:video-mono', 'mic:fft-audio,agent', 'say!'],
  'video-mono': ['mono:face-detect,motion,qrcode'],
  'face-detect': ['faces:websocket-ui,agent'],
  motion: ['motion:websocket-ui'],
  qrcode: ['codes:websocket-ui,agent'],
  'fft-audio': ['spectrum', 'bands:websocket-ui'],
  speech: ['voice:websocket-ui', 'phonemes:websocket-ui', 'say!'],
  'nao-bridge': ['joints', 'sonar', 'battery', 'posture', 'fall', 'status', 'results', 'command!'],
  agent: ['dialogue:websocket-ui', 'command!'],
  'foxglove-bridge': [],
};
function demoStats() {
  const ids = new Map(Object.keys(DEMO).map((name, i) => [name, i + 10]));
  const flows = [...ids].map(([name, id]) => ({ ...flow(id, `${name}/${name}`), kind: 'module' }));
  const channels = Object.entries(DEMO).flatMap(([owner, list]) => list.map((spec) => {
    const [short, subs = ''] = spec.split(':');
    return channel(`${owner}.${short.replace('!', '')}`, ids.get(owner),
      subs ? subs.split(',').map((s) => ids.get(s)) : [], short.endsWith('!') ? { kind: 'service' } : {});
  }));
  return { flows, channels };
}

test("the demo's graph fills the page's pane with labels at full size", () => {
  const g = buildGraph(demoStats());
  assert.equal([...g.nodes.values()].filter((n) => n.type === 'channel').length, 22);
  // The graph's pane on a 1280x720 and a 1920x1080 page; the page fits with a margin of 12 and
  // at most twice the size. Labels are 11 and 12 units high: at a scale of 1 or more, 11 px.
  for (const pane of [{ width: 871, height: 632 }, { width: 1475, height: 992 }]) {
    const { pos, width, height, scale } = layout(g, { pane, margin: 12, maxScale: 2 });
    assert.ok(scale >= 1, `scale ${scale} at ${pane.width}x${pane.height}`);
    const covered = (width * scale * height * scale) / (pane.width * pane.height);
    assert.ok(covered >= 0.5, `the graph covers ${covered} of ${pane.width}x${pane.height}`);
    assert.equal(pos.size, g.nodes.size);
    // Publishers left of their channels; the cycles through websocket-ui are closed by
    // subscriptions only.
    for (const e of g.edges.filter((x) => x.kind === 'publish')) {
      const a = pos.get(e.from);
      const b = pos.get(e.to);
      assert.ok(a.band === b.band && a.x < b.x, `${e.id} goes right`);
    }
  }
});

test('cycles and 1000 channels are laid out', () => {
  const flows = Array.from({ length: 50 }, (_, i) => flow(i + 10, `s${i}/s${i}`));
  const channels = Array.from({ length: 1000 }, (_, i) =>
    channel(`s${i % 50}.c${i}`, 10 + (i % 50), [10 + ((i * 7 + 1) % 50)]));
  const g = buildGraph({ flows, channels });
  const { pos, height } = layout(g, { pane: { width: 871, height: 632 } });
  assert.equal(pos.size, 1050);
  assert.ok(height > 0);
  const ys = new Set([...pos.values()].map((p) => `${p.x},${p.y}`));
  assert.equal(ys.size, 1050, 'distinct places');
});

test('detections become boxes in frame pixels', () => {
  assert.deepEqual(detectionBoxes({ faces: [{ x: 1, y: 2, w: 3, h: 4, score: 0.5 }] }),
    [{ x: 1, y: 2, w: 3, h: 4, label: 'face 0.50' }]);
  assert.deepEqual(detectionBoxes({ codes: [{ text: 'hi', corners: [[10, 10], [20, 12], [18, 30], [9, 25]] }] }),
    [{ x: 9, y: 10, w: 11, h: 20, label: 'hi' }]);
  assert.deepEqual(detectionBoxes({ regions: [{ x: 'a' }] }), []);
  assert.deepEqual(detectionBoxes(null), []);
  assert.equal(formatRate(0.25, 12), '0.3 Hz · 12 B/s');
});

test('one wheel event zooms by 1.2 a notch, never more than 1.25', () => {
  assert.equal(wheelZoom({ deltaY: -100, deltaMode: 0 }).toFixed(3), '1.200');
  assert.equal(wheelZoom({ deltaY: 100, deltaMode: 0 }).toFixed(3), (1 / 1.2).toFixed(3));
  assert.equal(wheelZoom({ deltaY: -1000, deltaMode: 0 }), 1.25, 'a fast wheel');
  assert.equal(wheelZoom({ deltaY: 1000, deltaMode: 0 }), 1 / 1.25);
  assert.ok(wheelZoom({ deltaY: -3, deltaMode: 1 }) > 1.2, 'three lines (Firefox)');
  assert.ok(wheelZoom({ deltaY: -4, deltaMode: 0 }) < 1.01, 'a touchpad');
});

test("a module's settings: each key's rule in words, and a field's text as the key's type", () => {
  assert.equal(settingRule({ key: 'period_ms', type: 'integer', min: 1n, max: 3600000n, default: 1000n }),
    'integer, 1 to 3600000, default 1000');
  assert.equal(settingRule({ key: 'mode', type: 'string', choices: ['a', 'b'], required: true }),
    'string, one of "a", "b", required');
  assert.equal(settingRule({ key: 'gain', type: 'number', min: 0.5 }), 'number, at least 0.5');
  assert.equal(parseSetting({ key: 'n', type: 'integer' }, ' 42 '), 42);
  assert.throws(() => parseSetting({ key: 'n', type: 'integer' }, '4.5'), /n: "4.5" is not an integer/);
  assert.throws(() => parseSetting({ key: 'n', type: 'number' }, ''), /is not a number/);
  assert.equal(parseSetting({ key: 'g', type: 'number' }, '2.5'), 2.5);
  assert.equal(parseSetting({ key: 's', type: 'string' }, '007'), '007');
  assert.equal(parseSetting({ key: 'b', type: 'boolean' }, false), false);
  assert.deepEqual(parseSetting({ key: 'l', type: 'array' }, '[1, "x"]'), [1, 'x']);
  assert.throws(() => parseSetting({ key: 'o', type: 'object' }, '{x'), /o: not JSON/);
});
