// SPDX-License-Identifier: Apache-2.0
// The physical room: direct and shared-memory paths between an owner and its subscribers
// (physical_paths.h: offers, grants, one-time tokens, the switch and the fallback) and the PHYS_*
// rows of the catalogue.
#pragma once

#include "families/physical/physical_paths.h"
#include "families/room.h"

#include <skrobot/runtime/flow/messages.h>

namespace skr::flow {

class Connection;

class PhysicalRoom final : public Room, public PhysicalPaths {
 public:
  explicit PhysicalRoom(Hub& hub);

  // Its rows (catalogue.h, family physical): handle(Connection&, msg::X&) for each.
  SKR_FLOW_ROOM_HANDLERS(physical)

  // Room
  void endpointLeft(Endpoint& e) override;
  void channelRemoved(const Channel& ch) override;
  void everySecond(Nanos now) override;
};

}  // namespace skr::flow
