// SPDX-License-Identifier: Apache-2.0
// The PHYS_* commands of owners and subscribers.
#include "families/physical/physical_room.h"

#include "connection.h"
#include "hub.h"

namespace skr::flow {

PhysicalRoom::PhysicalRoom(Hub& hub) : Room(hub), PhysicalPaths(hub.endpoints, hub.channels) {}

void PhysicalRoom::handle(Connection& c, msg::PhysOffer& m) {
  c.refused(Code::phys_offer, m.tag, m.chan_id, offer(c, m));
}

void PhysicalRoom::handle(Connection& c, msg::PhysRequest& m) {
  // Shared memory only between ends on the hub's Unix socket.
  c.refused(Code::phys_request, m.tag, m.chan_id,
            request(c, m, c.transport() == Transport::unix_socket));
}

void PhysicalRoom::handle(Connection& c, msg::PhysState& m) {
  c.refused(Code::phys_state, 0, m.chan_id, state(c, m));
}

void PhysicalRoom::handle(Connection& c, msg::PhysCount& m) {
  c.refused(Code::phys_count, 0, m.chan_id, count(c, m));
}

void PhysicalRoom::handle(Connection& c, msg::PhysSwitched& m) {
  c.refused(Code::phys_switched, 0, m.chan_id, switched(c, m));
}

void PhysicalRoom::handle(Connection& c, msg::PhysReceived& m) {
  c.refused(Code::phys_received, 0, m.chan_id, received(c, m));
}

void PhysicalRoom::handle(Connection& c, msg::PhysFallback& m) {
  c.refused(Code::phys_fallback, 0, m.chan_id, fallback(c, m));
}

void PhysicalRoom::handle(Connection& c, msg::PhysReplay& m) {
  c.refused(Code::phys_replay, 0, m.chan_id, replay(c, m));
}

void PhysicalRoom::endpointLeft(Endpoint& e) {
  dropEndpoint(e);  // before its subscriptions end: its grants are revoked, its offers go
}

void PhysicalRoom::channelRemoved(const Channel& ch) {
  dropChannel(ch.id);
}

void PhysicalRoom::everySecond(Nanos now) {
  PhysicalPaths::everySecond(now);
}

}  // namespace skr::flow
