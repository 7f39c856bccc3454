// SPDX-License-Identifier: Apache-2.0
// The session room: a connection's login (accounts, the authenticator's off-loop password checks,
// the login throttle), its switch to a flow and PING; the LOGIN, GO_ASYNC and PING rows of the
// catalogue. The connection's own state machine (login, authenticating, sync, flow) is in
// connection.h; this room decides each step.
#pragma once

#include "families/room.h"
#include "families/session/login_throttle.h"

#include <skrobot/hub/flow/accounts.h>
#include <skrobot/runtime/flow/messages.h>

#include <memory>
#include <vector>

namespace skr::flow {

class Connection;

class SessionRoom final : public Room {
 public:
  explicit SessionRoom(Hub& hub) : Room(hub) {}

  // The accounts (the users file, the development account); null before start().
  std::unique_ptr<Authenticator> auth;
  LoginThrottle throttle;

  // Its rows (catalogue.h, family session): handle(Connection&, msg::X&) for each.
  SKR_FLOW_ROOM_HANDLERS(session)

  // Room
  [[nodiscard]] Result<void> start() override;
  void stop() noexcept override;
  void sweep(Nanos now) override;

 private:
  // Verifies a LOGIN (after the throttle's delay, if any), off the loop; the answer comes back to
  // the connection if it is still there.
  void verify(Connection& c, msg::Login m);
  // The answer to a LOGIN once its password (or its port's binding) was checked.
  void finishLogin(Connection& c, const std::string& user, uint16_t minor, LoginResult r);

  // Logins held back by the throttle: verified by sweep() once `at` has passed.
  struct DelayedLogin {
    uint32_t connection = 0;
    Nanos at = 0;
    msg::Login login;
  };
  std::vector<DelayedLogin> delayed_;
};

}  // namespace skr::flow
