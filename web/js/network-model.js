// SPDX-License-Identifier: Apache-2.0
// The network page's model: hub.stats (docs/observability.md) as a graph of flows and channels,
// and its layered layout. Pure functions, no DOM: tests/web/network_model.test.mjs runs them in node.

// A flow whose output queue is above this fraction of the hub's limit is slow.
export const SLOW_QUEUE_FILL = 0.5;

export function formatRate(hz, bytesPerS) {
  const h = hz >= 10 ? Math.round(hz) : Math.round(hz * 10) / 10;
  return `${h} Hz · ${formatBytes(bytesPerS)}/s`;
}

export function formatBytes(n) {
  if (n >= 1e6) return `${(n / 1e6).toFixed(1)} MB`;
  if (n >= 1e3) return `${(n / 1e3).toFixed(1)} kB`;
  return `${Math.round(n)} B`;
}

// A value as JSON text: 64-bit integers (BigInt) as numbers when exact, else as strings; typed
// arrays as arrays.
export function jsonText(value, indent) {
  return JSON.stringify(value, (k, v) => {
    if (typeof v === 'bigint') return Number.isSafeInteger(Number(v)) ? Number(v) : v.toString();
    if (ArrayBuffer.isView(v)) return Array.from(/** @type {any} */ (v));
    return v;
  }, indent);
}

const isHubOwn = (name) => name.startsWith('hub.');

// The path the i-th of a channel's subscriber_flows takes (subscriber_paths): 'relay' through the
// hub, or the 'direct' or 'shm' path of physical mode; 'relay' from a hub that does not say.
export function subscriberPath(channel, i) {
  const p = (channel.subscriber_paths || [])[i];
  return p === 'direct' || p === 'shm' ? p : 'relay';
}
export function pathLabel(path) {
  return path === 'shm' ? 'shared memory' : path === 'direct' ? 'direct' : '';
}

// {nodes: Map(id -> node), edges: [edge], topology: string}. Node ids are "f:<flow id>" and
// "c:<channel name>"; a node is {id, type: 'flow'|'channel', label, title, cls: [], data}; an edge
// is {id, from, to, kind: 'publish'|'subscribe', service, label, width, cls: []}. The hub's own
// statistics client and channels are left out unless showHub; `filter` keeps the channels and
// flows whose name contains it, with what they connect to.
export function buildGraph(stats, { showHub = false, filter = '' } = {}) {
  const flows = new Map();
  for (const f of stats.flows || []) {
    if (!showHub && f.user === 'hub') continue;
    flows.set(f.id, f);
  }
  const needle = filter.trim().toLowerCase();
  const matches = (s) => !needle || s.toLowerCase().includes(needle);
  const nodes = new Map();
  const edges = [];
  const flowNode = (f) => {
    const id = `f:${f.id}`;
    if (!nodes.has(id)) {
      const slow = f.queue_fill > SLOW_QUEUE_FILL || f.dropped_per_s > 0;
      nodes.set(id, {
        id, type: 'flow', label: f.name, title: `${f.name} (${f.kind}, flow ${f.id})`,
        cls: [f.kind, ...(slow ? ['slow'] : [])], data: f,
      });
    }
    return id;
  };
  for (const c of stats.channels || []) {
    if (!showHub && isHubOwn(c.name)) continue;
    const owner = flows.get(c.owner_flow);
    const subs = (c.subscriber_flows || []).map((id) => flows.get(id)).filter(Boolean);
    if (needle && !matches(c.name) && !(owner && matches(owner.name)) &&
        !subs.some((f) => matches(f.name))) continue;
    const id = `c:${c.name}`;
    const dropping = c.dropped_per_s > 0;
    const cls = [c.kind];
    if (dropping) cls.push('drop');
    if (!(c.hz > 0)) cls.push('idle');
    if (!owner) cls.push('orphan');
    nodes.set(id, { id, type: 'channel', label: c.name, title: `${c.name} (${c.kind}, ${c.mime || 'no mime'})`, cls, data: c });
    const service = c.kind === 'service';
    if (owner) {
      edges.push({
        id: `p:${c.name}`, from: flowNode(owner), to: id, kind: 'publish', service,
        label: formatRate(c.hz || 0, c.bytes_per_s || 0),
        width: Math.min(6, 1 + Math.log10(1 + (c.bytes_per_s || 0) / 1000)),
        cls: dropping ? ['drop'] : [],
      });
    }
    const pathOf = new Map((c.subscriber_flows || []).map((fid, i) => [fid, subscriberPath(c, i)]));
    for (const f of subs) {
      const slow = f.queue_fill > SLOW_QUEUE_FILL || f.dropped_per_s > 0;
      const path = pathOf.get(f.id);
      const cls = dropping && slow ? ['drop'] : [];
      if (path !== 'relay') cls.push(`path-${path}`);
      edges.push({
        id: `s:${c.name}>${f.id}`, from: id, to: flowNode(f), kind: 'subscribe', service,
        label: pathLabel(path), width: 1, cls,
      });
    }
  }
  // Flows that own and follow nothing (a flowctl, a sync connection) still show.
  for (const f of flows.values()) if (!needle || matches(f.name)) flowNode(f);
  const topology = [...nodes.keys()].sort().join('|') + '#' + edges.map((e) => e.id).sort().join('|');
  return { nodes, edges, topology };
}

// Layered layout, left to right: cycles broken at their back edges (depth first), each node one
// layer right of its farthest predecessor, then the order within layers by the mean position of
// the neighbours (a few sweeps each way). Then it is shaped to the pane: a layer longer than
// `rows` is split into columns side by side, and the columns wrap into bands stacked top to
// bottom, `rows` and the bands chosen so that the drawing, scaled to fit `pane` (its width and
// height in pixels, with `margin` units around the drawing, at most `maxScale` pixels a unit), is
// as large as it can be. A band starts only at a column without publishers' edges coming in
// (their rates are drawn left of the channel), so nothing sticks out on the left. Sizes are in
// the drawing's units: nodes of `nodeWidth` x `nodeHeight`, `colGap` between columns, `rowGap`
// between rows, `bandGap` between bands. {pos: Map(id -> {x, y, layer, band}), width, height,
// scale}: the top left corners of the nodes, the extent of the drawing, and the scale that fits it.
export function layout(graph, {
  pane = { width: 1280, height: 720 }, margin = 0, maxScale = Infinity,
  nodeWidth = 200, nodeHeight = 22, colGap = 100, rowGap = 6, bandGap = 24, sweeps = 4,
} = {}) {
  const ids = [...graph.nodes.keys()].sort();
  const out = new Map(ids.map((id) => [id, []]));
  const inn = new Map(ids.map((id) => [id, []]));
  for (const e of graph.edges) {
    if (e.from === e.to || !out.has(e.from) || !out.has(e.to)) continue;
    out.get(e.from).push(e.to);
    inn.get(e.to).push(e.from);
  }
  // Back edges, found iteratively (200+ nodes deep would be fine recursively; a pathological
  // chain would not). The search starts from the flows, the most source-like first (more
  // published than followed), so that a channel is only ever reached from its owner: publishers
  // stay left of their channels, and only a subscription closes a cycle.
  const state = new Map();  // 1 on the stack, 2 done
  const back = new Set();
  const flowFirst = (id) => (graph.nodes.get(id).type === 'flow' ? 0 : 1);
  const roots = [...ids].sort((a, b) => flowFirst(a) - flowFirst(b) ||
    (inn.get(a).length - out.get(a).length) - (inn.get(b).length - out.get(b).length) || (a < b ? -1 : 1));
  for (const root of roots) {
    if (state.has(root)) continue;
    const stack = [[root, 0]];
    state.set(root, 1);
    while (stack.length) {
      const top = stack[stack.length - 1];
      const next = out.get(top[0])[top[1]++];
      if (next === undefined) {
        state.set(top[0], 2);
        stack.pop();
      } else if (state.get(next) === 1) {
        back.add(`${top[0]}>${next}`);
      } else if (!state.has(next)) {
        state.set(next, 1);
        stack.push([next, 0]);
      }
    }
  }
  const forward = (from, to) => !back.has(`${from}>${to}`);
  // Longest path from the sources, in topological order (Kahn).
  const indeg = new Map(ids.map((id) => [id, inn.get(id).filter((p) => forward(p, id)).length]));
  const layer = new Map(ids.map((id) => [id, 0]));
  const queue = ids.filter((id) => indeg.get(id) === 0);
  for (let i = 0; i < queue.length; i++) {
    const n = queue[i];
    for (const m of out.get(n)) {
      if (!forward(n, m)) continue;
      layer.set(m, Math.max(layer.get(m), layer.get(n) + 1));
      indeg.set(m, indeg.get(m) - 1);
      if (indeg.get(m) === 0) queue.push(m);
    }
  }
  const layers = [];
  for (const id of ids) {
    const l = layer.get(id);
    (layers[l] ||= []).push(id);
  }
  for (let l = 0; l < layers.length; l++) layers[l] ||= [];
  const index = new Map();
  const renumber = () => layers.forEach((list) => list.forEach((id, i) => index.set(id, i / Math.max(1, list.length - 1))));
  renumber();
  const mean = (list, fallback) => (list.length ? list.reduce((a, id) => a + index.get(id), 0) / list.length : fallback);
  for (let s = 0; s < sweeps; s++) {
    const down = s % 2 === 0;
    const order = down ? layers.keys() : [...layers.keys()].reverse();
    for (const l of order) {
      const neighbours = (id) => (down ? inn.get(id) : out.get(id)).filter((n) => (down ? layer.get(n) < l : layer.get(n) > l));
      const key = new Map(layers[l].map((id) => [id, mean(neighbours(id), index.get(id))]));
      layers[l].sort((a, b) => key.get(a) - key.get(b) || (a < b ? -1 : 1));
      renumber();
    }
  }
  const labelledIn = new Set(graph.edges.filter((e) => e.kind === 'publish').map((e) => e.to));
  const sizes = { pane, margin, maxScale, nodeWidth, nodeHeight, colGap, rowGap, bandGap };
  const shape = chooseShape(layers.map((list) => ({ n: list.length, open: !list.some((id) => labelledIn.has(id)) })), sizes);
  const colPitch = nodeWidth + colGap;
  const rowPitch = nodeHeight + rowGap;
  const pos = new Map();
  let top = 0;
  let width = 0;
  shape.bands.forEach((band, b) => {
    band.forEach((col, c) => {
      const list = layers[col.layer].slice(col.from, col.from + col.n);
      const y0 = top + ((band.rows - col.n) * rowPitch) / 2;
      list.forEach((id, i) => pos.set(id, { x: c * colPitch, y: y0 + i * rowPitch, layer: col.layer, band: b }));
    });
    width = Math.max(width, band.length * colPitch - colGap);
    top += band.rows * rowPitch - rowGap + bandGap;
  });
  return { pos, width, height: Math.max(0, top - bandGap), scale: shape.scale };
}

// Whether shape `a` beats `b`: larger, but with more bands only when more than 5% larger.
function better(a, b) {
  if (a.bands.length === b.bands.length) return a.scale > b.scale;
  return a.bands.length < b.bands.length ? a.scale * 1.05 >= b.scale : a.scale > b.scale * 1.05;
}

// The columns of layers of `n` nodes split with at most `rows` a column (evenly), in order:
// [{layer, from, n, open}], `open` for the first column of a layer whose nodes have no
// publishers' edges coming in (a band may start there).
function splitLayers(layers, rows) {
  const columns = [];
  layers.forEach(({ n, open }, layer) => {
    const k = Math.max(1, Math.ceil(n / rows));
    const per = Math.ceil(n / k);
    for (let c = 0; c < k; c++) {
      columns.push({ layer, from: c * per, n: Math.max(0, Math.min(per, n - c * per)), open: open && c === 0 });
    }
  });
  return columns;
}

// The columns wrapped into bands of `perBand` columns, each broken at the last column where a
// band may start (longer than `perBand` when there is none): [[column, ...] with .rows].
function wrapColumns(columns, perBand) {
  const bands = [];
  let i = 0;
  while (i < columns.length) {
    let end = Math.min(columns.length, i + perBand);
    if (end < columns.length && !columns[end].open) {
      let back = end;
      while (back > i + 1 && !columns[back].open) back--;
      if (columns[back].open) end = back;
      else while (end < columns.length && !columns[end].open) end++;
    }
    const band = columns.slice(i, end);
    band.rows = Math.max(1, ...band.map((c) => c.n));
    bands.push(band);
    i = end;
  }
  return bands;
}

// The shape of the drawing for layers [{n, open}] (sizes as layout's): {rows, bands, scale},
// the one that fits the pane at the largest scale. One with more bands must be more than 5%
// larger to be chosen (edges between bands are long): so a graph that fits at maxScale anyway
// keeps its fewest bands.
function chooseShape(layers, { pane, margin, maxScale, nodeWidth, nodeHeight, colGap, rowGap, bandGap }) {
  const longest = Math.max(1, ...layers.map((l) => l.n));
  // A layer in at most 40 columns: the distinct splits of the longest layer.
  const candidates = new Set();
  for (let k = 1; k <= Math.min(40, longest); k++) candidates.add(Math.ceil(longest / k));
  let best = null;
  for (const rows of candidates) {
    const columns = splitLayers(layers, rows);
    let lastCount = 0;
    for (let perBand = columns.length; perBand >= 1; perBand--) {
      const bands = wrapColumns(columns, perBand);
      if (bands.length === lastCount) continue;
      lastCount = bands.length;
      const w = Math.max(...bands.map((b) => b.length)) * (nodeWidth + colGap) - colGap;
      const h = bands.reduce((sum, b) => sum + b.rows * (nodeHeight + rowGap) - rowGap, 0) +
        (bands.length - 1) * bandGap;
      const scale = Math.min(maxScale, pane.width / (w + 2 * margin), pane.height / (h + 2 * margin));
      if (!best || better({ bands, scale }, best)) best = { rows, bands, scale };
    }
  }
  return best;
}

// The boxes of a detector's message, in its frame's pixels: faces and motion regions as
// {x, y, w, h}, codes as their corners' bounding box, with a label.
export function detectionBoxes(msg) {
  const boxes = [];
  if (!msg || typeof msg !== 'object') return boxes;
  for (const f of Array.isArray(msg.faces) ? msg.faces : []) {
    boxes.push({ x: f.x, y: f.y, w: f.w, h: f.h, label: f.score !== undefined ? `face ${Number(f.score).toFixed(2)}` : 'face' });
  }
  for (const r of Array.isArray(msg.regions) ? msg.regions : []) boxes.push({ x: r.x, y: r.y, w: r.w, h: r.h, label: 'motion' });
  for (const c of Array.isArray(msg.codes) ? msg.codes : []) {
    if (!Array.isArray(c.corners) || !c.corners.length) continue;
    const xs = c.corners.map((p) => p[0]);
    const ys = c.corners.map((p) => p[1]);
    const x = Math.min(...xs);
    const y = Math.min(...ys);
    boxes.push({ x, y, w: Math.max(...xs) - x, h: Math.max(...ys) - y, label: String(c.text ?? c.type ?? 'code').slice(0, 40) });
  }
  return boxes.filter((b) => [b.x, b.y, b.w, b.h].every(Number.isFinite));
}
