// SPDX-License-Identifier: Apache-2.0
// Every export of the package, used once with its declared types: `tsc --noEmit -p examples`
// (tests/js/types.test.mjs) fails when a declaration is wrong, and when an export is added that
// this file does not name (see `Unnamed` at the end).
import * as skr from 'skrobot';
import type {
  HubOptions, Session, ChannelInfo, PairChange, Address, BlobEntry, BlobProgress, BlobTransferOptions, BlobSource,
  ChannelType,
} from 'skrobot';
import {
  connect, Hub, Message, OwnedChannel, Subscription, Database, Watch, PAIR_STATES, Follower, Variant,
  Typed, FlowError, ClosedError, ProtocolError, NotFoundError, TimeoutError, OwnerGoneError,
  PermissionDeniedError, AuthFailedError, AlreadyExistsError, InternalError, InvalidArgumentError,
  IoError, LimitExceededError, NotLoggedInError, OverflowError, UnsupportedError, VersionMismatchError,
  ERROR_CLASSES, ERROR_VALUES, errorFromWire, encodeVariant, decodeVariant, readVariant, writeVariant,
  TAG, MAX_DEPTH, MAX_VALUE_BYTES, ByteReader, ByteWriter, asBytes, encodeUtf8, decodeUtf8,
  encodeFrame, decodeBody, codeName, CODE, BY_CODE, CODES, PARTS, ERRORS, CHANNEL_KINDS,
  PROTOCOL_MAJOR, CATALOGUE_MINOR, messageFrames, FrameSplitter, FRAME_HEADER_BYTES,
  DEFAULT_MAX_FRAME_BYTES, KIND, KIND_NAME, payloadBytes, monotonicNs, openWebSocket, SUBPROTOCOL,
  parseAddress, DEFAULT_ADDRESS, DEFAULT_TCP_PORT, ENCODINGS, HEADER_BYTES, MESSAGE_ENCODING, FORMAT,
  encodingOf, rawPayloadBytes, makeMediaFrame, parseMediaFrame, BlobChannel, BlobDownload, SyncConnection,
  BLOB_CHUNK_BYTES, BLOB_WINDOW, pageToken, pageTokenUrl, typeProblem, typeProperties, channelType,
  MESSAGE_ENCODINGS, TYPE_KEYS,
} from 'skrobot';

export async function main(): Promise<void> {
  const options: HubOptions = { user: 'guest', password: 'password', clientName: 'example', maxQueuedBytes: 1 << 23 };
  const hub: Hub = await connect(DEFAULT_ADDRESS, options);
  const session: Session | null = hub.session;
  const address: Address = parseAddress(DEFAULT_ADDRESS);
  hub.on('channel', (info: ChannelInfo) => console.log(info.name, info.kind, session?.user, address.kind));
  hub.on('offline', (e: Error | null) => console.log('offline', e?.message));

  // A page's login: a page token (LOGIN_TOKEN) fetched from the hub's web port for each login.
  const web = 'ws:127.0.0.1:8080/flow';
  const page: Hub = await connect(web, { token: pageToken(web) });
  const fixed: HubOptions = { token: 'a-token-fetched-before' };
  console.log(pageTokenUrl(web), page.session?.user, fixed.token);
  page.close();

  // Channels: publish views, strings and JSON; subscribe with a callback or an iterator.
  const camera: OwnedChannel = await hub.createChannel('camera', { mime: encodingOf(FORMAT.jpeg)?.mime ?? '', props: { fps: 30 } });
  camera.onSubscribers((on: boolean) => console.log('subscribers:', on));
  camera.publish(new Float32Array([1, 2]));
  camera.publish('text');
  camera.publish({ json: true });
  const sub: Subscription = hub.subscribe('guest.camera', (m: Message) => console.log(m.channel, m.payload.byteLength, m.text()));
  sub.close();
  for await (const m of hub.subscribe('guest.camera', { queueBytes: 1 << 20 })) {
    const frame = parseMediaFrame(m.payload);
    if (frame) console.log(frame.encoding, frame.width, encodingOf(frame.format)?.mime, rawPayloadBytes(encodingOf(frame.format), 2, 2));
    break;
  }
  camera.publish(makeMediaFrame({ format: FORMAT.rgb8, seq: 1n, width: 1, height: 1 }, new Uint8Array(3)));
  console.log(ENCODINGS.length, HEADER_BYTES, MESSAGE_ENCODING, KIND.streaming, KIND_NAME[1], payloadBytes('x'), monotonicNs());

  // Typed channels: what the messages are, with MCAP's words.
  const type: ChannelType = { messageEncoding: 'json', schemaName: 'lab.Pose', schemaEncoding: 'jsonschema', schema: '{}' };
  const poses: OwnedChannel = await hub.createChannel('poses', { mime: 'application/json', type });
  const problem: string | null = typeProblem({ messageEncoding: 'cdr' });
  const props: Record<string, string> = typeProperties(type);
  const declared: ChannelType = channelType(hub.channelByName(poses.name)?.props);
  console.log(problem, props[TYPE_KEYS.schemaName], declared.schemaName, MESSAGE_ENCODINGS.map((e) => e.name));

  // Services, with a deadline and an AbortSignal.
  await hub.serve('calc', (command: string, value: unknown, { requester }) => ({ command, value, requester }));
  try {
    const answer: unknown = await hub.call('guest.calc', 'add', [1, 2], { timeoutMs: 1000, signal: AbortSignal.timeout(2000) });
    console.log(answer);
  } catch (e) {
    if (e instanceof TimeoutError || e instanceof OwnerGoneError || e instanceof NotFoundError) console.log(e.code);
  }

  // Databases, the sync pulse, hub.stats.
  const db: Database = hub.db();
  await db.set('speed', Variant.f64(1));
  console.log(await db.get('speed'), await db.keys(), await db.getAll());
  await db.delete('speed');
  const watch: Watch = db.watch((c: PairChange) => console.log(c.state, c.key, c.value, PAIR_STATES.length), { onEnd: (e) => console.log(e) });
  await watch.ready;
  console.log(watch.pairs.size);
  watch.close();
  hub.subscribe('guest.camera', () => {}, { maxHz: 5 }).close();
  const follower: Follower = hub.follow('guest.beat', (p) => console.log(p.seq, p.sourceTimeNs, p.dropped), { every: 1 });
  follower.close();
  (await hub.createChannel('beat', { kind: 'sync' })).pulse();
  hub.stats((s: any) => console.log(s.hub)).close();
  const answer: any = await hub.admin('module_config', { name: 'example' });
  console.log(answer.keys);
  hub.close();

  // The codec and its tables.
  const bytes: Uint8Array = encodeVariant({ a: 1n, b: new Typed('uint64', 2n), c: Variant.u64(3), d: Variant.i64(4) });
  console.log(decodeVariant(bytes, { maxDepth: MAX_DEPTH, maxBytes: MAX_VALUE_BYTES }), TAG.map);
  const w = new ByteWriter();
  writeVariant(w, [true]);
  console.log(readVariant(new ByteReader(w.bytes())), asBytes(new ArrayBuffer(1)), decodeUtf8(encodeUtf8('é')));
  const parts: Uint8Array[] = encodeFrame('SUBSCRIBE', { tag: 1, chan_id: 2 });
  for (const f of messageFrames(parts[0], DEFAULT_MAX_FRAME_BYTES)) console.log(codeName(f.code), decodeBody(f.code, f.body));
  console.log(new FrameSplitter(1024).push(parts[0]).length, FRAME_HEADER_BYTES, CODE.PUBLISH, BY_CODE.get(0x44)?.name);
  console.log(CODES.length, PARTS.ChannelInfo, ERRORS[0], CHANNEL_KINDS[0], PROTOCOL_MAJOR, CATALOGUE_MINOR);
  console.log(parseAddress('tcp:robot:9000'), DEFAULT_TCP_PORT, SUBPROTOCOL, typeof openWebSocket);

  // Blob channels: list, upload from bytes or a stream (with its size), download as an iterator
  // or a ReadableStream, with progress and an AbortSignal; change events on the flow.
  const maps: BlobChannel = await hub.createBlobChannel('maps');
  const entries: BlobEntry[] = await maps.list('');
  console.log(entries.map((x) => [x.name, x.dir, x.size, x.version, x.mtimeNs]));
  const ac = new AbortController();
  const transferOptions: BlobTransferOptions = {
    signal: ac.signal, chunkBytes: BLOB_CHUNK_BYTES, window: BLOB_WINDOW,
    onProgress: (p: BlobProgress) => console.log(p.bytes, p.total),
  };
  const source: BlobSource = new Blob([new Uint8Array(8)]);
  const stored: { size: number, version: bigint } = await maps.upload('floor1.pgm', source, transferOptions);
  await maps.upload('floor2.pgm', new Blob([new Uint8Array(4)]).stream(), { size: 4 });
  const download: BlobDownload = maps.download('floor1.pgm', transferOptions);
  for await (const chunk of download) console.log(chunk.byteLength, download.size, download.version === stored.version);
  const stream: ReadableStream<Uint8Array> = maps.download('floor2.pgm').stream();
  const whole: Uint8Array = await maps.get('floor1.pgm');
  console.log(stream.locked, whole.byteLength);
  await maps.mkdir('old');
  await maps.rmdir('old');
  await maps.remove('floor2.pgm');
  const theirs: BlobChannel = hub.blobChannel('mapper.maps');
  console.log(theirs.name);
  hub.on('blobchanged', (c: { channel: string, change: string, path: string }) => console.log(c.channel, c.change, c.path));
  const sync: SyncConnection = await hub.syncConnection();
  console.log(sync.session.minor);

  // Errors.
  const e: FlowError = errorFromWire(ERROR_VALUES.timeout, 'late');
  const classes = [ClosedError, ProtocolError, PermissionDeniedError, AuthFailedError, AlreadyExistsError,
    InternalError, InvalidArgumentError, IoError, LimitExceededError, NotLoggedInError, OverflowError,
    UnsupportedError, VersionMismatchError];
  console.log(e.code, e instanceof ERROR_CLASSES.timeout, classes.length);
  console.log(Message, OwnedChannel, Subscription, Database, Follower, Hub);
}

// Every export is named above: adding one without using it here fails the type check.
const named = {
  connect, Hub, Message, OwnedChannel, Subscription, Database, Watch, PAIR_STATES, Follower, Variant, Typed, FlowError,
  ClosedError, ProtocolError, NotFoundError, TimeoutError, OwnerGoneError, PermissionDeniedError,
  AuthFailedError, AlreadyExistsError, InternalError, InvalidArgumentError, IoError, LimitExceededError,
  NotLoggedInError, OverflowError, UnsupportedError, VersionMismatchError, ERROR_CLASSES, ERROR_VALUES,
  errorFromWire, encodeVariant, decodeVariant, readVariant, writeVariant, TAG, MAX_DEPTH, MAX_VALUE_BYTES,
  ByteReader, ByteWriter, asBytes, encodeUtf8, decodeUtf8, encodeFrame, decodeBody, codeName, CODE,
  BY_CODE, CODES, PARTS, ERRORS, CHANNEL_KINDS, PROTOCOL_MAJOR, CATALOGUE_MINOR, messageFrames,
  FrameSplitter, FRAME_HEADER_BYTES, DEFAULT_MAX_FRAME_BYTES, KIND, KIND_NAME, payloadBytes, monotonicNs,
  openWebSocket, SUBPROTOCOL, parseAddress, DEFAULT_ADDRESS, DEFAULT_TCP_PORT, ENCODINGS, HEADER_BYTES,
  MESSAGE_ENCODING, FORMAT, encodingOf, rawPayloadBytes, makeMediaFrame, parseMediaFrame, BlobChannel, BlobDownload,
  SyncConnection, BLOB_CHUNK_BYTES, BLOB_WINDOW, pageToken, pageTokenUrl, typeProblem, typeProperties,
  channelType, MESSAGE_ENCODINGS, TYPE_KEYS,
};
type Unnamed = Exclude<keyof typeof skr, keyof typeof named>;
export const everyExportNamed: [Unnamed] extends [never] ? true : Unnamed = true;
