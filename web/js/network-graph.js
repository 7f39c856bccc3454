// SPDX-License-Identifier: Apache-2.0
// The network page's graph: flows (boxes) and channels (pills) in SVG, edges publisher -> channel
// -> subscriber with live rates. Laid out for the pane's size when the topology changes (and by
// "fit" when the pane's size changed); otherwise the rates, classes and titles are updated in
// place. Drag to pan, wheel to zoom (at most MAX_ZOOM_STEP a wheel event), click to select.
import { layout } from './network-model.js';

const SVG = 'http://www.w3.org/2000/svg';
const NODE_W = 200;
const NODE_H = 22;
const MAX_LABEL = 30;
const MARGIN = 12;        // around the graph at "fit", in the drawing's units
const MAX_FIT_SCALE = 2;  // "fit" does not blow a small graph up further
const ZOOM_STEP = 1.2;    // the zoom of one notch of a mouse wheel (100 pixels)...
const MAX_ZOOM_STEP = 1.25;  // ... and of any one wheel event, whatever its delta
// How far the pane's width or height may drift from those the graph was laid out for before
// "fit" lays it out again.
const RELAYOUT_DRIFT = 1.15;

// A wheel event's delta in pixels (Firefox counts lines, some mice pages).
const wheelPixels = (e) => e.deltaY * (e.deltaMode === 1 ? 40 : e.deltaMode === 2 ? 800 : 1);
// The zoom factor of one wheel event: ZOOM_STEP per 100 pixels, capped at MAX_ZOOM_STEP.
export function wheelZoom(e) {
  const k = Math.exp((-wheelPixels(e) / 100) * Math.log(ZOOM_STEP));
  return Math.min(MAX_ZOOM_STEP, Math.max(1 / MAX_ZOOM_STEP, k));
}

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
    this.graph = null;
    this.laidOutFor = null;  // the pane's size the graph was laid out for
    this.fitted = true;  // the view is "fit": kept so when the pane changes size
    this.panning = null;
    svg.addEventListener('wheel', (e) => {
      e.preventDefault();
      const k = wheelZoom(e);
      this.fitted = false;
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
      if (Math.abs(e.clientX - p.x) + Math.abs(e.clientY - p.y) > 3) {
        p.moved = true;
        this.fitted = false;
      }
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
    new ResizeObserver(() => {
      if (this.fitted) this.fit();
      else this.applyView();
    }).observe(svg);
    this.applyView();
  }

  // The pane's size in pixels.
  paneSize() {
    const r = this.svg.getBoundingClientRect();
    return { width: r.width || 800, height: r.height || 600 };
  }

  applyView() {
    const r = this.svg.getBoundingClientRect();
    const w = (r.width || 800) / this.view.scale;
    const h = (r.height || 600) / this.view.scale;
    this.svg.setAttribute('viewBox', `${this.view.x} ${this.view.y} ${w} ${h}`);
  }

  // Zooms so that the whole graph shows, centred; lays it out again first if the pane's size
  // changed since it was.
  fit() {
    const { width: pw, height: ph } = this.paneSize();
    const was = this.laidOutFor;
    const drift = (a, b) => Math.max(a / b, b / a) > RELAYOUT_DRIFT;
    if (this.graph && was && (drift(pw, was.width) || drift(ph, was.height))) this.rebuild(this.graph);
    const { width, height } = this.size;
    this.view.scale = Math.min(MAX_FIT_SCALE, Math.max(0.1,
      Math.min(pw / (width + 2 * MARGIN), ph / (height + 2 * MARGIN))));
    this.view.x = (width - pw / this.view.scale) / 2;
    this.view.y = (height - ph / this.view.scale) / 2;
    this.fitted = true;
    this.applyView();
  }

  select(id) {
    this.selected = id;
    for (const [nid, g] of this.nodeEls) g.classList.toggle('selected', nid === id);
    this.dispatchEvent(new CustomEvent('select', { detail: id }));
  }

  update(graph) {
    this.graph = graph;
    if (graph.topology !== this.topology) this.rebuild(graph);
    else this.refresh(graph);
  }

  // Classes, titles, widths and rates of what is drawn.
  refresh(graph) {
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
    this.topology = graph.topology;
    this.laidOutFor = this.paneSize();
    const { pos, width, height } = layout(graph, {
      pane: this.laidOutFor, margin: MARGIN, maxScale: MAX_FIT_SCALE, nodeWidth: NODE_W, nodeHeight: NODE_H,
    });
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
      // An edge to a later band, or back along a cycle, runs right to left: a gentle S across,
      // not a loop around the whole band.
      const dx = x2 > x1 ? Math.max(40, (x2 - x1) / 2) : 40;
      const path = el('path', {
        d: `M${x1},${y1} C${x1 + dx},${y1} ${x2 - dx},${y2} ${x2},${y2}`,
        'data-id': e.id, 'data-from': e.from, 'data-to': e.to,
      }, this.edgeLayer);
      let label = null;
      if (e.kind === 'publish') {
        // Left of the channel, in the gap between the columns (layout() never starts a band with
        // such a channel, so this stays inside the drawing).
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
    this.refresh(graph);
    if (this.selected && !graph.nodes.has(this.selected)) this.select(null);
    // A view the user has not zoomed or panned (the first one too) stays fitted to what is drawn.
    if (this.fitted) this.fit();
  }
}
