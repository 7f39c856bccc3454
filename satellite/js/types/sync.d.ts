export class Follower {
    /**
     * @param {import('./hub.js').Hub} hub @param {string} name
     * @param {(pulse: {seq: bigint, sourceTimeNs: bigint, dropped: number}) => unknown} fn @param {number} every
     */
    constructor(hub: import("./hub.js").Hub, name: string, fn: (pulse: {
        seq: bigint;
        sourceTimeNs: bigint;
        dropped: number;
    }) => unknown, every: number);
    hub: import("./hub.js").Hub;
    name: string;
    fn: (pulse: {
        seq: bigint;
        sourceTimeNs: bigint;
        dropped: number;
    }) => unknown;
    every: number;
    id: number;
    /** @param {{chan_id: number, seq: bigint, source_time_ns: bigint, dropped: number}} m */
    deliver(m: {
        chan_id: number;
        seq: bigint;
        source_time_ns: bigint;
        dropped: number;
    }): void;
    /** Stops following. */
    close(): void;
}
