// SPDX-License-Identifier: Apache-2.0
// What both entry points (index.js for browsers, node.js for Node.js) export.
export { Hub } from './hub.js';
export { parseAddress, DEFAULT_ADDRESS, DEFAULT_TCP_PORT } from './address.js';
export * from './errors.js';
export { Variant, Typed, TAG, MAX_DEPTH, MAX_VALUE_BYTES, encodeVariant, decodeVariant, readVariant, writeVariant } from './variant.js';
export { ByteReader, ByteWriter, asBytes, encodeUtf8, decodeUtf8 } from './bytes.js';
export { encodeFrame, decodeBody, codeName, CODE, BY_CODE, PROTOCOL_MAJOR, CATALOGUE_MINOR } from './codec.js';
export { CODES, PARTS, ERRORS, CHANNEL_KINDS } from './catalogue.js';
export { messageFrames, FrameSplitter, FRAME_HEADER_BYTES, DEFAULT_MAX_FRAME_BYTES } from './frames.js';
export { Message, OwnedChannel, Subscription, KIND, KIND_NAME, payloadBytes, monotonicNs } from './channels.js';
export { Database, Watch, PAIR_STATES } from './databases.js';
export { Follower } from './sync.js';
export { BlobChannel, BlobDownload, SyncConnection, BLOB_CHUNK_BYTES, BLOB_WINDOW } from './blobs.js';
export { openWebSocket, SUBPROTOCOL } from './transport-ws.js';
export { pageToken, pageTokenUrl } from './page-token.js';
export * from './media.js';
export { typeProblem, typeProperties, channelType, MESSAGE_ENCODINGS, TYPE_KEYS } from './channel-type.js';

/** @typedef {import('./hub.js').HubOptions} HubOptions */
/** @typedef {import('./hub.js').Session} Session */
/** @typedef {import('./channels.js').ChannelInfo} ChannelInfo */
/** @typedef {import('./databases.js').PairChange} PairChange */
/** @typedef {import('./address.js').Address} Address */
/** @typedef {import('./blobs.js').BlobEntry} BlobEntry */
/** @typedef {import('./blobs.js').BlobProgress} BlobProgress */
/** @typedef {import('./blobs.js').BlobTransferOptions} BlobTransferOptions */
/** @typedef {import('./blobs.js').BlobSource} BlobSource */
/** @typedef {import('./channel-type.js').ChannelType} ChannelType */
