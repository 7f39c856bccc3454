// The network page's graph: flows (boxes) and channels (pills) in SVG, edges publisher -> channel
// -> subscriber with live rates. Laid out again only when the topology changes; otherwise the
// rates, classes and titles are updated in place. Drag to pan, wheel to zoom, click to select.
import { layout } from './network-model.js';

const SVG = 'http://www.w3.org/2000/svg';
const NODE_W = 200;
const NODE_H = 22;
const MAX_LABEL = 30;

function el(name, attrs = {}, parent = null) {
  const e = document.createElementNS(SVG, name);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (parent) parent.appendChild(e);
  return e;
}

const shorten = (s) => (s.length > MAX_LABEL ? `${s.slice(0, MAX_LABEL - 1)}…` : s);

export class NetworkGraph extends EventTarget {
  constructor(svg) {
    super();
    this.svg = svg;
    this.view = { x: -20, y: -20, scale: 1 };
    this.edgeLayer = el('g', { class: 'edges' }, svg);
    this.nodeLayer = el('g', { class: 'nodes' }, svg);
    this.topology = '';
    this.nodeEls = new Map();
    this.edgeEls = new Map();
    this.selected = null;
    this.size = { width: 0, height: 0 };
    this.panning = null;
    svg.addEventListener('wheel', (e) => {
      e.preventDefault();
      const k = Math.exp(-e.deltaY * 0.0015);
      const r = svg.getBoundingClientRect();
      const px = this.view.x + (e.clientX - r.left) / this.view.scale;
      const py = this.view.y + (e.clientY - r.top) / this.view.scale;
      this.view.scale = Math.min(4, Math.max(0.1, this.view.scale * k));
      this.view.x = px - (e.clientX - r.left) / this.view.scale;
      this.view.y = py - (e.clientY - r.top) / this.view.scale;
      this.applyView();
    }, { passive: false });
    svg.addEventListener('pointerdown', (e) => {
      this.panning = { x: e.clientX, y: e.clientY, vx: this.view.x, vy: this.view.y, moved: false };
    });
    svg.addEventListener('pointermove', (e) => {
      const p = this.panning;
      if (!p) return;
      if (Math.abs(e.clientX - p.x) + Math.abs(e.clientY - p.y) > 3) p.moved = true;
      this.view.x = p.vx - (e.clientX - p.x) / this.view.scale;
      this.view.y = p.vy - (e.clientY - p.y) / this.view.scale;
      this.applyView();
    });
    svg.addEventListener('pointerup', (e) => {
      const moved = this.panning?.moved;
      this.panning = null;
      if (moved) return;
      const node = e.target.closest?.('.node');
      this.select(node ? node.dataset.id : null);
    });
    this.applyView();
  }

  applyView() {
    const r = this.svg.getBoundingClientRect();
    const w = (r.width || 800) / this.view.scale;
    const h = (r.height || 600) / this.view.scale;
    this.svg.setAttribute('viewBox', `${this.view.x} ${this.view.y} ${w} ${h}`);
  }

  // Zooms so that the whole graph shows.
  fit() {
    const r = this.svg.getBoundingClientRect();
    const w = this.size.width + NODE_W;
    const h = this.size.height + NODE_H;
    this.view.scale = Math.min(1.5, Math.max(0.1, Math.min((r.width || 800) / (w + 40), (r.height || 600) / (h + 40))));
    this.view.x = -20;
    this.view.y = -20;
    this.applyView();
  }

  select(id) {
    this.selected = id;
    for (const [nid, g] of this.nodeEls) g.classList.toggle('selected', nid === id);
    this.dispatchEvent(new CustomEvent('select', { detail: id }));
  }

  update(graph) {
    if (graph.topology !== this.topology) this.rebuild(graph);
    for (const [id, n] of graph.nodes) {
      const g = this.nodeEls.get(id);
      if (!g) continue;
      g.setAttribute('class', ['node', n.type, ...n.cls, ...(id === this.selected ? ['selected'] : [])].join(' '));
      g.querySelector('title').textContent = n.title;
    }
    for (const e of graph.edges) {
      const parts = this.edgeEls.get(e.id);
      if (!parts) continue;
      parts.path.setAttribute('class', ['edge', e.kind, ...(e.service ? ['service'] : []), ...e.cls].join(' '));
      parts.path.setAttribute('stroke-width', e.width.toFixed(2));
      if (parts.label) parts.label.textContent = e.label;
    }
  }

  rebuild(graph) {
    const first = this.topology === '';
    this.topology = graph.topology;
    const { pos, width, height } = layout(graph);
    this.size = { width, height };
    this.nodeLayer.replaceChildren();
    this.edgeLayer.replaceChildren();
    this.nodeEls.clear();
    this.edgeEls.clear();
    for (const e of graph.edges) {
      const a = pos.get(e.from);
      const b = pos.get(e.to);
      if (!a || !b) continue;
      const x1 = a.x + NODE_W;
      const y1 = a.y + NODE_H / 2;
      const x2 = b.x;
      const y2 = b.y + NODE_H / 2;
      const dx = Math.max(40, Math.abs(x2 - x1) / 2);
      const path = el('path', {
        d: `M${x1},${y1} C${x1 + dx},${y1} ${x2 - dx},${y2} ${x2},${y2}`,
        'data-id': e.id, 'data-from': e.from, 'data-to': e.to,
      }, this.edgeLayer);
      let label = null;
      if (e.kind === 'publish') {
        // Beside the channel, where the edges of a wrapped layer do not cross it.
        label = el('text', { class: 'edge-label', x: x2 - 6, y: y2 - 4, 'text-anchor': 'end', 'data-edge': e.id }, this.edgeLayer);
      }
      this.edgeEls.set(e.id, { path, label });
    }
    for (const [id, n] of graph.nodes) {
      const p = pos.get(id);
      const g = el('g', { transform: `translate(${p.x},${p.y})`, 'data-id': id, 'data-name': n.label }, this.nodeLayer);
      el('title', {}, g);
      const r = n.type === 'channel' ? NODE_H / 2 : 4;
      el('rect', { width: NODE_W, height: NODE_H, rx: r, ry: r }, g);
      const t = el('text', { x: 8, y: NODE_H / 2 + 4 }, g);
      t.textContent = shorten(n.label);
      this.nodeEls.set(id, g);
    }
    if (this.selected && !graph.nodes.has(this.selected)) this.select(null);
    if (first) this.fit();
  }
}
