// SPDX-License-Identifier: Apache-2.0
// The network page (/network on the hub's web port, docs/observability.md): the hub's flows and
// channels as a live graph, a table of the busiest channels, and the selected node's details:
// figures, rate history, properties and databases, a preview. It is a satellite on the JavaScript
// library: it logs in with a page token as the hub's page account (server.web.page_account), follows
// hub.stats, previews a channel by subscribing to it at PREVIEW_HZ, watches the database shown and
// sets variables as that account, under its rules; for an administrator account, a module's
// settings (network-settings.js).
import { channelType, connectPage, typeProblem } from '/skrobot/index.js';
import { NetworkGraph } from './network-graph.js';
import { buildGraph, formatBytes, formatRate, jsonText, pathLabel, subscriberPath } from './network-model.js';
import { Preview } from './network-preview.js';
import { SettingsPanel } from './network-settings.js';

const HISTORY = 120;                // seconds of rates kept per channel
const PREVIEW_HZ = 5;               // previews of a channel a second, at most (the newest wins)
const MAX_PREVIEW_BYTES = 8 << 20;  // larger messages are announced, not drawn

const $ = (id) => document.getElementById(id);
const graph = new NetworkGraph($('graph'));
const preview = new Preview($('preview'));

const state = {
  hub: null,           // the library's Hub, once online
  stats: null,
  history: new Map(),  // channel -> [{hz, bps, dropped}]
  selected: null,      // node id
  db: '',              // the database shown
  watch: null,         // its watch (the library's Watch: .pairs)
  previews: [],        // the previewed channels' subscriptions
  updates: 0,
};
// For tests and the curious: window.skrNetwork.
window.skrNetwork = state;
state.graph = graph;

const pairs = () => state.watch?.pairs ?? new Map();

function text(tag, content, cls) {
  const e = document.createElement(tag);
  if (content !== undefined) e.textContent = content;
  if (cls) e.className = cls;
  return e;
}

// Logs in, retrying with a growing wait until the hub answers (the library reconnects after).
async function connect() {
  for (let waitMs = 500; ; waitMs = Math.min(waitMs * 2, 8000)) {
    try {
      return await connectPage({ clientName: 'network page' });
    } catch (e) {
      $('status').textContent = `cannot log in (${e.message}), retrying…`;
      await new Promise((resolve) => { setTimeout(resolve, waitMs); });
    }
  }
}

const hub = await connect();
state.hub = hub;
const online = (session) => { $('status').textContent = `connected as ${session.user}`; };
online(hub.session);
hub.on('online', online);
hub.on('offline', () => { $('status').textContent = 'disconnected, retrying…'; });
// What no request awaits: a subscription refused, a channel gone.
hub.on('error', (e) => preview.notice(e.message));
hub.stats(onStats);
const settings = new SettingsPanel(hub, $);

function onStats(stats) {
  if (!stats || !Array.isArray(stats.channels)) return;
  state.stats = stats;
  state.updates++;
  if (stats.hub && $('hub').textContent !== stats.hub) {
    $('hub').textContent = stats.hub;
    document.title = `${stats.hub} · network`;
  }
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
  renderSatellites(stats);
  renderModules(stats);
  renderDetails();
  const channels = [...g.nodes.values()].filter((n) => n.type === 'channel').length;
  const flows = g.nodes.size - channels;
  state.renderMs = performance.now() - t0;
  $('summary').textContent = `${channels} channels, ${flows} flows, ${g.edges.length} edges · ` +
    `updated ${new Date(stats.time_ms).toLocaleTimeString()} (${state.renderMs.toFixed(0)} ms)`;
}

// A side table: a row per item (makeRow(item) -> tr), hidden while there is none.
function fillTable(id, items, makeRow) {
  $(id).hidden = items.length === 0;
  $(id).tBodies[0].replaceChildren(...items.map(makeRow));
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
  fillTable('serial', rows, (r) => {
    const tr = document.createElement('tr');
    if (r.dropped > 0) tr.className = 'drop';
    tr.append(text('td', r.port), text('td', r.state), text('td', formatBytes(r.in)),
      text('td', formatBytes(r.out)), text('td', String(r.dropped)), text('td', String(r.sessions)));
    return tr;
  });
}

// The config's satellites (docs/robot.md): hub.stats's "satellites", the list of flowctl ps.
function renderSatellites(stats) {
  const sats = stats.satellites || [];
  fillTable('satellites', sats, (s) => {
    const tr = document.createElement('tr');
    tr.dataset.satellite = s.name;
    if (s.state === 'failed' || s.state === 'backoff') tr.className = 'drop';
    const state = s.state === 'waiting' && s.waiting_for.length > 0
      ? `waiting for ${s.waiting_for.join(', ')}` : s.state;
    tr.append(text('td', s.name), text('td', state), text('td', s.pid ? String(s.pid) : '-'),
      text('td', s.pid ? `${Math.floor(s.uptime_s)} s` : '-'), text('td', String(s.restarts)),
      text('td', s.last_exit || '-'));
    return tr;
  });
}

// The modules the hub runs and those that failed (hub.stats's "modules"); a row shows the
// module's details and settings.
function renderModules(stats) {
  const mods = stats.modules || [];
  fillTable('modules', mods, (m) => {
    const tr = document.createElement('tr');
    tr.dataset.module = m.name;
    if (m.state === 'failed') tr.className = 'drop';
    tr.append(text('td', m.name), text('td', m.state === 'failed' ? `failed: ${m.reason}` : m.state),
      text('td', m.version ?? '-'), text('td', m.settings === undefined ? '-' : String(m.settings)));
    tr.addEventListener('click', () => select(`m:${m.name}`));
    return tr;
  });
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
function moduleOf(id) {
  return state.stats?.modules?.find((m) => `m:${m.name}` === id);
}

// A node was clicked: its details, its database, and for a channel a preview.
function select(id) {
  if (id === state.selected) return;
  state.selected = id;
  const c = id ? channelOf(id) : null;
  const f = id && !c ? flowOf(id) : null;
  $('details').hidden = !id;
  const dbs = c ? [c.name] : f ? [`_flow.${f.id}`, f.user] : [];
  const choose = $('db-choice');
  choose.replaceChildren(...dbs.map((d) => text('option', d)));
  choose.hidden = dbs.length === 0;
  $('db').hidden = dbs.length === 0;
  $('preview-title').hidden = !c;
  $('preview').hidden = !c;
  watchDatabase(dbs[0] || '');
  // A module's declared settings (administrators only).
  const module = f?.kind === 'module' ? f.client : id?.startsWith('m:') ? id.slice(2) : null;
  settings.show(module);
  if (c && c.kind === 'streaming') {
    preview.show(c.name, c.mime);
    previewChannels([c.name]);
  } else {
    preview.show(null, '');
    previewChannels([]);
    if (c) preview.notice(`a ${c.kind} channel: nothing to preview`);
  }
  renderDetails();
}

// Subscribes to the channels previewed (a channel, and the frames a detector's boxes belong to),
// each at most PREVIEW_HZ times a second: the hub keeps the newest (FlowProtocol's SUBSCRIBE_RATE).
function previewChannels(names) {
  for (const s of state.previews) s.close();
  state.previews = names.map((name) => hub.subscribe(name, (m) => {
    const bytes = m.payload;
    if (bytes.byteLength > MAX_PREVIEW_BYTES) {
      preview.notice(`${m.channel}: a message of ${bytes.byteLength} bytes, over the preview limit`);
      return;
    }
    // The payload is a view on the received buffer: the preview keeps a copy.
    preview.take(m.channel, bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength));
  }, { maxHz: PREVIEW_HZ }));
}

$('db-choice').addEventListener('change', (e) => watchDatabase(e.target.value));

function showDbStatus(textContent, ok) {
  $('db-status').textContent = textContent;
  $('db-status').className = ok ? 'ok' : 'error';
}

// Watches the database shown (its pairs, then each change; again after a reconnection).
function watchDatabase(db) {
  state.watch?.close();
  state.watch = null;
  state.db = db;
  $('db-status').textContent = '';
  if (db) {
    try {
      const w = hub.db(db).watch(() => { if (state.watch === w) onPairs(); }, {
        onEnd: (e) => { if (state.watch === w) showDbStatus(e.message, false); },
      });
      state.watch = w;
    } catch (e) {
      showDbStatus(e.message, false);
    }
  }
  renderDatabase();
}

function onPairs() {
  // A detector names its frames in its properties: show its boxes on them.
  const c = channelOf(state.selected);
  const source = c && state.db === c.name ? pairs().get('source') : null;
  if (typeof source === 'string' && source !== preview.source && source !== c.name) {
    preview.show(c.name, c.mime, source);
    previewChannels([c.name, source]);
  }
  renderDatabase();
  renderDetails();
}

function renderDatabase() {
  const body = $('db').tBodies[0];
  const shown = pairs();
  const keys = [...shown.keys()].sort();
  body.replaceChildren(...keys.map((k) => {
    const tr = document.createElement('tr');
    tr.dataset.key = k;
    const value = jsonText(shown.get(k)) ?? 'null';
    tr.append(text('td', k), text('td', value.length > 200 ? `${value.slice(0, 200)}…` : value));
    const td = document.createElement('td');
    const b = text('button', 'edit');
    b.type = 'button';
    b.addEventListener('click', () => {
      $('set-key').value = k;
      $('set-value').value = value;
    });
    td.appendChild(b);
    tr.appendChild(td);
    return tr;
  }));
  $('db-title').textContent = state.db ? `Database ${state.db}` : '';
  $('set-form').hidden = !state.db;
  $('set-form').title = `set as ${hub.session?.user ?? 'the page account'}, under its rules`;
}

// A change is made as the page's account (server.web.page_account), under its rules: the
// read-only web-page account is refused (permission_denied).
$('set-form').addEventListener('submit', async (e) => {
  e.preventDefault();
  let value;
  try {
    value = JSON.parse($('set-value').value);
  } catch (err) {
    showDbStatus(`the value is not JSON: ${err.message}`, false);
    return;
  }
  const key = $('set-key').value;
  try {
    await hub.db(state.db).set(key, value);
    showDbStatus(`${key} set`, true);
  } catch (err) {
    showDbStatus(`${key}: ${err.code ?? 'error'}: ${err.message}`, false);
  }
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
    // What its messages are (docs/channels.md, "Typed channels"), from its properties.
    if (state.db === c.name) {
      const t = channelType(Object.fromEntries(pairs()));
      if (t.messageEncoding) {
        const schema = t.schemaName ? ` ${t.schemaName} (${t.schemaEncoding})` : '';
        const problem = typeProblem(t);
        facts.push(['type', `${t.messageEncoding}${schema}${problem ? ` — ${problem}` : ''}`]);
      }
    }
  } else if (f) {
    $('details-title').textContent = f.name;
    facts.push(['kind', f.kind], ['flow', String(f.id)],
      ['in', `${formatRate(f.in_hz, f.in_bytes_per_s)} (${f.messages_in} messages)`],
      ['out', `${formatRate(f.out_hz, f.out_bytes_per_s)} (${f.messages_out} messages)`],
      ['queued', `${formatBytes(f.queued_bytes)} (${Math.round(100 * f.queue_fill)}% full)`],
      ['dropped', `${f.dropped} (${f.dropped_per_s}/s)`], ['pending requests', String(f.pending_requests)]);
  } else if (moduleOf(id)) {
    const m = moduleOf(id);
    $('details-title').textContent = `module ${m.name}`;
    facts.push(['state', m.state], ['version', m.version ?? '-'], ['file', m.file || '-'],
      [m.state === 'failed' ? 'reason' : 'about', (m.state === 'failed' ? m.reason : m.description) || '-']);
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
