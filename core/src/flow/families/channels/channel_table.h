// SPDX-License-Identifier: Apache-2.0
// The channel table and the router: channels by id and name, their subscriber lists, and the
// routing of published data to each subscriber (ChannelTable::publish, the relay's hot path).
// Knows nothing of databases or service requests: FlowServer::Impl wires those around it.
// Main loop thread only.
#pragma once

#include "endpoint.h"
#include "rate_window.h"

#include <skrobot/runtime/flow/protocol.h>
#include <skrobot/runtime/result.h>

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace skr::flow {

class Channel {
 public:
  uint16_t id = 0;
  uint64_t hash = 0;
  ChannelKind kind = ChannelKind::streaming;
  std::string name;  // <user>.<short>
  std::string mime;
  // The owner connected now; a blob channel keeps its owner_user while nobody of it is connected
  // (owner nullptr), and only that user writes to it.
  Endpoint* owner = nullptr;
  std::string owner_user;
  // A blob channel of another hub that a link (its owner) shows here: its files stay there, the
  // link passes reads on, and nothing is written here (docs/hub-links.md, "Blob channels").
  bool far = false;
  // May hold nullptr tombstones while a publish is being dispatched (see ChannelTable::publish).
  std::vector<Endpoint*> subscribers;
  // Subscribers whose physical path works (physical_paths.h): still subscribed, not relayed to.
  std::vector<Endpoint*> physical;
  size_t subscriber_count = 0;  // both lists
  // Polling: the endpoints registered; while there are any, the latest payload and its seq
  // (0: none published since the first registered).
  std::vector<uint32_t> pollers;
  std::string last;
  uint64_t last_seq = 0;
  uint64_t seq = 0;    // messages published on it (its count, for statistics too)
  uint64_t bytes = 0;  // their payload bytes
  // Messages a subscriber's queue dropped (counted where the drop happens, with the channel const).
  mutable uint64_t dropped = 0;
  size_t pending_requests = 0;  // kept by the RequestTable
  // Retained messages (plugin ABI 1.9): the last one its owner published under each key, oldest
  // first; each new subscriber gets them all when it subscribes. Shared so that a replay holds
  // them while a subscriber's handler publishes again.
  std::vector<std::pair<std::string, std::shared_ptr<const std::string>>> retained;
  size_t retained_bytes = 0;
  // seq, bytes, dropped at the hub's last one-second ticks (rate_window.h), for hub.stats.
  using Rates = RateWindow<3>;
  [[nodiscard]] Rates::Counters rateCounters() const noexcept { return {seq, bytes, dropped}; }
  Rates rates;
};

// What a streaming channel retains at most (publishRetained).
inline constexpr size_t kMaxRetainedKeys = 64;
inline constexpr size_t kMaxRetainedBytes = 16u << 20;
inline constexpr size_t kMaxRetainedKeyBytes = 255;

class ChannelTable {
 public:
  // `clock`: the monotonic time a channel's rate window starts at (tests drive their own).
  explicit ChannelTable(Nanos (*clock)() = &monotonicNs);

  [[nodiscard]] Channel* find(uint16_t id) noexcept {
    return id < channels_.size() ? channels_[id].get() : nullptr;
  }
  [[nodiscard]] Channel* findByName(const std::string& name) noexcept;
  [[nodiscard]] size_t count() const noexcept { return count_; }
  // Every channel, by id.
  template <class F>
  void forEach(F&& f) const {
    for (const auto& ch : channels_) {
      if (ch != nullptr) f(*ch);
    }
  }

  // The channel `id`, or not_found ("no channel with id N").
  [[nodiscard]] Result<Channel*> existing(uint16_t id);
  // The channel `id` when `e` owns it, or permission_denied ("only the owner <action> <name>").
  [[nodiscard]] Result<Channel*> owned(const Endpoint& e, uint16_t id, const char* action);

  // Adds "<user>.<short_name>" owned by `owner` (nullptr: a blob channel whose owner is not
  // connected), with a fresh id (ids rotate, so a removed channel's id is not reused at once).
  // Tells nobody. invalid_argument (name, kind), already_exists, limit_exceeded.
  [[nodiscard]] Result<Channel*> add(Endpoint* owner, const std::string& user,
                                     const std::string& short_name, ChannelKind kind,
                                     const std::string& mime);
  // Takes `ch` out of the table, its subscribers' and its owner's lists. Tells nobody.
  std::unique_ptr<Channel> erase(Channel& ch);

  // Subscribes `e` to the streaming or blob channel `id` (ok when it is already); the owner of a
  // streaming channel hears of the first subscriber. not_found, invalid_argument (a service).
  [[nodiscard]] Result<void> subscribe(Endpoint& e, uint16_t id);
  // Moves the subscriber `e` of `id` out of the relay (its physical path works) or back into it.
  // Nothing when `e` is not subscribed.
  void setPhysical(Endpoint& e, uint16_t id, bool physical);
  // ok when `e` was not subscribed; the owner (unless it is `e`) hears of the last one leaving.
  [[nodiscard]] Result<void> unsubscribe(Endpoint& e, uint16_t id);
  // Routes `payload` from the owner `e` to every subscriber of `id` (Endpoint::onData: a frame
  // queued per socket subscriber, a view for in-process ones; no copy here). Subscribers may
  // subscribe, unsubscribe or remove the channel from inside onData. not_found,
  // permission_denied (not the owner), invalid_argument (not streaming).
  [[nodiscard]] Result<void> publish(Endpoint& e, uint16_t id, std::string_view payload);
  // publish(), keeping `payload` as the message retained under `key` (replacing the one kept,
  // and the newest now): subscribe() hands every retained message to each new subscriber, oldest
  // first, before anything else. limit_exceeded past kMaxRetainedKeys or kMaxRetainedBytes
  // (nothing kept, nothing sent), invalid_argument for an empty or longer key than
  // kMaxRetainedKeyBytes; publish's errors.
  [[nodiscard]] Result<void> publishRetained(Endpoint& e, uint16_t id, std::string_view key,
                                             std::string_view payload);
  // Forgets the message retained under `key`, or all of them (nullopt). not_found: no such key,
  // or not a streaming channel `e` owns.
  [[nodiscard]] Result<void> clearRetained(Endpoint& e, uint16_t id,
                                           std::optional<std::string_view> key);

  // Polling (POLL_REGISTER, POLL_FETCH, POLL_DEREGISTER) of a streaming channel. not_found (no
  // such streaming channel; deregister: not registered by `endpoint`).
  [[nodiscard]] Result<void> pollRegister(uint32_t endpoint, uint16_t id);
  [[nodiscard]] Result<std::pair<uint64_t, std::string_view>> pollFetch(uint16_t id);
  [[nodiscard]] Result<void> pollDeregister(uint32_t endpoint, uint16_t id);
  // A leaving endpoint's registrations.
  void unpollAll(uint32_t endpoint);

  // In-process subscriptions by name that wait for (or follow) their channel.
  void want(const std::string& name, uint32_t endpoint);
  void unwant(const std::string& name, uint32_t endpoint);
  void unwantAll(uint32_t endpoint);
  [[nodiscard]] std::vector<uint32_t> wanting(const std::string& name) const;

 private:
  void compact(Channel& ch);

  std::vector<std::unique_ptr<Channel>> channels_;  // by id; [0] unused
  std::unordered_map<std::string, uint16_t> by_name_;
  uint16_t next_hint_ = 1;
  size_t count_ = 0;
  std::mt19937_64 rng_;
  std::multimap<std::string, uint32_t> wanted_;
  int dispatching_ = 0;  // > 0 while publish iterates subscribers: removals leave tombstones
  std::vector<uint16_t> tombstoned_;  // channels whose subscriber lists hold tombstones
  Nanos (*clock_)();
};

}  // namespace skr::flow
