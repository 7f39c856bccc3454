// SPDX-License-Identifier: Apache-2.0
// LOGIN, GO_ASYNC and PING: a connection becomes a logged-in synchronous connection, then a flow.
#include "families/session/session_room.h"

#include "connection.h"
#include "hub.h"

#include <skrobot/runtime/log.h>

#include <algorithm>

namespace skr::flow {

Result<void> SessionRoom::start() {
  const ServerOptions& opt = hub_.opt;
  std::optional<DevAccount> dev;
  if (opt.dev_account) dev = DevAccount{opt.dev_account->first, opt.dev_account->second};
  std::filesystem::path users = opt.users_file;
  if (users.empty() && !opt.data_dir.empty()) users = opt.data_dir / "users.json";
  auto a = Authenticator::create(users, dev, hub_.loop);
  if (!a) return a.error();
  auth = std::move(a).value();
  if (dev) {
    log::warn(kLogSource, "FLOW-DEV-ACCOUNT",
              "development account \"" + dev->user +
                  "\" is enabled on the Unix socket only (never on TCP); replace it with real "
                  "accounts: skrobot user add NAME, and remove accounts.dev_account");
  }
  if (opt.tcp_enabled && !auth->hasRealAccounts()) {
    return makeError(Errc::permission_denied,
                     "TCP is enabled but " +
                         (users.empty() ? std::string("no users file is configured")
                                        : "the users file " + users.string() + " has no accounts") +
                         "; create one with: skrobot user add NAME");
  }
  return {};
}

void SessionRoom::stop() noexcept {
  auth.reset();
}

void SessionRoom::handle(Connection& c, msg::Login& m) {
  const ServerOptions& opt = hub_.opt;
  if (c.over_limit) {
    c.replyError(ErrorCode::limit_exceeded,
                 "this hub serves " + std::to_string(opt.max_connections) +
                     " connections at most (server.max_connections); try again later");
    c.closeAfterFlush("too many connections");
    return;
  }
  if (m.major != kProtocolMajor) {
    const std::string why = "this hub speaks FlowProtocol " + std::to_string(kProtocolMajor) + "." +
                            std::to_string(kProtocolMinor) + ", the client " +
                            std::to_string(m.major) + "." + std::to_string(m.minor);
    log::warn(kLogSource, "FLOW-VERSION", c.describe() + ": " + why);
    c.replyError(ErrorCode::version_mismatch, why);
    c.closeAfterFlush("protocol version mismatch");
    return;
  }
  if (m.value_encoding > static_cast<uint8_t>(ValueEncoding::json)) {
    c.protocolError("LOGIN: unknown value encoding " + std::to_string(m.value_encoding));
    return;
  }
  c.client_name = m.client_name;
  c.authenticating(static_cast<ValueEncoding>(m.value_encoding));  // reading pauses meanwhile
  const Nanos now = monotonicNs();
  if (const Nanos wait = throttle.wait(m.user, c.source, now); wait > 0) {
    log::warn(kLogSource, "FLOW-LOGIN-THROTTLED",
              c.describe() + ": login as \"" + m.user + "\" held back " +
                  std::to_string(wait / kNsPerMs) + " ms after failed logins");
    delayed_.push_back({c.id, now + wait, std::move(m)});
    return;
  }
  verify(c, std::move(m));
}

void SessionRoom::verify(Connection& c, msg::Login m) {
  auth->verify(
      m.user, std::move(m.password), c.transport(),
      c.whenAlive<LoginResult>([this, user = m.user, minor = std::min(m.minor, kProtocolMinor)](
                                   Connection& c, LoginResult r) {
        if (!r.ok) {
          ++hub_.stats.logins_failed;
          throttle.failed(user, c.source, monotonicNs());
          log::warn(kLogSource, "FLOW-AUTH-FAILED",
                    c.describe() + ": login as \"" + user + "\" refused (" + r.reason + ")");
          c.replyError(ErrorCode::auth_failed, "wrong user name or password");
          c.closeAfterFlush("login refused");
          return;
        }
        c.user = user;
        c.access = auth->accessOf(user);
        throttle.succeeded(user, c.source);
        const uint32_t limit = c.access->limits().orElse(hub_.opt.user_limits).connections;
        if (hub_.endpoints.holdingsOf(user).endpoints > limit) {     // this one included
          const Error e = limitReached(user, "connections", limit);  // logged (FLOW-LIMIT)
          c.replyError(ErrorCode::limit_exceeded, e.message);
          c.closeAfterFlush("connection limit");
          return;
        }
        c.loggedIn(minor);
        hub_.loggedIn(c);
        c.send(msg::LoginOk{kProtocolMajor, kProtocolMinor, c.id, hub_.opt.app_name, c.user,
                            c.current_db});
        log::info(kLogSource, "FLOW-LOGIN", c.describe() + " logged in");
        c.unblock();
      }));
}

void SessionRoom::sweep(Nanos now) {
  if (delayed_.empty()) return;
  std::vector<DelayedLogin> due;
  std::erase_if(delayed_, [&](DelayedLogin& d) {
    if (d.at > now) return false;
    due.push_back(std::move(d));
    return true;
  });
  for (DelayedLogin& d : due) {
    if (Connection* c = hub_.connection(d.connection)) verify(*c, std::move(d.login));
  }
}

void SessionRoom::handle(Connection& c, msg::GoAsync&) {
  c.replyOk();
  c.becomeFlow();
  log::debug(kLogSource, "FLOW-ASYNC", c.describe() + " is now a flow");
  hub_.links.flowOpened(c);
}

void SessionRoom::handle(Connection& c, msg::Ping& m) {
  c.send(msg::Pong{m.echo});
}

}  // namespace skr::flow
