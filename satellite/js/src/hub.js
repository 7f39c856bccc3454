// SPDX-License-Identifier: Apache-2.0
// A connection to a hub: LOGIN, CHAN_LIST and GO_ASYNC, then a flow; reconnection with a backoff
// growing from 100 ms to 2 s (reset after 5 s online, as satellite/cpp's Satellite), after which
// owned channels are re-created, subscriptions and followed sync sources resumed. Every request
// made on the flow carries a tag and is answered by an event with that tag or by EV_ERROR.
import { typeProperties } from './channel-type.js';
import { encodeFrame, decodeBody, codeName, CODE, PROTOCOL_MAJOR, CATALOGUE_MINOR } from './codec.js';
import { BY_CODE } from './codec.js';
import { ClosedError, FlowError, ProtocolError, errorFromWire } from './errors.js';
import { Message, OwnedChannel, Subscription, KIND, channelInfo } from './channels.js';
import { Database } from './databases.js';
import { Follower } from './sync.js';
import { BlobChannel, SyncConnection, createBlobChannel } from './blobs.js';

const BACKOFF_FIRST_MS = 100;
const BACKOFF_MAX_MS = 2000;
const STABLE_MS = 5000;
/** EV_BLOB_CHANGED's change values. */
const BLOB_CHANGES = ['', 'written', 'removed', 'dir_made', 'dir_removed'];

/**
 * @typedef {object} HubOptions
 * @property {string} [user] the account (default ROBOT_USER in Node, else "guest")
 * @property {string} [password] (default ROBOT_PASSWORD in Node, else "password")
 * @property {string | (() => string | Promise<string>)} [token] log in with a page token
 *   (LOGIN_TOKEN, FlowProtocol 1.15; ws:/wss: only) instead of user and password, as the hub's
 *   page account; a function is called before each login, the first and every reconnection
 *   (pageToken() fetches a new one from the hub)
 * @property {string} [clientName] shown in hub.stats and logs
 * @property {boolean} [reconnect] reconnect after the connection is lost (default true)
 * @property {number} [maxFrameBytes] the largest frame taken from the hub (default 16 MiB)
 * @property {number} [maxQueuedBytes] publish() drops data while more than this waits to be
 *   written (default 8 MiB)
 * @property {number} [timeoutMs] connecting and logging in (default 10 s)
 * @property {any} [WebSocket] the WebSocket class for ws:/wss: where there is no global one
 * @property {{ca?: string, cert?: string, key?: string}} [tls] files for tls: (default ROBOT_TLS_*)
 */

/** The hub's answer to LOGIN. @typedef {{major: number, minor: number, connectionId: number, appName: string, user: string, currentDb: string}} Session */

export class Hub {
  /**
   * Use connect() (node.js / index.js) rather than this.
   * @param {import('./address.js').Address} address
   * @param {HubOptions} options
   * @param {(address: import('./address.js').Address, options: HubOptions) => Promise<import('./transport-node.js').Transport>} open
   */
  constructor(address, options, open) {
    this.address = address;
    this.options = options;
    /** @internal */
    this.open = open;
    /** @internal @type {import('./transport-node.js').Transport | null} */
    this.transport = null;
    /** @type {Session | null} */
    this.session = null;
    this.online = false;
    this.closed = false;
    /** Channels the hub announced, by id. @type {Map<number, import('./channels.js').ChannelInfo>} */
    this.channels = new Map();
    /** @type {Set<OwnedChannel>} */
    this.owned = new Set();
    /** @type {Set<Subscription>} */
    this.subscriptions = new Set();
    /** @type {Set<Follower>} */
    this.followers = new Set();
    /** @type {Set<import('./databases.js').Watch>} */
    this.watches = new Set();
    /** @internal Answers awaited on the flow, by tag. @type {Map<number, {resolve: (m: any) => void, reject: (e: Error) => void, code: string}>} */
    this.pending = new Map();
    /** @internal */
    this.tag = 0;
    this.currentDb = '';
    /** @internal The database writes in turn (databases.js). @type {Promise<unknown>} */
    this.dbWrites = Promise.resolve();
    /** @internal */
    this.backoffMs = BACKOFF_FIRST_MS;
    /** @internal */
    this.onlineSince = 0;
    /** @internal */
    this.timer = null;
    /** @internal @type {Map<string, Set<Function>>} */
    this.listeners = new Map();
    /** @internal The synchronous connection of blob requests, opened on first use. @type {Promise<SyncConnection> | null} */
    this.sync = null;
  }

  /**
   * Listens to `online` (session), `offline` (error or null), `channel` (ChannelInfo added or
   * changed), `channelremoved` (ChannelInfo), `blobchanged` ({channel, change: 'written' |
   * 'removed' | 'dir_made' | 'dir_removed', path, size, version}: a file of a subscribed blob
   * channel), `error` (a FlowError no request awaits).
   * @param {string} event @param {Function} fn @returns {() => void} removes it
   */
  on(event, fn) {
    if (!this.listeners.has(event)) this.listeners.set(event, new Set());
    this.listeners.get(event)?.add(fn);
    return () => this.listeners.get(event)?.delete(fn);
  }

  /** @internal @param {string} event @param {...any} args */
  emit(event, ...args) {
    for (const fn of this.listeners.get(event) ?? []) {
      try {
        fn(...args);
      } catch (e) {
        queueMicrotask(() => { throw e; });
      }
    }
  }

  /**
   * @internal An error of the application's own code (a callback that threw): to the `error`
   * listeners, else thrown on its own (as an EventEmitter does); never into the flow's reading.
   * @param {unknown} e
   */
  report(e) {
    if (this.listeners.get('error')?.size) this.emit('error', e);
    else queueMicrotask(() => { throw e; });
  }

  // -- connection

  /** Connects and logs in once; rejects on failure (a refused login, no hub). */
  async start() {
    await this.attempt();
  }

  async attempt() {
    // A page token is good for a while only: a new one for each login, before the connection opens.
    const { token } = this.options;
    const pageToken = typeof token === 'function' ? await token() : token;
    const t = await this.open(this.address, this.options);
    if (this.closed) {
      t.close();
      throw new ClosedError('closed');
    }
    const timeoutMs = this.options.timeoutMs ?? 10000;
    // The handshake, read frame by frame in order: LOGIN's reply, then CHAN_LIST's and GO_ASYNC's
    // (sent together). Online at once after the last, so that events in the same read follow.
    let step = 'login';
    /** @type {any[]} */
    let listed = [];
    let failed = null;
    await new Promise((resolve, reject) => {
      const timer = setTimeout(() => {
        failed = failed ?? new ClosedError(`the hub did not answer the login within ${timeoutMs} ms`);
        t.close(failed);
      }, timeoutMs);
      t.onclose = (e) => {
        if (step !== 'online') {
          clearTimeout(timer);
          reject(failed ?? e ?? new ClosedError('the hub closed the connection during login'));
          return;
        }
        this.lost(t, e);
      };
      const handshake = (code, body) => {
        if (code === CODE.REPLY_ERROR) {
          const m = decodeBody(code, body);
          throw errorFromWire(m.error, m.message);
        }
        if (code !== CODE.REPLY_OK) throw new ProtocolError(`${codeName(code)} before GO_ASYNC was answered`);
        if (step === 'login') {
          const m = decodeBody(CODE.LOGIN, body, { reply: true });
          if (m.major !== PROTOCOL_MAJOR) throw new FlowError('version_mismatch', `the hub speaks FlowProtocol ${m.major}`);
          this.session = {
            major: m.major, minor: Math.min(m.minor, CATALOGUE_MINOR), connectionId: m.connection_id,
            appName: m.app_name, user: m.user, currentDb: m.current_db,
          };
          t.send([...encodeFrame('CHAN_LIST'), ...encodeFrame('GO_ASYNC')]);
          step = 'list';
        } else if (step === 'list') {
          listed = decodeBody(CODE.CHAN_LIST, body, { reply: true }).items;
          step = 'async';
        } else {
          decodeBody(CODE.GO_ASYNC, body, { reply: true });
          step = 'online';
          clearTimeout(timer);
          this.transport = t;
          this.ready(listed);
          resolve(undefined);
        }
      };
      t.onframes = (frames) => {
        for (const f of frames) {
          try {
            if (step !== 'online') handshake(f.code, f.body);
            else if (this.transport === t) this.event(f.code, f.body);
          } catch (e) {
            failed = failed ?? /** @type {Error} */ (e);
            t.close(/** @type {Error} */ (e));
            return;
          }
        }
      };
      this.pageToken = pageToken;
      t.send(encodeFrame(...this.loginMessage()));
    });
  }

  /**
   * @internal The login frame for this client (the flow's and the synchronous connection's):
   * LOGIN_TOKEN with the page token of the flow's last login, else LOGIN with the account.
   * @param {string} [suffix] added to the client name ("sync": "skrobot.js/sync")
   * @returns {[string, Record<string, any>]} the frame's name and fields
   */
  loginMessage(suffix) {
    const env = /** @type {any} */ (globalThis).process?.env ?? {};
    const name = this.options.clientName ?? 'skrobot.js';
    const head = {
      major: PROTOCOL_MAJOR, minor: CATALOGUE_MINOR, value_encoding: 0,
      client_name: suffix ? `${name}/${suffix}` : name,
    };
    if (this.pageToken !== undefined) return ['LOGIN_TOKEN', { ...head, token: this.pageToken }];
    return ['LOGIN', {
      ...head,
      user: this.options.user ?? env.ROBOT_USER ?? 'guest',
      password: this.options.password ?? env.ROBOT_PASSWORD ?? 'password',
    }];
  }

  // Online: the channel table from CHAN_LIST, then what this client had.
  /** @internal */
  ready(items) {
    this.online = true;
    this.onlineSince = Date.now();
    this.currentDb = this.session?.currentDb ?? '';
    this.channels.clear();
    for (const m of items) this.channels.set(m.id, channelInfo(m));
    for (const c of this.owned) this.createOwned(c).catch((e) => this.emit('error', e));
    for (const s of this.subscriptions) {
      s.id = 0;
      this.resubscribe(s);
    }
    for (const f of this.followers) {
      f.id = 0;
      this.refollow(f);
    }
    for (const w of this.watches) w.start();
    this.emit('online', this.session);
  }

  /** @internal */
  lost(t, error) {
    if (this.transport !== t) return;
    this.transport = null;
    this.online = false;
    for (const c of this.owned) {
      c.id = 0;
      c.setSubscribers(false);
    }
    const pending = [...this.pending.values()];
    this.pending.clear();
    for (const p of pending) p.reject(new ClosedError(`the connection to the hub was lost before ${p.code} was answered`));
    this.emit('offline', error ?? null);
    if (this.closed || this.options.reconnect === false) return;
    if (Date.now() - this.onlineSince >= STABLE_MS) this.backoffMs = BACKOFF_FIRST_MS;
    this.retry();
  }

  /** @internal */
  retry() {
    const wait = this.backoffMs;
    this.backoffMs = Math.min(this.backoffMs * 2, BACKOFF_MAX_MS);
    this.timer = setTimeout(() => {
      this.timer = null;
      if (this.closed) return;
      this.attempt().catch((e) => {
        if (this.closed) return;
        this.emit('offline', e);
        this.retry();
      });
    }, wait);
  }

  /** Closes the connection for good; pending requests fail with ClosedError. */
  close() {
    this.closed = true;
    if (this.timer) clearTimeout(this.timer);
    for (const s of this.subscriptions) s.close();
    const t = this.transport;
    if (t) t.close();
    this.sync?.then((c) => c.close(), () => {});
    this.sync = null;
  }

  // -- sending

  /** @internal Sends one frame on the flow; false while offline. @param {string} name @param {Record<string, any>} fields */
  send(name, fields) {
    if (!this.transport || !this.online) return false;
    this.transport.send(encodeFrame(name, fields));
    return true;
  }

  /** @internal */
  congested() {
    return (this.transport?.buffered() ?? 0) > (this.options.maxQueuedBytes ?? 8 * 1024 * 1024);
  }

  /** @internal */
  nextTag() {
    this.tag = (this.tag % 0xffffffff) + 1;
    return this.tag;
  }

  /**
   * @internal Sends a tagged command and waits for the event with its tag (`answer`: the code awaited),
   * or, without `answer`, for nothing: then only a failure comes (EV_ERROR), and the promise
   * resolves once a DB_READ sent after it is answered, the flow being handled in order.
   * @param {string} name @param {Record<string, any>} fields @param {string} [answer]
   * @param {{signal?: AbortSignal, sync?: (answer: any) => void}} [options] sync: called with the
   *   answer at once, before the events that came with it (the promise settles a microtask later)
   * @returns {Promise<any>}
   */
  request(name, fields, answer, options = {}) {
    if (!this.online) return Promise.reject(new ClosedError(`not connected: ${name} not sent`));
    const signal = options.signal;
    if (signal?.aborted) return Promise.reject(signal.reason);
    const tag = this.nextTag();
    return new Promise((resolve, reject) => {
      const onAbort = () => {
        this.pending.delete(tag);
        reject(signal?.reason);
      };
      signal?.addEventListener('abort', onAbort, { once: true });
      const settle = (fn) => (v) => {
        signal?.removeEventListener('abort', onAbort);
        fn(v);
      };
      const done = settle(resolve);
      const sync = options.sync;
      this.pending.set(tag, { resolve: sync ? (v) => { sync(v); done(v); } : done, reject: settle(reject), code: name });
      this.send(name, { ...fields, tag });
      if (!answer) {
        // A barrier: its answer (value or error) says the command before it was handled.
        const barrier = this.nextTag();
        this.pending.set(barrier, {
          resolve: () => { if (this.pending.delete(tag)) settle(resolve)(undefined); },
          reject: () => { if (this.pending.delete(tag)) settle(resolve)(undefined); },
          code: name,
        });
        this.send('DB_READ', { tag: barrier, db: this.currentDb || this.session?.user || '', what: 2, key: '' });
      }
    });
  }

  /** @internal A tagged command with no answer but failures. @param {string} name @param {Record<string, any>} fields */
  command(name, fields) {
    return this.request(name, fields);
  }

  // -- events from the hub

  /** @internal */
  event(code, body) {
    const row = BY_CODE.get(code);
    if (!row || row.direction !== 'to_client' || row.via === 'sync' || row.via === 'link_flow') {
      throw new ProtocolError(`the hub sent ${codeName(code)} (0x${code.toString(16)}) on a flow`);
    }
    const m = decodeBody(code, body);
    switch (row.name) {
      case 'EV_DATA': {
        const info = this.channels.get(m.chan_id);
        for (const s of this.subscriptions) {
          if (s.id === m.chan_id) s.deliver(new Message(info?.name ?? '', m.payload));
        }
        break;
      }
      case 'EV_CHAN_ADDED': {
        const info = channelInfo(m);
        this.channels.set(info.id, info);
        const p = m.tag ? this.pending.get(m.tag) : undefined;
        if (p) {
          this.pending.delete(m.tag);
          p.resolve(info);
        }
        for (const s of this.subscriptions) if (!s.id && s.name === info.name) this.resubscribe(s);
        for (const f of this.followers) if (!f.id && f.name === info.name) this.refollow(f);
        this.emit('channel', info);
        break;
      }
      case 'EV_CHAN_HEADER': {
        const info = channelInfo(m);
        this.channels.set(info.id, info);
        this.emit('channel', info);
        break;
      }
      case 'EV_CHAN_REMOVED': {
        const info = this.channels.get(m.chan_id);
        this.channels.delete(m.chan_id);
        for (const s of this.subscriptions) if (s.id === m.chan_id) s.id = 0;
        for (const f of this.followers) if (f.id === m.chan_id) f.id = 0;
        for (const c of this.owned) if (c.id === m.chan_id) { c.id = 0; c.setSubscribers(false); }
        if (info) this.emit('channelremoved', info);
        break;
      }
      case 'EV_START_PUBLISH':
      case 'EV_STOP_PUBLISH':
        for (const c of this.owned) if (c.id === m.chan_id) c.setSubscribers(row.name === 'EV_START_PUBLISH');
        break;
      case 'EV_SERVICE_REQUEST':
        this.serviceRequest(m);
        break;
      case 'EV_SERVICE_RESPONSE': {
        const p = this.pending.get(m.tag);
        if (!p) break;  // abandoned (aborted) or from an older request
        this.pending.delete(m.tag);
        if (m.error) p.reject(errorFromWire(m.error, String(m.value)));
        else p.resolve(m.value);
        break;
      }
      case 'EV_DB_VALUE':
      case 'EV_DB_SYNCED': {
        const p = this.pending.get(m.tag);
        if (p) {
          this.pending.delete(m.tag);
          p.resolve(m.value);
        }
        break;
      }
      case 'EV_ERROR': {
        const e = errorFromWire(m.error, m.message);
        const p = m.tag ? this.pending.get(m.tag) : undefined;
        const w = m.tag ? [...this.watches].find((x) => x.tag === m.tag) : undefined;
        if (w) {
          w.end(e);
        } else if (p) {
          this.pending.delete(m.tag);
          p.reject(e);
        } else {
          this.emit('error', e);
        }
        break;
      }
      case 'EV_DROPPED':
        for (const s of this.subscriptions) if (s.id === m.chan_id) s.dropped += m.count;
        break;
      case 'EV_SYNC_PULSE':
        for (const f of this.followers) if (f.id === m.chan_id) f.deliver(m);
        break;
      case 'EV_DB_PAIR':
        for (const w of this.watches) if (w.db === m.db) w.deliver(m);
        break;
      case 'EV_DB_CHANGED':
        this.currentDb = m.name;
        break;
      case 'EV_BLOB_CHANGED': {
        const info = this.channels.get(m.chan_id);
        this.emit('blobchanged', {
          channel: info?.name ?? '', change: BLOB_CHANGES[m.change] ?? String(m.change), path: m.path,
          size: Number(m.size), version: m.version,
        });
        break;
      }
      default:
        break;  // events of features this library does not use (links, physical paths)
    }
  }

  // -- channels

  /**
   * Creates <user>.<shortName>; resolves once the hub announced it. Re-created after reconnection.
   * `type` declares what its messages are (docs/channels.md, "Typed channels"): added to `props`,
   * a TypeError when it breaks the rules (typeProblem).
   * @param {string} shortName
   * @param {{kind?: 'streaming' | 'service' | 'sync', mime?: string, props?: Record<string, unknown>, type?: import('./channel-type.js').ChannelType}} [options]
   * @returns {Promise<OwnedChannel>}
   */
  async createChannel(shortName, options = {}) {
    const props = options.type ? { ...(options.props ?? {}), ...typeProperties(options.type) } : options.props ?? null;
    const c = new OwnedChannel(this, shortName, { kind: options.kind ?? 'streaming', mime: options.mime ?? '', props });
    this.owned.add(c);
    try {
      await this.createOwned(c);
    } catch (e) {
      this.owned.delete(c);
      throw e;
    }
    return c;
  }

  /** @internal The id is set as EV_CHAN_ADDED is read: an EV_START_PUBLISH may follow in the same read. */
  async createOwned(c) {
    await this.request('CHAN_ADD', {
      kind: KIND[c.spec.kind], short_name: c.shortName, mime: c.spec.mime, props: c.spec.props,
    }, 'EV_CHAN_ADDED', {
      sync: (info) => {
        c.id = info.id;
        c.name = info.name;
      },
    });
    return c;
  }

  /**
   * Subscribes to a channel by name, now or once it exists (and again after reconnections). With
   * a callback each Message is handed to it; without, iterate the subscription (for await).
   * @param {string} name the full name
   * @param {((m: Message) => void) | {queueBytes?: number, bufferBytes?: number}} [callback]
   * @param {{queueBytes?: number, bufferBytes?: number, maxHz?: number}} [options] queueBytes: the
   *   hub's queue for this subscriber (SUBSCRIBE_QUEUE); maxHz: at most this many payloads a second,
   *   the newest kept (SUBSCRIBE_RATE, FlowProtocol 1.14; an older hub sends every payload)
   * @returns {Subscription}
   */
  subscribe(name, callback, options = {}) {
    if (callback && typeof callback === 'object') {
      options = callback;
      callback = undefined;
    }
    const s = new Subscription(this, name, /** @type {any} */ (callback), options);
    this.subscriptions.add(s);
    if (this.online) this.resubscribe(s);
    return s;
  }

  /** @internal */
  resubscribe(s) {
    const info = this.channelByName(s.name);
    if (!info) return;
    s.id = info.id;
    const minor = this.session?.minor ?? 0;
    const rate = s.maxHz && CODE.SUBSCRIBE_RATE !== undefined && minor >= 14;
    const queue = s.queueBytes && minor >= 13;
    const name = rate ? 'SUBSCRIBE_RATE' : queue ? 'SUBSCRIBE_QUEUE' : 'SUBSCRIBE';
    this.request(name, { chan_id: info.id, queue_bytes: s.queueBytes, max_hz: s.maxHz }, undefined)
      .catch((e) => this.emit('error', e));
  }

  /** @internal @param {Subscription} s */
  unsubscribe(s) {
    this.subscriptions.delete(s);
    const still = [...this.subscriptions].some((o) => o.id === s.id);
    if (s.id && !still) this.send('UNSUBSCRIBE', { tag: 0, chan_id: s.id });
    s.id = 0;
  }

  /** The announced channel of that name. @param {string} name */
  channelByName(name) {
    for (const info of this.channels.values()) if (info.name === name) return info;
    return undefined;
  }

  // -- services

  /**
   * Calls a service: resolves with the owner's answer. Fails with TimeoutError past timeoutMs
   * (0: the hub's default), OwnerGoneError, NotFoundError..., or the signal's reason when aborted.
   * @param {string} name @param {string} command @param {unknown} [value]
   * @param {{timeoutMs?: number, signal?: AbortSignal}} [options]
   */
  call(name, command, value = null, options = {}) {
    const info = this.channelByName(name);
    if (!info) return Promise.reject(errorFromWire(5, `no channel ${name}`));
    return this.request('SERVICE_REQUEST_TIMED', {
      chan_id: info.id, timeout_ms: options.timeoutMs ?? 0, command, value,
    }, 'EV_SERVICE_RESPONSE', options);
  }

  /**
   * Offers a service: `handler(command, value, {requester})` returns (or resolves to) the answer;
   * a thrown error answers {error: message}.
   * @param {string} shortName
   * @param {(command: string, value: any, request: {requester: string}) => unknown} handler
   * @param {{mime?: string, props?: Record<string, unknown>}} [options]
   */
  async serve(shortName, handler, options = {}) {
    const c = await this.createChannel(shortName, { ...options, kind: 'service' });
    c.handler = handler;
    return c;
  }

  /** @internal */
  serviceRequest(m) {
    const c = [...this.owned].find((o) => o.id === m.chan_id);
    const answer = (value) => this.send('SERVICE_RESPONSE', { chan_id: m.chan_id, request: m.request, value });
    if (!c?.handler) {
      answer({ error: 'no handler' });
      return;
    }
    Promise.resolve()
      .then(() => c.handler?.(m.command, m.value, { requester: m.requester }))
      .then((v) => answer(v ?? null), (e) => answer({ error: String(e?.message ?? e) }));
  }

  // -- blob channels (blobs.js)

  /**
   * The synchronous connection that blob requests go on (requests answered in order): opened on
   * first use, again after it was lost; closed with the hub.
   * @returns {Promise<SyncConnection>}
   */
  syncConnection() {
    if (this.closed) return Promise.reject(new ClosedError('closed'));
    if (!this.sync) {
      const p = SyncConnection.open(this);
      this.sync = p;
      p.then((c) => {
        c.onclose = () => { if (this.sync === p) this.sync = null; };
        if (this.closed) c.close();
      }, () => { if (this.sync === p) this.sync = null; });
    }
    return this.sync;
  }

  /**
   * Creates this user's blob channel <user>.<shortName>, or gives the existing one back, files
   * and all (BLOB_CREATE). UnsupportedError from a hub before FlowProtocol 1.3.
   * @param {string} shortName
   * @returns {Promise<BlobChannel>}
   */
  createBlobChannel(shortName) {
    return createBlobChannel(this, shortName);
  }

  /**
   * A blob channel by its full name (another user's, to list and download; requests on it fail
   * with NotFoundError while the hub has none of that name).
   * @param {string} name
   * @returns {BlobChannel}
   */
  blobChannel(name) {
    return new BlobChannel(this, name);
  }

  // -- databases, sync, stats

  /** A database by name (default: the user's). @param {string} [name] */
  db(name) {
    return new Database(this, name ?? this.session?.user ?? '');
  }

  /**
   * Follows a sync source: `fn(pulse)` per pulse; SYNC_DONE goes once it returned (or its
   * promise settled).
   * @param {string} name @param {(pulse: {seq: bigint, sourceTimeNs: bigint, dropped: number}) => unknown} fn
   * @param {{every?: number}} [options]
   */
  follow(name, fn, options = {}) {
    const f = new Follower(this, name, fn, options.every ?? 1);
    this.followers.add(f);
    if (this.online) this.refollow(f);
    return f;
  }

  /** @internal */
  refollow(f) {
    const info = this.channelByName(f.name);
    if (!info) return;
    f.id = info.id;
    this.request('SYNC_FOLLOW', { chan_id: info.id, every: f.every }).catch((e) => this.emit('error', e));
  }

  /**
   * The hub's statistics (hub.stats, JSON each second while followed): `fn(stats)`.
   * @param {(stats: any) => void} fn @returns {Subscription}
   */
  stats(fn) {
    return this.subscribe('hub.stats', (m) => fn(m.json()));
  }

  /**
   * An administrator's command (FlowProtocol's ADMIN: the commands flowctl sends, such as
   * `flows`, `reload` or `module_config`; docs/flow-protocol.md): resolves with its answer.
   * PermissionDeniedError for an account that is not an administrator. Sent on the synchronous
   * connection (Hub.syncConnection()).
   * @param {string} command @param {Record<string, unknown>} [args]
   * @returns {Promise<any>}
   */
  async admin(command, args = {}) {
    const conn = await this.syncConnection();
    const { value } = await conn.call('ADMIN', { command, args });
    return value;
  }
}
