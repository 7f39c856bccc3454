/**
 * Connects to a hub's web port and logs in; resolves once online.
 * @param {string} [address] ws:host:port/flow; default: the page's own host, /flow
 * @param {import('./hub.js').HubOptions} [options]
 * @returns {Promise<Hub>}
 */
export function connect(address?: string, options?: import("./hub.js").HubOptions): Promise<Hub>;
/**
 * For a page served by the hub's web port: connects to its /flow and logs in with a page token
 * fetched from /skrobot/token of the page's origin, a new one at each reconnection; the session
 * has the hub's page account (server.web.page_account, by default the read-only `web-page`).
 * @param {import('./hub.js').HubOptions} [options]
 * @returns {Promise<Hub>}
 */
export function connectPage(options?: import("./hub.js").HubOptions): Promise<Hub>;
export * from "./common.js";
import { Hub } from './hub.js';
