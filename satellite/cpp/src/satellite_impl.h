// SPDX-License-Identifier: Apache-2.0
// The inside of a Satellite (internal): connection state machine, channel table, pending
// requests. Everything runs on the satellite's loop thread.
#pragma once

#include <skrobot/runtime/flow/codec.h>
#include <skrobot/runtime/loop_handles.h>
#include <skrobot/satellite/satellite.h>

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "link.h"
#include "paths.h"

namespace skr::sat {

inline constexpr std::string_view kLogSource = "satellite";

struct Satellite::Impl final : detail::Link::Handler {
  enum class State { stopped, waiting, connecting, login, hello, listing, going_async, flow };

  struct Own {
    ChannelSpec spec;
    uint16_t id = 0;   // 0: not created on this connection (yet)
    uint32_t tag = 0;  // CHAN_ADD in flight
    bool subscribers = false;
    int retries = 0;  // CHAN_ADD refusals on this connection
  };

  Impl(Satellite& self, SatelliteOptions options);
  ~Impl();
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
  Impl(Impl&&) = delete;
  Impl& operator=(Impl&&) = delete;

  // --- connection (satellite_link.cpp) ---
  void start();
  void stop();
  void connectNow();
  void onLinkConnected() override;
  void onLinkFrame(uint8_t code, std::string_view body) override;
  void onLinkClosed(const std::string& why, bool protocol) override;
  // Closes the link (if any) for `why` and schedules a reconnection.
  void drop(const std::string& why, bool protocol = false);
  void lost(const std::string& why, bool protocol);
  void handshake(uint8_t code, std::string_view body);
  // Runs fn; an exception from an application's slot is logged (SAT-SLOT-EXCEPTION), not thrown.
  template <class F>
  void guarded(std::string_view handling, F&& fn);
  void onFlowOpen();
  void armTimer(Nanos delay_ns);
  void onTimer();
  void onOneSecond();

  // --- events on the flow (satellite_events.cpp) ---
  void event(uint8_t code, std::string_view body);
  void onChanAdded(flow::msg::EvChanAdded& ev);
  void onChanRemoved(const flow::msg::EvChanRemoved& ev);
  void onHubError(const flow::msg::EvError& ev);
  void upsert(const ChannelInfo& info);
  void attach(const std::string& name, uint16_t id);
  void sendChanAdd(Own& own);

  // --- helpers ---
  template <class M>
  void send(const M& m) {
    if (link == nullptr) return;
    if (flow::encode(link->out(), m)) {
      ++stats.frames_out;
      link->queued();
    }
  }
  [[nodiscard]] uint32_t nextTag() noexcept { return next_tag == 0 ? ++next_tag : next_tag++; }
  [[nodiscard]] bool flowOpen() const noexcept { return state == State::flow && link != nullptr; }
  [[nodiscard]] Own* findOwn(std::string_view name);  // short or full name
  [[nodiscard]] const Own* findOwn(std::string_view name) const;
  [[nodiscard]] Result<SyncClient*> syncClient();
  // Runs fn(SyncClient&) once, and once more on a fresh connection if the cached one was stale.
  template <class F>
  auto withSync(F&& fn) -> decltype(fn(std::declval<SyncClient&>())) {
    for (int attempt = 0;; ++attempt) {
      auto c = syncClient();
      if (!c) return c.error();
      auto r = fn(**c);
      if (r || (*c)->isOpen() || attempt == 1) return r;
      sync.reset();
    }
  }

  Satellite& self;
  SatelliteOptions opt;
  State state = State::stopped;
  uint64_t generation = 0;  // bumped on every connection attempt; slots may change it
  detail::Link* link = nullptr;
  Timer timer;                 // handshake time-out, or the wait before the next connection attempt
  Nanos backoff_ns = 0;        // the delay before the next connection attempt
  Nanos flow_opened_ns = 0;    // steadyNowNs() when the current flow opened
  uint32_t udp_keepalive = 0;  // one-second ticks of a udp: flow (onOneSecond)
  bool failure_logged = false;
  bool stopping = false;  // stop() is closing: no retry
  Nanos last_drop_log_ns = 0;

  // Errc::unsupported ("this hub (FlowProtocol 1.m) <lacks>: it needs 1.n") when the hub's
  // minor is older than the one that brought `code`.
  [[nodiscard]] Result<void> needs(flow::Code code, const char* lacks) const {
    const uint16_t minor = flow::minorOf(code);
    if (login.minor >= minor) return {};
    return makeError(Errc::unsupported, "this hub (FlowProtocol 1." + std::to_string(login.minor) +
                                            ") " + lacks + ": it needs 1." + std::to_string(minor));
  }
  LoginInfo login;
  std::string linked_hub;  // the far hub's name, when opt.hub_name made this a hub link
  SatelliteStats stats;
  std::map<uint16_t, ChannelInfo> table;                 // every channel of the hub
  std::map<std::string, uint16_t, std::less<>> by_name;  // full name -> id
  std::map<std::string, Own, std::less<>> own;           // short name -> our channel
  std::map<std::string, uint16_t, std::less<>> subs;     // full name -> id attached (0: waiting)
  std::map<std::string, uint32_t, std::less<>> follows;  // sync sources in subs -> every
  std::map<std::string, uint32_t, std::less<>> queues;   // subs with a queue asked for -> bytes
  std::map<uint32_t, ResponseHandler> pending;           // request tag -> handler
  std::map<uint32_t, ResponseHandler> reads;             // DB_READ tag -> handler
  std::vector<uint32_t> orphan_tags;  // CHAN_ADDs in flight for channels removed meanwhile
  std::string wanted_db;              // selectDatabase(); empty: the user's
  std::map<std::string, std::string, std::less<>> replicas;  // short name -> source (replicate())
  std::string flow_db;  // the flow's current database, as last asked
  uint32_t next_tag = 1;
  std::optional<SyncClient> sync;
  std::optional<Result<flow::TlsContext>> tls_context;  // tls: addresses, made once
  std::unique_ptr<flow::phys::Paths> paths;             // physical mode (the runtime's paths.h)
};

}  // namespace skr::sat
