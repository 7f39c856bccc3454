// SPDX-License-Identifier: Apache-2.0
// A pair database read and written on the flow: DB_READ answered by EV_DB_VALUE, and
// DB_SET_CURRENT + VAR_SET_ASYNC / VAR_DEL_ASYNC, settled once the hub handled them. Writes of
// one client go one at a time (the hub's current database is one per flow), so that a write
// never lands in another database than its own.

import { CODE } from './codec.js';
import { UnsupportedError } from './errors.js';

const WHAT = { get: 0, all: 1, keys: 2 };
/** EV_DB_PAIR's states (1.14). */
export const PAIR_STATES = Object.freeze(['removed', 'set', 'cleared', 'snapshot_end']);

/**
 * A change of a watched database: `set` (key, value), `removed` (key), `cleared` (every key),
 * `snapshot_end` (the pairs before it were the database's when the watch began).
 * @typedef {{db: string, key: string, state: 'set' | 'removed' | 'cleared' | 'snapshot_end', value: any}} PairChange
 */

/** A database watch (DB_WATCH, FlowProtocol 1.14), kept across reconnections. */
export class Watch {
  /**
   * @param {import('./hub.js').Hub} hub @param {string} db
   * @param {((change: PairChange) => void) | undefined} fn
   * @param {((error: Error) => void) | undefined} onEnd
   */
  constructor(hub, db, fn, onEnd) {
    this.hub = hub;
    this.db = db;
    this.fn = fn;
    this.onEnd = onEnd;
    /** The database's pairs as the hub last said (complete once `ready` resolved). @type {Map<string, any>} */
    this.pairs = new Map();
    this.tag = 0;
    this.closed = false;
    /** @type {(v: Watch) => void} */
    this.resolveReady = () => {};
    /** @type {(e: Error) => void} */
    this.rejectReady = () => {};
    /** Resolves at the first snapshot's end; rejects when the hub refuses the watch. @type {Promise<Watch>} */
    this.ready = new Promise((resolve, reject) => {
      this.resolveReady = resolve;
      this.rejectReady = reject;
    });
    this.ready.catch(() => {});
  }

  /** @internal Sends DB_WATCH (again after a reconnection: a new snapshot). */
  start() {
    this.tag = this.hub.nextTag();
    this.pairs = new Map();
    this.hub.send('DB_WATCH', { tag: this.tag, name: this.db });
  }

  /** @internal @param {{db: string, key: string, state: number, value: any}} m */
  deliver(m) {
    const change = { db: m.db, key: m.key, state: PAIR_STATES[m.state] ?? String(m.state), value: m.value };
    if (change.state === 'set') this.pairs.set(m.key, m.value);
    else if (change.state === 'removed') this.pairs.delete(m.key);
    else if (change.state === 'cleared') this.pairs.clear();
    else if (change.state === 'snapshot_end') this.resolveReady(this);
    try {
      this.fn?.(/** @type {PairChange} */ (change));
    } catch (e) {
      this.hub.report(e);
    }
  }

  /** @internal The hub ended the watch (refused, or the database removed). @param {Error} e */
  end(e) {
    this.closed = true;
    this.hub.watches.delete(this);
    this.rejectReady(e);
    if (this.onEnd) this.onEnd(e);
    else this.hub.report(e);
  }

  /** Ends the watch. */
  close() {
    if (this.closed) return;
    this.closed = true;
    this.hub.watches.delete(this);
    this.hub.send('DB_UNWATCH', { tag: 0, name: this.db });
  }
}

export class Database {
  /** @param {import('./hub.js').Hub} hub @param {string} name */
  constructor(hub, name) {
    this.hub = hub;
    this.name = name;
  }

  /** A key's value (NotFoundError when absent). @param {string} key */
  get(key) {
    return this.hub.request('DB_READ', { db: this.name, what: WHAT.get, key }, 'EV_DB_VALUE');
  }

  /** Every pair, as an object. @returns {Promise<Record<string, any>>} */
  getAll() {
    return this.hub.request('DB_READ', { db: this.name, what: WHAT.all, key: '' }, 'EV_DB_VALUE');
  }

  /** The keys, sorted. @returns {Promise<string[]>} */
  keys() {
    return this.hub.request('DB_READ', { db: this.name, what: WHAT.keys, key: '' }, 'EV_DB_VALUE');
  }

  /**
   * Watches the database (FlowProtocol 1.14): `fn` gets its pairs (`set`), `snapshot_end`, then
   * every change; `watch.pairs` mirrors it. The hub's refusal or the database's removal ends the
   * watch: `onEnd(error)` (else the hub's error listeners), and `watch.ready` rejects if it
   * never began. UnsupportedError from a hub (or this library's catalogue) before 1.14.
   * @param {(change: PairChange) => void} [fn]
   * @param {{onEnd?: (error: Error) => void}} [options]
   * @returns {Watch}
   */
  watch(fn, options = {}) {
    if (CODE.DB_WATCH === undefined || (this.hub.session?.minor ?? 0) < 14) {
      throw new UnsupportedError('a database watch needs FlowProtocol 1.14 on both sides');
    }
    const w = new Watch(this.hub, this.name, fn, options.onEnd);
    this.hub.watches.add(w);
    if (this.hub.online) w.start();
    return w;
  }

  /** Sets a key; resolves once the hub did it (PermissionDeniedError...). @param {string} key @param {unknown} value */
  set(key, value) {
    return this.write('VAR_SET_ASYNC', { key, value });
  }

  /** Deletes a key. @param {string} key */
  delete(key) {
    return this.write('VAR_DEL_ASYNC', { key });
  }

  /** @internal @param {string} name @param {Record<string, unknown>} fields */
  write(name, fields) {
    const hub = this.hub;
    const run = async () => {
      if (hub.currentDb !== this.name) {
        await hub.command('DB_SET_CURRENT', { name: this.name });
        hub.currentDb = this.name;
      }
      await hub.command(name, fields);
    };
    const p = hub.dbWrites.then(run, run);
    hub.dbWrites = p.catch(() => {});
    return p;
  }
}
