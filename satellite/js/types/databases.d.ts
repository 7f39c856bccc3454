export class Database {
    /** @param {import('./hub.js').Hub} hub @param {string} name */
    constructor(hub: import("./hub.js").Hub, name: string);
    hub: import("./hub.js").Hub;
    name: string;
    /** A key's value (NotFoundError when absent). @param {string} key */
    get(key: string): Promise<any>;
    /** Every pair, as an object. @returns {Promise<Record<string, any>>} */
    getAll(): Promise<Record<string, any>>;
    /** The keys, sorted. @returns {Promise<string[]>} */
    keys(): Promise<string[]>;
    /** Sets a key; resolves once the hub did it (PermissionDeniedError...). @param {string} key @param {unknown} value */
    set(key: string, value: unknown): Promise<void>;
    /** Deletes a key. @param {string} key */
    delete(key: string): Promise<void>;
    /** @internal @param {string} name @param {Record<string, unknown>} fields */
    write(name: string, fields: Record<string, unknown>): Promise<void>;
}
