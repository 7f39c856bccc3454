/** EV_DB_PAIR's states (1.14). */
export const PAIR_STATES: readonly string[];
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
    constructor(hub: import("./hub.js").Hub, db: string, fn: ((change: PairChange) => void) | undefined, onEnd: ((error: Error) => void) | undefined);
    hub: import("./hub.js").Hub;
    db: string;
    fn: (change: PairChange) => void;
    onEnd: (error: Error) => void;
    /** The database's pairs as the hub last said (complete once `ready` resolved). @type {Map<string, any>} */
    pairs: Map<string, any>;
    tag: number;
    closed: boolean;
    /** @type {(v: Watch) => void} */
    resolveReady: (v: Watch) => void;
    /** @type {(e: Error) => void} */
    rejectReady: (e: Error) => void;
    /** Resolves at the first snapshot's end; rejects when the hub refuses the watch. @type {Promise<Watch>} */
    ready: Promise<Watch>;
    /** @internal Sends DB_WATCH (again after a reconnection: a new snapshot). */
    start(): void;
    /** @internal @param {{db: string, key: string, state: number, value: any}} m */
    deliver(m: {
        db: string;
        key: string;
        state: number;
        value: any;
    }): void;
    /** @internal The hub ended the watch (refused, or the database removed). @param {Error} e */
    end(e: Error): void;
    /** Ends the watch. */
    close(): void;
}
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
    /**
     * Watches the database (FlowProtocol 1.14): `fn` gets its pairs (`set`), `snapshot_end`, then
     * every change; `watch.pairs` mirrors it. The hub's refusal or the database's removal ends the
     * watch: `onEnd(error)` (else the hub's error listeners), and `watch.ready` rejects if it
     * never began. UnsupportedError from a hub (or this library's catalogue) before 1.14.
     * @param {(change: PairChange) => void} [fn]
     * @param {{onEnd?: (error: Error) => void}} [options]
     * @returns {Watch}
     */
    watch(fn?: (change: PairChange) => void, options?: {
        onEnd?: (error: Error) => void;
    }): Watch;
    /** Sets a key; resolves once the hub did it (PermissionDeniedError...). @param {string} key @param {unknown} value */
    set(key: string, value: unknown): Promise<void>;
    /** Deletes a key. @param {string} key */
    delete(key: string): Promise<void>;
    /** @internal @param {string} name @param {Record<string, unknown>} fields */
    write(name: string, fields: Record<string, unknown>): Promise<void>;
}
/**
 * A change of a watched database: `set` (key, value), `removed` (key), `cleared` (every key),
 * `snapshot_end` (the pairs before it were the database's when the watch began).
 */
export type PairChange = {
    db: string;
    key: string;
    state: "set" | "removed" | "cleared" | "snapshot_end";
    value: any;
};
