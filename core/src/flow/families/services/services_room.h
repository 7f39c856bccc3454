// SPDX-License-Identifier: Apache-2.0
// The services room: pending service requests (request_table.h: routing to the owner and back,
// timeouts, owner-gone failures) and the SERVICE_* rows of the catalogue.
#pragma once

#include "families/room.h"
#include "families/services/request_table.h"

#include <skrobot/runtime/flow/messages.h>

namespace skr::flow {

class Connection;

class ServicesRoom final : public Room, public RequestTable {
 public:
  explicit ServicesRoom(Hub& hub);

  // Its rows (catalogue.h, family services): handle(Connection&, msg::X&) for each.
  SKR_FLOW_ROOM_HANDLERS(services)

  // Room
  void endpointLeft(Endpoint& e) override;
  void channelRemoved(const Channel& ch) override;
  void sweep(Nanos now) override;
};

}  // namespace skr::flow
