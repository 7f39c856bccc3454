// SPDX-License-Identifier: Apache-2.0
// A 1280x720 stream at 30 Hz from a C++ publisher to a page in Debian's chromium, as JPEG and as
// rgb8, through the hub's web port (/flow) beside the foxglove bridge carrying the same stream,
// in the same run: frames per second delivered to the page and the hub's CPU.
//
// One hub: a Unix socket, server.web (flows; the page at /bench, the library at /lib) and the
// foxglove-bridge module. Two ws_media_publisher processes (bench/websocket/media_publisher.cpp)
// publish guest.cam_jpeg (one JPEG made at start by OpenCV, about 150 KB) and guest.cam_rgb8
// (2.7 MB frames) at 30 Hz while subscribed, each frame with the next seq. The page
// (page/page.js) subscribes to one of them at a time through /flow (a page token, web-page) or
// through the bridge, and counts the frames, their seq gaps and, for JPEG, the frames
// createImageBitmap decoded. The /flow page is the hub's (web.mounts: /bench, and /lib for the
// library); the bridge's is the same files from a plain server here, since the hub's pages may
// connect to their own origin only (Content-Security-Policy). Per format and path, after a
// second of warm-up: frames/s arrived and decoded in the page over the window (10 s; --quick: 1.5 s),
// the hub process's CPU over it (utime + stime from /proc; the bridge runs in the hub, on a thread
// of its own) and chromium's. The full run adds the same subscriptions from node, which tell what
// the hub delivers from what the page takes. Targets: 30 Hz through /flow, and no more hub CPU
// than the bridge. Exits 1 on an error (no frame, a page error); a missed target is reported,
// not an error.
//
//   node bench/websocket/video_page.mjs [--quick] [--seconds S]
//
// The hub is SKROBOT_BIN (else build/release/bin/skrobot of this checkout), the modules
// SKROBOT_MODULE_DIR, the publisher WS_MEDIA_PUBLISHER (else
// build/release/bin/ws_media_publisher).
import { execFileSync, spawn } from 'node:child_process';
import { existsSync, mkdtempSync, readFileSync, rmSync, statSync } from 'node:fs';
import http from 'node:http';
import os from 'node:os';
import path from 'node:path';
import { cpuSeconds, flags, fmt, harness, killOnExit, repo, treeCpuSeconds } from './common.mjs';

const WIDTH = 1280;
const HEIGHT = 720;
const RATE_HZ = 30;
const WARMUP_MS = 1000;
const FPS_TARGET = RATE_HZ * 0.95;  // 30 Hz, give or take a frame and a half over the window

const opts = flags();
const seconds = Number(opts.seconds ?? (opts.quick ? 1.5 : 10));
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// One 1280x720 JPEG of a scene with edges and noise (a camera's, roughly): OpenCV, quality 85.
function makeJpeg(file) {
  const script = `
import cv2, numpy as np, sys
w, h = ${WIDTH}, ${HEIGHT}
x = np.linspace(0, 255, w, dtype=np.float32)
y = np.linspace(0, 255, h, dtype=np.float32)[:, None]
img = np.dstack([np.broadcast_to(x, (h, w)), np.broadcast_to(y, (h, w)), (x + y) / 2]).astype(np.uint8)
rng = np.random.default_rng(7)
for i in range(40):
    c = tuple(int(v) for v in rng.integers(0, 255, 3))
    p = (int(rng.integers(0, w)), int(rng.integers(0, h)))
    cv2.circle(img, p, int(rng.integers(10, 120)), c, -1)
    cv2.putText(img, 'skrobot %d' % i, (int(rng.integers(0, w - 200)), int(rng.integers(30, h))),
                cv2.FONT_HERSHEY_SIMPLEX, 1.0, c[::-1], 2)
img = cv2.add(img, rng.integers(0, 24, img.shape, dtype=np.uint8))
cv2.imwrite(sys.argv[1], img, [cv2.IMWRITE_JPEG_QUALITY, 85])
`;
  execFileSync('/usr/bin/python3', ['-c', script, file], { stdio: ['ignore', 'ignore', 'inherit'] });
}

// The same page and library for the bridge's path: the hub's web port sends every file with
// Content-Security-Policy connect-src 'self' (docs/security.md), so a page it serves may not open
// the bridge's port. A plain server on another port serves /bench and /lib from the same files,
// and at /plain the control row: WebSocket without a hub (the ws package), the rgb8 frames sent
// at 30 Hz as they are, one a message, a frame skipped while 8 MiB wait (the hub's default
// subscriber queue); what chromium takes on this machine whoever sends.
async function servePage(WebSocket, frame) {
  const roots = { '/bench/': path.join(repo, 'bench/websocket/page'), '/lib/': path.join(repo, 'satellite/js/src') };
  const server = http.createServer((req, res) => {
    const url = new URL(req.url, 'http://x');
    const prefix = Object.keys(roots).find((p) => url.pathname.startsWith(p));
    const name = prefix && path.basename(url.pathname);
    if (!name || !/^[\w.-]+\.(html|js)$/.test(name)) {
      res.writeHead(404).end();
      return;
    }
    try {
      const body = readFileSync(path.join(roots[prefix], name));
      res.writeHead(200, { 'content-type': name.endsWith('.js') ? 'text/javascript' : 'text/html' }).end(body);
    } catch {
      res.writeHead(404).end();
    }
  });
  const wss = new WebSocket.WebSocketServer({ server, path: '/plain' });
  wss.on('connection', (ws) => {
    let seq = 0;
    const timer = setInterval(() => {
      seq++;
      if (ws.bufferedAmount > 8 << 20) return;
      new DataView(frame.buffer, frame.byteOffset).setBigUint64(8, BigInt(seq), true);
      ws.send(frame);
    }, 1000 / RATE_HZ);
    ws.on('close', () => clearInterval(timer));
  });
  await new Promise((r) => server.listen(0, '127.0.0.1', r));
  const { port } = server.address();
  return {
    url: `http://127.0.0.1:${port}/bench/index.html`, ws: `ws://127.0.0.1:${port}/plain`,
    close: () => { wss.close(); server.close(); },
  };
}

// The page's counting in node (the full run's extra rows): the same subscription over ws: with the
// library (a page token) or the bridge's protocol through the ws package, frames counted and, for
// the bridge, the JSON parsed and base64 decoded; no JPEG decoding. Separates what the hub
// delivers over WebSocket from what chromium takes.
async function nodeViewer(skr, WebSocket, mode, where, channel) {
  const c = { frames: 0, skipped: 0, lastSeq: 0, bad: 0, decoded: 0, notDecoded: 0, decodeFailed: 0 };
  const arrived = (seq) => {
    c.frames++;
    if (c.lastSeq && seq > c.lastSeq + 1) c.skipped += seq - c.lastSeq - 1;
    c.lastSeq = seq;
  };
  let stop;
  if (mode === 'flow') {
    const hub = await skr.connect(where, { WebSocket, token: skr.pageToken(where), clientName: 'bench-node' });
    hub.subscribe(channel, (m) => {
      const f = skr.parseMediaFrame(m.payload);
      if (f) arrived(Number(f.seq));
      else c.bad++;
    });
    stop = () => hub.close();
  } else {
    const ws = new WebSocket(where, ['foxglove.websocket.v1']);
    ws.on('message', (data, binary) => {
      if (!binary) {
        const m = JSON.parse(String(data));
        const ch = m.op === 'advertise' && m.channels.find((x) => x.topic === channel);
        if (ch) ws.send(JSON.stringify({ op: 'subscribe', subscriptions: [{ id: 1, channelId: ch.id }] }));
        return;
      }
      if (data[0] !== 1 || data.readUInt32LE(1) !== 1) return;
      const m = JSON.parse(data.toString('utf8', 13));
      if (typeof m.data === 'string' && Buffer.from(m.data, 'base64').length > 0) arrived(m.seq);
      else c.bad++;
    });
    await new Promise((resolve, reject) => { ws.on('open', resolve); ws.on('error', reject); });
    stop = () => ws.close();
  }
  const until = Date.now() + 10000;
  while (c.frames === 0) {
    if (Date.now() > until) throw new Error(`node: no frame of ${channel} within 10 s`);
    await sleep(20);
  }
  return { counters: () => ({ ...c }), stop };
}

function publisherBin() {
  const bin = process.env.WS_MEDIA_PUBLISHER ?? path.join(repo, 'build/release/bin/ws_media_publisher');
  if (!existsSync(bin)) throw new Error(`no publisher at ${bin}: build the target ws_media_publisher or set WS_MEDIA_PUBLISHER`);
  return bin;
}

async function main() {
  const { startHub, freePort, launchChromium, webRequire } = await harness();
  const skr = await import('../../satellite/js/src/node.js');
  const WebSocket = webRequire('ws');
  const bin = publisherBin();
  const tmp = mkdtempSync(path.join(os.tmpdir(), 'skrobot-video-page-'));
  const jpeg = path.join(tmp, 'frame.jpg');
  makeJpeg(jpeg);
  const jpegBytes = statSync(jpeg).size;

  const webPort = await freePort();
  const foxPort = await freePort();
  const hub = await startHub([{ name: 'foxglove-bridge', config: { address: '127.0.0.1', port: foxPort } }], {
    server: {
      web: {
        port: webPort, flows: true,
        mounts: { '/bench': path.join(repo, 'bench/websocket/page'), '/lib': path.join(repo, 'satellite/js/src') },
      },
    },
  });
  killOnExit(hub.proc, hub.dir);
  const publishers = [];
  let chromium;
  const rgb8 = skr.makeMediaFrame({ format: skr.FORMAT.rgb8, seq: 0, width: WIDTH, height: HEIGHT },
    new Uint8Array(WIDTH * HEIGHT * 3).fill(0x80));
  const plain = await servePage(WebSocket, rgb8);
  try {
    const env = { ...process.env, ROBOT_USER: 'guest', ROBOT_PASSWORD: 'password' };
    for (const [name, args] of [['cam_jpeg', ['jpeg', `${WIDTH}x${HEIGHT}`, String(RATE_HZ), jpeg]],
      ['cam_rgb8', ['rgb8', `${WIDTH}x${HEIGHT}`, String(RATE_HZ)]]]) {
      const p = spawn(bin, [hub.address, name, ...args], { env, stdio: ['ignore', 'pipe', 'pipe'] });
      killOnExit(p);
      p.out = '';
      p.stdout.on('data', (d) => { p.out += d; });
      p.stderr.on('data', (d) => { p.out += d; });
      publishers.push(p);
    }
    chromium = await launchChromium();
    const pageErrors = [];
    const pages = {};
    for (const [mode, url] of [['flow', `http://127.0.0.1:${webPort}/bench/index.html`], ['foxglove', plain.url]]) {
      const page = await chromium.context.newPage();
      page.on('pageerror', (e) => pageErrors.push(String(e)));
      await page.goto(url);
      await page.waitForFunction(() => window.bench !== undefined, null, { timeout: 10000 });
      pages[mode] = page;
    }

    console.log(`${WIDTH}x${HEIGHT} at ${RATE_HZ} Hz from a C++ publisher (ws_media_publisher, local:) to a page in chromium,`);
    console.log(`through the hub's /flow (library, page token) and through foxglove-bridge (JSON, base64), the hub pid ${hub.proc.pid};`);
    console.log(`JPEG ${(jpegBytes / 1024).toFixed(0)} KiB a frame, rgb8 ${(WIDTH * HEIGHT * 3 / 1024).toFixed(0)} KiB; ${seconds} s per row after ${WARMUP_MS / 1000} s of warm-up`);
    console.log('');
    console.log('format  client, path     sent fps     fps  decoded fps  seq gaps  not decoded  hub CPU %  chromium CPU %');
    const rows = {};
    const clients = opts.quick ? ['page'] : ['page', 'node'];
    const fox = `ws://127.0.0.1:${foxPort}/`;
    for (const format of ['jpeg', 'rgb8']) {
      for (const client of clients) {
        // plain: the control row, rgb8 to the page from a plain WebSocket server (no hub).
        const modes = client === 'page' && format === 'rgb8' ? ['flow', 'foxglove', 'plain'] : ['flow', 'foxglove'];
        for (const mode of modes) {
          const channel = `guest.cam_${format}`;
          let viewer;
          if (client === 'page') {
            const page = pages[mode === 'plain' ? 'foxglove' : mode];
            const where = mode === 'plain' ? plain.ws : fox;
            await page.evaluate(([m, w, ch]) => window.bench.start(m, w, ch), [mode, where, channel]);
            viewer = { counters: () => page.evaluate(() => window.bench.counters()), stop: () => page.evaluate(() => window.bench.stop()) };
          } else {
            viewer = await nodeViewer(skr, WebSocket, mode, mode === 'flow' ? `ws://127.0.0.1:${webPort}/flow` : fox, channel);
          }
          await sleep(WARMUP_MS);
          const c0 = await viewer.counters();
          const t0 = process.hrtime.bigint();
          const cpu0 = cpuSeconds(hub.proc.pid);
          const browser0 = treeCpuSeconds(process.pid, /chrom/);
          await sleep(seconds * 1000);
          const c1 = await viewer.counters();
          const t1 = process.hrtime.bigint();
          const cpu1 = cpuSeconds(hub.proc.pid);
          const browser1 = treeCpuSeconds(process.pid, /chrom/);
          await viewer.stop();
          await sleep(500);  // the bridge lets go of the channel; the publisher stops
          const dt = Number(t1 - t0) / 1e9;
          if (c1.bad > 0) throw new Error(`${format} ${client} ${mode}: ${c1.bad} messages the client could not read`);
          const r = {
            sent: (c1.lastSeq - c0.lastSeq) / dt,
            fps: (c1.frames - c0.frames) / dt,
            decoded: (c1.decoded - c0.decoded) / dt,
            gaps: c1.skipped - c0.skipped,
            notDecoded: c1.notDecoded - c0.notDecoded + c1.decodeFailed - c0.decodeFailed,
            cpu: ((cpu1 - cpu0) / dt) * 100,
            browser: ((browser1 - browser0) / dt) * 100,
          };
          rows[`${format} ${client} ${mode}`] = r;
          const label = `${client} ${{ flow: '/flow', foxglove: 'bridge', plain: 'no hub' }[mode]}`;
          const decodes = format === 'jpeg' && client === 'page';
          console.log(`${format.padEnd(7)} ${label.padEnd(14)} ${fmt(r.sent).padStart(10)} ${fmt(r.fps).padStart(7)} ${(decodes ? fmt(r.decoded) : '-').padStart(12)} ` +
            `${String(r.gaps).padStart(9)} ${(decodes ? String(r.notDecoded) : '-').padStart(12)} ${(mode === 'plain' ? '-' : fmt(r.cpu)).padStart(10)} ` +
            `${(client === 'page' ? fmt(r.browser) : '-').padStart(15)}`);
        }
      }
    }
    if (pageErrors.length) throw new Error(`the page failed: ${pageErrors.join('; ')}`);
    console.log('sent fps: frames published over the window (the seq of the last frame received); seq gaps: frames the');
    console.log('client never got (dropped by the hub or the bridge for a slow reader, or refused by the publisher\'s');
    console.log('full output); CPU: 100% is one core; chromium: all its processes. node rows');
    console.log('(the full run): the same subscriptions from node (ws package), counted without decoding JPEG. no hub:');
    console.log('the same rgb8 frames from a plain WebSocket server in this script, what chromium takes without the hub.');
    console.log('');
    for (const format of ['jpeg', 'rgb8']) {
      const f = rows[`${format} page flow`];
      const b = rows[`${format} page foxglove`];
      const fpsOk = f.fps >= FPS_TARGET;
      const cpuOk = f.cpu <= b.cpu;
      console.log(`${format}: /flow ${fmt(f.fps)} fps (target ${RATE_HZ} Hz: ${fpsOk ? 'met' : 'missed'}), ` +
        `hub CPU ${fmt(f.cpu)}% vs the bridge's ${fmt(b.cpu)}% (target no more: ${cpuOk ? 'met' : 'missed'})`);
    }
  } catch (e) {
    console.error(`the hub's log:\n${hub.log}`);
    for (const p of publishers) console.error(`${p.spawnargs.slice(2, 4).join(' ')}:\n${p.out}`);
    throw e;
  } finally {
    plain.close();
    await chromium?.close();
    for (const p of publishers) p.kill('SIGTERM');
    await Promise.all(publishers.map((p) => new Promise((r) => (p.exitCode !== null ? r() : p.on('exit', r)))));
    for (const p of publishers) {
      const m = /published (\d+) refused (\d+)/.exec(p.out);
      if (m) console.log(`publisher ${p.spawnargs[2]}: ${m[1]} frames published, ${m[2]} refused (its output full)`);
    }
    await hub.stop();
    rmSync(tmp, { recursive: true, force: true });
  }
}

await main();
process.exit(0);  // the harness's hub.stop() leaves a 10 s timer behind
