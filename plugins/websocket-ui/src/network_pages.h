// SPDX-License-Identifier: Apache-2.0
// The /network page's side of websocket-ui (docs/observability.md): the hub's statistics, channel
// previews and database views, for the browsers that opened that page. Loop thread only.
//
// To a page, as text: {"type": "network_hello", "hub", "edit", "preview_hz"}, {"type": "stats",
// "data": <hub.stats>}, {"type": "db", "db", "pairs": {...}} then {"type": "db", "db", "key",
// "value" (null: removed)}, {"type": "set", "db", "key", "ok", "error"}, {"type": "notice",
// "text"}. Previews as binary: u16 (little-endian) name length, the channel's name, its message as
// it came.
#pragma once

#include <skrobot/web/ws_server.h>
#include "browser_protocol.h"

#include <skrobot/plugin_channels.hpp>
#include <skrobot/plugin_watch.hpp>

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <string_view>

namespace skr::wsui {

struct NetworkOptions {
  double preview_hz = 5;                     // previews per channel per second, at most
  std::size_t max_preview_bytes = 8u << 20;  // larger messages are announced, not sent
  std::string token;                         // needed to set variables; empty: editing is off
};

class NetworkPages {
 public:
  NetworkPages(skr::plugin::Host& host, WsServer& server, NetworkOptions options);

  [[nodiscard]] bool has(std::uint64_t conn) const { return pages_.count(conn) != 0; }
  void join(std::uint64_t conn);
  void leave(std::uint64_t conn);
  void preview(std::uint64_t conn, const std::vector<std::string>& channels);
  void watchDatabase(std::uint64_t conn, const std::string& db);
  void setVariable(std::uint64_t conn, const SetVariable& request);
  // Sends the previews held back by the rate limit (the module's fast tick).
  void flush(std::int64_t now_ms);
  void stop();

 private:
  struct Previewed {
    skr::plugin::Subscription sub;
    std::set<std::uint64_t> pages;
    std::string held;  // the newest message not sent yet (the rate limit)
    bool holding = false;
    std::int64_t sent_ms = -1000000;
  };
  struct Page {
    std::vector<std::string> previews;
    std::string db;
    skr::plugin::DatabaseWatch watch;
  };

  void onStats(std::string_view payload);
  void onPreview(const std::string& channel, std::string_view payload);
  void sendPreview(const std::string& channel, Previewed& p, std::string_view payload);
  void dropPreviews(std::uint64_t conn, Page& page);
  void notice(std::uint64_t conn, const std::string& text);
  std::int64_t nowMs() const { return host_.nowNs() / 1000000; }

  skr::plugin::Host& host_;
  WsServer& server_;
  NetworkOptions options_;
  std::map<std::uint64_t, Page> pages_;
  std::map<std::string, Previewed> previewed_;
  skr::plugin::Subscription stats_;  // hub.stats, while a page is open
};

}  // namespace skr::wsui
