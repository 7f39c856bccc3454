// SPDX-License-Identifier: Apache-2.0
// Typed channels (docs/channels.md): what a channel's messages are, in its properties with MCAP's
// words (message_encoding; schema_name, schema_encoding and schema where the encoding has
// schemas). The keys and encodings come from media-codes.js, generated from channel_type.hpp; the
// rules are channel_type::check's.
import { MESSAGE_ENCODINGS, TYPE_KEYS } from './media-codes.js';

export { MESSAGE_ENCODINGS, TYPE_KEYS };

/**
 * A channel's type. Empty strings for what it leaves out.
 * @typedef {{messageEncoding: string, schemaName?: string, schemaEncoding?: string, schema?: string}} ChannelType
 */

/**
 * Why a channel may not declare `type`, or null.
 * @param {ChannelType} type
 * @returns {string | null}
 */
export function typeProblem(type) {
  const { messageEncoding = '', schemaName = '', schemaEncoding = '', schema = '' } = type;
  const anySchema = !!(schemaName || schemaEncoding || schema);
  if (!messageEncoding) return anySchema ? 'a schema needs a message_encoding' : null;
  const e = MESSAGE_ENCODINGS.find((m) => m.name === messageEncoding);
  if (!e) return `unknown message_encoding "${messageEncoding}"`;
  if (!anySchema) {
    return e.schema === 'required'
      ? `message_encoding ${messageEncoding} needs a schema (schema_name, schema_encoding, schema)` : null;
  }
  if (e.schema === 'none') return `message_encoding ${messageEncoding} takes no schema`;
  if (!schemaName) return 'a schema needs a schema_name';
  if (!e.schemaEncodings.includes(schemaEncoding)) {
    return `schema_encoding "${schemaEncoding}" does not go with message_encoding ${messageEncoding} (${e.schemaEncodings.join('|')})`;
  }
  if (!schema) return `schema ${schemaName} has no text (the schema property)`;
  return null;
}

/**
 * A typed channel's properties: message_encoding and, where it has one, the schema's three.
 * TypeError naming why when the type breaks the rules.
 * @param {ChannelType} type
 * @returns {Record<string, string>}
 */
export function typeProperties(type) {
  const problem = typeProblem(type);
  if (problem) throw new TypeError(`channel type: ${problem}`);
  /** @type {Record<string, string>} */
  const props = { [TYPE_KEYS.messageEncoding]: type.messageEncoding };
  if (type.schemaName) {
    props[TYPE_KEYS.schemaName] = type.schemaName;
    props[TYPE_KEYS.schemaEncoding] = type.schemaEncoding ?? '';
    props[TYPE_KEYS.schema] = type.schema ?? '';
  }
  return props;
}

/**
 * The type a channel's properties declare (a ChannelInfo's props, or a database's pairs).
 * @param {Record<string, unknown> | null | undefined} props
 * @returns {ChannelType}
 */
export function channelType(props) {
  const text = (/** @type {string} */ k) => (typeof props?.[k] === 'string' ? /** @type {string} */ (props[k]) : '');
  return {
    messageEncoding: text(TYPE_KEYS.messageEncoding), schemaName: text(TYPE_KEYS.schemaName),
    schemaEncoding: text(TYPE_KEYS.schemaEncoding), schema: text(TYPE_KEYS.schema),
  };
}
