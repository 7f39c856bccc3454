// SPDX-License-Identifier: Apache-2.0
// The sync room: sync pulse sources and their targets (sync_pulses.h), what each flow follows in
// its database, and the SYNC_* rows of the catalogue.
#pragma once

#include "families/room.h"
#include "families/sync/sync_pulses.h"

#include <skrobot/runtime/flow/messages.h>

namespace skr::flow {

class Connection;

class SyncRoom final : public Room, public SyncPulses {
 public:
  explicit SyncRoom(Hub& hub);

  // The sources `e` follows, into its flow database ("sync_following").
  void noteFollowed(const Endpoint& e);

  // Its rows (catalogue.h, family sync): handle(Connection&, msg::X&) for each.
  SKR_FLOW_ROOM_HANDLERS(sync)

  // Room
  void endpointLeft(Endpoint& e) override;
  void channelRemoved(const Channel& ch) override;
};

}  // namespace skr::flow
