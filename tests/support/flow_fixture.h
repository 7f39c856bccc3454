// SPDX-License-Identifier: Apache-2.0
// A hub's FlowServer on its own loop thread, and clients that talk to it over real sockets.
#pragma once

#include "eventually.h"
#include "temp_dir.h"
#include "test_client.h"

#include <skrobot/hub/flow/accounts.h>
#include <skrobot/hub/flow/hub_stats.h>
#include <skrobot/hub/flow/server.h>
#include <skrobot/runtime/loop.h>

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>

namespace skr::test {

class FlowFixture : public ::testing::Test {
 protected:
  flow::ServerOptions defaults() {
    flow::ServerOptions o;
    o.app_name = "skrobot-test-" + std::to_string(::getpid());
    o.unix_path = (dir_.path() / "hub.sock").string();
    o.data_dir = dir_.path() / "data";
    o.dev_account = std::make_pair(std::string("guest"), std::string("password"));
    return o;
  }

  Result<void> startHub(flow::ServerOptions o) {
    opts_ = o;
    hub_ = std::make_unique<LoopThread>(LoopOptions{});
    hub_->start();
    Result<void> r;
    hub_->loop().invoke([&] {
      server_ = std::make_unique<flow::FlowServer>(hub_->loop(), o);
      r = server_->start();
    });
    return r;
  }
  void startHub() { ASSERT_TRUE(startHub(defaults())); }

  // A hub for boards over UDP: the accounts alice (password "right") and board ("board-secret",
  // UDP key `key`), and a UDP port on 127.0.0.1 (0: any free one). A restart passes the port it
  // had and keeps the users file. Returns the port (0 when the hub did not start).
  // The id of the channel named `name` in the hub's table (0: none yet).
  uint16_t channelId(const std::string& name) {
    flow::HubSnapshot s;
    onHub([&] { s = server_->snapshot(); });
    for (const auto& c : s.channels) {
      if (c.name == name) return c.id;
    }
    return 0;
  }

  uint16_t startUdpBoardHub(const flow::UdpKey& key, uint16_t port = 0) {
    auto o = defaults();
    o.users_file = dir_.path() / "users.json";
    if (port == 0) {
      auto users = flow::UsersFile::load(o.users_file);
      EXPECT_TRUE(users);
      if (!users || !users->add("alice", "right") || !users->add("board", "board-secret") ||
          !users->setUdpKey("board", key) || !users->save()) {
        ADD_FAILURE() << "cannot write " << o.users_file;
        return 0;
      }
    }
    flow::transport::UdpOptions udp;
    udp.address = "127.0.0.1";
    udp.port = port;
    o.udp = udp;
    if (auto r = startHub(o); !r) {
      ADD_FAILURE() << r.error().message;
      return 0;
    }
    uint16_t bound = 0;
    onHub([&] { bound = server_->udpPort(); });
    return bound;
  }

  void stopHub() {
    if (!hub_) return;
    hub_->loop().invoke([&] { server_.reset(); });
    hub_.reset();
  }
  void TearDown() override { stopHub(); }

  template <class F>
  void onHub(F&& f) {
    hub_->loop().invoke(std::forward<F>(f));
  }
  flow::ServerStats stats() {
    flow::ServerStats s;
    onHub([&] { s = server_->stats(); });
    return s;
  }

  TestClient connect() {
    auto c = TestClient::connectUnix(opts_.unix_path);
    EXPECT_TRUE(c) << c.error().message;
    return c ? std::move(c).value() : TestClient();
  }
  TestClient flowClient(const std::string& user = "guest", const std::string& pw = "password") {
    TestClient c = connect();
    auto r = c.loginFlow(user, pw);
    EXPECT_TRUE(r) << r.error().message;
    return c;
  }
  TestClient syncClient(const std::string& user = "guest", const std::string& pw = "password") {
    TestClient c = connect();
    auto r = c.login(user, pw);
    EXPECT_TRUE(r) << r.error().message;
    return c;
  }
  // A synchronous connection of a client that speaks protocol 1.<minor>.
  TestClient olderClient(uint16_t minor, const std::string& user = "guest",
                         const std::string& pw = "password") {
    TestClient c = connect();
    auto r = c.login(user, pw, flow::ValueEncoding::binary, minor);
    EXPECT_TRUE(r) << r.error().message;
    return c;
  }

  // Creates a channel from `owner` and returns its id (from the creator's EV_CHAN_ADDED).
  uint16_t addChannel(TestClient& owner, const std::string& name,
                      flow::ChannelKind kind = flow::ChannelKind::streaming,
                      flow::Variant props = flow::Variant(flow::Variant::Map{}),
                      uint32_t tag = 77) {
    flow::msg::ChanAdd m;
    m.tag = tag;
    m.kind = static_cast<uint8_t>(kind);
    m.short_name = name;
    m.mime = "application/octet-stream";
    m.props = std::move(props);
    EXPECT_TRUE(owner.send(m));
    for (;;) {
      auto ev = as<flow::msg::EvChanAdded>(owner.waitFor(flow::Code::ev_chan_added));
      EXPECT_TRUE(ev.has_value());
      if (!ev) return 0;
      if (ev->tag == tag) return ev->info.id;
    }
  }

  // The subscribers channel `id` has now, as the hub's statistics count them (0: no such channel).
  size_t subscribersOf(uint16_t id) {
    flow::HubSnapshot s;
    onHub([&] { s = server_->snapshot(); });
    for (const auto& c : s.channels) {
      if (c.id == id) return c.subscriber_flows.size();
    }
    return 0;
  }
  TempDir dir_;
  flow::ServerOptions opts_;
  std::unique_ptr<LoopThread> hub_;
  std::unique_ptr<flow::FlowServer> server_;
};

}  // namespace skr::test
