// SPDX-License-Identifier: Apache-2.0
// A pair database read and written on the flow: DB_READ answered by EV_DB_VALUE, and
// DB_SET_CURRENT + VAR_SET_ASYNC / VAR_DEL_ASYNC, settled once the hub handled them.

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

  async select() {
    if (this.hub.currentDb === this.name) return;
    await this.hub.command('DB_SET_CURRENT', { name: this.name });
    this.hub.currentDb = this.name;
  }

  /** Sets a key; resolves once the hub did it (PermissionDeniedError...). @param {string} key @param {unknown} value */
  async set(key, value) {
    await this.select();
    await this.hub.command('VAR_SET_ASYNC', { key, value });
  }

  /** Deletes a key. @param {string} key */
  async delete(key) {
    await this.select();
    await this.hub.command('VAR_DEL_ASYNC', { key });
  }
}
