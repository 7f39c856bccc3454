// SPDX-License-Identifier: Apache-2.0
// SYNC_PULSE, SYNC_FOLLOW, SYNC_UNFOLLOW and SYNC_DONE.
#include "families/sync/sync_room.h"

#include "connection.h"
#include "hub.h"

namespace skr::flow {

SyncRoom::SyncRoom(Hub& hub) : Room(hub), SyncPulses(hub.endpoints, hub.channels) {}

void SyncRoom::noteFollowed(const Endpoint& e) {
  if (PairDatabase* db = hub_.databases.store().find("_flow." + std::to_string(e.id))) {
    (void)db->set("sync_following", Variant(followedBy(e.id)));
  }
}

void SyncRoom::handle(Connection& c, msg::SyncPulse& m) {
  c.refused(Code::sync_pulse, 0, m.chan_id, pulse(c, m.chan_id, m.source_time_ns));
}

void SyncRoom::handle(Connection& c, msg::SyncFollow& m) {
  auto r = follow(c, m.chan_id, m.every);
  if (r) noteFollowed(c);
  c.refused(Code::sync_follow, m.tag, m.chan_id, r);
}

void SyncRoom::handle(Connection& c, msg::SyncUnfollow& m) {
  auto r = unfollow(c, m.chan_id);
  if (r) noteFollowed(c);
  c.refused(Code::sync_unfollow, m.tag, m.chan_id, r);
}

void SyncRoom::handle(Connection& c, msg::SyncDone& m) {
  done(c, m.chan_id, m.seq);
}

void SyncRoom::endpointLeft(Endpoint& e) {
  dropEndpoint(e.id);
}

void SyncRoom::channelRemoved(const Channel& ch) {
  dropSource(ch.id);
}

}  // namespace skr::flow
