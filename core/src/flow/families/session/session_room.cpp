// SPDX-License-Identifier: Apache-2.0
// LOGIN, LOGIN_TOKEN, GO_ASYNC and PING: a connection becomes a logged-in synchronous connection,
// then a flow.
#include "families/session/session_room.h"

#include "connection.h"
#include "hub.h"

#include <skrobot/runtime/log.h>

#include <algorithm>

namespace skr::flow {

Result<void> SessionRoom::start() {
  const ServerOptions& opt = hub_.opt;
  std::optional<DevAccount> dev;
  const bool dev_on_web = opt.web && opt.web->flows && opt.web->dev_account;
  if (opt.dev_account) {
    dev = DevAccount{opt.dev_account->first, opt.dev_account->second, dev_on_web};
  }
  std::filesystem::path users = opt.users_file;
  if (users.empty() && !opt.data_dir.empty()) users = opt.data_dir / "users.json";
  auto a = Authenticator::create(users, dev, hub_.loop);
  if (!a) return a.error();
  auth = std::move(a).value();
  if (dev) {
    log::warn(kLogSource, "FLOW-DEV-ACCOUNT",
              "development account \"" + dev->user +
                  (dev_on_web ? "\" is enabled on the Unix socket and on WebSocket from this "
                                "machine (server.web.dev_account; never on TCP)"
                              : "\" is enabled on the Unix socket only (never on TCP)") +
                  "; replace it with real accounts: skrobot user add NAME, and remove "
                  "accounts.dev_account");
  }
  // Flows from other machines need real accounts: TCP, or the web port's flows off loopback.
  const bool web_remote = opt.web && opt.web->flows && !isLoopbackAddress(opt.web->address);
  if ((opt.tcp_enabled || web_remote) && !auth->hasRealAccounts()) {
    return makeError(Errc::permission_denied,
                     std::string(opt.tcp_enabled ? "TCP" : "the web port's flows (server.web)") +
                         " is enabled but " +
                         (users.empty() ? std::string("no users file is configured")
                                        : "the users file " + users.string() + " has no accounts") +
                         "; create one with: skrobot user add NAME");
  }
  if (opt.web && opt.web->flows) {
    const std::string& page = opt.web->page_account;
    if (page == kBuiltInPageAccount) {
      if (auth->hasUser(page)) {
        return makeError(Errc::already_exists,
                         "the users file has an account \"" + page +
                             "\", the name of the built-in page account (server.web.page_account)"
                             ": rename it, or name it in server.web.page_account to use it");
      }
      // Read-only: subscribe to every channel and read every database; nothing else.
      auto rules = std::make_shared<AccessRules>();
      for (const Action a : {Action::publish, Action::call, Action::db_write}) {
        (void)rules->setRule(a, {});
      }
      page_access_ = std::move(rules);
    } else if (!auth->hasUser(page)) {
      return makeError(Errc::not_found, "server.web.page_account \"" + page +
                                            "\" is not an account of the users file");
    }
    page_tokens =
        std::make_unique<PageTokens>(page, static_cast<Nanos>(opt.web->token_ttl_ms) * kNsPerMs);
  }
  return {};
}

Result<PageTokens::Issued> SessionRoom::issuePageToken(const std::string& address) {
  if (!page_tokens) return makeError(Errc::unsupported, "no page tokens (server.web.flows)");
  auto t = page_tokens->issue(address, monotonicNs());
  if (!t) {
    log::warn(kLogSource, "FLOW-TOKEN",
              "refused a page token to " + address + ": " + t.error().message);
  } else {
    log::debug(kLogSource, "FLOW-TOKEN", "page token for \"" + t->account + "\" to " + address);
  }
  return t;
}

void SessionRoom::handle(Connection& c, msg::LoginToken& m) {
  if (!admit(c, m.major, m.minor, m.value_encoding)) return;
  c.client_name = m.client_name;
  c.authenticating(static_cast<ValueEncoding>(m.value_encoding));  // reading pauses meanwhile
  const std::string account = pageAccount();
  if (c.transport() != Transport::websocket && c.transport() != Transport::websocket_loopback) {
    LoginResult r;
    r.reason = "a page token on " + std::string(transportName(c.transport())) + " (WebSocket only)";
    finishLogin(c, account, std::min(m.minor, kProtocolMinor), std::move(r));
    return;
  }
  // Held back after failed logins as LOGIN is (the same throttle, by account and source).
  const Nanos now = monotonicNs();
  if (const Nanos wait = throttle.wait(account, c.source, now); wait > 0) {
    log::warn(kLogSource, "FLOW-LOGIN-THROTTLED",
              c.describe() + ": page token login as \"" + account + "\" held back " +
                  std::to_string(wait / kNsPerMs) + " ms after failed logins");
    delayed_.push_back({c.id, now + wait, {}, std::move(m)});
    return;
  }
  loginWithToken(c, m);
}

std::string SessionRoom::pageAccount() const {
  return page_tokens ? hub_.opt.web->page_account : std::string(kBuiltInPageAccount);
}

void SessionRoom::loginWithToken(Connection& c, const msg::LoginToken& m) {
  LoginResult r;
  if (!page_tokens) {
    r.reason = "no page tokens (server.web.flows is off)";
  } else {
    r.ok = page_tokens->redeem(m.token, c.peerAddress(), monotonicNs(), &r.reason).has_value();
    if (r.ok) r.reason = "page token";
  }
  finishLogin(c, pageAccount(), std::min(m.minor, kProtocolMinor), std::move(r));
}

void SessionRoom::stop() noexcept {
  auth.reset();
}

bool SessionRoom::admit(Connection& c, uint16_t major, uint16_t minor, uint8_t value_encoding) {
  const ServerOptions& opt = hub_.opt;
  if (c.over_limit) {
    c.replyError(ErrorCode::limit_exceeded,
                 "this hub serves " + std::to_string(opt.max_connections) +
                     " connections at most (server.max_connections); try again later");
    c.closeAfterFlush("too many connections");
    return false;
  }
  if (major != kProtocolMajor) {
    const std::string why = "this hub speaks FlowProtocol " + std::to_string(kProtocolMajor) + "." +
                            std::to_string(kProtocolMinor) + ", the client " +
                            std::to_string(major) + "." + std::to_string(minor);
    log::warn(kLogSource, "FLOW-VERSION", c.describe() + ": " + why);
    c.replyError(ErrorCode::version_mismatch, why);
    c.closeAfterFlush("protocol version mismatch");
    return false;
  }
  if (value_encoding > static_cast<uint8_t>(ValueEncoding::json)) {
    c.protocolError("LOGIN: unknown value encoding " + std::to_string(value_encoding));
    return false;
  }
  return true;
}

void SessionRoom::handle(Connection& c, msg::Login& m) {
  if (!admit(c, m.major, m.minor, m.value_encoding)) return;
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
  c.access = page_access_ && user == kBuiltInPageAccount ? page_access_ : auth->accessOf(user);
  throttle.succeeded(user, c.source);
  const uint32_t limit = c.access->limits().orElse(hub_.opt.user_limits).connections;
  if (hub_.endpoints.holdingsOf(user).endpoints > limit) {     // this one included
    const Error e = limitReached(user, "connections", limit);  // logged (FLOW-LIMIT)
    c.replyError(ErrorCode::limit_exceeded, e.message);
    c.closeAfterFlush("connection limit");
    return;
  }
  c.satellite = r.satellite;
  c.loggedIn(minor);
  hub_.loggedIn(c);
  c.send(
      msg::LoginOk{kProtocolMajor, kProtocolMinor, c.id, hub_.opt.app_name, c.user, c.current_db});
  log::info(kLogSource, "FLOW-LOGIN",
            c.describe() + " logged in" +
                (c.satellite.empty() ? "" : " (supervised satellite " + c.satellite + ")"));
  if (!c.satellite.empty() && on_satellite_login) on_satellite_login(c.satellite, c.id);
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
    Connection* c = hub_.connection(d.connection);
    if (c == nullptr) continue;
    if (d.token) {
      loginWithToken(*c, *d.token);
    } else {
      verify(*c, std::move(d.login));
    }
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
