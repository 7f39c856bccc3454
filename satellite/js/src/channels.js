// SPDX-License-Identifier: Apache-2.0
// Channels: the ones this client owns (publish, first/last subscriber events) and subscriptions
// (callbacks or async iterators). Payloads go out as the caller's views and come in as views into
// the received bytes.
import { asBytes, encodeUtf8, decodeUtf8 } from './bytes.js';
import { CHANNEL_KINDS } from './catalogue.js';

/** Channel kinds by name ({streaming: 1, ...}) and back. */
export const KIND = Object.freeze(Object.fromEntries(CHANNEL_KINDS.map(([name, value]) => [name, value])));
export const KIND_NAME = Object.freeze(Object.fromEntries(CHANNEL_KINDS.map(([name, value]) => [value, name])));

/**
 * A payload as bytes: an ArrayBuffer or typed array as it is (a view), a string as UTF-8, anything
 * else as JSON text.
 * @param {ArrayBuffer | ArrayBufferView | string | unknown} data
 * @returns {Uint8Array}
 */
export function payloadBytes(data) {
  if (data instanceof ArrayBuffer || ArrayBuffer.isView(data)) return asBytes(data);
  if (typeof data === 'string') return encodeUtf8(data);
  return encodeUtf8(JSON.stringify(data));
}

/**
 * The channel facts the hub announces (ChannelInfo), with the kind as a name.
 * @typedef {{id: number, hash: bigint, kind: string, name: string, owner: string,
 *   ownerConnection: number, mime: string, subscribers: number, props: any}} ChannelInfo
 */

/** @param {Record<string, any>} m a decoded ChannelInfo @returns {ChannelInfo} */
export function channelInfo(m) {
  return {
    id: m.id, hash: m.hash, kind: KIND_NAME[m.kind] ?? String(m.kind), name: m.name, owner: m.owner,
    ownerConnection: m.owner_connection, mime: m.mime, subscribers: m.subscribers, props: m.props,
  };
}

/** One received payload. */
export class Message {
  /** @param {string} channel @param {Uint8Array} payload */
  constructor(channel, payload) {
    /** The channel's full name. */
    this.channel = channel;
    /** A view into the received bytes: copy it (slice()) to keep it past the callback. */
    this.payload = payload;
  }

  /** The payload as UTF-8 text. */
  text() { return decodeUtf8(this.payload); }

  /** The payload as JSON. */
  json() { return JSON.parse(this.text()); }
}

/** A channel this client created; re-created after each reconnection. */
export class OwnedChannel {
  /** @param {import('./hub.js').Hub} hub @param {string} shortName @param {{kind: string, mime: string, props: any}} spec */
  constructor(hub, shortName, spec) {
    this.hub = hub;
    this.shortName = shortName;
    this.spec = spec;
    /** The full name, <user>.<short name>, once created. */
    this.name = '';
    /** The id on the current connection (0 while offline). */
    this.id = 0;
    /** True while at least one subscriber listens (EV_START_PUBLISH .. EV_STOP_PUBLISH). */
    this.hasSubscribers = false;
    this.removed = false;
    /** Payloads publish() dropped (offline or congested). */
    this.dropped = 0;
    /** @type {Set<(on: boolean) => void>} */
    this.listeners = new Set();
    /** @type {((command: string, value: any, request: {requester: string}) => any) | null} */
    this.handler = null;
  }

  /**
   * Calls `fn(true)` when a first subscriber arrives and `fn(false)` when the last one leaves.
   * @param {(hasSubscribers: boolean) => void} fn
   * @returns {() => void} removes the listener
   */
  onSubscribers(fn) {
    this.listeners.add(fn);
    return () => this.listeners.delete(fn);
  }

  /** @param {boolean} on */
  setSubscribers(on) {
    if (this.hasSubscribers === on) return;
    this.hasSubscribers = on;
    for (const fn of this.listeners) {
      try {
        fn(on);
      } catch (e) {
        this.hub.report(e);
      }
    }
  }

  /**
   * Publishes one payload. Returns false when it was dropped: offline, or the hub is not taking
   * what was written (more than the hub option maxQueuedBytes, default 8 MiB, waits in this
   * process): data is dropped, never queued without bound. `dropped` counts them.
   * @param {ArrayBuffer | ArrayBufferView | string | unknown} data
   */
  publish(data) {
    if (!this.id || this.removed || this.hub.congested()) {
      this.dropped += 1;
      return false;
    }
    return this.hub.send('PUBLISH', { chan_id: this.id, payload: payloadBytes(data) });
  }

  /** Replaces properties (a null value removes its key). @param {Record<string, unknown>} props */
  setProps(props) {
    this.spec.props = { ...(this.spec.props ?? {}), ...props };
    for (const [k, v] of Object.entries(props)) if (v === null) delete this.spec.props[k];
    return this.hub.command('CHAN_SET_PROPS', { chan_id: this.id, props });
  }

  /** A sync source's pulse (SYNC_PULSE), stamped with this process's monotonic clock. */
  pulse(sourceTimeNs = monotonicNs()) {
    if (!this.id || this.removed) return false;
    return this.hub.send('SYNC_PULSE', { chan_id: this.id, source_time_ns: BigInt(sourceTimeNs) });
  }

  /** Removes the channel (not re-created after a reconnection). */
  remove() {
    this.removed = true;
    this.hub.owned.delete(this);
    if (this.id) this.hub.send('CHAN_REMOVE', { tag: 0, chan_id: this.id });
    this.id = 0;
  }
}

/** A monotonic clock in ns (CLOCK_MONOTONIC in Node; performance.now() elsewhere). */
export function monotonicNs() {
  const p = /** @type {any} */ (globalThis).process;
  if (p?.hrtime?.bigint) return p.hrtime.bigint();
  return BigInt(Math.round(performance.now() * 1e6));
}

/** A subscription by channel name: kept across reconnections and channel re-creations. */
export class Subscription {
  /**
   * @param {import('./hub.js').Hub} hub
   * @param {string} name
   * @param {((m: Message) => void) | undefined} callback
   * @param {{queueBytes?: number, bufferBytes?: number, maxHz?: number}} options
   */
  constructor(hub, name, callback, options) {
    this.hub = hub;
    this.name = name;
    this.callback = callback;
    this.queueBytes = options.queueBytes ?? 0;
    /** At most this many payloads a second (0: all), FlowProtocol 1.14. */
    this.maxHz = options.maxHz ?? 0;
    /** Bytes an unread async iterator holds before dropping the oldest (default 8 MiB). */
    this.bufferBytes = options.bufferBytes ?? 8 * 1024 * 1024;
    /** Payloads the hub dropped for this client (EV_DROPPED) and the iterator dropped unread. */
    this.dropped = 0;
    this.id = 0;
    this.closed = false;
    /** @type {Message[]} */
    this.queue = [];
    this.queued = 0;
    /** @type {((r: IteratorResult<Message>) => void) | null} */
    this.waiter = null;
  }

  /** @param {Message} m */
  deliver(m) {
    if (this.callback) {
      try {
        this.callback(m);
      } catch (e) {
        this.hub.report(e);
      }
      return;
    }
    if (this.waiter) {
      const w = this.waiter;
      this.waiter = null;
      w({ value: m, done: false });
      return;
    }
    this.queue.push(m);
    this.queued += m.payload.byteLength;
    while (this.queued > this.bufferBytes && this.queue.length > 1) {
      this.queued -= /** @type {Message} */ (this.queue.shift()).payload.byteLength;
      this.dropped += 1;
    }
  }

  /** Ends the subscription; an iterator ends after what it holds. */
  close() {
    if (this.closed) return;
    this.closed = true;
    this.hub.unsubscribe(this);
    if (this.waiter) {
      const w = this.waiter;
      this.waiter = null;
      w({ value: undefined, done: true });
    }
  }

  /** @returns {AsyncIterator<Message>} */
  [Symbol.asyncIterator]() {
    return {
      next: () => {
        const m = this.queue.shift();
        if (m) {
          this.queued -= m.payload.byteLength;
          return Promise.resolve({ value: m, done: false });
        }
        if (this.closed) return Promise.resolve({ value: undefined, done: true });
        return new Promise((resolve) => { this.waiter = resolve; });
      },
      return: () => {
        this.close();
        return Promise.resolve({ value: undefined, done: true });
      },
    };
  }
}
