// The hub's statistics as data (docs/observability.md): once a second while someone listens, per
// channel its messages, bytes and drops per second and its subscribers, per flow its traffic,
// output queue and pending requests, published as JSON on the streaming channel `hub.stats` and
// answered on request by the service `hub.inspect` (command "stats"). Every satellite, page and
// tool (flowctl top, hz, info, graph) reads the same figures. Main loop thread only.
#pragma once

#include <skrobot/core/clock.h>
#include <skrobot/core/loop.h>
#include <skrobot/flow/server.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace skr::flow {

// Counters since each channel or flow began, read at one instant (FlowServer::snapshot()).
struct ChannelCounters {
  uint16_t id = 0;
  std::string name;
  ChannelKind kind = ChannelKind::streaming;
  std::string mime;
  uint32_t owner_flow = 0;  // 0: nobody connected (a blob channel kept for its owner)
  std::vector<uint32_t> subscriber_flows;
  std::vector<std::string> subscriber_paths;  // one per subscriber_flows: relay, direct or shm
  uint64_t messages = 0, bytes = 0, dropped = 0;
  uint32_t pending_requests = 0;
};
struct FlowCounters {
  uint32_t id = 0;
  std::string user, client, kind;  // kind: satellite, sync, module, link, replica
  uint64_t messages_in = 0, bytes_in = 0, messages_out = 0, bytes_out = 0, dropped = 0;
  uint64_t path_messages = 0, path_bytes = 0;  // of those out: what came on its paths
  uint64_t queued_bytes = 0;
  uint32_t pending_requests = 0;
};
struct HubSnapshot {
  Nanos at = 0;  // monotonic
  uint64_t queue_limit =
      0;  // server.subscriber_queue_bytes: a satellite's queue_fill is against it
  std::vector<ChannelCounters> channels;
  std::vector<FlowCounters> flows;
};

// The statistics of the interval between two snapshots, as hub.stats carries them: a map of
//   hub, time_ms (wall clock), interval_s,
//   channels: [{name, kind, mime, owner, owner_flow, subscribers, subscriber_flows,
//               subscriber_paths ("relay", "direct" or "shm", one per subscriber_flows),
//               messages, bytes, dropped, hz, bytes_per_s, dropped_per_s, pending_requests}],
//   flows: [{id, name ("<user>/<client>"), user, client, kind, messages_in, bytes_in,
//            messages_out, bytes_out, dropped, in_hz, out_hz, in_bytes_per_s, out_bytes_per_s,
//            dropped_per_s, queued_bytes, queue_fill, pending_requests}]
// Rates of a channel or flow that `before` does not have count from zero.
[[nodiscard]] Variant statsBetween(const HubSnapshot& before, const HubSnapshot& now,
                                   const std::string& hub_name);

class HubStats {
 public:
  // Creates hub.stats and hub.inspect as the in-process client "hub" ("statistics") and starts
  // the one-second tick. Failures (a replica already named hub.stats, say) are logged.
  HubStats(Loop& loop, FlowServer& server);
  ~HubStats();
  HubStats(const HubStats&) = delete;
  HubStats& operator=(const HubStats&) = delete;
  HubStats(HubStats&&) = delete;
  HubStats& operator=(HubStats&&) = delete;

  // The statistics last computed (an empty map before any): each second while hub.stats has a
  // subscriber, and at each hub.inspect request while it has none (then over the time since the
  // previous request).
  [[nodiscard]] const Variant& current() const noexcept { return current_; }

 private:
  void compute();
  void everySecond();

  Loop& loop_;
  FlowServer& server_;
  std::unique_ptr<LocalClient> client_;
  uint16_t stats_chan_ = 0, inspect_chan_ = 0;
  HubSnapshot last_;
  Variant current_ = Variant::Map{};
  bool watched_ = false;  // hub.stats has a subscriber
  TickId tick_{};
};

}  // namespace skr::flow
