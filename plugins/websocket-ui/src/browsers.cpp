// SPDX-License-Identifier: Apache-2.0
#include "browsers.h"

#include <utility>

namespace skr::wsui {

std::optional<std::string> Browsers::startOwn(const WsServerOptions& options,
                                              WsServerEvents events) {
  return server_.start(options, std::move(events));
}

void Browsers::startOnHub(skr::plugin::Host& host, const WsServerOptions& options,
                          WsServerEvents events) {
  skr::plugin::WebSocketEndpoint::Events ev;
  ev.opened = [this, opened = events.opened](skr_ws_conn conn, const std::string& peer) {
    conns_.insert(conn);
    ++hub_stats_.accepted;
    if (opened) opened(conn, peer);
  };
  ev.closed = [this, closed = events.closed](skr_ws_conn conn, const std::string& why) {
    conns_.erase(conn);
    if (closed) closed(conn, why);
  };
  ev.message = [this, message = events.message, log = events.log,
                prefix = options.log_tag + "-REFUSED " + options.peer_noun + " "](
                   skr_ws_conn conn, bool text, std::string_view data) {
    if (!message) return;
    int code = 1008;
    if (auto refusal = message(conn, !text, std::string(data), code)) {
      ++hub_stats_.refused;
      // As the own server logs it (<log_tag>-REFUSED).
      if (log) log(2, prefix + std::to_string(conn) + ": " + *refusal);
      close(conn, code, *refusal);
    }
  };
  endpoint_ = skr::plugin::WebSocketEndpoint(host, options.ws_path, options.subprotocol,
                                             options.max_message_bytes, options.max_queued_bytes,
                                             std::move(ev));
}

void Browsers::stop() noexcept {
  server_.stop();
  endpoint_.reset();
  conns_.clear();
}

void Browsers::send(std::uint64_t conn, bool binary, std::string data, bool droppable) {
  if (!endpoint_.active()) {
    server_.send(conn, binary, std::move(data), droppable);
    return;
  }
  if (conn != 0) {
    endpoint_.send(conn, !binary, data, droppable);
    return;
  }
  for (const auto c : conns_) endpoint_.send(c, !binary, data, droppable);
}

void Browsers::close(std::uint64_t conn, int code, const std::string& reason) {
  if (!endpoint_.active()) {
    server_.close(conn, code, reason);
    return;
  }
  endpoint_.close(conn, static_cast<std::uint16_t>(code), reason);
}

WsServerStats Browsers::stats() const {
  if (!endpoint_.active()) return server_.stats();
  WsServerStats s = hub_stats_;
  s.connections = conns_.size();
  return s;
}

}  // namespace skr::wsui
