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
    constructor(address: import("./address.js").Address, options: HubOptions, open: (address: import("./address.js").Address, options: HubOptions) => Promise<import("./transport-node.js").Transport>);
    address: import("./address.js").Address;
    options: HubOptions;
    /** @internal */
    open: (address: import("./address.js").Address, options: HubOptions) => Promise<import("./transport-node.js").Transport>;
    /** @internal @type {import('./transport-node.js').Transport | null} */
    transport: import("./transport-node.js").Transport | null;
    /** @type {Session | null} */
    session: Session | null;
    online: boolean;
    closed: boolean;
    /** Channels the hub announced, by id. @type {Map<number, import('./channels.js').ChannelInfo>} */
    channels: Map<number, import("./channels.js").ChannelInfo>;
    /** @type {Set<OwnedChannel>} */
    owned: Set<OwnedChannel>;
    /** @type {Set<Subscription>} */
    subscriptions: Set<Subscription>;
    /** @type {Set<Follower>} */
    followers: Set<Follower>;
    /** @type {Set<import('./databases.js').Watch>} */
    watches: Set<import("./databases.js").Watch>;
    /** @internal Answers awaited on the flow, by tag. @type {Map<number, {resolve: (m: any) => void, reject: (e: Error) => void, code: string}>} */
    pending: Map<number, {
        resolve: (m: any) => void;
        reject: (e: Error) => void;
        code: string;
    }>;
    /** @internal */
    tag: number;
    currentDb: string;
    /** @internal The database writes in turn (databases.js). @type {Promise<unknown>} */
    dbWrites: Promise<unknown>;
    /** @internal */
    backoffMs: number;
    /** @internal */
    onlineSince: number;
    /** @internal */
    timer: any;
    /** @internal @type {Map<string, Set<Function>>} */
    listeners: Map<string, Set<Function>>;
    /** @internal The synchronous connection of blob requests, opened on first use. @type {Promise<SyncConnection> | null} */
    sync: Promise<SyncConnection> | null;
    /**
     * Listens to `online` (session), `offline` (error or null), `channel` (ChannelInfo added or
     * changed), `channelremoved` (ChannelInfo), `blobchanged` ({channel, change: 'written' |
     * 'removed' | 'dir_made' | 'dir_removed', path, size, version}: a file of a subscribed blob
     * channel), `error` (a FlowError no request awaits).
     * @param {string} event @param {Function} fn @returns {() => void} removes it
     */
    on(event: string, fn: Function): () => void;
    /** @internal @param {string} event @param {...any} args */
    emit(event: string, ...args: any[]): void;
    /**
     * @internal An error of the application's own code (a callback that threw): to the `error`
     * listeners, else thrown on its own (as an EventEmitter does); never into the flow's reading.
     * @param {unknown} e
     */
    report(e: unknown): void;
    /** Connects and logs in once; rejects on failure (a refused login, no hub). */
    start(): Promise<void>;
    attempt(): Promise<void>;
    pageToken: string;
    /**
     * @internal The login frame for this client (the flow's and the synchronous connection's):
     * LOGIN_TOKEN with the page token of the flow's last login, else LOGIN with the account.
     * @param {string} [suffix] added to the client name ("sync": "skrobot.js/sync")
     * @returns {[string, Record<string, any>]} the frame's name and fields
     */
    loginMessage(suffix?: string): [string, Record<string, any>];
    /** @internal */
    ready(items: any): void;
    /** @internal */
    lost(t: any, error: any): void;
    /** @internal */
    retry(): void;
    /** Closes the connection for good; pending requests fail with ClosedError. */
    close(): void;
    /** @internal Sends one frame on the flow; false while offline. @param {string} name @param {Record<string, any>} fields */
    send(name: string, fields: Record<string, any>): boolean;
    /** @internal */
    congested(): boolean;
    /** @internal */
    nextTag(): number;
    /**
     * @internal Sends a tagged command and waits for the event with its tag (`answer`: the code awaited),
     * or, without `answer`, for nothing: then only a failure comes (EV_ERROR), and the promise
     * resolves once a DB_READ sent after it is answered, the flow being handled in order.
     * @param {string} name @param {Record<string, any>} fields @param {string} [answer]
     * @param {{signal?: AbortSignal, sync?: (answer: any) => void}} [options] sync: called with the
     *   answer at once, before the events that came with it (the promise settles a microtask later)
     * @returns {Promise<any>}
     */
    request(name: string, fields: Record<string, any>, answer?: string, options?: {
        signal?: AbortSignal;
        sync?: (answer: any) => void;
    }): Promise<any>;
    /** @internal A tagged command with no answer but failures. @param {string} name @param {Record<string, any>} fields */
    command(name: string, fields: Record<string, any>): Promise<any>;
    /** @internal */
    event(code: any, body: any): void;
    /**
     * Creates <user>.<shortName>; resolves once the hub announced it. Re-created after reconnection.
     * `type` declares what its messages are (docs/channels.md, "Typed channels"): added to `props`,
     * a TypeError when it breaks the rules (typeProblem).
     * @param {string} shortName
     * @param {{kind?: 'streaming' | 'service' | 'sync', mime?: string, props?: Record<string, unknown>, type?: import('./channel-type.js').ChannelType}} [options]
     * @returns {Promise<OwnedChannel>}
     */
    createChannel(shortName: string, options?: {
        kind?: "streaming" | "service" | "sync";
        mime?: string;
        props?: Record<string, unknown>;
        type?: import("./channel-type.js").ChannelType;
    }): Promise<OwnedChannel>;
    /** @internal The id is set as EV_CHAN_ADDED is read: an EV_START_PUBLISH may follow in the same read. */
    createOwned(c: any): Promise<any>;
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
    subscribe(name: string, callback?: ((m: Message) => void) | {
        queueBytes?: number;
        bufferBytes?: number;
    }, options?: {
        queueBytes?: number;
        bufferBytes?: number;
        maxHz?: number;
    }): Subscription;
    /** @internal */
    resubscribe(s: any): void;
    /** @internal @param {Subscription} s */
    unsubscribe(s: Subscription): void;
    /** The announced channel of that name. @param {string} name */
    channelByName(name: string): import("./channels.js").ChannelInfo;
    /**
     * Calls a service: resolves with the owner's answer. Fails with TimeoutError past timeoutMs
     * (0: the hub's default), OwnerGoneError, NotFoundError..., or the signal's reason when aborted.
     * @param {string} name @param {string} command @param {unknown} [value]
     * @param {{timeoutMs?: number, signal?: AbortSignal}} [options]
     */
    call(name: string, command: string, value?: unknown, options?: {
        timeoutMs?: number;
        signal?: AbortSignal;
    }): Promise<any>;
    /**
     * Offers a service: `handler(command, value, {requester})` returns (or resolves to) the answer;
     * a thrown error answers {error: message}.
     * @param {string} shortName
     * @param {(command: string, value: any, request: {requester: string}) => unknown} handler
     * @param {{mime?: string, props?: Record<string, unknown>}} [options]
     */
    serve(shortName: string, handler: (command: string, value: any, request: {
        requester: string;
    }) => unknown, options?: {
        mime?: string;
        props?: Record<string, unknown>;
    }): Promise<OwnedChannel>;
    /** @internal */
    serviceRequest(m: any): void;
    /**
     * The synchronous connection that blob requests go on (requests answered in order): opened on
     * first use, again after it was lost; closed with the hub.
     * @returns {Promise<SyncConnection>}
     */
    syncConnection(): Promise<SyncConnection>;
    /**
     * Creates this user's blob channel <user>.<shortName>, or gives the existing one back, files
     * and all (BLOB_CREATE). UnsupportedError from a hub before FlowProtocol 1.3.
     * @param {string} shortName
     * @returns {Promise<BlobChannel>}
     */
    createBlobChannel(shortName: string): Promise<BlobChannel>;
    /**
     * A blob channel by its full name (another user's, to list and download; requests on it fail
     * with NotFoundError while the hub has none of that name).
     * @param {string} name
     * @returns {BlobChannel}
     */
    blobChannel(name: string): BlobChannel;
    /** A database by name (default: the user's). @param {string} [name] */
    db(name?: string): Database;
    /**
     * Follows a sync source: `fn(pulse)` per pulse; SYNC_DONE goes once it returned (or its
     * promise settled).
     * @param {string} name @param {(pulse: {seq: bigint, sourceTimeNs: bigint, dropped: number}) => unknown} fn
     * @param {{every?: number}} [options]
     */
    follow(name: string, fn: (pulse: {
        seq: bigint;
        sourceTimeNs: bigint;
        dropped: number;
    }) => unknown, options?: {
        every?: number;
    }): Follower;
    /** @internal */
    refollow(f: any): void;
    /**
     * The hub's statistics (hub.stats, JSON each second while followed): `fn(stats)`.
     * @param {(stats: any) => void} fn @returns {Subscription}
     */
    stats(fn: (stats: any) => void): Subscription;
    /**
     * An administrator's command (FlowProtocol's ADMIN: the commands flowctl sends, such as
     * `flows`, `reload` or `module_config`; docs/flow-protocol.md): resolves with its answer.
     * PermissionDeniedError for an account that is not an administrator. Sent on the synchronous
     * connection (Hub.syncConnection()).
     * @param {string} command @param {Record<string, unknown>} [args]
     * @returns {Promise<any>}
     */
    admin(command: string, args?: Record<string, unknown>): Promise<any>;
}
export type HubOptions = {
    /**
     * the account (default ROBOT_USER in Node, else "guest")
     */
    user?: string;
    /**
     * (default ROBOT_PASSWORD in Node, else "password")
     */
    password?: string;
    /**
     * log in with a page token
     * (LOGIN_TOKEN, FlowProtocol 1.15; ws:/wss: only) instead of user and password, as the hub's
     * page account; a function is called before each login, the first and every reconnection
     * (pageToken() fetches a new one from the hub)
     */
    token?: string | (() => string | Promise<string>);
    /**
     * shown in hub.stats and logs
     */
    clientName?: string;
    /**
     * reconnect after the connection is lost (default true)
     */
    reconnect?: boolean;
    /**
     * the largest frame taken from the hub (default 16 MiB)
     */
    maxFrameBytes?: number;
    /**
     * publish() drops data while more than this waits to be
     * written (default 8 MiB)
     */
    maxQueuedBytes?: number;
    /**
     * connecting and logging in (default 10 s)
     */
    timeoutMs?: number;
    /**
     * the WebSocket class for ws:/wss: where there is no global one
     */
    WebSocket?: any;
    /**
     * files for tls: (default ROBOT_TLS_*)
     */
    tls?: {
        ca?: string;
        cert?: string;
        key?: string;
    };
};
/**
 * The hub's answer to LOGIN.
 */
export type Session = {
    major: number;
    minor: number;
    connectionId: number;
    appName: string;
    user: string;
    currentDb: string;
};
import { OwnedChannel } from './channels.js';
import { Subscription } from './channels.js';
import { Follower } from './sync.js';
import { SyncConnection } from './blobs.js';
import { Message } from './channels.js';
import { BlobChannel } from './blobs.js';
import { Database } from './databases.js';
