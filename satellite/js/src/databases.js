// SPDX-License-Identifier: Apache-2.0
// A pair database read and written on the flow: DB_READ answered by EV_DB_VALUE, and
// DB_SET_CURRENT + VAR_SET_ASYNC / VAR_DEL_ASYNC, settled once the hub handled them. Writes of
// one client go one at a time (the hub's current database is one per flow), so that a write
// never lands in another database than its own.

const WHAT = { get: 0, all: 1, keys: 2 };

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
