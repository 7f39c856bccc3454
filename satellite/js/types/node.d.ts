/**
 * Connects to a hub and logs in; resolves once online (rejects on a refused login or no hub).
 * @param {string} [address] local:/path, tcp:host:port, tls:host:port, ws:host:port/flow
 * @param {import('./hub.js').HubOptions} [options]
 * @returns {Promise<Hub>}
 */
export function connect(address?: string, options?: import("./hub.js").HubOptions): Promise<Hub>;
export * from "./common.js";
import { Hub } from './hub.js';
