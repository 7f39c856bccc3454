/**
 * The URL of a hub's page tokens: /skrobot/token of the page's own origin, or of the hub whose
 * web port a ws:/wss: address names (ws://host:port/flow gives http://host:port/skrobot/token).
 * @param {string} [address] a ws: or wss: address; default: the page's origin
 * @returns {string}
 */
export function pageTokenUrl(address?: string): string;
/**
 * A function that fetches a new page token each time it is called: the `token` option of
 * connect(), so that every login (the first and each reconnection) has a fresh one.
 * @param {string} [address] a ws: or wss: address of the hub; default: the page's own origin
 * @returns {() => Promise<string>}
 */
export function pageToken(address?: string): () => Promise<string>;
