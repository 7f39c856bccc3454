// SPDX-License-Identifier: Apache-2.0
// Blob channels (FlowProtocol 1.3, docs/blob-channels.md): files kept by the hub, listed,
// downloaded and uploaded on a synchronous connection of the client's own (LOGIN, then requests
// answered in order by REPLY_OK or REPLY_ERROR), opened beside the flow on first use. A transfer
// keeps at most `window` requests of `chunkBytes` ahead of their answers (as satellite/cpp's
// SyncClient: 8 of 1 MiB) and asks for no more until the caller has taken a chunk, so that a file
// of any size costs about window x chunkBytes of memory, never the whole file.
import { encodeFrame, decodeBody, codeName, CODE, PROTOCOL_MAJOR, CATALOGUE_MINOR } from './codec.js';
import { asBytes, encodeUtf8 } from './bytes.js';
import {
  ClosedError, InvalidArgumentError, NotFoundError, ProtocolError, UnsupportedError, VersionMismatchError,
  errorFromWire,
} from './errors.js';
import { channelInfo } from './channels.js';

/** Bytes asked for, or sent, per request (the hub takes at most 4 MiB). */
export const BLOB_CHUNK_BYTES = 1024 * 1024;
/** Requests of a transfer sent ahead of their answers (the hub works on 8 of a connection at once). */
export const BLOB_WINDOW = 8;
const BLOB_MINOR = 3;

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
  /** @param {import('./transport-node.js').Transport} transport */
  constructor(transport) {
    /** @internal */
    this.transport = transport;
    /** @internal The requests awaiting their answers, oldest first. @type {{resolve: (f: import('./frames.js').Frame) => void, reject: (e: Error) => void, name: string}[]} */
    this.waiting = [];
    this.closed = false;
    /** The session of this connection (LOGIN's answer). @type {{minor: number, connectionId: number}} */
    this.session = { minor: 0, connectionId: 0 };
    /** Called once when the connection ends. @type {(error: Error) => void} */
    this.onclose = () => {};
    transport.onframes = (frames) => {
      for (const f of frames) {
        const w = this.waiting.shift();
        if (!w) {
          this.fail(new ProtocolError(`the hub sent ${codeName(f.code)} with no request waiting`));
          return;
        }
        w.resolve(f);
      }
    };
    transport.onclose = (e) => this.fail(e ?? new ClosedError('the synchronous connection closed'));
  }

  /**
   * Opens and logs in with the hub's account and transport.
   * @param {import('./hub.js').Hub} hub
   * @returns {Promise<SyncConnection>}
   */
  static async open(hub) {
    const c = new SyncConnection(await hub.open(hub.address, hub.options));
    const timeoutMs = hub.options.timeoutMs ?? 10000;
    const timer = setTimeout(() => c.fail(new ClosedError(`the hub did not answer the login within ${timeoutMs} ms`)), timeoutMs);
    try {
      const m = await c.call(...hub.loginMessage('sync'));
      if (m.major !== PROTOCOL_MAJOR) throw new VersionMismatchError(`the hub speaks FlowProtocol ${m.major}`);
      c.session = { minor: Math.min(m.minor, CATALOGUE_MINOR), connectionId: m.connection_id };
    } catch (e) {
      c.close();
      throw e;
    } finally {
      clearTimeout(timer);
    }
    return c;
  }

  /**
   * Sends a request; resolves with its answer's frame (REPLY_OK or REPLY_ERROR), in order.
   * @param {string} name @param {Record<string, any>} fields
   * @returns {Promise<import('./frames.js').Frame>}
   */
  request(name, fields) {
    if (this.closed) return Promise.reject(new ClosedError(`the synchronous connection closed: ${name} not sent`));
    const frame = encodeFrame(name, fields);
    return new Promise((resolve, reject) => {
      this.waiting.push({ resolve, reject, name });
      this.transport.send(frame);
    });
  }

  /**
   * An answer's fields (REPLY_OK's body decoded as `name`'s reply); REPLY_ERROR throws its FlowError.
   * @param {string} name @param {import('./frames.js').Frame} f
   * @returns {Record<string, any>}
   */
  answer(name, f) {
    if (f.code === CODE.REPLY_ERROR) {
      const m = decodeBody(f.code, f.body);
      throw errorFromWire(m.error, m.message);
    }
    if (f.code !== CODE.REPLY_OK) throw new ProtocolError(`${codeName(f.code)} in answer to ${name}`);
    return decodeBody(CODE[name], f.body, { reply: true });
  }

  /** A request and its answer's fields. @param {string} name @param {Record<string, any>} fields */
  async call(name, fields) {
    return this.answer(name, await this.request(name, fields));
  }

  /** @internal @param {Error} e */
  fail(e) {
    if (this.closed) return;
    this.closed = true;
    this.transport.close();
    const waiting = this.waiting;
    this.waiting = [];
    for (const w of waiting) w.reject(new ClosedError(`the synchronous connection was lost before ${w.name} was answered: ${e.message}`));
    this.onclose(e);
  }

  /** Closes the connection; requests on their way fail with ClosedError. */
  close() {
    this.fail(new ClosedError('closed'));
  }
}

// Resolves as `p`, or rejects with the signal's reason once it is aborted.
function raced(p, signal) {
  if (!signal) return p;
  if (signal.aborted) return Promise.reject(signal.reason);
  return new Promise((resolve, reject) => {
    const onAbort = () => reject(signal.reason);
    signal.addEventListener('abort', onAbort, { once: true });
    p.then((v) => { signal.removeEventListener('abort', onAbort); resolve(v); },
      (e) => { signal.removeEventListener('abort', onAbort); reject(e); });
  });
}

function chunkOption(options) {
  const n = options.chunkBytes ?? BLOB_CHUNK_BYTES;
  if (!Number.isInteger(n) || n < 1 || n > 4 * 1024 * 1024) throw new RangeError(`chunkBytes: ${n} is not in 1..4 MiB`);
  const w = options.window ?? BLOB_WINDOW;
  if (!Number.isInteger(w) || w < 1) throw new RangeError(`window: ${w} is not a positive integer`);
  return { chunk: n, window: w };
}

// The source's bytes in pieces of at most `chunk`: views of bytes; slices of a Blob; a stream's
// pieces gathered into buffers of `chunk` (a piece of `chunk` or more when none is being gathered
// goes as views). Checks that a stream gives exactly `size` bytes.
/** @returns {{size: number, pieces: AsyncGenerator<Uint8Array>}} */
function sourcePieces(source, size, chunk) {
  if (source instanceof ArrayBuffer || ArrayBuffer.isView(source)) {
    const bytes = asBytes(source);
    return {
      size: bytes.byteLength,
      pieces: (async function* () {
        for (let at = 0; at < bytes.byteLength; at += chunk) yield bytes.subarray(at, at + chunk);
      })(),
    };
  }
  const B = /** @type {any} */ (globalThis).Blob;
  if (B && source instanceof B) {
    const blob = /** @type {Blob} */ (source);
    return {
      size: blob.size,
      pieces: (async function* () {
        for (let at = 0; at < blob.size; at += chunk) yield new Uint8Array(await blob.slice(at, at + chunk).arrayBuffer());
      })(),
    };
  }
  let iterable = /** @type {any} */ (source);
  if (typeof iterable?.getReader === 'function' && typeof iterable[Symbol.asyncIterator] !== 'function') {
    iterable = readerIterable(iterable);
  }
  if (typeof iterable?.[Symbol.asyncIterator] !== 'function' && typeof iterable?.[Symbol.iterator] !== 'function') {
    throw new TypeError('an upload takes bytes, a Blob, a ReadableStream or an (async) iterable of bytes');
  }
  if (!Number.isSafeInteger(size) || size < 0) {
    throw new TypeError('an upload from a stream needs options.size (the hub is told the size first)');
  }
  return {
    size,
    pieces: (async function* () {
      let buf = null;
      let fill = 0;
      let seen = 0;
      for await (const item of iterable) {
        let piece = typeof item === 'string' ? encodeUtf8(item) : asBytes(item);
        seen += piece.byteLength;
        if (seen > size) throw new InvalidArgumentError(`the source gave more than the ${size} bytes announced`);
        while (piece.byteLength > 0) {
          if (!buf && piece.byteLength >= chunk) {
            yield piece.subarray(0, chunk);
            piece = piece.subarray(chunk);
            continue;
          }
          buf ??= new Uint8Array(Math.min(chunk, size - (seen - piece.byteLength)));
          const k = Math.min(buf.byteLength - fill, piece.byteLength);
          buf.set(piece.subarray(0, k), fill);
          fill += k;
          piece = piece.subarray(k);
          if (fill === buf.byteLength) {
            yield buf;  // in flight from now on: the next is a new buffer
            buf = null;
            fill = 0;
          }
        }
      }
      if (seen < size) throw new InvalidArgumentError(`the source ended after ${seen} of the ${size} bytes announced`);
      if (buf && fill) yield buf.subarray(0, fill);
    })(),
  };
}

// A ReadableStream's reader as an async iterable (browsers whose streams are not iterable).
async function* readerIterable(stream) {
  const reader = stream.getReader();
  try {
    for (;;) {
      const r = await reader.read();
      if (r.done) return;
      yield r.value;
    }
  } finally {
    reader.releaseLock();
  }
}

/**
 * A download: iterate it (for await: Uint8Array views, each valid as long as it is kept) or take
 * it as a WHATWG ReadableStream with stream(); once only. `size` and `version` are known after the
 * first chunk. The next chunks are asked for as the caller takes them, at most `window` ahead.
 */
export class BlobDownload {
  /** @param {BlobChannel} channel @param {string} path @param {BlobTransferOptions} options */
  constructor(channel, path, options) {
    this.channel = channel;
    this.path = path;
    /** @internal */
    this.options = options;
    /** The file's size, once the first chunk came. @type {number | null} */
    this.size = null;
    /** The version downloaded (every chunk is of it), once the first chunk came. @type {bigint | null} */
    this.version = null;
    /** @internal */
    this.started = false;
  }

  /** @returns {AsyncGenerator<Uint8Array>} */
  [Symbol.asyncIterator]() {
    if (this.started) throw new TypeError('a download is read once');
    this.started = true;
    return this.chunks();
  }

  /** @internal */
  async *chunks() {
    const { chunk, window } = chunkOption(this.options);
    const { signal, onProgress } = this.options;
    const conn = await raced(this.channel.hub.syncConnection(), signal);
    const chanId = this.channel.id(conn);
    const ask = (version, offset) => conn.request('BLOB_GET', {
      chan_id: chanId, path: this.path, version, offset: BigInt(offset), max_bytes: chunk,
    });
    /** @type {Promise<import('./frames.js').Frame>[]} */
    const ahead = [];
    try {
      const first = conn.answer('BLOB_GET', await raced(ask(0n, 0), signal));
      const version = first.version;
      const total = Number(first.total_size);
      this.size = total;
      this.version = version;
      let got = first.data.byteLength;
      onProgress?.({ bytes: got, total });
      if (got) yield first.data;
      let asked = got;
      while (got < total) {
        while (ahead.length < window && asked < total) {
          ahead.push(ask(version, asked));
          asked += Math.min(chunk, total - asked);
        }
        const m = conn.answer('BLOB_GET', await raced(/** @type {Promise<any>} */ (ahead.shift()), signal));
        if (m.version !== version || m.data.byteLength === 0) {
          throw new ProtocolError('BLOB_GET: an answer of another version, or empty, before the end');
        }
        got += m.data.byteLength;
        onProgress?.({ bytes: got, total });
        yield m.data;
      }
    } finally {
      // Stopped early (aborted, failed, or the caller broke off): the answers still on their way
      // are read and dropped by the connection.
      for (const p of ahead) p.catch(() => {});
    }
  }

  /**
   * The download as a WHATWG ReadableStream of Uint8Array (pulled: a chunk is asked for only when
   * the stream's reader wants one). Cancelling it stops the download.
   * @returns {ReadableStream<Uint8Array>}
   */
  stream() {
    const it = this[Symbol.asyncIterator]();
    return new ReadableStream({
      async pull(controller) {
        const r = await it.next();
        if (r.done) controller.close();
        else controller.enqueue(r.value);
      },
      async cancel() {
        await it.return(undefined);
      },
    }, { highWaterMark: 0 });
  }
}

/** A blob channel by name: its own (Hub.createBlobChannel) or another user's, to read (Hub.blobChannel). */
export class BlobChannel {
  /** @param {import('./hub.js').Hub} hub @param {string} name the full name (<user>.<name>) @param {number} [id] */
  constructor(hub, name, id = 0) {
    this.hub = hub;
    this.name = name;
    /** @internal The id BLOB_CREATE gave (the flow may not have heard of the channel yet). */
    this.createdId = id;
  }

  /** @internal The channel's id; NotFoundError when the hub has none of that name. @param {SyncConnection} conn */
  id(conn) {
    if (conn.session.minor < BLOB_MINOR) {
      throw new UnsupportedError(`this hub (FlowProtocol 1.${conn.session.minor}) has no blob channels: they need 1.${BLOB_MINOR}`);
    }
    const info = this.hub.channelByName(this.name);
    if (info && info.kind !== 'blob') throw new InvalidArgumentError(`${this.name} is a ${info.kind} channel, not a blob channel`);
    const id = info?.id ?? this.createdId;
    if (!id) throw new NotFoundError(`no blob channel ${this.name}`);
    return id;
  }

  /** @internal @param {string} name @param {Record<string, any>} fields */
  async call(name, fields) {
    const conn = await this.hub.syncConnection();
    return conn.call(name, { chan_id: this.id(conn), ...fields });
  }

  /**
   * A directory's entries, sorted by name.
   * @param {string} [dir] (default: the root)
   * @returns {Promise<BlobEntry[]>}
   */
  async list(dir = '') {
    const { value } = await this.call('BLOB_LIST', { dir });
    if (!Array.isArray(value)) throw new ProtocolError('BLOB_LIST: expected a list');
    return value.map((e) => ({
      name: String(e.name ?? ''), dir: Boolean(e.dir), size: Number(e.size ?? 0),
      mtimeNs: BigInt(e.mtime_ns ?? 0), version: BigInt(e.version ?? 0),
    }));
  }

  /** Makes a directory (and missing parents). @param {string} path */
  async mkdir(path) {
    await this.call('BLOB_MKDIR', { path });
  }

  /** Removes an empty directory. @param {string} path */
  async rmdir(path) {
    await this.call('BLOB_RMDIR', { path });
  }

  /** Removes a file. @param {string} path */
  async remove(path) {
    await this.call('BLOB_REMOVE', { path });
  }

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
  async upload(path, source, options = {}) {
    const { chunk, window } = chunkOption(options);
    const { signal, onProgress } = options;
    if (signal?.aborted) throw signal.reason;
    const { size, pieces } = sourcePieces(source, options.size, chunk);
    const conn = await raced(this.hub.syncConnection(), signal);
    const chanId = this.id(conn);
    const put = await raced(conn.call('BLOB_PUT', { chan_id: chanId, path, total_size: BigInt(size), upload_id: 0n }), signal);
    const uploadId = put.upload_id;
    /** @type {Promise<import('./frames.js').Frame>[]} */
    const ahead = [];
    let version = 0n;
    let sent = 0;
    const settle = async () => {
      const m = conn.answer('BLOB_CHUNK', await raced(/** @type {Promise<any>} */ (ahead.shift()), signal));
      if (m.version) version = m.version;
      onProgress?.({ bytes: Number(m.received), total: size });
    };
    try {
      if (size === 0) ahead.push(conn.request('BLOB_CHUNK', { chan_id: chanId, upload_id: uploadId, offset: 0n, data: new Uint8Array(0) }));
      while (sent < size) {
        while (ahead.length >= window) await settle();
        const r = await raced(pieces.next(), signal);
        if (r.done) break;
        ahead.push(conn.request('BLOB_CHUNK', { chan_id: chanId, upload_id: uploadId, offset: BigInt(sent), data: r.value }));
        sent += r.value.byteLength;
      }
      while (ahead.length) await settle();
      if (!version) throw new ProtocolError('the upload ended without a version');
      return { size, version };
    } catch (e) {
      for (const p of ahead) p.catch(() => {});
      pieces.return(undefined).catch(() => {});
      // Drop the upload on the hub (after the chunks on their way, the answers being in order).
      if (!conn.closed) await conn.call('BLOB_ABORT', { chan_id: chanId, upload_id: uploadId }).catch(() => {});
      throw e;
    }
  }

  /**
   * Downloads a file: one whole version, even if it is replaced meanwhile. NotFoundError when
   * there is no such file.
   * @param {string} path @param {BlobTransferOptions} [options]
   * @returns {BlobDownload}
   */
  download(path, options = {}) {
    return new BlobDownload(this, path, options);
  }

  /**
   * A whole file in memory (for small files: a large one is better iterated, download()).
   * @param {string} path @param {BlobTransferOptions} [options]
   * @returns {Promise<Uint8Array>}
   */
  async get(path, options = {}) {
    const d = this.download(path, options);
    let out = new Uint8Array(0);
    let at = 0;
    for await (const c of d) {
      if (out.byteLength !== d.size) out = new Uint8Array(d.size ?? 0);
      out.set(c, at);
      at += c.byteLength;
    }
    return out;
  }
}

/**
 * Creates the caller's blob channel <user>.<shortName>, or gives the existing one back (with its
 * files).
 * @param {import('./hub.js').Hub} hub @param {string} shortName
 * @returns {Promise<BlobChannel>}
 */
export async function createBlobChannel(hub, shortName) {
  const conn = await hub.syncConnection();
  if (conn.session.minor < BLOB_MINOR) throw new UnsupportedError(`this hub (FlowProtocol 1.${conn.session.minor}) has no blob channels`);
  const info = channelInfo(await conn.call('BLOB_CREATE', { short_name: shortName }));
  return new BlobChannel(hub, info.name, info.id);
}
