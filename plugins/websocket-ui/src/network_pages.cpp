// SPDX-License-Identifier: Apache-2.0
#include "network_pages.h"

#include <skrobot/support/json.hpp>

#include <memory>
#include <optional>
#include <utility>

namespace skr::wsui {
namespace {

using skr::support::jsonQuote;

// Compares without stopping at the first difference, so that the time taken says nothing about
// how much of a guessed token was right.
bool sameToken(const std::string& a, const std::string& b) {
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  for (std::size_t i = 0; i < a.size(); ++i) {
    diff |= static_cast<unsigned char>(a[i] ^ (i < b.size() ? b[i] : 0));
  }
  return diff == 0;
}

}  // namespace

NetworkPages::NetworkPages(skr::plugin::Host& host, WsServer& server, NetworkOptions options)
    : host_(host), server_(server), options_(std::move(options)) {}

void NetworkPages::join(std::uint64_t conn) {
  if (has(conn)) return;
  pages_[conn];
  if (!stats_.active()) {
    // The hub computes its statistics only while hub.stats has a subscriber: one for all pages.
    try {
      stats_ =
          skr::plugin::Subscription(host_, "hub.stats", [this](std::string_view p) { onStats(p); });
    } catch (const skr::plugin::Failure& e) {
      host_.log.warn("WSUI-NETWORK", "cannot follow hub.stats: ", e.what());
    }
  }
  std::string msg = R"({"type":"network_hello","hub":)" + jsonQuote(skr::plugin::hubName(host_)) +
                    R"(,"edit":)" + (options_.token.empty() ? "false" : "true") +
                    R"(,"preview_hz":)" + std::to_string(options_.preview_hz) + "}";
  server_.send(conn, false, std::move(msg), false);
}

void NetworkPages::leave(std::uint64_t conn) {
  auto it = pages_.find(conn);
  if (it == pages_.end()) return;
  dropPreviews(conn, it->second);
  pages_.erase(it);
  if (pages_.empty()) stats_.reset();
}

void NetworkPages::stop() {
  pages_.clear();
  previewed_.clear();
  stats_.reset();
}

void NetworkPages::onStats(std::string_view payload) {
  std::string msg;
  msg.reserve(payload.size() + 24);
  msg.append(R"({"type":"stats","data":)").append(payload).append("}");
  for (const auto& [conn, page] : pages_) server_.send(conn, false, msg);
}

void NetworkPages::dropPreviews(std::uint64_t conn, Page& page) {
  for (const auto& name : page.previews) {
    auto it = previewed_.find(name);
    if (it == previewed_.end()) continue;
    it->second.pages.erase(conn);
    if (it->second.pages.empty()) previewed_.erase(it);  // unsubscribes
  }
  page.previews.clear();
}

void NetworkPages::preview(std::uint64_t conn, const std::vector<std::string>& channels) {
  auto it = pages_.find(conn);
  if (it == pages_.end()) return;
  dropPreviews(conn, it->second);
  for (const auto& name : channels) {
    auto [p, added] = previewed_.try_emplace(name);
    if (added) {
      try {
        p->second.sub = skr::plugin::Subscription(
            host_, name, [this, name](std::string_view m) { onPreview(name, m); });
      } catch (const skr::plugin::Failure& e) {
        previewed_.erase(p);
        notice(conn, "cannot preview " + name + ": " + e.what());
        continue;
      }
    }
    p->second.pages.insert(conn);
    it->second.previews.push_back(name);
  }
}

void NetworkPages::onPreview(const std::string& channel, std::string_view payload) {
  auto it = previewed_.find(channel);
  if (it == previewed_.end()) return;
  Previewed& p = it->second;
  const std::int64_t now = nowMs();
  if (now - p.sent_ms >= static_cast<std::int64_t>(1000 / options_.preview_hz)) {
    p.sent_ms = now;
    p.holding = false;
    sendPreview(channel, p, payload);
  } else {
    p.held.assign(payload);  // the newest wins
    p.holding = true;
  }
}

void NetworkPages::flush(std::int64_t now_ms) {
  const auto period = static_cast<std::int64_t>(1000 / options_.preview_hz);
  for (auto& [name, p] : previewed_) {
    if (!p.holding || now_ms - p.sent_ms < period) continue;
    p.sent_ms = now_ms;
    p.holding = false;
    sendPreview(name, p, p.held);
  }
}

void NetworkPages::sendPreview(const std::string& channel, Previewed& p, std::string_view payload) {
  if (payload.size() > options_.max_preview_bytes) {
    for (auto conn : p.pages) {
      notice(conn, channel + ": a message of " + std::to_string(payload.size()) +
                       " bytes, over the preview limit");
    }
    return;
  }
  std::string msg;
  msg.reserve(2 + channel.size() + payload.size());
  msg.push_back(static_cast<char>(channel.size() & 0xFF));
  msg.push_back(static_cast<char>(channel.size() >> 8));
  msg.append(channel).append(payload);
  for (auto conn : p.pages) server_.send(conn, true, msg);
}

void NetworkPages::watchDatabase(std::uint64_t conn, const std::string& db) {
  auto it = pages_.find(conn);
  if (it == pages_.end()) return;
  Page& page = it->second;
  page.watch.reset();
  page.db = db;
  if (db.empty()) return;
  // The watch calls back with every pair while it is made: gathered into one message.
  auto initial = std::make_shared<std::optional<std::string>>(std::string());
  auto on_change = [this, conn, db, initial](const std::string& key,
                                             const std::optional<std::string>& value) {
    if (*initial) {
      std::string& pairs = **initial;
      if (value) pairs.append(pairs.empty() ? "" : ",").append(jsonQuote(key) + ":" + *value);
      return;
    }
    server_.send(conn, false,
                 R"({"type":"db","db":)" + jsonQuote(db) + R"(,"key":)" + jsonQuote(key) +
                     R"(,"value":)" + (value ? *value : std::string("null")) + "}");
  };
  try {
    page.watch = skr::plugin::DatabaseWatch(host_, db, on_change);
  } catch (const skr::plugin::Failure& e) {
    server_.send(
        conn, false,
        R"({"type":"db","db":)" + jsonQuote(db) + R"(,"error":)" + jsonQuote(e.what()) + "}");
    return;
  }
  server_.send(conn, false,
               R"({"type":"db","db":)" + jsonQuote(db) + R"(,"pairs":{)" + **initial + "}}");
  initial->reset();
}

void NetworkPages::setVariable(std::uint64_t conn, const SetVariable& r) {
  if (!has(conn)) return;
  auto answer = [&](bool ok, const std::string& error) {
    std::string msg = R"({"type":"set","db":)" + jsonQuote(r.db) + R"(,"key":)" + jsonQuote(r.key) +
                      R"(,"ok":)" + (ok ? "true" : "false");
    if (!ok) msg += R"(,"error":)" + jsonQuote(error);
    server_.send(conn, false, msg + "}", false);
  };
  if (options_.token.empty()) {
    return answer(false, "editing is off: websocket-ui's network_token is not set");
  }
  if (!sameToken(r.token, options_.token)) {
    host_.log.warn("WSUI-REFUSED", "browser ", conn, ": set ", r.db, " ", r.key, ": wrong token");
    return answer(false, "wrong token");
  }
  if (!skr::plugin::dbSet(host_, r.db, r.key, r.value_json)) {
    return answer(false, "the hub refused it (see its log): websocket-ui's account may not write " +
                             r.db + ", or the value is not valid there");
  }
  host_.log.info("WSUI-NETWORK", "browser ", conn, " set ", r.db, " ", r.key);
  answer(true, "");
}

void NetworkPages::notice(std::uint64_t conn, const std::string& text) {
  server_.send(conn, false, R"({"type":"notice","text":)" + jsonQuote(text) + "}");
}

}  // namespace skr::wsui
