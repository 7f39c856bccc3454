/**
 * Parses an address; throws TypeError naming what is wrong.
 * @param {string} text
 * @returns {Address}
 */
export function parseAddress(text: string): Address;
export const DEFAULT_ADDRESS: "local:/tmp/Robot";
export const DEFAULT_TCP_PORT: 9000;
export type Address = {
    kind: "local";
    path: string;
} | {
    kind: "tcp" | "tls";
    host: string;
    port: number;
} | {
    kind: "ws" | "wss";
    url: string;
};
