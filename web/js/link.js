// SPDX-License-Identifier: Apache-2.0
// The WebSocket to websocket-ui: JSON commands in, media frames out. Reconnects with a backoff.
export const SUBPROTOCOL = 'skrobot-avatar.v1';

export class Link extends EventTarget {
  constructor(url, page = 'avatar') {
    super();
    this.url = url;
    this.page = page;
    this.ws = null;
    this.connected = false;
    this.retryMs = 250;
    this.sentFrames = 0;
    this.skippedFrames = 0;
    this.open();
  }

  open() {
    const ws = new WebSocket(this.url, SUBPROTOCOL);
    ws.binaryType = 'arraybuffer';
    ws.onopen = () => {
      this.connected = true;
      this.retryMs = 250;
      ws.send(JSON.stringify({ type: 'hello', version: 1, page: this.page }));
      this.dispatchEvent(new Event('open'));
    };
    ws.onmessage = (e) => {
      if (typeof e.data === 'string') {
        let msg;
        try { msg = JSON.parse(e.data); } catch { return; }
        this.dispatchEvent(new CustomEvent('command', { detail: msg }));
      } else {
        this.dispatchEvent(new CustomEvent('binary', { detail: e.data }));
      }
    };
    ws.onclose = (e) => {
      const was = this.connected;
      this.connected = false;
      this.ws = null;
      this.dispatchEvent(new CustomEvent('close', { detail: { code: e.code, reason: e.reason, was } }));
      setTimeout(() => this.open(), this.retryMs);
      this.retryMs = Math.min(this.retryMs * 2, 4000);
    };
    this.ws = ws;
  }

  // Media frames are skipped, not queued, while the socket is backed up (keeps latency low).
  sendFrame(buffer, maxBuffered = 512 * 1024) {
    if (!this.connected || this.ws.bufferedAmount > maxBuffered) {
      this.skippedFrames++;
      return false;
    }
    this.ws.send(buffer);
    this.sentFrames++;
    return true;
  }

  sendJson(msg) {
    if (this.connected) this.ws.send(JSON.stringify(msg));
  }
}
