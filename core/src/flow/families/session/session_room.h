// SPDX-License-Identifier: Apache-2.0
// The session room: a connection's login (accounts, the authenticator's off-loop password checks,
// the login throttle), its switch to a flow and PING; the LOGIN, LOGIN_TOKEN, GO_ASYNC and PING
// rows of the catalogue. The connection's own state machine (login, authenticating, sync, flow) is
// in connection.h; this room decides each step.
#pragma once

#include "families/room.h"
#include "families/session/login_throttle.h"
#include "families/session/page_tokens.h"

#include <skrobot/hub/flow/accounts.h>
#include <skrobot/runtime/flow/messages.h>

#include <functional>
#include <memory>
#include <optional>
#include <vector>

namespace skr::flow {

class Connection;

class SessionRoom final : public Room {
 public:
  explicit SessionRoom(Hub& hub) : Room(hub) {}

  // The accounts (the users file, the development account); null before start().
  std::unique_ptr<Authenticator> auth;
  LoginThrottle throttle;
  // Page tokens (server.web with flows): issued at POST /skrobot/token; null without.
  std::unique_ptr<PageTokens> page_tokens;

  // Called (on the loop thread) when a supervised satellite logged in with its run's password.
  std::function<void(const std::string& satellite, uint32_t connection)> on_satellite_login;

  // The built-in page account (server.web.page_account's default): read-only, in memory.
  static constexpr std::string_view kBuiltInPageAccount = "web-page";

  // A token for a page fetched from `address` (the web port's POST /skrobot/token), logged
  // FLOW-TOKEN. limit_exceeded when throttled; unsupported without page tokens.
  [[nodiscard]] Result<PageTokens::Issued> issuePageToken(const std::string& address);

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
  // LOGIN_TOKEN's (WebSocket only; after the throttle's delay, if any): the page token redeemed
  // from this connection's peer address; a refusal is a failed login (FLOW-AUTH-FAILED).
  void loginWithToken(Connection& c, const msg::LoginToken& m);
  // The account page tokens log in as (server.web.page_account).
  [[nodiscard]] std::string pageAccount() const;
  // The checks every login starts with (connection limit, protocol version, value encoding):
  // false when it was answered and the connection closes.
  bool admit(Connection& c, uint16_t major, uint16_t minor, uint8_t value_encoding);
  // The answer to a LOGIN once its password (or its port's binding) was checked.
  void finishLogin(Connection& c, const std::string& user, uint16_t minor, LoginResult r);

  // Logins held back by the throttle: verified by sweep() once `at` has passed.
  struct DelayedLogin {
    uint32_t connection = 0;
    Nanos at = 0;
    msg::Login login;
    std::optional<msg::LoginToken> token{};  // a LOGIN_TOKEN rather than `login`
  };
  std::vector<DelayedLogin> delayed_;
  // The built-in page account's rules when server.web.page_account is it; else null.
  std::shared_ptr<const AccessRules> page_access_;
};

}  // namespace skr::flow
