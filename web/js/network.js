// SPDX-License-Identifier: Apache-2.0
// The network page (/network, docs/observability.md): the hub's flows and channels as a live
// graph, a table of the busiest channels, and the selected node's details: figures, rate history,
// properties and databases (editable with the token websocket-ui's config names), a preview.
import { Link } from './link.js';
import { NetworkGraph } from './network-graph.js';
import { buildGraph, formatBytes, formatRate, pathLabel, subscriberPath } from './network-model.js';
import { Preview, splitPreview } from './network-preview.js';

const HISTORY = 120;  // seconds of rates kept per channel

const $ = (id) => document.getElementById(id);
const scheme = location.protocol === 'https:' ? 'wss' : 'ws';
const link = new Link(`${scheme}://${location.host}/ws`, 'network');
const graph = new NetworkGraph($('graph'));
const preview = new Preview($('preview'));

const state = {
  hello: null,
  stats: null,
  history: new Map(),  // channel -> [{hz, bps, dropped}]
  selected: null,      // node id
  db: '',              // the database shown
  dbPairs: new Map(),
  updates: 0,
};
// For tests and the curious: window.skrNetwork.
window.skrNetwork = state;
state.graph = graph;

function text(tag, content, cls) {
  const e = document.createElement(tag);
  if (content !== undefined) e.textContent = content;
  if (cls) e.className = cls;
  return e;
}

link.addEventListener('open', () => {
  $('status').textContent = 'connected';
  // After a reconnection: ask again for what was shown.
  if (state.selected) select(state.selected, true);
});
link.addEventListener('close', () => { $('status').textContent = 'disconnected, retrying…'; });
link.addEventListener('command', (e) => onMessage(e.detail));
link.addEventListener('binary', async (e) => {
  if (!state.hello) return;  // the avatar's messages before the hub knew this page
  const p = splitPreview(e.detail);
  if (p) await preview.take(p.name, p.payload);
});

function onMessage(msg) {
  switch (msg.type) {
    case 'network_hello':
      state.hello = msg;
      document.title = `${msg.hub || 'hub'} · network`;
      $('hub').textContent = msg.hub || '';
      return;
    case 'stats':
      return onStats(msg.data);
    case 'db':
      return onDatabase(msg);
    case 'set':
      $('db-status').textContent = msg.ok ? `${msg.key} set` : `${msg.key}: ${msg.error}`;
      $('db-status').className = msg.ok ? 'ok' : 'error';
      return;
    case 'notice':
      preview.notice(msg.text);
      return;
    default:
  }
}

function onStats(stats) {
  if (!stats || !Array.isArray(stats.channels)) return;
  state.stats = stats;
  state.updates++;
  for (const c of stats.channels) {
    let h = state.history.get(c.name);
    if (!h) state.history.set(c.name, (h = []));
    h.push({ hz: c.hz || 0, bps: c.bytes_per_s || 0, dropped: c.dropped_per_s || 0 });
    if (h.length > HISTORY) h.shift();
  }
  render();
  document.body.dataset.updates = String(state.updates);
}

function render() {
  const { stats } = state;
  if (!stats) return;
  const t0 = performance.now();
  const g = buildGraph(stats, { showHub: $('show-hub').checked, filter: $('filter').value });
  graph.update(g);
  renderTable(stats);
  renderSerial(stats);
  renderDetails();
  const channels = [...g.nodes.values()].filter((n) => n.type === 'channel').length;
  const flows = g.nodes.size - channels;
  state.renderMs = performance.now() - t0;
  $('summary').textContent = `${channels} channels, ${flows} flows, ${g.edges.length} edges · ` +
    `updated ${new Date(stats.time_ms).toLocaleTimeString()} (${state.renderMs.toFixed(0)} ms)`;
}

// The busiest channels, like flowctl top.
function renderTable(stats) {
  const body = $('top').tBodies[0];
  const rows = stats.channels.filter((c) => $('show-hub').checked || !c.name.startsWith('hub.'))
    .sort((a, b) => (b.bytes_per_s - a.bytes_per_s) || (b.hz - a.hz) || (a.name < b.name ? -1 : 1)).slice(0, 15);
  body.replaceChildren(...rows.map((c) => {
    const tr = document.createElement('tr');
    if (c.dropped_per_s > 0) tr.className = 'drop';
    tr.dataset.channel = c.name;
    tr.append(text('td', c.name), text('td', String(c.hz)), text('td', `${formatBytes(c.bytes_per_s)}/s`),
      text('td', String(c.subscribers)), text('td', String(c.dropped)));
    tr.addEventListener('click', () => graph.select(`c:${c.name}`));
    return tr;
  }));
}

// Boards' lines: serial ports (server.serial) and the UDP port (server.udp), with what their
// checks dropped (a bad CRC or framing; a bad MAC, a replay, a lost datagram).
function renderSerial(stats) {
  const rows = (stats.serial || []).map((p) => ({
    port: p.device,
    state: p.in_session ? 'session' : p.open ? 'open' : 'away',
    in: p.bytes_in, out: p.bytes_out,
    dropped: p.bad_check + p.bad_framing + p.bad_version + p.too_long,
    sessions: p.sessions,
  }));
  if (stats.udp) {
    const u = stats.udp;
    rows.push({
      port: `udp :${u.port}`, state: `${u.open_sessions} open`, in: u.bytes_in, out: u.bytes_out,
      dropped: u.bad_mac + u.replayed + u.lost + u.malformed + u.unknown_session, sessions: u.sessions,
    });
  }
  $('serial').hidden = rows.length === 0;
  $('serial').tBodies[0].replaceChildren(...rows.map((r) => {
    const tr = document.createElement('tr');
    if (r.dropped > 0) tr.className = 'drop';
    tr.append(text('td', r.port), text('td', r.state), text('td', formatBytes(r.in)),
      text('td', formatBytes(r.out)), text('td', String(r.dropped)), text('td', String(r.sessions)));
    return tr;
  }));
}

graph.addEventListener('select', (e) => select(e.detail));
// A new filter: drawn at once, and zoomed to what is left.
for (const [id, event] of [['show-hub', 'change'], ['filter', 'input']]) {
  $(id).addEventListener(event, () => {
    render();
    graph.fit();
  });
}
$('fit').addEventListener('click', () => graph.fit());

function channelOf(id) {
  return state.stats?.channels.find((c) => `c:${c.name}` === id);
}
function flowOf(id) {
  return state.stats?.flows.find((f) => `f:${f.id}` === id);
}

// A node was clicked: its details, its database, and for a channel a preview.
function select(id, again = false) {
  const changed = id !== state.selected;
  state.selected = id;
  if (!changed && !again) return;
  const c = id ? channelOf(id) : null;
  const f = id && !c ? flowOf(id) : null;
  $('details').hidden = !id;
  const dbs = c ? [c.name] : f ? [`_flow.${f.id}`, f.user] : [];
  const choose = $('db-choice');
  choose.replaceChildren(...dbs.map((d) => text('option', d)));
  watchDatabase(dbs[0] || '');
  if (c && (c.kind === 'streaming' || c.kind === 'blob')) {
    preview.show(c.name, c.mime);
    link.sendJson({ type: 'preview', channels: [c.name] });
  } else {
    preview.show(null, '');
    link.sendJson({ type: 'preview', channels: [] });
  }
  renderDetails();
}

$('db-choice').addEventListener('change', (e) => watchDatabase(e.target.value));

function watchDatabase(db) {
  state.db = db;
  state.dbPairs = new Map();
  $('db-status').textContent = '';
  renderDatabase();
  link.sendJson({ type: 'database', db });
}

function onDatabase(msg) {
  if (msg.db !== state.db) return;
  if (msg.error) {
    $('db-status').textContent = msg.error;
    $('db-status').className = 'error';
  } else if (msg.pairs) {
    state.dbPairs = new Map(Object.entries(msg.pairs));
  } else if (msg.key === '' && msg.value === null) {
    state.dbPairs.clear();
  } else if (msg.value === null) {
    state.dbPairs.delete(msg.key);
  } else {
    state.dbPairs.set(msg.key, msg.value);
  }
  // A detector names its frames in its properties: show its boxes on them.
  const c = channelOf(state.selected);
  const source = c && msg.db === c.name ? state.dbPairs.get('source') : null;
  if (typeof source === 'string' && source !== preview.source && source !== c.name) {
    preview.show(c.name, c.mime, source);
    link.sendJson({ type: 'preview', channels: [c.name, source] });
  }
  renderDatabase();
}

function renderDatabase() {
  const body = $('db').tBodies[0];
  const keys = [...state.dbPairs.keys()].sort();
  const editable = !!state.hello?.edit;
  body.replaceChildren(...keys.map((k) => {
    const tr = document.createElement('tr');
    tr.dataset.key = k;
    const value = JSON.stringify(state.dbPairs.get(k));
    tr.append(text('td', k), text('td', value.length > 200 ? `${value.slice(0, 200)}…` : value));
    if (editable) {
      const td = document.createElement('td');
      const b = text('button', 'edit');
      b.type = 'button';
      b.addEventListener('click', () => {
        $('set-key').value = k;
        $('set-value').value = value;
      });
      td.appendChild(b);
      tr.appendChild(td);
    }
    return tr;
  }));
  $('db-title').textContent = state.db ? `Database ${state.db}` : '';
  $('set-form').hidden = !editable || !state.db;
}

$('set-form').addEventListener('submit', (e) => {
  e.preventDefault();
  let value;
  try {
    value = JSON.parse($('set-value').value);
  } catch (err) {
    $('db-status').textContent = `the value is not JSON: ${err.message}`;
    $('db-status').className = 'error';
    return;
  }
  link.sendJson({ type: 'set', db: state.db, key: $('set-key').value, value, token: $('set-token').value });
});

// The selected node's figures and, for a channel, its rate history.
function renderDetails() {
  const id = state.selected;
  if (!id || !state.stats) return;
  const c = channelOf(id);
  const f = c ? null : flowOf(id);
  const dl = $('facts');
  const facts = [];
  const names = new Map(state.stats.flows.map((x) => [x.id, x.name]));
  if (c) {
    $('details-title').textContent = c.name;
    facts.push(['kind', c.kind], ['mime', c.mime || '—'], ['owner', c.owner || '(offline)'],
      ['subscribers', (c.subscriber_flows || []).map((i, k) => {
        const name = names.get(i) || `flow ${i}`;
        const path = pathLabel(subscriberPath(c, k));
        return path ? `${name} (${path})` : name;
      }).join(', ') || 'none'],
      ['rate', formatRate(c.hz, c.bytes_per_s)], ['messages', String(c.messages)],
      ['bytes', formatBytes(c.bytes)], ['dropped', `${c.dropped} (${c.dropped_per_s}/s)`]);
    if (c.kind === 'service') facts.push(['pending requests', String(c.pending_requests)]);
  } else if (f) {
    $('details-title').textContent = f.name;
    facts.push(['kind', f.kind], ['flow', String(f.id)],
      ['in', `${formatRate(f.in_hz, f.in_bytes_per_s)} (${f.messages_in} messages)`],
      ['out', `${formatRate(f.out_hz, f.out_bytes_per_s)} (${f.messages_out} messages)`],
      ['queued', `${formatBytes(f.queued_bytes)} (${Math.round(100 * f.queue_fill)}% full)`],
      ['dropped', `${f.dropped} (${f.dropped_per_s}/s)`], ['pending requests', String(f.pending_requests)]);
  } else {
    $('details-title').textContent = `${id} (gone)`;
  }
  dl.replaceChildren(...facts.flatMap(([k, v]) => [text('dt', k), text('dd', v)]));
  const plot = $('rate-plot');
  plot.hidden = !c;
  if (c) drawHistory(plot, state.history.get(c.name) || []);
}

function drawHistory(canvas, h) {
  const g = canvas.getContext('2d');
  const { width, height } = canvas;
  g.fillStyle = '#111';
  g.fillRect(0, 0, width, height);
  const maxHz = Math.max(1, ...h.map((p) => p.hz));
  const maxBps = Math.max(1, ...h.map((p) => p.bps));
  const line = (key, max, colour) => {
    g.strokeStyle = colour;
    g.beginPath();
    h.forEach((p, i) => {
      const x = width - (h.length - 1 - i) * (width / HISTORY);
      const y = height - 4 - (p[key] / max) * (height - 16);
      if (i === 0) g.moveTo(x, y); else g.lineTo(x, y);
    });
    g.stroke();
  };
  line('bps', maxBps, '#ffa726');
  line('hz', maxHz, '#4fc3f7');
  for (const [i, p] of h.entries()) {
    if (p.dropped > 0) {
      g.fillStyle = '#e53935';
      g.fillRect(width - (h.length - 1 - i) * (width / HISTORY) - 1, 0, 3, 6);
    }
  }
  g.fillStyle = '#ccc';
  g.font = '11px sans-serif';
  g.fillText(`${maxHz} Hz`, 4, 12);
  g.fillText(`${formatBytes(maxBps)}/s`, width - 70, 12);
  canvas.title = `last ${h.length} s: messages per second (blue), bytes per second (orange), drops (red)`;
}
