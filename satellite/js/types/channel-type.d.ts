/**
 * A channel's type. Empty strings for what it leaves out.
 * @typedef {{messageEncoding: string, schemaName?: string, schemaEncoding?: string, schema?: string}} ChannelType
 */
/**
 * Why a channel may not declare `type`, or null.
 * @param {ChannelType} type
 * @returns {string | null}
 */
export function typeProblem(type: ChannelType): string | null;
/**
 * A typed channel's properties: message_encoding and, where it has one, the schema's three.
 * TypeError naming why when the type breaks the rules.
 * @param {ChannelType} type
 * @returns {Record<string, string>}
 */
export function typeProperties(type: ChannelType): Record<string, string>;
/**
 * The type a channel's properties declare (a ChannelInfo's props, or a database's pairs).
 * @param {Record<string, unknown> | null | undefined} props
 * @returns {ChannelType}
 */
export function channelType(props: Record<string, unknown> | null | undefined): ChannelType;
/**
 * A channel's type. Empty strings for what it leaves out.
 */
export type ChannelType = {
    messageEncoding: string;
    schemaName?: string;
    schemaEncoding?: string;
    schema?: string;
};
import { MESSAGE_ENCODINGS } from './media-codes.js';
import { TYPE_KEYS } from './media-codes.js';
export { MESSAGE_ENCODINGS, TYPE_KEYS };
