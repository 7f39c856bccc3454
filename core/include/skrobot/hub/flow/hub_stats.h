// SPDX-License-Identifier: Apache-2.0
// The hub's statistics as data (docs/observability.md): per channel its messages, bytes and
// drops per second over the last second and the last ten, and its subscribers; per flow its
// traffic, output queue and pending requests; the main loop's late wake-ups. Published as JSON
// on the streaming channel `hub.stats` each second while someone listens, and answered on
// request by the service `hub.inspect` (command "stats"). The rates come from windows that the
// hub's one-second tick closes (FlowServer::sampleRates), so every satellite, page and tool
// (flowctl top, info, graph) reads the same figures, whoever asked before. Main loop thread only.
#pragma once

#include <skrobot/hub/flow/server.h>
#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/loop.h>

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace skr::flow {

// Per second over one window, rounded to 0.01 (0 for a window that covers no time yet).
struct ChannelRates {
  double hz = 0, bytes_per_s = 0, dropped_per_s = 0;
};
struct FlowRates {
  double in_hz = 0, out_hz = 0, in_bytes_per_s = 0, out_bytes_per_s = 0, dropped_per_s = 0,
         path_hz = 0;
};

// Counters since each channel or flow began, read at one instant (FlowServer::snapshot()), and
// its rates over the windows that the last sampleRates() closed: the last second and the last
// ten, or the time since it began when that is shorter (age_s, up to the last sample).
struct ChannelCounters {
  uint16_t id = 0;
  std::string name;
  ChannelKind kind = ChannelKind::streaming;
  std::string mime;
  uint32_t owner_flow = 0;  // 0: nobody connected (a blob channel kept for its owner)
  std::vector<uint32_t> subscriber_flows;
  std::vector<std::string> subscriber_paths;  // one per subscriber_flows: relay, direct or shm
  // One per subscriber_flows: its SUBSCRIBE_RATE cap (0: none) and the frames the cap skipped.
  std::vector<uint16_t> subscriber_max_hz;
  std::vector<uint64_t> subscriber_skipped;
  uint64_t messages = 0, bytes = 0, dropped = 0;
  uint32_t pending_requests = 0;
  ChannelRates last_1s, last_10s;
  double age_s = 0;
};
struct FlowCounters {
  uint32_t id = 0;
  std::string user, client, kind;  // kind: satellite, sync, module, link, replica
  uint64_t messages_in = 0, bytes_in = 0, messages_out = 0, bytes_out = 0, dropped = 0;
  uint64_t path_messages = 0, path_bytes = 0;  // of those out: what came on its paths
  uint64_t queued_bytes = 0;
  uint64_t queue_bytes = 0;  // its queue's size (server.subscriber_queue_bytes or SUBSCRIBE_QUEUE)
  uint32_t pending_requests = 0;
  FlowRates last_1s, last_10s;
  double age_s = 0;
};
// A serial port of server.serial: its line's counters since it was last opened.
struct SerialCounters {
  std::string device;
  bool open = false, in_session = false;
  transport::SerialStats line;
};
// server.udp's port: its counters since the hub started, and the sessions open now.
struct UdpCounters {
  uint16_t port = 0;
  uint64_t open_sessions = 0;
  transport::UdpStats stats;
};
// server.web's port: its counters since the hub started.
struct WebCounters {
  uint16_t port = 0;
  uint64_t requests = 0;           // request heads read
  uint64_t files = 0;              // files answered (200)
  uint64_t not_found = 0;          // 404
  uint64_t upgrades = 0;           // WebSockets handed to the FlowServer
  uint64_t endpoint_upgrades = 0;  // WebSockets handed to modules' endpoints (plugin ABI 1.8)
  uint64_t tokens = 0;             // page tokens issued
  uint64_t refused_host = 0;       // a Host not accepted (403, FLOW-WS-REFUSED)
  uint64_t refused_origin = 0;     // an Origin not allowed on /flow (403, FLOW-WS-REFUSED)
  uint64_t refused = 0;            // other refusals: bad heads, upgrades, methods, timeouts
};
struct HubSnapshot {
  Nanos at = 0;  // monotonic
  // What the windows cover (seconds between the last samples; less on a hub younger than them)
  // and the wall clock (ms since 1970) of the last sample, where they end.
  double interval_s = 0, interval_10s_s = 0;
  int64_t rates_until_ms = 0;
  std::vector<ChannelCounters> channels;
  std::vector<FlowCounters> flows;
  std::vector<SerialCounters> serial;
  std::optional<UdpCounters> udp;  // set when server.udp is
  std::optional<WebCounters> web;  // set when server.web is
};

// A snapshot as hub.stats carries it: a map of
//   hub, time_ms (wall clock), interval_s, interval_10s_s, rates_until_ms,
//   channels: [{name, kind, mime, owner, owner_flow, subscribers, subscriber_flows,
//               subscriber_paths ("relay", "direct" or "shm", one per subscriber_flows),
//               subscriber_max_hz, subscriber_skipped (SUBSCRIBE_RATE's cap, 0: none, and the
//               frames it skipped; one per subscriber_flows),
//               messages, bytes, dropped, hz, bytes_per_s, dropped_per_s, hz_10s,
//               bytes_per_s_10s, dropped_per_s_10s, age_s, pending_requests}],
//   flows: [{id, name ("<user>/<client>"), user, client, kind, messages_in, bytes_in,
//            messages_out, bytes_out, dropped, in_hz, out_hz, in_bytes_per_s, out_bytes_per_s,
//            dropped_per_s, path_messages, path_bytes, path_hz, the same rates with "_10s",
//            age_s, queued_bytes, queue_fill, pending_requests}],
//   serial: [{device, open, in_session, bytes_in, bytes_out, frames_in, frames_out, bad_check,
//             bad_framing, bad_version, too_long, overrun, dropped_out, resyncs, sessions}]
//   udp (when server.udp is set): {port, open_sessions, datagrams_in, datagrams_out, bytes_in,
//        bytes_out, cookies_sent, short_hello, bad_cookie, bad_mac, unknown_session, malformed,
//        replayed, lost, reordered, too_large, send_failed, overrun, sessions, timeouts}
//   web (when server.web is set): {port, requests, files, not_found, upgrades, tokens,
//        refused_host, refused_origin, refused}
// (HubStats adds "loop", the main loop's figures, and the sections of addSection: "satellites",
// the supervisor's list, skrobot/hub/supervisor.h.)
[[nodiscard]] Variant statsOf(const HubSnapshot& snapshot, const std::string& hub_name);

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

  // The statistics now: totals as they stand, rates as of the last one-second tick (the same
  // for every reader until the next), and the loop's figures.
  [[nodiscard]] Variant current() const;
  // A section another part of the hub adds to the statistics under `key` (the supervisor's
  // "satellites"), read at each publication. Remove it before that part goes.
  void addSection(const std::string& key, std::function<Variant()> read);
  void removeSection(const std::string& key) noexcept;

 private:
  void everySecond();

  Loop& loop_;
  FlowServer& server_;
  std::unique_ptr<LocalClient> client_;
  uint16_t stats_chan_ = 0, inspect_chan_ = 0;
  bool watched_ = false;  // hub.stats has a subscriber
  TickId tick_{};
  std::map<std::string, std::function<Variant()>> sections_;
};

}  // namespace skr::flow
