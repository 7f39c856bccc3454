/**
 * Connects to a hub's web port and logs in; resolves once online.
 * @param {string} [address] ws:host:port/flow; default: the page's own host, /flow
 * @param {import('./hub.js').HubOptions} [options]
 * @returns {Promise<Hub>}
 */
export function connect(address?: string, options?: import("./hub.js").HubOptions): Promise<Hub>;
export * from "./common.js";
import { Hub } from './hub.js';
