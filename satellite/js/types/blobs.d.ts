/**
 * Creates the caller's blob channel <user>.<shortName>, or gives the existing one back (with its
 * files).
 * @param {import('./hub.js').Hub} hub @param {string} shortName
 * @returns {Promise<BlobChannel>}
 */
export function createBlobChannel(hub: import("./hub.js").Hub, shortName: string): Promise<BlobChannel>;
/** Bytes asked for, or sent, per request (the hub takes at most 4 MiB). */
export const BLOB_CHUNK_BYTES: number;
/** Requests of a transfer sent ahead of their answers (the hub works on 8 of a connection at once). */
export const BLOB_WINDOW: 8;
/**
 * One entry of a directory (BLOB_LIST).
 * @typedef {{name: string, dir: boolean, size: number, mtimeNs: bigint, version: bigint}} BlobEntry
 */
/** A transfer's progress: bytes done (acknowledged by the hub, or received) of total. @typedef {{bytes: number, total: number}} BlobProgress */
/**
 * Options of a transfer.
 * @typedef {object} BlobTransferOptions
 * @property {(progress: BlobProgress) => void} [onProgress] after each chunk; the last has bytes === total
 * @property {AbortSignal} [signal] stops the transfer: an upload is dropped by the hub (BLOB_ABORT)
 * @property {number} [chunkBytes] per request (default BLOB_CHUNK_BYTES, at most 4 MiB)
 * @property {number} [window] requests ahead of their answers (default BLOB_WINDOW)
 */
/**
 * What can be uploaded: bytes (sent as views), a Blob (read a chunk at a time), or a stream of
 * bytes (a WHATWG ReadableStream, a Node Readable or any (async) iterable of Uint8Array or string),
 * which needs `size`.
 * @typedef {ArrayBuffer | ArrayBufferView | Blob | ReadableStream<Uint8Array> | AsyncIterable<Uint8Array | string> | Iterable<Uint8Array>} BlobSource
 */
/**
 * A synchronous connection: LOGIN, then requests whose answers come in the order asked, so that
 * many may be on their way at once. Used by blob channels; opened by Hub.syncConnection().
 */
export class SyncConnection {
    /**
     * Opens and logs in with the hub's account and transport.
     * @param {import('./hub.js').Hub} hub
     * @returns {Promise<SyncConnection>}
     */
    static open(hub: import("./hub.js").Hub): Promise<SyncConnection>;
    /** @param {import('./transport-node.js').Transport} transport */
    constructor(transport: import("./transport-node.js").Transport);
    /** @internal */
    transport: import("./transport-node.js").Transport;
    /** @internal The requests awaiting their answers, oldest first. @type {{resolve: (f: import('./frames.js').Frame) => void, reject: (e: Error) => void, name: string}[]} */
    waiting: {
        resolve: (f: import("./frames.js").Frame) => void;
        reject: (e: Error) => void;
        name: string;
    }[];
    closed: boolean;
    /** The session of this connection (LOGIN's answer). @type {{minor: number, connectionId: number}} */
    session: {
        minor: number;
        connectionId: number;
    };
    /** Called once when the connection ends. @type {(error: Error) => void} */
    onclose: (error: Error) => void;
    /**
     * Sends a request; resolves with its answer's frame (REPLY_OK or REPLY_ERROR), in order.
     * @param {string} name @param {Record<string, any>} fields
     * @returns {Promise<import('./frames.js').Frame>}
     */
    request(name: string, fields: Record<string, any>): Promise<import("./frames.js").Frame>;
    /**
     * An answer's fields (REPLY_OK's body decoded as `name`'s reply); REPLY_ERROR throws its FlowError.
     * @param {string} name @param {import('./frames.js').Frame} f
     * @returns {Record<string, any>}
     */
    answer(name: string, f: import("./frames.js").Frame): Record<string, any>;
    /** A request and its answer's fields. @param {string} name @param {Record<string, any>} fields */
    call(name: string, fields: Record<string, any>): Promise<Record<string, any>>;
    /** @internal @param {Error} e */
    fail(e: Error): void;
    /** Closes the connection; requests on their way fail with ClosedError. */
    close(): void;
}
/**
 * A download: iterate it (for await: Uint8Array views, each valid as long as it is kept) or take
 * it as a WHATWG ReadableStream with stream(); once only. `size` and `version` are known after the
 * first chunk. The next chunks are asked for as the caller takes them, at most `window` ahead.
 */
export class BlobDownload {
    /** @param {BlobChannel} channel @param {string} path @param {BlobTransferOptions} options */
    constructor(channel: BlobChannel, path: string, options: BlobTransferOptions);
    channel: BlobChannel;
    path: string;
    /** @internal */
    options: BlobTransferOptions;
    /** The file's size, once the first chunk came. @type {number | null} */
    size: number | null;
    /** The version downloaded (every chunk is of it), once the first chunk came. @type {bigint | null} */
    version: bigint | null;
    /** @internal */
    started: boolean;
    /** @internal */
    chunks(): AsyncGenerator<any, void, unknown>;
    /**
     * The download as a WHATWG ReadableStream of Uint8Array (pulled: a chunk is asked for only when
     * the stream's reader wants one). Cancelling it stops the download.
     * @returns {ReadableStream<Uint8Array>}
     */
    stream(): ReadableStream<Uint8Array>;
    /** @returns {AsyncGenerator<Uint8Array>} */
    [Symbol.asyncIterator](): AsyncGenerator<Uint8Array>;
}
/** A blob channel by name: its own (Hub.createBlobChannel) or another user's, to read (Hub.blobChannel). */
export class BlobChannel {
    /** @param {import('./hub.js').Hub} hub @param {string} name the full name (<user>.<name>) @param {number} [id] */
    constructor(hub: import("./hub.js").Hub, name: string, id?: number);
    hub: import("./hub.js").Hub;
    name: string;
    /** @internal The id BLOB_CREATE gave (the flow may not have heard of the channel yet). */
    createdId: number;
    /** @internal The channel's id; NotFoundError when the hub has none of that name. @param {SyncConnection} conn */
    id(conn: SyncConnection): number;
    /** @internal @param {string} name @param {Record<string, any>} fields */
    call(name: string, fields: Record<string, any>): Promise<Record<string, any>>;
    /**
     * A directory's entries, sorted by name.
     * @param {string} [dir] (default: the root)
     * @returns {Promise<BlobEntry[]>}
     */
    list(dir?: string): Promise<BlobEntry[]>;
    /** Makes a directory (and missing parents). @param {string} path */
    mkdir(path: string): Promise<void>;
    /** Removes an empty directory. @param {string} path */
    rmdir(path: string): Promise<void>;
    /** Removes a file. @param {string} path */
    remove(path: string): Promise<void>;
    /**
     * Uploads a file, replacing `path` atomically once its last byte is stored. Resolves with its
     * size and new version. Refusals are FlowErrors (PermissionDeniedError: not the owner's user;
     * LimitExceededError: a quota); on failure or abort the hub drops the upload (BLOB_ABORT)
     * before the promise rejects, and the old file stays.
     * @param {string} path
     * @param {BlobSource} source
     * @param {BlobTransferOptions & {size?: number}} [options] size: the bytes a stream gives
     * @returns {Promise<{size: number, version: bigint}>}
     */
    upload(path: string, source: BlobSource, options?: BlobTransferOptions & {
        size?: number;
    }): Promise<{
        size: number;
        version: bigint;
    }>;
    /**
     * Downloads a file: one whole version, even if it is replaced meanwhile. NotFoundError when
     * there is no such file.
     * @param {string} path @param {BlobTransferOptions} [options]
     * @returns {BlobDownload}
     */
    download(path: string, options?: BlobTransferOptions): BlobDownload;
    /**
     * A whole file in memory (for small files: a large one is better iterated, download()).
     * @param {string} path @param {BlobTransferOptions} [options]
     * @returns {Promise<Uint8Array>}
     */
    get(path: string, options?: BlobTransferOptions): Promise<Uint8Array>;
}
/**
 * One entry of a directory (BLOB_LIST).
 */
export type BlobEntry = {
    name: string;
    dir: boolean;
    size: number;
    mtimeNs: bigint;
    version: bigint;
};
/**
 * A transfer's progress: bytes done (acknowledged by the hub, or received) of total.
 */
export type BlobProgress = {
    bytes: number;
    total: number;
};
/**
 * Options of a transfer.
 */
export type BlobTransferOptions = {
    /**
     * after each chunk; the last has bytes === total
     */
    onProgress?: (progress: BlobProgress) => void;
    /**
     * stops the transfer: an upload is dropped by the hub (BLOB_ABORT)
     */
    signal?: AbortSignal;
    /**
     * per request (default BLOB_CHUNK_BYTES, at most 4 MiB)
     */
    chunkBytes?: number;
    /**
     * requests ahead of their answers (default BLOB_WINDOW)
     */
    window?: number;
};
/**
 * What can be uploaded: bytes (sent as views), a Blob (read a chunk at a time), or a stream of
 * bytes (a WHATWG ReadableStream, a Node Readable or any (async) iterable of Uint8Array or string),
 * which needs `size`.
 */
export type BlobSource = ArrayBuffer | ArrayBufferView | Blob | ReadableStream<Uint8Array> | AsyncIterable<Uint8Array | string> | Iterable<Uint8Array>;
