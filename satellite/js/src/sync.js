// SPDX-License-Identifier: Apache-2.0
// Following a sync source (docs/sync-pulse.md): each EV_SYNC_PULSE goes to the callback, and
// SYNC_DONE answers it once the callback returned or its promise settled.

export class Follower {
  /**
   * @param {import('./hub.js').Hub} hub @param {string} name
   * @param {(pulse: {seq: bigint, sourceTimeNs: bigint, dropped: number}) => unknown} fn @param {number} every
   */
  constructor(hub, name, fn, every) {
    this.hub = hub;
    this.name = name;
    this.fn = fn;
    this.every = every;
    this.id = 0;
  }

  /** @param {{chan_id: number, seq: bigint, source_time_ns: bigint, dropped: number}} m */
  deliver(m) {
    const done = () => this.hub.send('SYNC_DONE', { chan_id: m.chan_id, seq: m.seq });
    Promise.resolve()
      .then(() => this.fn({ seq: m.seq, sourceTimeNs: m.source_time_ns, dropped: m.dropped }))
      .then(done, (e) => {
        done();
        this.hub.report(e);
      });
  }

  /** Stops following. */
  close() {
    this.hub.followers.delete(this);
    if (this.id) this.hub.send('SYNC_UNFOLLOW', { tag: 0, chan_id: this.id });
    this.id = 0;
  }
}
