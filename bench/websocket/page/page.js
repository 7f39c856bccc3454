// SPDX-License-Identifier: Apache-2.0
// The page of bench/websocket/video_page.mjs, served by the hub's web port (/bench, the library
// at /lib). window.bench subscribes to one video channel, through the hub's /flow (the library,
// logged in with a page token as web-page) or through the foxglove bridge (its protocol by hand:
// advertise, subscribe, binary messages of JSON), and counts what arrives as a page that shows it
// would take it: the pixels' bytes (rgb8: a view of the frame, or the bridge's base64 decoded),
// and for JPEG a createImageBitmap of each frame (at most two decodes under way; a frame that
// comes while both are busy is not decoded, and counted). "plain" is the driver's control: media
// frames, one a WebSocket message, from a server without a hub. The driver reads the counters.
import { FORMAT, connectPage, encodingOf, parseMediaFrame } from '/lib/index.js';

const FOXGLOVE_SUBPROTOCOL = 'foxglove.websocket.v1';
const MAX_DECODING = 2;
const JPEG_MIME = encodingOf(FORMAT.jpeg).mime;

const counters = () => ({
  frames: 0, bytes: 0, skipped: 0, decoded: 0, notDecoded: 0, decodeFailed: 0, bad: 0, lastSeq: 0,
});
let c = counters();
let decoding = 0;
let close = () => {};

// A frame's pixels or JPEG bytes arrived: count it, and decode a JPEG as a page would show it.
function arrived(seq, format, bytes) {
  c.frames++;
  c.bytes += bytes.byteLength;
  if (c.lastSeq && seq > c.lastSeq + 1) c.skipped += seq - c.lastSeq - 1;
  c.lastSeq = seq;
  if (format !== 'jpeg') return;
  if (decoding >= MAX_DECODING) {
    c.notDecoded++;
    return;
  }
  decoding++;
  createImageBitmap(new Blob([bytes], { type: JPEG_MIME })).then((bitmap) => {
    if (bitmap.width > 0) c.decoded++;
    bitmap.close();
  }, () => { c.decodeFailed++; }).finally(() => { decoding--; });
}

function fromBase64(text) {
  if (Uint8Array.fromBase64) return Uint8Array.fromBase64(text);
  const s = atob(text);
  const out = new Uint8Array(s.length);
  for (let i = 0; i < s.length; i++) out[i] = s.charCodeAt(i);
  return out;
}

// Through the hub's /flow: the library with a page token.
async function flow(channel) {
  const hub = await connectPage({ clientName: 'bench-page' });
  const sub = hub.subscribe(channel, (m) => {
    const f = parseMediaFrame(m.payload);
    if (!f) {
      c.bad++;
      return;
    }
    arrived(Number(f.seq), f.encoding, f.payload);
  });
  await new Promise((resolve, reject) => {
    const until = Date.now() + 10000;
    const check = () => {
      if (c.frames > 0) resolve();
      else if (Date.now() > until) reject(new Error(`no frame of ${channel} within 10 s`));
      else setTimeout(check, 20);
    };
    check();
  });
  close = () => {
    sub.close();
    hub.close();
  };
}

// Through the foxglove bridge: advertise names the topic's channel id; messages are opcode 1,
// u32 subscription id, u64 log time, then the JSON of foxglove.CompressedImage or RawImage.
async function foxglove(url, topic) {
  const ws = new WebSocket(url, FOXGLOVE_SUBPROTOCOL);
  ws.binaryType = 'arraybuffer';
  const text = new TextDecoder();
  await new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`no frame of ${topic} from ${url} within 10 s`)), 10000);
    ws.onerror = () => reject(new Error(`${url}: WebSocket error`));
    ws.onmessage = (e) => {
      if (typeof e.data === 'string') {
        const m = JSON.parse(e.data);
        const ch = m.op === 'advertise' && m.channels.find((x) => x.topic === topic);
        if (ch) ws.send(JSON.stringify({ op: 'subscribe', subscriptions: [{ id: 1, channelId: ch.id }] }));
        return;
      }
      const v = new DataView(e.data);
      if (v.getUint8(0) !== 1 || v.getUint32(1, true) !== 1) return;
      const m = JSON.parse(text.decode(new Uint8Array(e.data, 13)));
      if (typeof m.data !== 'string') {
        c.bad++;
        return;
      }
      arrived(m.seq, m.format === 'jpeg' ? 'jpeg' : m.encoding, fromBase64(m.data));
      if (c.frames === 1) {
        clearTimeout(timer);
        resolve();
      }
    };
  });
  close = () => {
    if (ws.readyState === 1) ws.send(JSON.stringify({ op: 'unsubscribe', subscriptionIds: [1] }));
    ws.close();
  };
}

// The control: each binary message one media frame.
async function plain(url) {
  const ws = new WebSocket(url);
  ws.binaryType = 'arraybuffer';
  await new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`no frame from ${url} within 10 s`)), 10000);
    ws.onerror = () => reject(new Error(`${url}: WebSocket error`));
    ws.onmessage = (e) => {
      const f = parseMediaFrame(e.data);
      if (!f) {
        c.bad++;
        return;
      }
      arrived(Number(f.seq), f.encoding, f.payload);
      if (c.frames === 1) {
        clearTimeout(timer);
        resolve();
      }
    };
  });
  close = () => ws.close();
}

window.bench = {
  // Subscribes (resolves at the first frame) with the counters at zero.
  async start(mode, where, channel) {
    close();
    c = counters();
    if (mode === 'flow') await flow(channel);
    else if (mode === 'plain') await plain(where);
    else await foxglove(where, channel);
    document.getElementById('status').textContent = `${mode}: ${channel}`;
  },
  counters: () => ({ ...c }),
  stop() {
    close();
    close = () => {};
    document.getElementById('status').textContent = 'stopped';
  },
};
document.getElementById('status').textContent = 'ready';
