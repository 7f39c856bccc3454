// SPDX-License-Identifier: Apache-2.0
// Endpoints: the satellites of one hub as its parts see them, a socket Connection or an
// in-process LocalClient, and the table of those connected now. Main loop thread only.
#pragma once

#include <skrobot/hub/flow/access.h>
#include <skrobot/runtime/flow/messages.h>
#include <skrobot/runtime/flow/protocol.h>
#include <skrobot/runtime/flow/variant.h>

#include "rate_window.h"

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace skr::flow {

inline constexpr const char* kLogSource = "flow";

class Channel;
struct BlobEvent;

// A satellite: events reach it through these calls, on the main loop thread. Whoever owns it
// (the server for a Connection, the module for a LocalClient) removes it from the hub
// (FlowServer::Impl::removeEndpoint) before destroying it.
class Endpoint {
 public:
  Endpoint() = default;
  virtual ~Endpoint() = default;
  Endpoint(const Endpoint&) = delete;
  Endpoint& operator=(const Endpoint&) = delete;
  Endpoint(Endpoint&&) = delete;
  Endpoint& operator=(Endpoint&&) = delete;

  uint32_t id = 0;
  std::string user;
  std::string client_name;
  std::string current_db;
  // A connection from another hub that said HUB_LINK_HELLO: that hub's name (hub links).
  std::string linked_hub;
  // A supervised satellite that logged in with the password made for its run: its name.
  std::string satellite;
  // What it may do (flow/access.h): a connection's is its user's, set at login; the development
  // account's and a module's are the defaults (every rule "**", no administrator role).
  std::shared_ptr<const AccessRules> access = AccessRules::defaults();
  // Its user's limits, the account's own or the hub's (set when it logs in), and its service
  // requests not answered yet (the request table counts them).
  UserLimits limits;
  uint32_t pending_requests = 0;
  // What crossed between it and the hub ("in": to the hub): frames and their bytes for a
  // connection, payloads published and delivered for a module. Written to its flow database
  // once a second (FlowServer::Impl::writeFlowStats).
  struct Traffic {
    uint64_t messages_in = 0, bytes_in = 0, messages_out = 0, bytes_out = 0, dropped = 0;
    uint64_t sync_pulses = 0, sync_dropped = 0;  // pulses it got, and dropped while it was busy
    uint64_t path_messages = 0, path_bytes = 0;  // of those out: on its paths (PHYS_RECEIVED)
  } traffic;
  std::vector<uint16_t> owned;       // channels it owns
  std::vector<uint16_t> subscribed;  // channels it is subscribed to
  // Its traffic at the hub's last one-second ticks (rate_window.h), for hub.stats: messages and
  // bytes in, messages and bytes out, dropped, path messages.
  using Rates = RateWindow<6>;
  [[nodiscard]] Rates::Counters rateCounters() const noexcept {
    return {traffic.messages_in, traffic.bytes_in, traffic.messages_out,
            traffic.bytes_out,   traffic.dropped,  traffic.path_messages};
  }
  Rates rates;

  // True when it takes events (a flow, or a local client); sync connections do not.
  [[nodiscard]] virtual bool receivesEvents() const = 0;
  // Its output is backed up: service requests to it fail with `overflow` instead of queueing.
  [[nodiscard]] virtual bool congested() const = 0;
  [[nodiscard]] virtual std::string describe() const = 0;
  // For statistics: "satellite", "sync" (a synchronous connection), "module", "link" (a linked
  // hub), "replica"; and the bytes waiting in its output queue (in-process ones have none).
  [[nodiscard]] virtual const char* kind() const = 0;
  [[nodiscard]] virtual size_t queuedBytes() const { return 0; }
  // Its subscriber queue's size (SUBSCRIBE_QUEUE may raise it): 0 for in-process ones.
  [[nodiscard]] virtual size_t queueLimitBytes() const { return 0; }
  // SUBSCRIBE_RATE's cap (1.14) on its subscription to `chan` (max_hz 0: none) and the frames
  // the cap skipped (replaced by a newer one before they could go).
  struct RateCap {
    uint16_t max_hz = 0;
    uint64_t skipped = 0;
  };
  [[nodiscard]] virtual RateCap rateCap(uint16_t /*chan*/) const { return {}; }

  // Data published on a channel it subscribes to; `payload` is valid during the call only.
  virtual void onData(const Channel& ch, std::string_view payload) = 0;
  virtual void onSubscribers(const Channel& ch, bool first) = 0;
  virtual void onRequest(const Channel& ch, uint64_t request, const std::string& command,
                         const std::string& requester, const Variant& value) = 0;
  // The answer to a request it made: `sync` ones were SERVICE_CALLs waiting for a reply.
  virtual void onResponse(uint16_t chan_id, uint32_t tag, bool sync, ErrorCode error,
                          const Variant& value) = 0;
  virtual void onChannelAdded(const Channel& ch, uint32_t tag) = 0;
  virtual void onChannelRemoved(const Channel& ch) = 0;
  virtual void onChannelHeader(const Channel& ch) = 0;
  virtual void onError(Code command, uint32_t tag, uint16_t chan_id, ErrorCode error,
                       const std::string& message) = 0;
  virtual void onDbChanged(const std::string& name) = 0;
  // A file of a blob channel it subscribes to changed (in-process clients ignore it for now).
  virtual void onBlobChanged(const Channel& /*ch*/, const BlobEvent& /*event*/) {}
  // Physical mode (1.7, physical_paths.h): to a channel's owner (grant, revoke, relay) and to a
  // subscriber (its path). In-process clients take no paths.
  virtual void onPhysical(const msg::EvPhysGrant& /*m*/) {}
  virtual void onPhysical(const msg::EvPhysPath& /*m*/) {}
  virtual void onPhysical(const msg::EvPhysRevoke& /*m*/) {}
  virtual void onPhysical(const msg::EvPhysRelay& /*m*/) {}
  virtual void onPhysical(const msg::EvPhysSwitch& /*m*/) {}
  virtual void onPhysical(const msg::EvPhysResume& /*m*/) {}
  virtual void onPhysical(const msg::EvPhysMarker& /*m*/) {}
  // The protocol minor it speaks: a connection's is the lower of its client's and ours.
  [[nodiscard]] virtual uint16_t protocolMinor() const { return kProtocolMinor; }
  // A pulse of a sync source it follows; it answers with SyncPulses::done when its tick is over.
  virtual void onSyncPulse(const Channel& /*ch*/, uint64_t /*seq*/, uint64_t /*source_time_ns*/,
                           uint32_t /*dropped*/) {}
  // A sync source it owns got its first target (`first`) or lost its last one (SyncPulses): a
  // hub link follows the far source only while someone here does.
  virtual void onFollowers(const Channel& /*ch*/, bool /*first*/) {}
};

// The endpoints connected now, by id. Does not own them.
class EndpointTable {
 public:
  // `clock`: the monotonic time an endpoint's rate window starts at (tests drive their own).
  explicit EndpointTable(Nanos (*clock)() = &monotonicNs) : clock_(clock) {}

  // Gives `e` a fresh id (never 0) and registers it; its rate window starts now.
  uint32_t add(Endpoint& e) {
    e.rates = Endpoint::Rates(clock_(), e.rateCounters());
    e.id = next_id_++;
    if (next_id_ == 0) next_id_ = 1;
    by_id_[e.id] = &e;
    return e.id;
  }
  // False when `id` was not registered (removed already).
  bool remove(uint32_t id) { return by_id_.erase(id) != 0; }
  [[nodiscard]] Endpoint* find(uint32_t id) const noexcept {
    auto it = by_id_.find(id);
    return it == by_id_.end() ? nullptr : it->second;
  }

  // Calls f(Endpoint&) for every endpoint that takes events. f may add or remove endpoints:
  // the ids are copied first, and one removed meanwhile is skipped.
  // What the endpoints of `user` hold together: connections (or in-process clients), channels,
  // pending service requests.
  struct Holdings {
    uint32_t endpoints = 0, channels = 0, pending_requests = 0;
  };
  [[nodiscard]] Holdings holdingsOf(std::string_view user) const {
    Holdings h;
    for (const auto& [id, e] : by_id_) {
      if (e->user != user) continue;
      ++h.endpoints;
      h.channels += static_cast<uint32_t>(e->owned.size());
      h.pending_requests += e->pending_requests;
    }
    return h;
  }

  template <class F>
  void forEach(F&& f) const {
    for (const auto& [id, e] : by_id_) f(*e);
  }

  template <class F>
  void forEachEventReceiver(F&& f) const {
    std::vector<uint32_t> ids;
    ids.reserve(by_id_.size());
    for (const auto& [id, e] : by_id_) {
      if (e->receivesEvents()) ids.push_back(id);
    }
    for (uint32_t id : ids) {
      if (Endpoint* e = find(id)) f(*e);
    }
  }

 private:
  Nanos (*clock_)();
  uint32_t next_id_ = 1;
  std::unordered_map<uint32_t, Endpoint*> by_id_;
};

}  // namespace skr::flow
