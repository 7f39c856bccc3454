// SPDX-License-Identifier: Apache-2.0
// The services room: pending service requests (request_table.h: routing to the owner and back,
// timeouts, owner-gone failures) and the SERVICE_* rows of the catalogue.
#pragma once

#include "families/room.h"
#include "families/services/request_table.h"

#include <skrobot/flow/messages.h>

namespace skr::flow {

class Connection;

class ServicesRoom final : public Room, public RequestTable {
 public:
  explicit ServicesRoom(Hub& hub);

  void handle(Connection& c, msg::ServiceCall& m);
  void handle(Connection& c, msg::ServiceRequest& m);
  void handle(Connection& c, msg::ServiceRequestTimed& m);
  void handle(Connection& c, msg::ServiceResponse& m);

  // Room
  void endpointLeft(Endpoint& e) override;
  void channelRemoved(const Channel& ch) override;
  void sweep(Nanos now) override;
};

}  // namespace skr::flow
