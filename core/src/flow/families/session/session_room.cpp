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
  const uint16_t minor = std::min(m.minor, kProtocolMinor);
  if (!c.bound_account.empty()) {
    // The transport already knows the account: a serial port bound to it (the port is the
    // credential) or a UDP session opened with its key (docs/microcontrollers.md).
    LoginResult r;
    r.ok = (m.user.empty() || m.user == c.bound_account) && auth->hasUser(c.bound_account);
    r.reason = r.ok ? "bound to the account"
                    : "this " + std::string(transport::transportKindName(c.transportKind())) +
                          " session is bound to account \"" + c.bound_account + "\"";
    finishLogin(c, r.ok ? c.bound_account : m.user, minor, std::move(r));
    return;
  }
  auth->verify(m.user, std::move(m.password), c.transport(),
               c.whenAlive<LoginResult>([this, user = m.user, minor](Connection& c, LoginResult r) {
                 finishLogin(c, user, minor, std::move(r));
               }));
}

void SessionRoom::finishLogin(Connection& c, const std::string& user, uint16_t minor,
                              LoginResult r) {
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
  c.send(
      msg::LoginOk{kProtocolMajor, kProtocolMinor, c.id, hub_.opt.app_name, c.user, c.current_db});
  log::info(kLogSource, "FLOW-LOGIN", c.describe() + " logged in");
  c.unblock();
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
  // A small session learns the channels it watches that exist already.
  if (c.watches()) {
    hub_.channels.forEach([&](const Channel& ch) {
      if (ch.owner != &c) c.onChannelAdded(ch, 0);
    });
  }
}

void SessionRoom::handle(Connection& c, msg::SessionLimits& m) {
  // A frame limit below a ChannelInfo with a short name would starve the session.
  constexpr uint32_t kSmallestFrame = 64;
  if (m.max_frame != 0 && m.max_frame < kSmallestFrame) {
    c.replyError(ErrorCode::invalid_argument,
                 "max_frame " + std::to_string(m.max_frame) + " is below 64 bytes");
    return;
  }
  if ((m.events & ~msg::session_events_all) != 0) {
    c.replyError(ErrorCode::invalid_argument, "unknown event bits in SESSION_LIMITS");
    return;
  }
  std::vector<std::string> patterns;
  for (size_t at = 0; at < m.watch.size();) {
    const size_t space = std::min(m.watch.find(' ', at), m.watch.size());
    if (space > at) patterns.emplace_back(m.watch, at, space - at);
    at = space + 1;
  }
  auto watch = NameFilter::parse(patterns);
  if (!watch) {
    c.replyError(ErrorCode::invalid_argument, "watch: " + watch.error().message);
    return;
  }
  c.limitSession(m.max_frame, (m.events & msg::session_events_channels) != 0,
                 std::move(watch).value());
  c.replyOk();
}

void SessionRoom::handle(Connection& c, msg::Ping& m) {
  c.send(msg::Pong{m.echo});
}

}  // namespace skr::flow
