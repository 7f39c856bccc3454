/**
 * A payload as bytes: an ArrayBuffer or typed array as it is (a view), a string as UTF-8, anything
 * else as JSON text.
 * @param {ArrayBuffer | ArrayBufferView | string | unknown} data
 * @returns {Uint8Array}
 */
export function payloadBytes(data: ArrayBuffer | ArrayBufferView | string | unknown): Uint8Array;
/**
 * The channel facts the hub announces (ChannelInfo), with the kind as a name.
 * @typedef {{id: number, hash: bigint, kind: string, name: string, owner: string,
 *   ownerConnection: number, mime: string, subscribers: number, props: any}} ChannelInfo
 */
/** @param {Record<string, any>} m a decoded ChannelInfo @returns {ChannelInfo} */
export function channelInfo(m: Record<string, any>): ChannelInfo;
/** A monotonic clock in ns (CLOCK_MONOTONIC in Node; performance.now() elsewhere). */
export function monotonicNs(): any;
/** Channel kinds by name ({streaming: 1, ...}) and back. */
export const KIND: Readonly<{
    [k: string]: string | number;
}>;
export const KIND_NAME: Readonly<{
    [k: string]: string | number;
}>;
/** One received payload. */
export class Message {
    /** @param {string} channel @param {Uint8Array} payload */
    constructor(channel: string, payload: Uint8Array);
    /** The channel's full name. */
    channel: string;
    /** A view into the received bytes: copy it (slice()) to keep it past the callback. */
    payload: Uint8Array<ArrayBufferLike>;
    /** The payload as UTF-8 text. */
    text(): string;
    /** The payload as JSON. */
    json(): any;
}
/** A channel this client created; re-created after each reconnection. */
export class OwnedChannel {
    /** @param {import('./hub.js').Hub} hub @param {string} shortName @param {{kind: string, mime: string, props: any}} spec */
    constructor(hub: import("./hub.js").Hub, shortName: string, spec: {
        kind: string;
        mime: string;
        props: any;
    });
    hub: import("./hub.js").Hub;
    shortName: string;
    spec: {
        kind: string;
        mime: string;
        props: any;
    };
    /** The full name, <user>.<short name>, once created. */
    name: string;
    /** The id on the current connection (0 while offline). */
    id: number;
    /** True while at least one subscriber listens (EV_START_PUBLISH .. EV_STOP_PUBLISH). */
    hasSubscribers: boolean;
    removed: boolean;
    /** Payloads publish() dropped (offline or congested). */
    dropped: number;
    /** @type {Set<(on: boolean) => void>} */
    listeners: Set<(on: boolean) => void>;
    /** @type {((command: string, value: any, request: {requester: string}) => any) | null} */
    handler: ((command: string, value: any, request: {
        requester: string;
    }) => any) | null;
    /**
     * Calls `fn(true)` when a first subscriber arrives and `fn(false)` when the last one leaves.
     * @param {(hasSubscribers: boolean) => void} fn
     * @returns {() => void} removes the listener
     */
    onSubscribers(fn: (hasSubscribers: boolean) => void): () => void;
    /** @param {boolean} on */
    setSubscribers(on: boolean): void;
    /**
     * Publishes one payload. Returns false when it was dropped: offline, or the hub is not taking
     * what was written (more than the hub option maxQueuedBytes, default 8 MiB, waits in this
     * process): data is dropped, never queued without bound. `dropped` counts them.
     * @param {ArrayBuffer | ArrayBufferView | string | unknown} data
     */
    publish(data: ArrayBuffer | ArrayBufferView | string | unknown): boolean;
    /** Replaces properties (a null value removes its key). @param {Record<string, unknown>} props */
    setProps(props: Record<string, unknown>): Promise<any>;
    /** A sync source's pulse (SYNC_PULSE), stamped with this process's monotonic clock. */
    pulse(sourceTimeNs?: any): boolean;
    /** Removes the channel (not re-created after a reconnection). */
    remove(): void;
}
/** A subscription by channel name: kept across reconnections and channel re-creations. */
export class Subscription {
    /**
     * @param {import('./hub.js').Hub} hub
     * @param {string} name
     * @param {((m: Message) => void) | undefined} callback
     * @param {{queueBytes?: number, bufferBytes?: number, maxHz?: number}} options
     */
    constructor(hub: import("./hub.js").Hub, name: string, callback: ((m: Message) => void) | undefined, options: {
        queueBytes?: number;
        bufferBytes?: number;
        maxHz?: number;
    });
    hub: import("./hub.js").Hub;
    name: string;
    callback: (m: Message) => void;
    queueBytes: number;
    /** At most this many payloads a second (0: all), FlowProtocol 1.14. */
    maxHz: number;
    /** Bytes an unread async iterator holds before dropping the oldest (default 8 MiB). */
    bufferBytes: number;
    /** Payloads the hub dropped for this client (EV_DROPPED) and the iterator dropped unread. */
    dropped: number;
    id: number;
    closed: boolean;
    /** @type {Message[]} */
    queue: Message[];
    queued: number;
    /** @type {((r: IteratorResult<Message>) => void) | null} */
    waiter: ((r: IteratorResult<Message>) => void) | null;
    /** @param {Message} m */
    deliver(m: Message): void;
    /** Ends the subscription; an iterator ends after what it holds. */
    close(): void;
    /** @returns {AsyncIterator<Message>} */
    [Symbol.asyncIterator](): AsyncIterator<Message>;
}
/**
 * The channel facts the hub announces (ChannelInfo), with the kind as a name.
 */
export type ChannelInfo = {
    id: number;
    hash: bigint;
    kind: string;
    name: string;
    owner: string;
    ownerConnection: number;
    mime: string;
    subscribers: number;
    props: any;
};
