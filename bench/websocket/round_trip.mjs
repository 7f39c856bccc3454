// SPDX-License-Identifier: Apache-2.0
// Round trips from Node.js through one hub over WebSocket (the hub's web port, /flow) beside the
// same client over the Unix socket, in the same run: 16 B, 1 KiB and 64 KiB; TCP beside them
// separates what loopback TCP costs from what WebSocket adds.
//
// One hub (a Unix socket, TCP on loopback for the account "bench", and server.web with flows and
// the loopback dev account). An echo peer, a second node process on local:, subscribes to each
// transport's <user>.ping_<transport> and publishes each payload again on
// guest.pong_<transport>: publish and subscribe, the library's cheapest path (a service call adds
// a value's encoding and the hub's request table). The measuring client connects once per
// transport and does sequential round trips (publish on ping, wait for the same bytes on pong),
// in blocks that alternate between the transports so that a change of load on the machine falls
// on all. Prints per size and transport the median and p99 in microseconds and the round trips
// per second, and the ratio ws/local (target: within 1.5x) and ws/tcp. Exits 1 on an error (a
// lost or wrong echo); a missed target is reported, not an error.
//
//   node bench/websocket/round_trip.mjs [--quick] [--count N]
//
// --quick: 300 round trips per size and transport (default 3000). The hub is SKROBOT_BIN, else
// build/release/bin/skrobot of this checkout.
import { spawn } from 'node:child_process';
import { fileURLToPath } from 'node:url';
import { flags, fmt, harness, killOnExit, percentile } from './common.mjs';

const SIZES = [16, 1024, 65536];
const BLOCK = 100;  // round trips before switching transport
const TARGET_RATIO = 1.5;
const STALL_MS = 5000;  // a round trip that takes this long is lost
const TRANSPORTS = ['local', 'tcp', 'ws'];
// Who each transport's client logs in as: TCP refuses the dev account.
const USER = { local: 'guest', tcp: 'bench', ws: 'guest' };
const PASSWORD = { guest: 'password', bench: 'bench-password' };

const opts = flags();
if (opts.echo) {
  await echo(opts.echo);
} else {
  await main();
  process.exit(0);  // the harness's hub.stop() leaves a 10 s timer behind
}

// The echo peer: ping_<t> in, pong_<t> out, until stdin closes (the measuring process left).
async function echo(address) {
  const skr = await import('../../satellite/js/src/node.js');
  const hub = await skr.connect(address, { user: 'guest', password: 'password', clientName: 'echo' });
  for (const t of TRANSPORTS) {
    const pong = await hub.createChannel(`pong_${t}`);
    hub.subscribe(`${USER[t]}.ping_${t}`, (m) => pong.publish(m.payload));
  }
  process.stdout.write('ready\n');
  process.stdin.on('end', () => { hub.close(); process.exit(0); });
  process.stdin.resume();
}

// One measuring connection: publish on ping_<t>, the same bytes back on pong_<t>.
async function client(skr, address, t, options) {
  const user = USER[t];
  const hub = await skr.connect(address, { user, password: PASSWORD[user], clientName: `rt-${t}`, ...options });
  const ping = await hub.createChannel(`ping_${t}`);
  let waiting = null;
  let failing = null;
  let since = 0;
  hub.subscribe(`guest.pong_${t}`, (m) => {
    const w = waiting;
    waiting = null;
    failing = null;
    w?.(m.payload);
  });
  return {
    hub, ping,
    // One round trip of `payload` (its first 4 bytes are its number): the time in ns.
    once(payload) {
      return new Promise((resolve, reject) => {
        const t0 = process.hrtime.bigint();
        since = Date.now();
        failing = reject;
        waiting = (back) => {
          const ns = Number(process.hrtime.bigint() - t0);
          if (back.byteLength !== payload.byteLength || back[0] !== payload[0] || back[1] !== payload[1] ||
              back[2] !== payload[2] || back[3] !== payload[3] || back[back.length - 1] !== payload[payload.length - 1]) {
            reject(new Error(`${t}: the echo of ${payload.byteLength} B came back wrong`));
          } else {
            resolve(ns);
          }
        };
        if (!ping.publish(payload)) reject(new Error(`${t}: publish refused (offline or congested)`));
      });
    },
    // Fails the round trip under way when it has waited longer than `ms`.
    stalled(ms) {
      if (!failing || Date.now() - since < ms) return;
      const f = failing;
      failing = null;
      waiting = null;
      f(new Error(`${t}: no echo within ${ms} ms`));
    },
  };
}

// Round trips until the echo answers (both ends subscribed): the peer may still be setting up.
async function warm(c, t) {
  const probe = new Uint8Array(16);
  const until = Date.now() + 10000;
  for (;;) {
    const once = c.once(probe);
    once.catch(() => {});  // a probe given up on may still fail later: ignored
    const r = await Promise.race([once, new Promise((res) => setTimeout(res, 200, null))]);
    if (r !== null) return;
    if (Date.now() > until) throw new Error(`${t}: no echo within 10 s`);
  }
}

async function main() {
  const count = Number(opts.count ?? (opts.quick ? 300 : 3000));
  const { startHub, freePort, webRequire } = await harness();
  const skr = await import('../../satellite/js/src/node.js');
  const WebSocket = globalThis.WebSocket ?? webRequire('ws');
  if (!globalThis.WebSocket) {
    // ws masks what a client sends in JavaScript unless bufferutil (web/package.json) loads.
    let native = false;
    try { native = !!webRequire('bufferutil').mask && !process.env.WS_NO_BUFFER_UTIL; } catch { /* absent */ }
    console.log(`client: the ws package ${webRequire('ws/package.json').version}, masking ${native ? 'in bufferutil (native)' : 'in JavaScript'}`);
  }
  const port = await freePort();
  const tcpPort = await freePort();
  const hub = await startHub([], {
    users: [{ name: 'bench', password: PASSWORD.bench }],
    server: { tcp: true, tcp_port: tcpPort, web: { port, flows: true, dev_account: true } },
  });
  killOnExit(hub.proc, hub.dir);
  const peer = spawn(process.execPath, [fileURLToPath(import.meta.url), '--echo', hub.address],
    { stdio: ['pipe', 'pipe', 'inherit'] });
  killOnExit(peer);
  const clients = [];
  try {
    await new Promise((resolve, reject) => {
      peer.stdout.on('data', (d) => { if (String(d).includes('ready')) resolve(); });
      peer.on('exit', (code) => reject(new Error(`the echo peer exited ${code}`)));
    });
    const transports = {
      local: await client(skr, hub.address, 'local'),
      tcp: await client(skr, `tcp:127.0.0.1:${tcpPort}`, 'tcp'),
      ws: await client(skr, `ws://127.0.0.1:${port}/flow`, 'ws', { WebSocket }),
    };
    clients.push(...Object.values(transports));
    for (const [t, c] of Object.entries(transports)) await warm(c, t);
    await new Promise((r) => setTimeout(r, 300));  // a late echo of a probe is dropped, not taken

    console.log(`round trips through one hub (pid ${hub.proc.pid}): a node client over ws: (the web port's /flow, the ws`);
    console.log(`package), local: (Unix socket) and tcp: (loopback), in alternating blocks of ${BLOCK}; an echo peer over`);
    console.log(`local: publishes each payload back (publish/subscribe, *.ping_* -> guest.pong_*); ${count} round trips`);
    console.log('per size and transport');
    console.log('');
    console.log('size      transport  median us    p99 us   round trips/s');
    const watchdog = setInterval(() => { for (const c of clients) c.stalled(STALL_MS); }, 1000);
    const verdicts = [];
    try {
      for (const size of SIZES) {
        const payload = new Uint8Array(size).map((_, i) => (i * 31) & 0xff);
        const ns = { local: [], tcp: [], ws: [] };
        let n = 0;
        for (const t of TRANSPORTS) for (let i = 0; i < 20; i++) await transports[t].once(payload);
        while (TRANSPORTS.some((t) => ns[t].length < count)) {
          for (const t of TRANSPORTS) {
            for (let i = 0; i < BLOCK && ns[t].length < count; i++) {
              new DataView(payload.buffer).setUint32(0, ++n, true);
              payload[size - 1] = n & 0xff;
              ns[t].push(await transports[t].once(payload));
            }
          }
        }
        const row = {};
        for (const t of TRANSPORTS) {
          const us = ns[t].map((x) => x / 1000).sort((a, b) => a - b);
          const mean = us.reduce((a, b) => a + b, 0) / us.length;
          row[t] = { median: percentile(us, 50), p99: percentile(us, 99), rate: 1e6 / mean };
          const label = size >= 1024 ? `${size / 1024} KiB` : `${size} B`;
          console.log(`${label.padEnd(9)} ${t.padEnd(9)} ${fmt(row[t].median).padStart(10)} ${fmt(row[t].p99).padStart(9)} ${fmt(row[t].rate, 0).padStart(15)}`);
        }
        const ratio = row.ws.median / row.local.median;
        const ok = ratio <= TARGET_RATIO;
        verdicts.push(ok);
        console.log(`          ws/local   ${fmt(ratio, 2)}x median, ${fmt(row.ws.p99 / row.local.p99, 2)}x p99, ` +
          `${fmt(row.local.rate / row.ws.rate, 2)}x time per round trip (target within ${TARGET_RATIO}x: ${ok ? 'met' : 'missed'})`);
        console.log(`          ws/tcp     ${fmt(row.ws.median / row.tcp.median, 2)}x median, ${fmt(row.ws.p99 / row.tcp.p99, 2)}x p99`);
      }
    } finally {
      clearInterval(watchdog);
    }
    console.log('');
    console.log(`target (ws median within ${TARGET_RATIO}x of local): ${verdicts.every((x) => x) ? 'met at every size' : 'missed'}`);
  } finally {
    for (const c of clients) c.hub.close();
    peer.stdin.end();
    await hub.stop();
  }
}
