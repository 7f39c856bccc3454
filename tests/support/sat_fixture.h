// SPDX-License-Identifier: Apache-2.0
// Satellites on loop threads of their own, recording their signals, against a real hub.
#pragma once

#include <skrobot/runtime/flow/udp.h>
#include <skrobot/satellite.h>
#include <skrobot/satellite/sync_client.h>

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <algorithm>
#include <memory>
#include <mutex>
#include <optional>
#include <regex>
#include <string>
#include <type_traits>
#include <vector>

#include "hub_process.h"

namespace skr::sat::test {

// What a satellite's signals said, as lines: "connected", "ready:guest.x", "data:guest.x:...".
class Events {
 public:
  void add(std::string line) {
    std::lock_guard lock(m_);
    lines_.push_back(std::move(line));
  }
  [[nodiscard]] size_t count(const std::string& prefix) const {
    std::lock_guard lock(m_);
    return static_cast<size_t>(std::count_if(lines_.begin(), lines_.end(), [&](const auto& l) {
      return l.compare(0, prefix.size(), prefix) == 0;
    }));
  }
  [[nodiscard]] std::vector<std::string> with(const std::string& prefix) const {
    std::lock_guard lock(m_);
    std::vector<std::string> out;
    for (const auto& l : lines_) {
      if (l.compare(0, prefix.size(), prefix) == 0) out.push_back(l.substr(prefix.size()));
    }
    return out;
  }
  void clear() {
    std::lock_guard lock(m_);
    lines_.clear();
  }
  [[nodiscard]] std::string dump() const {
    std::lock_guard lock(m_);
    std::string out;
    for (const auto& l : lines_) out += l + "\n";
    return out;
  }

 private:
  mutable std::mutex m_;
  std::vector<std::string> lines_;
};

// A Satellite on its own LoopThread. on(f) runs f(satellite) on that thread and returns its
// result. Its signals are recorded in `events`.
class SatOnThread {
 public:
  explicit SatOnThread(SatelliteOptions options) : thread_(LoopOptions{.name = "sat"}) {
    thread_.start();
    thread_.loop().invoke([&] {
      sat_ = std::make_unique<Satellite>(thread_.loop(), std::move(options));
      record();
    });
  }
  ~SatOnThread() {
    thread_.loop().invoke([&] { sat_.reset(); });
    thread_.stop();
  }
  SatOnThread(const SatOnThread&) = delete;
  SatOnThread& operator=(const SatOnThread&) = delete;
  SatOnThread(SatOnThread&&) = delete;
  SatOnThread& operator=(SatOnThread&&) = delete;

  template <class F>
  auto on(F&& f) {
    using R = decltype(f(std::declval<Satellite&>()));
    if constexpr (std::is_void_v<R>) {
      thread_.loop().invoke([&] { f(*sat_); });
    } else {
      std::optional<R> r;
      thread_.loop().invoke([&] { r.emplace(f(*sat_)); });
      return std::move(*r);
    }
  }
  void start() {
    on([](Satellite& s) { s.start(); });
  }
  [[nodiscard]] bool connected() {
    return on([](Satellite& s) { return s.isConnected(); });
  }

  Events events;

 private:
  void record() {
    Satellite& s = *sat_;
    const auto name = [&s](uint16_t id) {
      const ChannelInfo* c = s.channel(id);
      return c != nullptr ? c->name : "#" + std::to_string(id);
    };
    s.connected.connect(&s, [this] { events.add("connected"); });
    s.disconnected.connect(&s,
                           [this](const std::string& why) { events.add("disconnected:" + why); });
    s.channelReady.connect(&s, [this](const ChannelInfo& c) { events.add("ready:" + c.name); });
    s.subscribed.connect(&s, [this](const ChannelInfo& c) { events.add("subscribed:" + c.name); });
    s.channelAdded.connect(&s, [this](const ChannelInfo& c) { events.add("added:" + c.name); });
    s.channelRemoved.connect(&s, [this](const ChannelInfo& c) { events.add("removed:" + c.name); });
    s.channelChanged.connect(&s, [this](const ChannelInfo& c) {
      events.add("changed:" + c.name + ":" + flow::variantToJsonText(c.props));
    });
    s.startPublish.connect(&s, [this, name](uint16_t id) { events.add("start:" + name(id)); });
    s.stopPublish.connect(&s, [this, name](uint16_t id) { events.add("stop:" + name(id)); });
    s.data.connect(&s, [this, name](uint16_t id, const std::string& payload) {
      events.add("data:" + name(id) + ":" + payload);
    });
    s.serviceResponse.connect(&s, [this](const Response& r) {
      events.add("response:" + std::to_string(r.tag) + ":" + flow::variantToJsonText(r.value));
    });
    s.error.connect(&s, [this](const FlowError& e) { events.add("error:" + e.message); });
    s.databasesSynced.connect(
        &s, [this](uint32_t tag) { events.add("synced:" + std::to_string(tag)); });
    s.blobChanged.connect(&s, [this, name](const BlobChange& b) {
      events.add("blob:" + name(b.chan_id) + ":" + b.path + ":" + std::to_string(b.size));
    });
    s.syncPulse.connect(&s, [this, name](const SyncPulse& p) {
      events.add("pulse:" + name(p.chan_id) + ":" + std::to_string(p.seq) + ":" +
                 std::to_string(p.dropped));
    });
  }

  LoopThread thread_;
  std::unique_ptr<Satellite> sat_;
};

class SatTest : public ::testing::Test {
 protected:
  void startHub(const std::string& tcp_user = {}) {
    if (!hub_) hub_ = std::make_unique<HubProcess>(SKROBOT_BIN, dir_.path(), tcp_user);
    ASSERT_TRUE(hub_->start()) << hub_->log();
  }
  [[nodiscard]] std::string address() const {
    return "local:" + (dir_.path() / "hub.sock").string();
  }
  [[nodiscard]] SatelliteOptions options(const std::string& name) const {
    SatelliteOptions o;
    o.connection.address = Address::parse(address()).value();
    o.connection.client_name = name;
    return o;
  }
  // A satellite, started, and connected when `wait` (the hub must be running).
  std::unique_ptr<SatOnThread> satellite(const std::string& name, bool wait = true) {
    auto s = std::make_unique<SatOnThread>(options(name));
    s->start();
    if (wait) {
      EXPECT_TRUE(eventually([&] { return s->connected(); })) << hubLog();
    }
    return s;
  }
  // A hub with server.udp on 127.0.0.1 (a free port) besides its socket, and the account alice
  // (TCP on too) with the UDP key that `skrobot user key` made: udpAddress() and udp_key_hex_.
  void startUdpHub(uint32_t session_timeout_ms = 10000) {
    udp_port_ = freeUdpPort();
    ASSERT_NE(udp_port_, 0);
    hub_ = std::make_unique<HubProcess>(
        SKROBOT_BIN, dir_.path(), "alice",
        R"(, "udp": {"address": "127.0.0.1", "port": )" + std::to_string(udp_port_) +
            R"(, "session_timeout_ms": )" + std::to_string(session_timeout_ms) + "}");
    const fs::path log = dir_.path() / "user-key.log";
    Child key(
        {SKROBOT_BIN, "user", "key", "alice", "--users", (dir_.path() / "users.json").string()}, {},
        log);
    key.wait();
    std::ifstream in(log);
    std::string line;
    while (std::getline(in, line)) {
      if (std::regex_match(line, std::regex("[0-9a-f]{32}"))) udp_key_hex_ = line;
    }
    ASSERT_EQ(udp_key_hex_.size(), 32u) << "skrobot user key printed no key";
    startHub();
  }
  [[nodiscard]] std::string udpAddress() const {
    return "udp:127.0.0.1:" + std::to_string(udp_port_);
  }
  // Satellite options for alice over udp: with her key.
  [[nodiscard]] SatelliteOptions udpOptions(const std::string& name) const {
    SatelliteOptions o = options(name);
    o.connection.address = Address::parse(udpAddress()).value();
    o.connection.user = "alice";
    o.connection.password.clear();  // a UDP session's LOGIN needs none
    o.connection.udp_key = flow::transport::parseUdpKey(udp_key_hex_).value();
    return o;
  }
  static uint16_t freeUdpPort() {
    const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    uint16_t port = 0;
    if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0) {
      port = ntohs(a.sin_port);
    }
    ::close(fd);
    return port;
  }

  [[nodiscard]] std::string hubLog() const { return hub_ ? hub_->log() : ""; }
  // The hub's statistics (hub.inspect "stats", docs/observability.md); empty when it does not
  // answer.
  [[nodiscard]] std::optional<flow::Variant> hubStats() const {
    auto sync = SyncClient::connect(options("stats").connection);
    if (!sync) return std::nullopt;
    auto v = sync->call("hub.inspect", "stats", flow::Variant());
    if (!v || v->find("channels") == nullptr || v->find("flows") == nullptr) return std::nullopt;
    return std::move(v).value();
  }

  TempDir dir_;
  std::unique_ptr<HubProcess> hub_;
  uint16_t udp_port_ = 0;
  std::string udp_key_hex_;
};

}  // namespace skr::sat::test
