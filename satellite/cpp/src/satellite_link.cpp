// SPDX-License-Identifier: Apache-2.0
// The satellite's connection: connect, LOGIN, CHAN_LIST, GO_ASYNC, and reconnection with backoff.
#include <skrobot/runtime/log.h>

#include <chrono>

#include "satellite_impl.h"

namespace skr::sat {

namespace msg = flow::msg;
using flow::Code;

namespace {
Nanos steadyNowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}
}  // namespace

// Decoding reports errors as values, so whatever throws in `fn` is a slot of the application,
// connected to one of our signals. It must not unwind through libuv, nor pass for the hub's
// fault: it is logged as the application's and the satellite goes on (the connection stays up).
template <class F>
void Satellite::Impl::guarded(std::string_view handling, F&& fn) {
  const auto threw = [&](const std::string& what) {
    ++stats.slot_exceptions;
    log::error(kLogSource, "SAT-SLOT-EXCEPTION",
               "a slot connected to this satellite threw while handling " + std::string(handling) +
                   ": " + what + " (an error of the application, not of the hub)");
  };
  try {
    fn();
  } catch (const std::exception& e) {
    threw(e.what());
  } catch (...) {
    threw("an exception that is not a std::exception");
  }
}

Satellite::Impl::Impl(Satellite& s, SatelliteOptions options)
    : self(s), opt(std::move(options)), timer(s.loop(), [this] { onTimer(); }) {
  if (opt.reconnect_min_ns <= 0) opt.reconnect_min_ns = kNsPerMs;
  opt.reconnect_max_ns = std::max(opt.reconnect_max_ns, opt.reconnect_min_ns);
  backoff_ns = opt.reconnect_min_ns;
  login.user = opt.connection.user;
  flow::phys::Paths::Host h;
  h.loop = &self.loop();
  h.offer = [this](const flow::msg::PhysOffer& m) { send(m); };
  h.request = [this](const flow::msg::PhysRequest& m) { send(m); };
  h.state = [this](const flow::msg::PhysState& m) { send(m); };
  h.count = [this](const flow::msg::PhysCount& m) { send(m); };
  h.received = [this](const flow::msg::PhysReceived& m) { send(m); };
  h.switched = [this](const flow::msg::PhysSwitched& m) { send(m); };
  h.fallback = [this](const flow::msg::PhysFallback& m) { send(m); };
  h.replay = [this](const flow::msg::PhysReplay& m) { send(m); };
  h.next_tag = [this] { return nextTag(); };
  h.hub_minor = [this] { return login.minor; };
  h.tcp_listen = opt.path_tcp;
  h.deliver_view = [this](uint16_t chan, std::string_view payload) {
    self.dataView.emit(chan, payload);
  };
  h.wants_copy = [this] { return self.data.connectionCount() > 0; };
  h.deliver_copy = [this](uint16_t chan, const std::string& payload) {
    self.data.emit(chan, payload);
  };
  paths = std::make_unique<flow::phys::Paths>(std::move(h));
}

Satellite::Impl::~Impl() {
  paths.reset();
  if (link != nullptr) link->close();
  link = nullptr;
}

void Satellite::Impl::start() {
  if (state != State::stopped) return;
  backoff_ns = opt.reconnect_min_ns;
  failure_logged = false;
  connectNow();
}

void Satellite::Impl::stop() {
  if (state == State::stopped) return;
  if (state == State::flow) {
    log::info(kLogSource, "SAT-STOP", "closing the flow to " + opt.connection.address.toString());
  }
  stopping = true;
  drop("stopped");
  stopping = false;
  state = State::stopped;
}

void Satellite::Impl::connectNow() {
  ++generation;
  state = State::connecting;
  if (opt.connection.address.kind == Address::Kind::tls && !tls_context) {
    // Certificates and keys are read once per satellite, not at every reconnection.
    tls_context = flow::TlsContext::create(flow::TlsRole::client, opt.connection.tls);
  }
  flow::transport::DialOptions dial;
  dial.tls = tls_context ? &*tls_context : nullptr;
  dial.udp_user = opt.connection.user;
  dial.udp_key = opt.connection.udp_key;
  dial.udp_handshake_ms = opt.connection.timeout_ms;
  link = detail::Link::open(self.loop(), opt.connection.address, dial,
                            opt.connection.max_frame_bytes, *this);
  armTimer(opt.handshake_timeout_ns);
}

void Satellite::Impl::armTimer(Nanos delay_ns) {
  timer.startIn(delay_ns);
}

void Satellite::Impl::onTimer() {
  switch (state) {
    case State::waiting:
      connectNow();
      return;
    case State::connecting:
    case State::login:
    case State::hello:
    case State::listing:
    case State::going_async:
      guarded("a handshake time-out", [this] {
        drop("no answer from the hub within " +
             std::to_string(opt.handshake_timeout_ns / kNsPerMs) + " ms");
      });
      return;
    case State::stopped:
    case State::flow:
      return;
  }
}

void Satellite::Impl::onLinkConnected() {
  state = State::login;
  msg::Login m;
  m.user = opt.connection.user;
  m.password = opt.connection.password;
  m.client_name = opt.connection.client_name;
  send(m);
}

void Satellite::Impl::onLinkFrame(uint8_t code, std::string_view body) {
  ++stats.frames_in;
  guarded(flow::codeName(code), [&] {
    if (state == State::flow) {
      event(code, body);
    } else {
      handshake(code, body);
    }
  });
}

void Satellite::Impl::onLinkClosed(const std::string& why, bool protocol) {
  link = nullptr;  // it deletes itself
  guarded("the loss of the connection", [&] { lost(why, protocol); });
}

void Satellite::Impl::drop(const std::string& why, bool protocol) {
  if (link != nullptr) link->close();
  link = nullptr;
  lost(why, protocol);
}

void Satellite::Impl::lost(const std::string& why, bool protocol) {
  const bool was_flow = state == State::flow;
  const std::string where = opt.connection.address.toString();
  if (stopping) {
    // stop() logged it
  } else if (protocol) {
    ++stats.protocol_errors;
    log::warn(kLogSource, "SAT-PROTOCOL",
              "killing the connection to the hub at " + where + ", it broke the protocol: " + why);
  } else if (was_flow) {
    log::warn(kLogSource, "SAT-DISCONNECTED", "lost the hub at " + where + ": " + why);
  } else if (!stopping && !failure_logged) {
    failure_logged = true;
    log::warn(kLogSource, "SAT-RETRY",
              "cannot reach the hub at " + where + ": " + why + "; retrying in the background");
  } else {
    log::debug(kLogSource, "SAT-RETRY", "hub at " + where + ": " + why);
  }
  timer.stop();
  paths->reset();
  table.clear();
  by_name.clear();
  for (auto& [name, o] : own) o.id = 0, o.tag = 0, o.subscribers = false, o.retries = 0;
  for (auto& [name, id] : subs) id = 0;
  flow_db.clear();
  orphan_tags.clear();
  auto failed = std::move(pending);
  pending.clear();
  auto failed_reads = std::move(reads);
  reads.clear();
  if (was_flow && steadyNowNs() - flow_opened_ns >= opt.reconnect_reset_after_ns) {
    backoff_ns = opt.reconnect_min_ns;  // that flow was sound: the hub went away since
  }
  if (opt.reconnect && !stopping) {
    state = State::waiting;
    armTimer(backoff_ns);
    backoff_ns = std::min(backoff_ns * 2, opt.reconnect_max_ns);
  } else {
    state = State::stopped;
  }
  const uint64_t gen = generation;
  for (auto& [tag, handler] : failed) {
    Response r{0, tag, flow::ErrorCode::io_error,
               flow::Variant("the connection to the hub was lost")};
    if (handler) handler(r);
    self.serviceResponse.emit(r);
  }
  for (auto& [tag, handler] : failed_reads) {
    if (handler) {
      handler(Response{0, tag, flow::ErrorCode::io_error,
                       flow::Variant("the connection to the hub was lost")});
    }
  }
  if (protocol && gen == generation) {
    self.error.emit(FlowError{0, 0, 0, uint16_t(flow::ErrorCode::protocol_error), why});
  } else if (!was_flow && !stopping && !opt.reconnect && gen == generation) {
    self.error.emit(FlowError{0, 0, 0, uint16_t(flow::ErrorCode::io_error), why});  // gave up
  }
  if (was_flow && gen == generation) self.disconnected.emit(why);
}

void Satellite::Impl::handshake(uint8_t code, std::string_view body) {
  const auto c = static_cast<Code>(code);
  if (c == Code::reply_error && (state == State::login || state == State::hello)) {
    auto e = flow::decode<msg::ReplyError>(body);
    if (!e) return drop("REPLY_ERROR: " + e.error().message, true);
    const std::string why = (state == State::hello ? "hub link to " : "login to ") +
                            opt.connection.address.toString() + " as \"" +
                            (state == State::hello ? opt.hub_name : opt.connection.user) +
                            "\" refused: " + e->message;
    const auto command = state == State::hello ? Code::hub_link_hello : Code::login;
    log::error(kLogSource, "SAT-LOGIN", why);
    backoff_ns = opt.reconnect_max_ns;  // a refused login is not retried in a hurry
    failure_logged = true;
    const uint64_t gen = generation;
    self.error.emit(FlowError{uint8_t(command), 0, 0, e->error, e->message});
    if (gen == generation) drop(why);
    return;
  }
  if (c != Code::reply_ok) {
    return drop("the hub sent " + std::string(flow::codeName(code)) + " during login", true);
  }
  switch (state) {
    case State::login: {
      auto ok = flow::decode<msg::LoginOk>(body);
      if (!ok) return drop(ok.error().message, true);
      login = std::move(ok).value();
      flow_db = login.current_db;
      state = State::listing;
      if (!opt.hub_name.empty()) {
        if (login.minor < flow::minorOf(Code::hub_link_hello)) {
          backoff_ns = opt.reconnect_max_ns;
          return drop("the hub at " + opt.connection.address.toString() +
                      " speaks FlowProtocol 1." + std::to_string(login.minor) +
                      ": hub links need 1.5");
        }
        send(msg::HubLinkHello{opt.hub_name});
        state = State::hello;
      }
      send(msg::Empty<Code::chan_list>{});  // the channels that exist, then the flow: both go
      send(msg::Empty<Code::go_async>{});   // in one write, so no channel is missed in between
      return;
    }
    case State::hello: {
      auto ok = flow::decode<msg::HubLinkHelloOk>(body);
      if (!ok) return drop(ok.error().message, true);
      linked_hub = std::move(ok->hub_name);
      state = State::listing;
      return;
    }
    case State::listing: {
      auto list = flow::decode<msg::ChannelList>(body);
      if (!list) return drop(list.error().message, true);
      for (const auto& info : list->channels) upsert(info);
      state = State::going_async;
      return;
    }
    case State::going_async:
      if (!body.empty()) return drop("GO_ASYNC reply has a body", true);
      state = State::flow;
      timer.stop();
      onFlowOpen();
      return;
    default:
      return;
  }
}

void Satellite::Impl::onFlowOpen() {
  ++stats.connections;
  flow_opened_ns = steadyNowNs();  // backoff_ns is reset by lost() if this flow stays up
  failure_logged = false;
  log::info(kLogSource, "SAT-CONNECTED",
            "connected to " + login.app_name + " at " + opt.connection.address.toString() + " as " +
                login.user + " (connection " + std::to_string(login.connection_id) + ")");
  if (!wanted_db.empty() && wanted_db != flow_db) {
    send(msg::DbSetCurrent{nextTag(), wanted_db});
    flow_db = wanted_db;
  }
  const uint64_t gen = generation;
  self.connected.emit();
  if (gen != generation || state != State::flow) return;
  for (auto& [name, o] : own) {
    if (o.id == 0 && o.tag == 0) sendChanAdd(o);
  }
  for (const auto& [short_name, source] : replicas) {
    send(msg::ReplicateChannel{nextTag(), source, short_name});
  }
  std::vector<std::pair<std::string, uint16_t>> ready;
  for (const auto& [name, id] : subs) {
    if (auto it = by_name.find(name); it != by_name.end() && id == 0)
      ready.emplace_back(name, it->second);
  }
  for (const auto& [name, id] : ready) {
    attach(name, id);
    if (gen != generation || state != State::flow) return;
  }
}

// Channels of ours that the hub refused for a moment (the old connection's copy still there)
// are asked for again once a second, a few times. A udp: flow sends a TIME_PROBE every 2 s, as a
// board does: the hub ends a UDP session that sends nothing for its session_timeout_ms, and the
// answers keep our side's silence limit from passing (udp_client.h).
void Satellite::Impl::onOneSecond() {
  if (!flowOpen()) return;
  if (opt.connection.address.kind == Address::Kind::udp && ++udp_keepalive % 2 == 0) {
    send(msg::TimeProbe{0, static_cast<uint64_t>(realtimeNs())});
  }
  paths->tick();
  for (auto& [name, o] : own) {
    if (o.id == 0 && o.tag == 0 && o.retries > 0 && o.retries < 10) sendChanAdd(o);
  }
}

}  // namespace skr::sat
